#!/usr/bin/env bash
# Set-up, build, then the main job on the bundled sample: build its .hlod, check it, describe it.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
dir=$(scripts/build.sh)
mkdir -p data
"$dir/strata" build data/bunny.off -o data/bunny.hlod
"$dir/strata" verify data/bunny.hlod
"$dir/strata" info data/bunny.hlod

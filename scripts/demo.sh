#!/usr/bin/env bash
# Set-up, build, then the main job on the bundled sample: build its .hlod, check it, describe it, and
# render it headless to a PNG and an OpenEXR image.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
strata="$(scripts/build.sh)/editor/strata"
mkdir -p data
"$strata" build data/bunny.off -o data/bunny.hlod
"$strata" verify data/bunny.hlod
"$strata" info data/bunny.hlod
"$strata" render data/bunny.hlod -o data/bunny.png --size 1280x720
"$strata" render data/bunny.hlod -o data/bunny.exr --size 1280x720 --channels RGBA,Z,N,level,id
echo "demo: wrote data/bunny.hlod, data/bunny.png and data/bunny.exr"

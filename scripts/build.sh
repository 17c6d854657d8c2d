#!/usr/bin/env bash
# Configures and builds into build/ (or build-sanitize/ with STRATA_SANITIZE=1). Prints the build dir.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${STRATA_SANITIZE:-0}" = 1 ]; then
  dir=build-sanitize; extra=(-DSTRATA_SANITIZE=ON -DCMAKE_BUILD_TYPE=Debug)
else
  dir=build; extra=(-DCMAKE_BUILD_TYPE=RelWithDebInfo)
fi
cmake -S . -B "$dir" -G Ninja "${extra[@]}" >/dev/null
cmake --build "$dir" >&2
echo "$dir"

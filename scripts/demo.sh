#!/usr/bin/env bash
# Set-up, build, then the main job on the bundled sample: build its .hlod, check it, describe it,
# render it headless to PNG and OpenEXR, and run the museum flythrough script (EXR frames and an MP4).
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
"$strata" run scripts/museum_flythrough.lua data/bunny.hlod data/bunny.hlod data/flythrough 6 960x540 30
echo "demo: wrote data/bunny.hlod, data/bunny.png, data/bunny.exr;" \
     "the flythrough's EXR frames (RGBA + Z) are in data/flythrough/, its video is data/flythrough/flythrough.mp4"

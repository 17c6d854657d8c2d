#!/usr/bin/env bash
# Set-up, build, then the main job on the bundled sample: build its .hlod, check it, describe it,
# render it headless to PNG and OpenEXR, and run the museum flythrough script (EXR frames and an MP4);
# then the same for the bundled terrain and its flythrough.
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
# A real terrain (southern Colorado, 3 arc-seconds, elevations in feet, no CRS in the file) and a flight
# over it at a height above its ground.
"$strata" build data/trinidad.nc --crs EPSG:4326 --elevation-unit ft -o data/trinidad.hlod
"$strata" verify data/trinidad.hlod
"$strata" info data/trinidad.hlod
"$strata" run scripts/terrain_flythrough.lua data/trinidad.hlod data/terrain_flythrough 4 960x540 24
# Olinda's DEM with the Landsat 7 image of the same ground draped over it (bands 3, 2, 1), as a map.
"$strata" build data/olinda_dem.tif --texture data/olinda_l7.tif --texture-bands 3,2,1 -o data/olinda.hlod
"$strata" render data/olinda.hlod --top --size 800x800 -o data/olinda_map.png
# A site stitched into that ground (thesis 003): a bumpy patch with an open boundary, built to keep its
# boundary, placed at the centre at a tenth of the terrain's width, seen three ways over magenta.
awk 'BEGIN {
    n = 40; print "OFF"; print (n + 1) * (n + 1), 2 * n * n, 0
    for (y = 0; y <= n; y++) for (x = 0; x <= n; x++) printf "%d %d %.4f\n", 10 * x - 200, 10 * y - 200, 20 * sin(x / 3) * cos(y / 4)
    for (y = 0; y < n; y++) for (x = 0; x < n; x++) {
        a = y * (n + 1) + x; printf "3 %d %d %d\n3 %d %d %d\n", a, a + 1, a + n + 2, a, a + n + 2, a + n + 1
    }
}' >data/site_patch.off
"$strata" build data/site_patch.off --lock-boundary -o data/site_patch.hlod
mkdir -p data/site_on_olinda
"$strata" run scripts/site_on_terrain.lua data/olinda.hlod data/site_patch.hlod data/site_on_olinda
echo "demo: wrote data/bunny.hlod, data/bunny.png, data/bunny.exr;" \
     "the flythrough's EXR frames (RGBA + Z) are in data/flythrough/, its video is data/flythrough/flythrough.mp4;" \
     "the terrain's are in data/terrain_flythrough/; Olinda's textured terrain is data/olinda.hlod, its map data/olinda_map.png;" \
     "a site embedded in it is seen in data/site_on_olinda/view1.png … view3.png"

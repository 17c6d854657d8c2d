#!/usr/bin/env bash
# The example scripts in scripts/ on the bundled sample, small: they finish, write what they say, and
# batch_build skips what is up to date.
source "$(dirname "$0")/common.sh"
root=$2
[ -s "$root/data/bunny.off" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
mkdir -p "$WORK/scans" && cp "$root/data/bunny.off" "$WORK/scans/" && write_octahedron "$WORK/scans/octa.off"

expect_success "batch_build" "$STRATA" run "$root/scripts/batch_build.lua" "$WORK/scans" "$WORK/models"
checks=$((checks + 1)); grep -q "2 built, 0 up to date" "$WORK/out.txt" || fail "batch_build: $(tail -1 "$WORK/out.txt")"
expect_success "batch_build again" "$STRATA" run "$root/scripts/batch_build.lua" "$WORK/scans" "$WORK/models"
checks=$((checks + 1)); grep -q "0 built, 2 up to date" "$WORK/out.txt" || fail "batch_build rerun: $(tail -1 "$WORK/out.txt")"

expect_success "lod_sweep" "$STRATA" run "$root/scripts/lod_sweep.lua" "$WORK/models/bunny.hlod" "$WORK/sweep.csv" 160x90
checks=$((checks + 1)); [ "$(wc -l <"$WORK/sweep.csv")" -eq 7 ] || fail "lod_sweep: $(cat "$WORK/sweep.csv")"

expect_success "orbit_capture" "$STRATA" run "$root/scripts/orbit_capture.lua" "$WORK/models/bunny.hlod" "$WORK/orbit" 8 96x64 8
checks=$((checks + 1)); [ -s "$WORK/orbit/orbit00007.exr" ] && [ -s "$WORK/orbit/orbit.mp4" ] || fail "orbit_capture wrote no frames or video"
expect_success "museum_flythrough" "$STRATA" run "$root/scripts/museum_flythrough.lua" "$WORK/models/bunny.hlod" \
    "$WORK/models/octa.hlod" "$WORK/museum" 1 96x54 8
checks=$((checks + 1)); [ -s "$WORK/museum/frame00008.exr" ] && [ -s "$WORK/museum/flythrough.mp4" ] && [ -s "$WORK/museum/tour.json" ] \
    || fail "museum_flythrough wrote no frames, video or path"
if command -v exrheader >/dev/null; then  # the frames hold exactly RGBA and Z
    checks=$((checks + 1))
    channels=$(exrheader "$WORK/museum/frame00000.exr" | grep -E "^ +[A-Z]+, " | awk -F, '{print $1}' | tr -d ' ' | sort | tr '\n' ' ')
    [ "$channels" = "A B G R Z " ] || fail "museum frame channels: '$channels'"
fi
# The terrain flythrough over a real DEM: frames, video and flight, and every second of the flight at
# least the clearance asked above the ground under it, as the model's heights give it.
dem=$root/data/olinda_dem.tif
[ -s "$dem" ] || { echo "data/olinda_dem.tif missing: run scripts/setup.sh"; exit 1; }
expect_success "build the terrain" "$STRATA" build "$dem" -o "$WORK/olinda.hlod" -q
expect_success "terrain_flythrough" "$STRATA" run "$root/scripts/terrain_flythrough.lua" "$WORK/olinda.hlod" "$WORK/terrain" 3 96x54 4 120
checks=$((checks + 1)); [ -s "$WORK/terrain/frame00011.exr" ] && [ -s "$WORK/terrain/flythrough.mp4" ] && [ -s "$WORK/terrain/flight.json" ] \
    || fail "terrain_flythrough wrote no frames, video or flight"
checks=$((checks + 1)); grep -qE "a loop from longitude, latitude -34\.(8|9)[0-9]*°, -(7\.9|8\.0)[0-9]*° round and back" "$WORK/out.txt" ||
    fail "terrain_flythrough: not over Olinda: $(cat "$WORK/out.txt")"
cat > "$WORK/clearance.lua" <<'LUA'
local strata = require "strata"
local model, flight = strata.load(arg[1]), strata.load_path(arg[2])
for k = 1, 3 do
    local p = flight:sample(flight:key_time(k)).position
    local ground = model:height_at{ p[1], p[2] }
    assert(ground and p[3] - ground >= 120 - 1e-6, ("key %d at %.1f m over ground at %s"):format(k, p[3], tostring(ground)))
end
LUA
expect_success "the flight keeps its clearance" "$STRATA" run "$WORK/clearance.lua" "$WORK/olinda.hlod" "$WORK/terrain/flight.json"

# A site on the terrain: a bumpy patch with an open boundary (stitched into the ground) and a closed
# octahedron (standing), each at the centre, three 1280×720 views over magenta: the background shows at
# the top-left corner, the site at the centre of the view from above, and no magenta around it there (a
# crack at the join would show).
write_patch "$WORK/patch.off" 20
expect_success "build the open site" "$STRATA" build -q "$WORK/patch.off" --lock-boundary -o "$WORK/patch.hlod"
expect_success "build the closed site" "$STRATA" build -q "$WORK/scans/octa.off" --lock-boundary -o "$WORK/octa.hlod"
pixels=$root/tests/support/png_pixels.py
for site in patch octa; do
    mkdir -p "$WORK/$site"
    expect_success "site_on_terrain $site" "$STRATA" run "$root/scripts/site_on_terrain.lua" "$WORK/olinda.hlod" "$WORK/$site.hlod" "$WORK/$site"
    for view in 1 2 3; do
        image=$WORK/$site/view$view.png
        checks=$((checks + 1)); [ "$(python3 "$pixels" size "$image")" = "1280 720" ] || fail "$site view$view: not 1280×720"
        checks=$((checks + 1)); [ "$(python3 "$pixels" pixel "$image" 0 0)" = "255 0 255 255" ] || fail "$site view$view: no magenta at the top-left"
    done
    checks=$((checks + 1)); [ "$(python3 "$pixels" box "$WORK/$site/view3.png" 1,0,1,1 560 280 720 440 | awk '{print $5}')" = "25600" ] ||
        fail "$site: magenta around the site from above: $(python3 "$pixels" box "$WORK/$site/view3.png" 1,0,1,1 560 280 720 440)"
done
checks=$((checks + 1)); [ "$(python3 "$pixels" pixel "$WORK/patch/view3.png" 640 360)" != "$(python3 "$pixels" pixel "$WORK/octa/view3.png" 640 360)" ] ||
    fail "the two sites look the same from above"
# The embedding file is made once: a second run reuses it as it is.
cp "$WORK/patch/site_on_terrain.hlod" "$WORK/first.hlod"
touch -d '2000-01-01' "$WORK/patch/site_on_terrain.hlod"
expect_success "site_on_terrain again" "$STRATA" run "$root/scripts/site_on_terrain.lua" "$WORK/olinda.hlod" "$WORK/patch.hlod" "$WORK/patch"
checks=$((checks + 1)); [ "$(stat -c %Y "$WORK/patch/site_on_terrain.hlod")" = "$(date -d '2000-01-01' +%s)" ] || fail "the embedding file was made again"
expect_failure "site_on_terrain without arguments" "usage: strata run site_on_terrain.lua TERRAIN.hlod SITE.hlod OUTDIR" \
    "$STRATA" run "$root/scripts/site_on_terrain.lua"
expect_failure "site_on_terrain on a scan" "not a terrain" "$STRATA" run "$root/scripts/site_on_terrain.lua" "$WORK/octa.hlod" "$WORK/patch.hlod" "$WORK/patch"
finish

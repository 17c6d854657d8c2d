#!/usr/bin/env bash
# A terrain straight from a real DEM (issue 17): `strata build DEM.tif` makes a model that verifies and
# describes its georeference; bad rasters and bad terrain options fail by name, leaving nothing.
source "$(dirname "$0")/common.sh"
dem=$2/data/olinda_dem.tif
[ -s "$dem" ] || { echo "data/olinda_dem.tif missing: run scripts/setup.sh"; exit 1; }
expect_success "build terrain" "$STRATA" build "$dem" -o "$WORK/olinda.hlod"
checks=$((checks + 1)); grep -q "terrain, 24200 triangles" "$WORK/out.txt" || fail "build: not 110 × 110 cells of two triangles: $(cat "$WORK/out.txt")"
expect_success "verify terrain" "$STRATA" verify "$WORK/olinda.hlod"
# strata.build from Lua builds the same bytes as the CLI (tests/lua/build_terrain_api.lua tests its options).
printf 'local strata = require "strata"\nstrata.build{ input = arg[1], output = arg[2] }\nprint("built")\n' >"$WORK/build_dem.lua"
expect_success "build terrain from Lua" "$STRATA" run "$WORK/build_dem.lua" "$dem" "$WORK/olinda_lua.hlod"
checks=$((checks + 1)); cmp -s "$WORK/olinda_lua.hlod" "$WORK/olinda.hlod" || fail "strata.build and strata build made different terrains"
expect_success "info terrain" "$STRATA" info "$WORK/olinda.hlod"
checks=$((checks + 1)); grep -q "^georef .*UTM Zone 25, Southern Hemisphere" "$WORK/out.txt" || fail "info: no CRS: $(grep georef "$WORK/out.txt")"
size=$(gdalinfo "$dem" | sed -n 's/^Size is \([0-9]*\), \([0-9]*\)$/\1 × \2/p')
checks=$((checks + 1)); grep -q "^terrain     $size samples, 89.99.. × 89.99.. m apart, 0 nodata" "$WORK/out.txt" ||
    fail "info: not the raster's $size samples: $(grep terrain "$WORK/out.txt")"

# A map of it (--top): the world file and .prj place the picture. GDAL reads the world file as the PNG's
# geotransform; the outermost covered pixels' centres lie within a pixel of the DEM's outermost samples
# (gdalinfo's geotransform, pixel centres); the .prj is the DEM's CRS (ESRI WKT has no TOWGS84: the
# DEM's null one aside).
expect_success "render a map" "$STRATA" render "$WORK/olinda.hlod" --top --size 300x300 --samples 1 --background 0,0,0,0 -o "$WORK/map.png"
checks=$((checks + 1)); grep -q "placed by map.pgw and map.prj" "$WORK/out.txt" || fail "render --top: no world file: $(cat "$WORK/out.txt")"
read -r x0 y0 x1 y1 _ < <(python3 "$2/tests/support/png_pixels.py" box "$WORK/map.png" 0,0,0,0)
map=$(GDAL_PAM_ENABLED=NO gdalinfo -json "$WORK/map.png" | tr -d ' \n' | sed -n 's/.*"geoTransform":\[\([^]]*\)\].*/\1/p')
dem_g=$(GDAL_PAM_ENABLED=NO gdalinfo -json "$dem" | tr -d ' \n' | sed -n 's/.*"geoTransform":\[\([^]]*\)\].*/\1/p')
checks=$((checks + 1))
awk -v m="$map" -v d="$dem_g" -v x0="$x0" -v y0="$y0" -v x1="$x1" -v y1="$y1" -v n=111 'BEGIN {
    split(m, g, ","); split(d, e, ",")
    # GDAL: the upper-left corner of pixel (i, j) is (g1 + i g2 + j g3, g4 + i g5 + j g6); centres at +0.5.
    west = g[1] + (x0 + 0.5) * g[2]; east = g[1] + (x1 + 0.5) * g[2]
    north = g[4] + (y0 + 0.5) * g[6]; south = g[4] + (y1 + 0.5) * g[6]
    want_w = e[1] + 0.5 * e[2]; want_e = e[1] + (n - 0.5) * e[2]; want_n = e[4] + 0.5 * e[6]; want_s = e[4] + (n - 0.5) * e[6]
    px = g[2]; bad = 0
    if ((west - want_w)^2 > px^2 || (east - want_e)^2 > px^2 || (north - want_n)^2 > px^2 || (south - want_s)^2 > px^2) bad = 1
    if (bad) printf "covered %.1f..%.1f x %.1f..%.1f, the DEM %.1f..%.1f x %.1f..%.1f (pixel %.1f)\n", west, east, south, north, want_w, want_e, want_s, want_n, px
    exit bad }' || fail "render --top: the world file does not place the terrain on its samples"
checks=$((checks + 1))
proj4() { gdalsrsinfo -o proj4 "$1" 2>/dev/null | sed 's/ +towgs84=0,0,0,0,0,0,0//' | tr -d '\n'; }
[ "$(proj4 "$WORK/map.prj")" = "$(proj4 "$dem")" ] && [ -n "$(proj4 "$dem")" ] ||
    fail "render --top: map.prj is not the DEM's CRS: $(cat "$WORK/map.prj")"
# The same map as a GeoTIFF: its tags place it where the world file does, its pixels are the PNG's.
expect_success "render a GeoTIFF map" "$STRATA" render "$WORK/olinda.hlod" --top --size 300x300 --samples 1 --background 0,0,0,0 -o "$WORK/map.tif"
checks=$((checks + 1)); grep -q "placed by its GeoTIFF tags" "$WORK/out.txt" || fail "render --top -o .tif: not georeferenced: $(cat "$WORK/out.txt")"
tif=$(GDAL_PAM_ENABLED=NO gdalinfo -json "$WORK/map.tif" | tr -d ' \n' | sed -n 's/.*"geoTransform":\[\([^]]*\)\].*/\1/p')
checks=$((checks + 1)); [ "$tif" = "$map" ] || fail "the GeoTIFF's geotransform $tif is not the world file's $map"
checks=$((checks + 1)); [ "$(proj4 "$WORK/map.tif")" = "$(proj4 "$dem")" ] || fail "the GeoTIFF's CRS is not the DEM's"
for pixel in "150 150" "40 200" "260 90"; do
    checks=$((checks + 1))
    [ "$(GDAL_PAM_ENABLED=NO gdallocationinfo -valonly "$WORK/map.tif" $pixel)" = "$(GDAL_PAM_ENABLED=NO gdallocationinfo -valonly "$WORK/map.png" $pixel)" ] ||
        fail "GeoTIFF pixel $pixel differs from the PNG's"
done
checks=$((checks + 1)); ! ls "$WORK" | grep -q "map.tif.tmp" || fail "a temporary GeoTIFF was left behind"
expect_failure "a GeoTIFF where none can be written" "cannot write $WORK/nowhere/map.tif" "$STRATA" render "$WORK/olinda.hlod" --top --size 50x50 -o "$WORK/nowhere/map.tif"

# From Lua: at sample centres height_at is what gdallocationinfo reads, to_geo is where gdaltransform
# puts the sample in longitude and latitude, to_local returns, and off the raster there is no ground.
samples="3 105
60 20
110 0
0 110
57 64"
cat > "$WORK/ground.lua" <<'LUA'
local strata = require "strata"
local model = strata.load(arg[1])
local step, rows = tonumber(arg[2]), tonumber(arg[3])
for line in io.lines(arg[4]) do
    local c, r = line:match("(%d+) (%d+)")
    local x, y = c * step, (rows - 1 - r) * step
    local geo = model:to_geo{ x, y, 0 }
    local back = model:to_local{ geo[1], geo[2], 0 }
    assert(math.abs(back[1] - x) < 1e-6 and math.abs(back[2] - y) < 1e-6, "to_local does not return to_geo's point")
    print(("%.6f %.9f %.9f"):format(model:height_at{ x, y }, geo[1], geo[2]))
end
assert(model:height_at{ -step, 0 } == nil and model:height_at{ 0, rows * step } == nil, "ground off the raster")
LUA
echo "$samples" > "$WORK/samples.txt"
step=$(GDAL_PAM_ENABLED=NO gdalinfo -json "$dem" | tr -d ' \n' | sed -n 's/.*"geoTransform":\[[^,]*,\([^,]*\),.*/\1/p')
expect_success "heights and coordinates from Lua" "$STRATA" run "$WORK/ground.lua" "$WORK/olinda.hlod" "$step" 111 "$WORK/samples.txt"
cp "$WORK/out.txt" "$WORK/lua_ground.txt"
gdal=$(echo "$samples" | GDAL_PAM_ENABLED=NO gdallocationinfo -valonly "$dem")
where=$(echo "$samples" | awk '{print $1 + 0.5, $2 + 0.5}' | gdaltransform -t_srs EPSG:4326 "$dem")
checks=$((checks + 1))
paste -d ' ' "$WORK/lua_ground.txt" <(echo "$gdal") <(echo "$where") | awk '{
    # Lua: height lon lat; GDAL: height; gdaltransform: lon lat 0. Float32 heights within 1 mm; 1e-8 degrees is 1 mm.
    if ((($1 - $4)^2 > 1e-6) || (($2 - $5)^2 > 1e-16) || (($3 - $6)^2 > 1e-16)) { print "sample " NR ": " $0; bad = 1 } }
    END { exit bad }' || fail "Lua's heights or coordinates differ from GDAL's: $(paste -d ' ' "$WORK/lua_ground.txt" <(echo "$gdal") <(echo "$where"))"
echo "require('strata').load(arg[1]):height_at{0, 0}" > "$WORK/mesh_ground.lua"
write_octahedron "$WORK/octa.off" && "$STRATA" build "$WORK/octa.off" -o "$WORK/octa.hlod" -q
expect_failure "height_at on a mesh" "octa.hlod: not a terrain" "$STRATA" run "$WORK/mesh_ground.lua" "$WORK/octa.hlod"

# No georeference: a raster GDAL reads whose samples lie nowhere.
gdal_translate -q -of AAIGrid "$dem" "$WORK/grid.asc" && rm -f "$WORK/grid.prj"
sed -i '/^xllcorner/s/.*/xllcorner 0/' "$WORK/grid.asc"
expect_failure "no CRS" "grid.asc: no CRS" "$STRATA" build "$WORK/grid.asc" -o "$WORK/grid.hlod"
expect_success "the CRS given" "$STRATA" build "$WORK/grid.asc" --crs EPSG:31985 -o "$WORK/grid.hlod" -q
expect_success "info of the CRS given" "$STRATA" info "$WORK/grid.hlod"
checks=$((checks + 1)); grep -q "^georef      EPSG:31985 SIRGAS 2000 / UTM zone 25S, model origin" "$WORK/out.txt" ||
    fail "info: the CRS not by code and name: $(grep georef "$WORK/out.txt")"
expect_status "an unknown frame" 2 "--frame utm: not a CRS PROJ knows" "$STRATA" build "$WORK/grid.asc" --frame utm -o "$WORK/degrees.hlod"
expect_status "odd cube cells" 2 "even" "$STRATA" build "$dem" --cube-cells 33 -o "$WORK/x.hlod"
expect_success "larger cubes" "$STRATA" build "$dem" --cube-cells 128 -o "$WORK/big_cubes.hlod" -q
expect_success "verify larger cubes" "$STRATA" verify "$WORK/big_cubes.hlod"
expect_status "a negative height tolerance" 2 "--height-tolerance" "$STRATA" build "$dem" --height-tolerance -1 -o "$WORK/x.hlod"
# The finest height lattice costs more bytes than the default's; -v says which lattice was used.
expect_success "exact heights" "$STRATA" build "$dem" --height-tolerance 0 -o "$WORK/exact.hlod" -v
checks=$((checks + 1)); grep -q "heights: on a 0.1.* m lattice at level" "$WORK/out.txt" ||
    fail "-v: no finest height lattice: $(grep heights: "$WORK/out.txt")"
checks=$((checks + 1)); [ "$(stat -c %s "$WORK/exact.hlod")" -gt "$(stat -c %s "$WORK/olinda.hlod")" ] ||
    fail "the finest heights took no more bytes than the default's"
expect_status "fill not a number" 2 "--fill-nodata takes an elevation" "$STRATA" build "$dem" --fill-nodata low -o "$WORK/x.hlod"
checks=$((checks + 1)); ls "$WORK" | grep -q -e "degrees.hlod" -e "x.hlod" && fail "a failed build left output: $(ls "$WORK")"

# A real DEM in degrees (trinidad.nc: 3 arc-seconds, elevations in feet, no CRS in the file): the
# tangent plane at its centre, heights in metres (Blanca Peak's sample, 14 176 ft, is the highest).
trinidad=$2/data/trinidad.nc
if [ -s "$trinidad" ]; then
    expect_success "build in degrees" "$STRATA" build "$trinidad" --crs EPSG:4326 --elevation-unit ft -o "$WORK/trinidad.hlod" -q
    expect_success "verify in degrees" "$STRATA" verify "$WORK/trinidad.hlod"
    expect_success "info in degrees" "$STRATA" info "$WORK/trinidad.hlod"
    checks=$((checks + 1)); grep -q "^frame .*enu, the flat tangent plane at longitude -105°, latitude 37.5°" "$WORK/out.txt" ||
        fail "info: not the tangent plane at the centre: $(grep frame "$WORK/out.txt")"
    checks=$((checks + 1)); grep -q "^extent .* m, heights .* to 4320.89" "$WORK/out.txt" ||
        fail "info: the highest sample is not 14176 ft: $(grep extent "$WORK/out.txt")"
    # Out of core in the tangent plane: 128 MiB holds one tile at a time, not the eight the threads ask
    # for; the bytes are the whole raster's.
    expect_success "in tiles" "$STRATA" build "$trinidad" --crs EPSG:4326 --elevation-unit ft --memory 128M --threads 8 -o "$WORK/tiled.hlod" -q
    checks=$((checks + 1)); cmp -s "$WORK/trinidad.hlod" "$WORK/tiled.hlod" || fail "a tiled build differs from the whole raster's"
    expect_status "an unknown elevation unit" 2 "elevation-unit" "$STRATA" build "$trinidad" --crs EPSG:4326 --elevation-unit furlong -o "$WORK/x.hlod"
    # Reprojected into UTM 13N: a plane in metres, where its world file can place a map.
    expect_success "build reprojected" "$STRATA" build "$trinidad" --crs EPSG:4326 --elevation-unit ft --frame EPSG:32613 -o "$WORK/utm.hlod" -q
    expect_success "verify reprojected" "$STRATA" verify "$WORK/utm.hlod"
    expect_success "info reprojected" "$STRATA" info "$WORK/utm.hlod"
    checks=$((checks + 1)); grep -q "^frame .*reprojected from EPSG:4326" "$WORK/out.txt" && grep -q "^georef .*EPSG:32613" "$WORK/out.txt" ||
        fail "info: not reprojected into EPSG:32613: $(cat "$WORK/out.txt")"
    expect_success "map of the reprojected terrain" "$STRATA" render "$WORK/utm.hlod" --top --size 200x200 --samples 1 -o "$WORK/utm.png"
    checks=$((checks + 1)); grep -q "placed by utm.pgw and utm.prj" "$WORK/out.txt" || fail "render --top: no world file for a reprojected terrain"
    expect_usage "a frame in degrees" "--frame EPSG:4326: not a projected CRS" "$STRATA" build "$trinidad" --crs EPSG:4326 --frame EPSG:4326 -o "$WORK/x.hlod"
fi

# Imagery draped (issue 17 §2): the Landsat 7 image of the same ground, bands 3, 2, 1.
image=$2/data/olinda_l7.tif
expect_success "build textured" "$STRATA" build "$dem" --texture "$image" --texture-bands 3,2,1 --cube-cells 16 -o "$WORK/textured.hlod" -q
expect_success "verify textured" "$STRATA" verify "$WORK/textured.hlod"
expect_success "info textured" "$STRATA" info "$WORK/textured.hlod"
checks=$((checks + 1)); grep -q "^textures .* texels a cube, BC1 sRGB with mips" "$WORK/out.txt" || fail "info: no textures: $(cat "$WORK/out.txt")"
texels=$(sed -n 's/^textures *\([0-9]*\) × .*/\1/p' "$WORK/out.txt")
echo 'local m = require("strata").load(arg[1]); print(m:info().texture_size, require("strata").load(arg[2]):info().texture_size)' > "$WORK/texels.lua"
expect_success "texture size from Lua" "$STRATA" run "$WORK/texels.lua" "$WORK/textured.hlod" "$WORK/olinda.hlod"
checks=$((checks + 1)); grep -q "^$texels	nil$" "$WORK/out.txt" || fail "info().texture_size: not $texels and nil: $(cat "$WORK/out.txt")"
expect_failure "a texture that is not there" "nowhere.tif: no such file" "$STRATA" build "$dem" --texture "$WORK/nowhere.tif" -o "$WORK/x.hlod"
expect_failure "a band the image lacks" "olinda_l7.tif: has 6 bands, no band 9" "$STRATA" build "$dem" --texture "$image" --texture-bands 9,2,1 -o "$WORK/x.hlod"
GDAL_PAM_ENABLED=NO gdal_translate -q -co PROFILE=BASELINE "$image" "$WORK/plain.tif"
expect_failure "an image without georeference" "plain.tif: no georeference" "$STRATA" build "$dem" --texture "$WORK/plain.tif" -o "$WORK/x.hlod"
expect_usage "a texture for a mesh" "drape imagery over a terrain" "$STRATA" build "$WORK/octa.off" --texture "$image" -o "$WORK/x.hlod"
expect_usage "a terrain's boundary locked" "--lock-boundary locks a mesh's open boundary, for embedding it in a terrain; .*olinda_dem.tif is an elevation raster" \
    "$STRATA" build "$dem" --lock-boundary -o "$WORK/x.hlod"
expect_usage "a texture size that is not a power of two" "power of two" "$STRATA" build "$dem" --texture "$image" --texture-size 100 -o "$WORK/x.hlod"
checks=$((checks + 1)); [ ! -e "$WORK/x.hlod" ] || fail "a refused texture left $WORK/x.hlod behind"
finish

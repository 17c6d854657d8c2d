#!/usr/bin/env bash
# A terrain straight from a real DEM (issue 17): `strata build DEM.tif` makes a model that verifies and
# describes its georeference; bad rasters and bad terrain options fail by name, leaving nothing.
source "$(dirname "$0")/common.sh"
dem=$2/data/olinda_dem.tif
[ -s "$dem" ] || { echo "data/olinda_dem.tif missing: run scripts/setup.sh"; exit 1; }
expect_success "build terrain" "$STRATA" build "$dem" -o "$WORK/olinda.hlod"
checks=$((checks + 1)); grep -q "terrain, 24200 triangles" "$WORK/out.txt" || fail "build: not 110 × 110 cells of two triangles: $(cat "$WORK/out.txt")"
expect_success "verify terrain" "$STRATA" verify "$WORK/olinda.hlod"
expect_success "info terrain" "$STRATA" info "$WORK/olinda.hlod"
checks=$((checks + 1)); grep -q "^georef .*UTM Zone 25, Southern Hemisphere" "$WORK/out.txt" || fail "info: no CRS: $(grep georef "$WORK/out.txt")"
size=$(gdalinfo "$dem" | sed -n 's/^Size is \([0-9]*\), \([0-9]*\)$/\1 × \2/p')
checks=$((checks + 1)); grep -q "^terrain     $size samples, 89.99.. × 89.99.. m apart, 0 nodata" "$WORK/out.txt" ||
    fail "info: not the raster's $size samples: $(grep terrain "$WORK/out.txt")"

# No georeference: a raster GDAL reads whose samples lie nowhere.
gdal_translate -q -of AAIGrid "$dem" "$WORK/grid.asc" && rm -f "$WORK/grid.prj"
sed -i '/^xllcorner/s/.*/xllcorner 0/' "$WORK/grid.asc"
expect_failure "no CRS" "grid.asc: no CRS" "$STRATA" build "$WORK/grid.asc" -o "$WORK/grid.hlod"
expect_success "the CRS given" "$STRATA" build "$WORK/grid.asc" --crs EPSG:31985 -o "$WORK/grid.hlod" -q
expect_success "info of the CRS given" "$STRATA" info "$WORK/grid.hlod"
checks=$((checks + 1)); grep -q "^georef      EPSG:31985 SIRGAS 2000 / UTM zone 25S, model origin" "$WORK/out.txt" ||
    fail "info: the CRS not by code and name: $(grep georef "$WORK/out.txt")"
expect_status "an unknown frame" 2 "frame" "$STRATA" build "$WORK/grid.asc" --frame utm -o "$WORK/degrees.hlod"
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
    expect_status "an unknown elevation unit" 2 "elevation-unit" "$STRATA" build "$trinidad" --crs EPSG:4326 --elevation-unit furlong -o "$WORK/x.hlod"
fi
finish

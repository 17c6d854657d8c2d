#!/usr/bin/env bash
# strata embed (issue 18): a small open site, built with --lock-boundary, embedded in the olinda terrain
# with --at writes an embedding file that info describes and verify accepts; a closed site stands; an
# unlocked site, a site without a place, a terrain that is none, a site off the raster, a corrupt EMBD and
# an unwritable output fail by name (status 1, or 2 for arguments), leaving no output.
source "$(dirname "$0")/common.sh"
dem=$2/data/olinda_dem.tif
[ -s "$dem" ] || { echo "data/olinda_dem.tif missing: run scripts/setup.sh"; exit 1; }
expect_success "build terrain" "$STRATA" build -q "$dem" -o "$WORK/olinda.hlod"

write_patch "$WORK/patch.off"
expect_success "build the site locked" "$STRATA" build -q "$WORK/patch.off" --lock-boundary -o "$WORK/site.hlod"
expect_success "build the site unlocked" "$STRATA" build -q "$WORK/patch.off" -o "$WORK/loose.hlod"
write_octahedron "$WORK/statue.off"
expect_success "build a closed site" "$STRATA" build -q "$WORK/statue.off" --lock-boundary -o "$WORK/statue.hlod"

# Near the raster's centre (34°52'16"W, 7°59'43"S).
at=-34.8710,-7.9952
mkdir -p "$WORK/out"
expect_success "embed" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/out/site_on_olinda.hlod" --at "$at"
for line in "embedded in .*olinda.hlod, [0-9.]* s" "^  zone        level [0-9]* of 0 … [0-9]* (cells of [0-9]* samples): [1-9][0-9]* partly, [0-9]* wholly covered; m \(as ΔH asks, not capped\|capped\)" \
    "^  ΔH          [0-9.]* m" "^  skirt       [1-9][0-9]* triangles, 160 boundary vertices" "^  bytes       EMBD [0-9]* ([0-9.]* a boundary vertex), file [0-9]*"; do
    checks=$((checks + 1)); grep -q -- "$line" "$WORK/out.txt" || fail "embed's report lacks '$line': $(cat "$WORK/out.txt")"
done
cp "$WORK/out.txt" "$WORK/report.txt"
expect_success "info" "$STRATA" info "$WORK/out/site_on_olinda.hlod"
checks=$((checks + 1)); grep -q "^embedding   ../site.hlod on terrain ../olinda.hlod" "$WORK/out.txt" || fail "info: no embedding: $(cat "$WORK/out.txt")"
checks=$((checks + 1)); grep -q "^zone        level [0-9]* of 0 … [0-9]*, cells of [0-9]* samples" "$WORK/out.txt" || fail "info: no zone: $(cat "$WORK/out.txt")"
checks=$((checks + 1)); grep -q "^placement   site → terrain: translation .*, scale 1, heading 0°" "$WORK/out.txt" || fail "info: no placement: $(cat "$WORK/out.txt")"
checks=$((checks + 1)); grep -q "boundary locked" "$WORK/out.txt" || fail "info: the skirt's boundary is not locked: $(cat "$WORK/out.txt")"
expect_success "verify" "$STRATA" verify "$WORK/out/site_on_olinda.hlod"
checks=$((checks + 1)); grep -q ": ok: .*the boundary locked at every level, its embedding sound" "$WORK/out.txt" || fail "verify: $(cat "$WORK/out.txt")"
# Turned and scaled, the same site is embedded too; quiet says nothing.
expect_success "embed turned and scaled" "$STRATA" embed -q "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/turned.hlod" --at "$at" --scale 1.5 --heading 30 --threads 1
checks=$((checks + 1)); [ ! -s "$WORK/out.txt" ] || fail "embed -q printed: $(cat "$WORK/out.txt")"
expect_success "info turned" "$STRATA" info "$WORK/turned.hlod"
checks=$((checks + 1)); grep -q "scale 1.5, heading 30°" "$WORK/out.txt" || fail "info: not turned and scaled: $(grep placement "$WORK/out.txt")"

# Placed by a matrix (the site's model coordinates → the terrain's): the --at embedding's translation,
# turned a quarter counter-clockwise, kept as given; a matrix that is not 16 numbers, that mirrors, or
# that comes with --at is refused.
expect_success "info the placed embedding" "$STRATA" info "$WORK/out/site_on_olinda.hlod"
shift=$(sed -n 's/^placement   site → terrain: translation (\([^)]*\)).*/\1/p' "$WORK/out.txt" | tr -d ' ')
checks=$((checks + 1)); [ "$(echo "$shift" | tr ',' '\n' | wc -l)" = 3 ] || fail "no translation in info: $(cat "$WORK/out.txt")"
expect_success "embed by a matrix" "$STRATA" embed -q "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/by_matrix.hlod" --matrix "0,1,0,0,-1,0,0,0,0,0,1,0,$shift,1"
expect_success "info by a matrix" "$STRATA" info "$WORK/by_matrix.hlod"
checks=$((checks + 1)); grep -q "translation ($(echo "$shift" | sed 's/,/, /g')), scale 1, heading -90°" "$WORK/out.txt" || fail "info: not the matrix given: $(grep placement "$WORK/out.txt")"
expect_usage "a matrix of 3 numbers" "--matrix: it takes 16 comma-separated numbers, column-major, not 3" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/x.hlod" --matrix 1,2,3
expect_usage "a mirroring matrix" "--matrix: a placement matrix must not mirror the site" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/x.hlod" --matrix "-1,0,0,0,0,1,0,0,0,0,1,0,$shift,1"
expect_usage "a matrix and --at" "excludes" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/x.hlod" --matrix "1,0,0,0,0,1,0,0,0,0,1,0,$shift,1" --at "$at"

# A site smaller than one raster cell (20 m in a 90 m DEM), placed by a matrix in the middle of the cell
# from (55, 55) to (56, 56) (89.994 m spacing): embedded in the cell, which keeps a hole.
expect_success "embed a site inside one cell" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/tiny.hlod" \
    --matrix 0.05,0,0,0,0,0.05,0,0,0,0,0.05,0,4994.67,4994.67,32.7,1
checks=$((checks + 1)); grep -q "^  zone        .*: 1 partly, 0 wholly covered" "$WORK/out.txt" || fail "a site inside one cell: $(cat "$WORK/out.txt")"
expect_success "verify the site inside one cell" "$STRATA" verify "$WORK/tiny.hlod"

# A plain mesh as the site: built into OUT_site.hlod with its boundary locked, then embedded as the
# .hlod is; a second run reuses that model; a mesh has no georeference, and a malformed one is named.
expect_success "embed a mesh" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/patch.off" -o "$WORK/from_mesh.hlod" --at "$at"
checks=$((checks + 1)); grep -q "^$WORK/from_mesh_site.hlod: the site model, $WORK/patch.off built with its boundary locked" "$WORK/out.txt" || fail "embed a mesh: $(cat "$WORK/out.txt")"
checks=$((checks + 1)); grep -q "^  skirt       [1-9][0-9]* triangles, 160 boundary vertices" "$WORK/out.txt" || fail "embed a mesh: $(cat "$WORK/out.txt")"
expect_success "info the mesh's model" "$STRATA" info "$WORK/from_mesh_site.hlod"
checks=$((checks + 1)); grep -q "boundary locked" "$WORK/out.txt" || fail "the mesh's model is not locked: $(cat "$WORK/out.txt")"
built=$(stat -c %y "$WORK/from_mesh_site.hlod")
expect_success "embed the mesh again" "$STRATA" embed -q "$WORK/olinda.hlod" "$WORK/patch.off" -o "$WORK/from_mesh.hlod" --at "$at" --heading 10
checks=$((checks + 1)); [ "$(stat -c %y "$WORK/from_mesh_site.hlod")" = "$built" ] || fail "the mesh's model was built again"
expect_usage "a mesh without a place" "patch.off has no georeference (CRS): place it with --at LON,LAT or --matrix" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/patch.off" -o "$WORK/x.hlod"
printf 'OFF\n3 1 0\n0 0 0\n1 0 0\n' > "$WORK/broken.off"
expect_failure "a malformed mesh" "broken.off" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/broken.off" -o "$WORK/x.hlod" --at "$at"
checks=$((checks + 1)); [ -z "$(ls "$WORK" | grep '^x\(_site\)\?.hlod')" ] || fail "a malformed mesh left $(ls "$WORK" | grep '^x')"
expect_failure "a mesh off the raster" "patch.off: placed at .* it lies wholly off the terrain's raster" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/patch.off" -o "$WORK/x.hlod" --at -30,-8
checks=$((checks + 1)); [ -z "$(ls "$WORK" | grep '^x\(_site\)\?.hlod')" ] || fail "a mesh off the raster left $(ls "$WORK" | grep '^x')"

# On a textured terrain the skirt carries the ground's imagery (TXTR), which info describes and verify checks;
# the untextured terrain's skirt has none.
checks=$((checks + 1)); ! grep -q "^textures" "$WORK/out.txt" || fail "info: an untextured terrain's skirt has textures: $(cat "$WORK/out.txt")"
expect_success "build a textured terrain" "$STRATA" build -q "$dem" --texture "$2/data/olinda_l7.tif" --texture-bands 3,2,1 -o "$WORK/textured.hlod"
expect_success "embed on the textured terrain" "$STRATA" embed "$WORK/textured.hlod" "$WORK/site.hlod" -o "$WORK/on_textured.hlod" --at "$at"
checks=$((checks + 1)); grep -q "^  bytes       EMBD .*, of which the skirt's imagery [1-9][0-9]*$" "$WORK/out.txt" || fail "embed: the imagery's bytes not reported: $(cat "$WORK/out.txt")"
expect_success "info on the textured embedding" "$STRATA" info "$WORK/on_textured.hlod"
checks=$((checks + 1)); grep -q "^textures .* texels a cube, BC1 sRGB with mips" "$WORK/out.txt" || fail "info: the skirt has no textures: $(cat "$WORK/out.txt")"
expect_success "verify the textured embedding" "$STRATA" verify "$WORK/on_textured.hlod"
checks=$((checks + 1)); grep -q ": ok: .*its embedding sound" "$WORK/out.txt" || fail "verify: $(cat "$WORK/out.txt")"

# A closed site stands: nothing cut, a file without cubes.
expect_success "embed a closed site" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/statue.hlod" -o "$WORK/statue_on_olinda.hlod" --at "$at"
checks=$((checks + 1)); grep -q "stands on .*nothing cut" "$WORK/out.txt" || fail "a closed site: $(cat "$WORK/out.txt")"
expect_success "verify a standing site's file" "$STRATA" verify "$WORK/statue_on_olinda.hlod"
expect_success "info a standing site's file" "$STRATA" info "$WORK/statue_on_olinda.hlod"
checks=$((checks + 1)); grep -q "standing: a closed mesh on the ground" "$WORK/out.txt" || fail "info: not standing: $(cat "$WORK/out.txt")"

# Refusals, each leaving no output.
x=$WORK/x.hlod
expect_failure "an unlocked site" "loose.hlod: its open boundary is not locked; rebuild it with strata build --lock-boundary" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/loose.hlod" -o "$x" --at "$at"
expect_usage "no place" "site.hlod has no georeference (CRS): place it with --at LON,LAT" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$x"
expect_usage "a bad --at" "--at takes a longitude and a latitude" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$x" --at 34.8
expect_usage "no output" "--output is required" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" --at "$at"
expect_usage "a bad scale" "scale" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$x" --at "$at" --scale 0
expect_failure "a missing terrain" "nowhere.hlod" "$STRATA" embed "$WORK/nowhere.hlod" "$WORK/site.hlod" -o "$x" --at "$at"
expect_failure "a missing site" "nosite.hlod" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/nosite.hlod" -o "$x" --at "$at"
expect_failure "a terrain that is none" "site.hlod: not a terrain" "$STRATA" embed "$WORK/site.hlod" "$WORK/site.hlod" -o "$x" --at "$at"
expect_failure "a site off the raster" "site.hlod: placed at .* it lies wholly off the terrain's raster" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$x" --at -30,-8
expect_failure "a site reaching off the raster" "site.hlod: the mesh reaches outside the terrain's raster" \
    "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$x" --at -34.9152,-7.9507
expect_failure "an unwritable output" "$WORK/nowhere/x.hlod: cannot create the output file" "$STRATA" embed "$WORK/olinda.hlod" "$WORK/site.hlod" -o "$WORK/nowhere/x.hlod" --at "$at"
checks=$((checks + 1)); [ -z "$(ls "$WORK" | grep '^x.hlod')" ] || fail "a refused embedding left $(ls "$WORK" | grep '^x.hlod')"

# A byte flipped in EMBD: info and verify name the file and the section.
cp "$WORK/out/site_on_olinda.hlod" "$WORK/corrupt.hlod"
python3 - "$WORK/corrupt.hlod" <<'EOF'
import struct, sys
data = bytearray(open(sys.argv[1], 'rb').read())
count = struct.unpack_from('<I', data, 12)[0]
for i in range(count):
    tag, _, offset = struct.unpack_from('<4sIQ', data, 32 + 32 * i)
    if tag == b'EMBD':
        data[offset + 20] ^= 0x10
open(sys.argv[1], 'wb').write(data)
EOF
expect_failure "info on a corrupt EMBD" "corrupt.hlod: section 'EMBD' checksum mismatch" "$STRATA" info "$WORK/corrupt.hlod"
expect_failure "verify on a corrupt EMBD" "corrupt.hlod: section 'EMBD' checksum mismatch" "$STRATA" verify "$WORK/corrupt.hlod"

cat "$WORK/report.txt"
finish

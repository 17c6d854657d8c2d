#!/usr/bin/env bash
# Files as other programs write them (tests/data/meshes, each the same tetrahedron) build into models that
# verify; a quirk read past rather than refused is a warning naming the file and the line.
source "$(dirname "$0")/common.sh"
samples=$2/tests/data/meshes
for file in "$samples"/*.ply "$samples"/*.obj "$samples"/*.off "$samples"/*.stl; do
    name=$(basename "$file")
    expect_success "build $name" "$STRATA" build "$file" -o "$WORK/$name.hlod" -q
    checks=$((checks + 1))
    "$STRATA" info "$WORK/$name.hlod" | grep -q ": 4 vertices, 4 triangles" || fail "$name: the model is not the tetrahedron (4 vertices, 4 triangles)"
    expect_success "verify $name" "$STRATA" verify -q "$WORK/$name.hlod"
done
expect_success "Blender 2.47's header" "$STRATA" build "$samples/blender247_free_text_header.ply" -o "$WORK/b.hlod" -q
checks=$((checks + 1))
grep -q "warning: .*blender247_free_text_header.ply: PLY header line [0-9]*: skipped 'Created by Blender3D 247" "$WORK/err.txt" ||
    { fail "no warning for Blender's free-text header line:"; cat "$WORK/err.txt"; }
checks=$((checks + 1))
[ "$(grep -c warning "$WORK/err.txt")" -eq 1 ] || fail "more than one warning for one file"
finish

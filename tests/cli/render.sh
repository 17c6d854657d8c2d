#!/usr/bin/env bash
# strata render, headless: a .hlod beside a mesh into PNG and EXR (channels listed by exrheader), what
# each view option does to the pixels (read by tests/support/png_pixels.py), and bad input: missing
# file, bad extension, bad size, unknown channel, unwritable output.
source "$(dirname "$0")/common.sh"
sample=$2/data/bunny.off
[ -s "$sample" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$sample" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }
write_octahedron "$WORK/octa.off"

# Pixels are read back by tests/support/png_pixels.py (colours as --background takes them: linear).
root=$2
pixels() { python3 "$root/tests/support/png_pixels.py" "$@"; }
# check NAME ACTUAL EXPECTED: one check that ACTUAL (a number or words) is EXPECTED.
check() { checks=$((checks + 1)); [ "$2" = "$3" ] || fail "$1: got '$2', expected '$3'"; }
# check_that NAME CONDITION...: one check of an arithmetic condition, e.g. check_that "x" "$a > 3".
check_that() {
    local name=$1
    shift
    checks=$((checks + 1))
    (( $* )) || fail "$name: not $*"
}

expect_success "png" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/bunny.png" --size 200x150 --background 0,0,1,1 --samples 1
checks=$((checks + 1)); [ "$(head -c 8 "$WORK/bunny.png" | od -An -c | tr -d ' ')" = "211PNG\r\n032\n" ] || fail "not a PNG"
checks=$((checks + 1)); grep -q "triangles" "$WORK/out.txt" || fail "no summary printed"
check "--size" "$(pixels size "$WORK/bunny.png")" "200 150"
# Framed on the model: the centre pixel is the model, the corners exactly the background asked for, and
# the model's pixels lie inside the frame with room to spare.
for corner in "0 0" "199 0" "0 149" "199 149"; do
    check "corner $corner" "$(pixels pixel "$WORK/bunny.png" $corner)" "0 0 255 255"
done
checks=$((checks + 1)); [ "$(pixels pixel "$WORK/bunny.png" 100 75)" != "0 0 255 255" ] || fail "the centre pixel is background"
read -r x0 y0 x1 y1 covered <<<"$(pixels box "$WORK/bunny.png" 0,0,1,1)"
check_that "model framed" "$x0 > 0 && $y0 > 0 && $x1 < 199 && $y1 < 149 && $x0 < 100 && 100 < $x1 && $y0 < 75 && 75 < $y1"
check_that "model fills the frame" "$covered > 200 * 150 / 8"

expect_success "exr with a mesh and every channel" "$STRATA" render "$WORK/bunny.hlod" "$WORK/octa.off" -o "$WORK/frame.exr" \
    --size 160x120 --channels RGBA,Z,N,level,id --eye 0.1,0.2,0.5 --target 0,0.1,0 --fov 40 --pixel-error 2
expect_success "exr with depth only" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/depth.exr" --size 48x40 --channels Z
if command -v exrheader >/dev/null; then
    # exactly the channels asked for, in the size asked for
    exr_channels() { exrheader "$1" | sed -n '/^channels/,/^[a-z]/p' | sed -n 's/^ *\([A-Za-z.]*\), .*/\1/p' | sort | tr '\n' ' '; }
    exr_window() { exrheader "$1" | sed -n 's/^dataWindow.*: *\(.*\)$/\1/p'; }
    check "channels RGBA,Z,N,level,id" "$(exr_channels "$WORK/frame.exr")" "A B G N.X N.Y N.Z R Z id level "
    check "channels Z" "$(exr_channels "$WORK/depth.exr")" "Z "
    check "exr size" "$(exr_window "$WORK/frame.exr")" "(0 0) - (159 119)"
    check "exr size, depth only" "$(exr_window "$WORK/depth.exr")" "(0 0) - (47 39)"
fi

# Each view option changes the picture the way it should. One sample a pixel, so that a pixel is one
# surface's colour, not a blend of it and the background.
small=(--size 96x72 --samples 1 -q)
expect_success "shaded" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/shaded.png" "${small[@]}"
checks=$((checks + 1)); [ ! -s "$WORK/out.txt" ] || fail "-q printed something"
expect_success "levels view" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/levels.png" "${small[@]}" --debug levels
expect_success "cube boxes" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/boxes.png" "${small[@]}" --boxes
# The residency view of a full-detail render: the same pixels covered (its colours: test_render.cpp).
expect_success "residency view" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/residency.png" "${small[@]}" --debug residency
check "residency view covers what the shaded view covers" "$(pixels box "$WORK/residency.png" 0,0,0,0)" "$(pixels box "$WORK/shaded.png" 0,0,0,0)"
expect_usage "unknown debug view" "--debug" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.png" "${small[@]}" --debug nosuch
# The levels view: the model's pixels are level-palette colours under the headlight, the shaded view's
# are not; the boxes: lines in the exact palette colours, which the shaded view never shows.
palette_source=$root/nodes/hlod_model_draw.cpp
read -r total tinted exact <<<"$(pixels palette "$WORK/shaded.png" 0,0,0,0 "$palette_source")"
check_that "shaded view has no level colours ($tinted of $total)" "$total > 500 && $tinted * 50 < $total && $exact == 0"
shaded_total=$total
read -r total tinted exact <<<"$(pixels palette "$WORK/levels.png" 0,0,0,0 "$palette_source")"
check_that "levels view in level colours ($tinted of $total)" "$total == $shaded_total && $tinted * 10 > $total * 9"
read -r total tinted exact <<<"$(pixels palette "$WORK/boxes.png" 0,0,0,0 "$palette_source")"
check_that "boxes drawn in level colours ($exact of $total)" "$exact > 100 && $total > $shaded_total"
# The wireframe of an octahedron (built as a one-level model): its outline, and the background inside
# its faces, where the shaded view has the surface.
"$STRATA" build "$WORK/octa.off" -o "$WORK/octa.hlod" -q || fail "octahedron build failed"
expect_success "octahedron shaded" "$STRATA" render "$WORK/octa.hlod" -o "$WORK/octa_shaded.png" "${small[@]}"
expect_success "octahedron wireframe" "$STRATA" render "$WORK/octa.hlod" -o "$WORK/octa_wire.png" "${small[@]}" --debug wireframe
read -r sx0 sy0 sx1 sy1 solid <<<"$(pixels box "$WORK/octa_shaded.png" 0,0,0,0)"
read -r wx0 wy0 wx1 wy1 lines <<<"$(pixels box "$WORK/octa_wire.png" 0,0,0,0)"
check "wireframe outline" "$wx0 $wy0 $wx1 $wy1" "$sx0 $sy0 $sx1 $sy1"
check_that "wireframe: lines ($lines pixels) over a solid of $solid" "$lines > 20 && $lines * 2 < $solid"
checks=$((checks + 1)); [ "$(pixels pixel "$WORK/octa_shaded.png" 48 36)" != "0 0 0 0" ] || fail "the shaded octahedron misses the centre"
check "wireframe: background inside a face" "$(pixels pixel "$WORK/octa_wire.png" 48 36)" "0 0 0 0"
# --no-morph: from close by (two levels drawn) the same triangles, drawn unmorphed: other pixels.
close_up=(--size 96x72 --samples 1 --eye 0.34,0.23,1.25 --target 0,0,0)
expect_success "morphed" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/morph.png" "${close_up[@]}"
# The draw calls are left out: one per run of cubes on one pool page, so they follow the order in
# which the loader threads happened to deliver the cubes, not what is drawn.
morphed_summary=$(sed 's/, [0-9]* draw calls//; s/, cull.*//' "$WORK/out.txt")
expect_success "without morph" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/no_morph.png" "${close_up[@]}" --no-morph
check "--no-morph draws the same cubes" "$(sed 's/, [0-9]* draw calls//; s/, cull.*//; s/no_morph/morph/' "$WORK/out.txt")" "$morphed_summary"
read -r differing _ <<<"$(pixels changed "$WORK/morph.png" "$WORK/no_morph.png" 0)"
check_that "--no-morph moves pixels ($differing)" "$differing > 0"

# --eye and --target: the same look moved right moves the model left in the picture, by about the
# move over the width the view spans at the model's distance; moved up, the model goes down.
view() { "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/$1.png" --size 160x120 --samples 1 --fov 40 --background 0,0,0,1 -q --eye "$2" --target "$3"; }
expect_success "eye and target" view look 0,0,3 0,0,0
expect_success "eye and target moved right" view right 0.25,0,3 0.25,0,0
expect_success "eye and target moved up" view up 0,0.25,3 0,0.25,0
read -r lx0 ly0 lx1 ly1 _ <<<"$(pixels box "$WORK/look.png" 0,0,0,1)"
read -r rx0 ry0 rx1 ry1 _ <<<"$(pixels box "$WORK/right.png" 0,0,0,1)"
read -r ux0 uy0 ux1 uy1 _ <<<"$(pixels box "$WORK/up.png" 0,0,0,1)"
# The model (about 1 across, at the origin) 3 away, 120 pixels spanning 2·3·tan 20° ≈ 2.18 there: a move
# of 0.25 is about 14 pixels (12 to 16 over the model's depth).
check_that "moved right: the model moves left ($lx0..$lx1 to $rx0..$rx1)" \
    "$lx0 - $rx0 >= 9 && $lx0 - $rx0 <= 17 && $lx1 - $rx1 >= 9 && $lx1 - $rx1 <= 17 && $ly0 - $ry0 <= 1 && $ry0 - $ly0 <= 1"
check_that "moved up: the model moves down ($ly0..$ly1 to $uy0..$uy1)" \
    "$uy0 - $ly0 >= 9 && $uy0 - $ly0 <= 17 && $uy1 - $ly1 >= 9 && $uy1 - $ly1 <= 17 && $ux0 - $lx0 <= 1 && $lx0 - $ux0 <= 1"

# --ortho: parallel projection. Two equal octahedra, one far behind the other: in perspective the far
# one is drawn smaller, in orthographic projection they are the same size.
awk 'NR == 3, NR == 8 { $1 += 4; $3 -= 12 } { print }' "$WORK/octa.off" >"$WORK/octa_far.off"
pair=("$WORK/octa.off" "$WORK/octa_far.off" --size 192x144 --samples 1 -q)
expect_success "two octahedra, perspective" "$STRATA" render "${pair[@]}" -o "$WORK/persp.png"
expect_success "two octahedra, orthographic" "$STRATA" render "${pair[@]}" -o "$WORK/ortho.png" --ortho
read -r near far extra <<<"$(pixels runs "$WORK/persp.png" 0,0,0,0)"
check_that "perspective: two objects, the far one smaller (${near:-} ${far:-} ${extra:-})" "${far:-0} > 0 && ${extra:-0} == 0 && $far * 10 < $near * 9"
read -r near far extra <<<"$(pixels runs "$WORK/ortho.png" 0,0,0,0)"
check_that "orthographic: two objects of one size (${near:-} ${far:-} ${extra:-})" "${far:-0} > 5 && ${extra:-0} == 0 && $far - $near <= 1 && $near - $far <= 1"

# --samples: multisampling smooths edges and leaves the rest of the picture alone.
expect_success "eight samples" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/samples8.png" --size 96x72 --samples 8 -q
read -r differing off_edge <<<"$(pixels changed "$WORK/shaded.png" "$WORK/samples8.png")"
check_that "samples change edge pixels ($differing) and no others ($off_edge)" "$differing > 20 && $off_edge == 0"

# Streaming: a render reads only what its view needs and waits for all of it, so the least budget that
# holds the view gives the default's very bytes.
expect_success "a small streaming budget" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/shaded16.png" "${small[@]}" --memory 16M
checks=$((checks + 1)); cmp -s "$WORK/shaded.png" "$WORK/shaded16.png" || fail "--memory 16M changed the image"
expect_usage "budget below the least" "less than the least, 16M" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.png" --memory 3M
expect_usage "budget not a size" "not a size" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.png" --memory 2X
expect_success "a GPU budget" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/shaded_gpu.png" "${small[@]}" --memory 64M --gpu-memory 16M
checks=$((checks + 1)); cmp -s "$WORK/shaded.png" "$WORK/shaded_gpu.png" || fail "--gpu-memory 16M changed the image"
expect_usage "GPU budget below the least" "--gpu-memory: '8M' is less than the least, 16M" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.png" --gpu-memory 8M

expect_failure "missing file" "missing.hlod" "$STRATA" render "$WORK/missing.hlod" -o "$WORK/x.png"
expect_usage "bad extension" ".png, .exr or .tif" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.jpg"
expect_usage "bad size" "WIDTHxHEIGHT" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.png" --size 12by3
expect_usage "unknown channel" "Q" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.exr" --channels RGBA,Q
expect_failure "unwritable output" "cannot write" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/octa.off/x.png" --size 32x32
checks=$((checks + 1)); [ -z "$(ls "$WORK" | grep '^x\.')" ] || fail "a failed render left $(ls "$WORK" | grep '^x\.')"
finish

#!/usr/bin/env bash
# strata render, headless: a .hlod beside a mesh into PNG and EXR (channels listed by exrheader), the
# debug views, and bad input: missing file, bad extension, bad size, unknown channel, unwritable output.
source "$(dirname "$0")/common.sh"
sample=$2/data/bunny.off
[ -s "$sample" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$sample" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }
write_octahedron "$WORK/octa.off"

expect_success "png" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/bunny.png" --size 200x150
checks=$((checks + 1)); [ "$(head -c 8 "$WORK/bunny.png" | od -An -c | tr -d ' ')" = "211PNG\r\n032\n" ] || fail "not a PNG"
checks=$((checks + 1)); grep -q "triangles" "$WORK/out.txt" || fail "no summary printed"
expect_success "exr with a mesh and every channel" "$STRATA" render "$WORK/bunny.hlod" "$WORK/octa.off" -o "$WORK/frame.exr" \
    --size 160x120 --channels RGBA,Z,N,level,id --eye 0.1,0.2,0.5 --target 0,0.1,0 --fov 40 --pixel-error 2
if command -v exrheader >/dev/null; then
    checks=$((checks + 1))
    exrheader "$WORK/frame.exr" >"$WORK/header.txt" || fail "exrheader cannot read the file"
    for channel in R G B A Z N.X N.Y N.Z level id; do
        grep -q "^ *$channel," "$WORK/header.txt" || fail "exrheader lists no channel $channel"
    done
fi
# Each view option changes the picture.
expect_success "shaded" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/shaded.png" --size 64x48 -q
checks=$((checks + 1)); [ ! -s "$WORK/out.txt" ] || fail "-q printed something"
expect_success "levels view" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/levels.png" --size 64x48 --debug levels -q
expect_success "cube boxes" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/boxes.png" --size 64x48 --boxes -q
expect_success "wireframe without morph" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/wire.png" --size 64x48 --debug wireframe --no-morph -q
expect_success "another target" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/target.png" --size 64x48 --target 0,0.15,0 -q
expect_success "orthographic" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/ortho.png" --size 64x48 --ortho -q
for view in levels boxes wire target ortho; do
    checks=$((checks + 1))
    cmp -s "$WORK/shaded.png" "$WORK/$view.png" && fail "$view.png is the same picture as shaded.png"
done

expect_failure "missing file" "missing.hlod" "$STRATA" render "$WORK/missing.hlod" -o "$WORK/x.png"
expect_usage "bad extension" ".png or .exr" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.jpg"
expect_usage "bad size" "WIDTHxHEIGHT" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.png" --size 12by3
expect_usage "unknown channel" "Q" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/x.exr" --channels RGBA,Q
expect_failure "unwritable output" "cannot write" "$STRATA" render "$WORK/bunny.hlod" -o "$WORK/octa.off/x.png" --size 32x32
checks=$((checks + 1)); [ -z "$(ls "$WORK" | grep '^x\.')" ] || fail "a failed render left $(ls "$WORK" | grep '^x\.')"
finish

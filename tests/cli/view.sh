#!/usr/bin/env bash
# strata view in a real GLFW window under Xvfb: opens a model beside a mesh, draws frames, quits by
# itself and writes the last one, which shows the model in the middle of the window (pixels read by
# tests/support/png_pixels.py); without a display it says so and fails cleanly.
source "$(dirname "$0")/common.sh"
sample=$2/data/bunny.off
[ -s "$sample" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
command -v Xvfb >/dev/null || { echo "Xvfb missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$sample" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }
write_octahedron "$WORK/octa.off"

expect_success "window" with_x 800x600 "$STRATA" view "$WORK/bunny.hlod" "$WORK/octa.off" \
    --size 320x240 --frames 5 --screenshot "$WORK/shot.png"
checks=$((checks + 1)); [ -s "$WORK/shot.png" ] || fail "no screenshot written"
checks=$((checks + 1)); grep -q "wheel zooms" "$WORK/out.txt" || fail "no help on the controls printed"
root=$2
pixels() { python3 "$root/tests/support/png_pixels.py" "$@"; }
checks=$((checks + 1)); [ "$(pixels size "$WORK/shot.png")" = "320 240" ] || fail "the screenshot is $(pixels size "$WORK/shot.png"), not 320x240"
# What the screenshot shows: with the panels hidden, the model framed in the middle on the background.
printf 'editor:panels(false)\n' >"$WORK/no_panels.lua"
expect_success "window without panels" with_x 800x600 "$STRATA" view "$WORK/bunny.hlod" \
    --size 320x240 --frames 5 --script "$WORK/no_panels.lua" --screenshot "$WORK/model.png"
# The bottom corners (the stats line is along the top) are the background, linear 0.06, 0.06, 0.07:
# 69, 69, 74 in 8-bit sRGB, give or take the rounding.
for corner in "0 239" "319 239"; do
    read -r r g b a <<<"$(pixels pixel "$WORK/model.png" $corner)"
    checks=$((checks + 1))
    (( r >= 68 && r <= 70 && g >= 68 && g <= 70 && b >= 73 && b <= 76 && a == 255 )) || fail "corner $corner is $r $g $b $a, not the background"
done
read -r _ _ _ _ centre <<<"$(pixels box "$WORK/model.png" at:0,239 107 80 213 160)"
checks=$((checks + 1))
(( ${centre:-0} > 106 * 80 / 2 )) || fail "the model covers ${centre:-0} of the 106x80 pixels in the middle of the screenshot"
# A script's frames shown in a window while it runs.
printf 'local strata = require "strata"\nlocal s = strata.scene()\ns:add(strata.load(arg[1]))\nlocal c = strata.camera{ width = 160, height = 120 }\nc:look_at({0, 0.1, 0.4}, s:bounds().center)\nfor i = 1, 3 do assert(strata.render(s, c):stats().triangles > 0) end\nprint("window script: ok")\n' >"$WORK/show.lua"
expect_success "run --window" with_x 800x600 "$STRATA" run --window "$WORK/show.lua" "$WORK/bunny.hlod"
checks=$((checks + 1)); grep -q "window script: ok" "$WORK/out.txt" || fail "the windowed script did not finish"
expect_failure "no display" "no display" env -u DISPLAY -u WAYLAND_DISPLAY "$STRATA" view "$WORK/bunny.hlod" --frames 1
expect_failure "missing file" "missing.hlod" with_x 640x480 "$STRATA" view "$WORK/missing.hlod" --frames 1
finish

#!/usr/bin/env bash
# strata view in a real GLFW window under Xvfb: opens a model beside a mesh, draws frames, quits by
# itself and writes the last one; without a display it says so and fails cleanly.
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
# A script's frames shown in a window while it runs.
printf 'local strata = require "strata"\nlocal s = strata.scene()\ns:add(strata.load(arg[1]))\nlocal c = strata.camera{ width = 160, height = 120 }\nc:look_at({0, 0.1, 0.4}, s:bounds().center)\nfor i = 1, 3 do assert(strata.render(s, c):stats().triangles > 0) end\nprint("window script: ok")\n' >"$WORK/show.lua"
expect_success "run --window" with_x 800x600 "$STRATA" run --window "$WORK/show.lua" "$WORK/bunny.hlod"
checks=$((checks + 1)); grep -q "window script: ok" "$WORK/out.txt" || fail "the windowed script did not finish"
expect_failure "no display" "no display" env -u DISPLAY -u WAYLAND_DISPLAY "$STRATA" view "$WORK/bunny.hlod" --frames 1
expect_failure "missing file" "missing.hlod" with_x 640x480 "$STRATA" view "$WORK/missing.hlod" --frames 1
finish

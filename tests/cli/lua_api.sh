#!/usr/bin/env bash
# strata run: the Lua API scripts in tests/lua (each asserts its own results), started from another
# directory; a scene one of them saved, run from yet another; and bad scripts: syntax error, runtime error, wrong argument types, missing files, each
# with file:line, a non-zero exit and no crash.
source "$(dirname "$0")/common.sh"
root=$2
[ -s "$root/data/bunny.off" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$root/data/bunny.off" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }
cd "$WORK"
for script in "$root"/tests/lua/*.lua; do
    expect_success "$(basename "$script")" "$STRATA" run "$script" "$WORK/bunny.hlod" "$WORK" "$root/data/bunny.off"
    checks=$((checks + 1)); grep -q ": ok$" "$WORK/out.txt" || fail "$(basename "$script") did not finish"
done

# The scene save_scene_api.lua saved, run from elsewhere by `strata run` and `strata shell`: its files are
# found beside it.
cd /
expect_success "saved scene runs" "$STRATA" run "$WORK/scene_project/scene.lua"
expect_success "saved scene in the shell" "$STRATA" shell "$WORK/scene_project/scene.lua" \
    <<<'print(scene:find("bunny"):info().pixel_error, #bookmarks, paths.tour:duration() > 0)'
checks=$((checks + 1)); grep -q "^2.0	2	true$" "$WORK/out.txt" || fail "saved scene in the shell: $(cat "$WORK/out.txt")"
cd "$WORK"

# Arguments and modules beside the script.
mkdir -p "$WORK/proj"
printf 'return { twice = function(x) return 2 * x end }\n' >"$WORK/proj/helper.lua"
printf 'local h = require "helper"\nprint(select("#", ...), arg[0] ~= nil, arg[2], h.twice(21))\n' >"$WORK/proj/main.lua"
expect_success "args and require" "$STRATA" run "$WORK/proj/main.lua" a --flag
checks=$((checks + 1)); grep -q "^2	true	--flag	42$" "$WORK/out.txt" || fail "args/require: $(cat "$WORK/out.txt")"

printf 'local x = = 1\n' >"$WORK/syntax.lua"
expect_failure "syntax error" "syntax.lua:1:" "$STRATA" run "$WORK/syntax.lua"
printf 'local t = nil\nprint(t.field)\n' >"$WORK/runtime.lua"
expect_failure "runtime error" "runtime.lua:2:" "$STRATA" run "$WORK/runtime.lua"
checks=$((checks + 1)); grep -q "stack traceback" "$WORK/err.txt" || fail "no traceback"
printf 'local strata = require "strata"\nstrata.camera():look_at({1, 2}, {0, 0, 0})\n' >"$WORK/types.lua"
expect_failure "wrong argument type" "bad argument #1 to 'look_at' ({x, y, z} (3 finite numbers) expected, got a table of 2 values)" \
    "$STRATA" run "$WORK/types.lua"
printf 'local strata = require "strata"\nstrata.load(42)\nstrata.load("missing.hlod")\n' >"$WORK/load.lua"
printf 'local strata = require "strata"\nstrata.load("%s/missing.hlod")\n' "$WORK" >"$WORK/missing.lua"
expect_failure "missing model" "missing.lua:2:.*missing.hlod" "$STRATA" run "$WORK/missing.lua"
printf 'local strata = require "strata"\nstrata.transform{ translat = {1, 2, 3} }\n' >"$WORK/typo.lua"
expect_failure "unknown option" "unknown option 'translat'" "$STRATA" run "$WORK/typo.lua"
expect_failure "missing script" "cannot open" "$STRATA" run "$WORK/nothing.lua"
# ffmpeg out of reach: the video call says what to install (video_api.lua left its frames in $WORK).
printf 'require("strata").video{ frames = "%s/f%%03d.png", output = "%s/no.mp4" }\n' "$WORK" "$WORK" >"$WORK/noffmpeg.lua"
expect_failure "ffmpeg missing" "install Debian's ffmpeg package" env PATH=/nonexistent "$STRATA" run "$WORK/noffmpeg.lua"
checks=$((checks + 1)); [ ! -e "$WORK/no.mp4" ] || fail "a failed video left its file"
finish

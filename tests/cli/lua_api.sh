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

# Scripts that crashed strata (a signal) before: each is a Lua error now, exit status exactly 1, with a message.
expect_status_1() {  # NAME PATTERN SCRIPT-TEXT
    checks=$((checks + 1))
    printf '%s\n' "$3" >"$WORK/crash.lua"
    "$STRATA" run "$WORK/crash.lua" >"$WORK/out.txt" 2>"$WORK/err.txt"
    local status=$?
    [ $status -eq 1 ] || { fail "$1: exit status $status, not 1"; cat "$WORK/err.txt"; return; }
    grep -qF -- "$2" "$WORK/err.txt" || { fail "$1: stderr lacks '$2':"; cat "$WORK/err.txt"; }
}
# getmetatable gives the type's name (a string, with no __gc); through debug, the finalizer checks its argument.
expect_status_1 "finalizer called by hand" "attempt to call a nil value (field '__gc')" \
    'getmetatable(strata.scene()).__gc(1)'
expect_status_1 "finalizer through debug" "bad argument #1 to '__gc' (strata.Node expected, got number)" \
    'debug.getmetatable(strata.scene()).__gc(1)'
expect_status_1 "callback raising nothing" "on_progress: (error object is a nil value)" \
    "strata.build{input = \"$root/data/bunny.off\", output = \"$WORK/x.hlod\", on_progress = function() error() end}"
checks=$((checks + 1)); [ ! -e "$WORK/x.hlod" ] || fail "a cancelled build left its output"
expect_status_1 "printf pattern" "frame pattern '/tmp/%s%s%s%n'" \
    'strata.video{frames = "/tmp/%s%s%s%n", output = "'"$WORK"'/x.mp4"}'
# strata.build with tiles and a memory ceiling: a list of files (the octahedron's halves, which share
# their equator) builds one closed model; bad memory values and a ceiling too low are errors naming them.
printf 'OFF\n6 4 0\n1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n' >"$WORK/top.off"
printf 'OFF\n6 4 0\n1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n' >"$WORK/bottom.off"
cat >"$WORK/tiles.lua" <<EOF
local strata = require "strata"
local stats = strata.build{ input = { "$WORK/top.off", "$WORK/bottom.off" }, output = "$WORK/octa.hlod", memory = "1G" }
assert(stats.triangles == 8, stats.triangles)
assert(stats.memory_estimate > 0 and stats.memory_estimate < 2^30, stats.memory_estimate)
assert(strata.build{ input = "$WORK/top.off", output = "$WORK/top.hlod", memory = 1 << 30 }.triangles == 4)
print("tiles: ok")
EOF
expect_success "build tiles from Lua" "$STRATA" run "$WORK/tiles.lua"
checks=$((checks + 1)); grep -q "^tiles: ok$" "$WORK/out.txt" || fail "build tiles from Lua did not finish"
expect_success "verify Lua tiles" "$STRATA" verify "$WORK/octa.hlod"
checks=$((checks + 1)); grep -q "every level closed" "$WORK/out.txt" || fail "the Lua tiles did not weld into a closed model"
expect_status_1 "bad memory size" "option 'memory': '2 GB' is not a size in bytes" \
    "strata.build{input = \"$WORK/top.off\", output = \"$WORK/m.hlod\", memory = \"2 GB\"}"
expect_status_1 "memory ceiling" "memory must be at least 16M" \
    "strata.build{input = \"$WORK/top.off\", output = \"$WORK/m.hlod\", memory = \"1k\"}"
checks=$((checks + 1)); [ ! -e "$WORK/m.hlod" ] || fail "a refused build left its output"
expect_status_1 "input list of numbers" "option 'input': item 2 must be a string" \
    "strata.build{input = {\"$WORK/top.off\", 3}, output = \"$WORK/m.hlod\"}"
expect_status_1 "several inputs, no output" "option 'output' is required when 'input' names several files" \
    "strata.build{input = {\"$WORK/top.off\", \"$WORK/bottom.off\"}}"
# Error values that are not strings, at the top level.
expect_status_1 "error()" "(error object is a nil value)" 'error()'
expect_status_1 "error({})" "(error object is a table value)" 'error({})'
expect_status_1 "__tostring returning a table" "(error object is a table value whose __tostring failed)" \
    'error(setmetatable({}, {__tostring = function() return {} end}))'
expect_status_1 "__tostring raising" "(error object is a table value whose __tostring failed)" \
    'error(setmetatable({}, {__tostring = function() error("inner") end}))'
expect_status_1 "__tostring" "a described error" 'error(setmetatable({}, {__tostring = function() return "a described error" end}))'
expect_status_1 "the registry" "debug.getregistry is not available in strata" 'debug.getregistry()["strata.Node"] = {}'
# The shell and the editor's console print such errors too, and go on.
checks=$((checks + 1))
printf 'error(setmetatable({}, {__tostring = function() return {} end}))\nerror()\nprint("still here")\n' |
    "$STRATA" shell >"$WORK/out.txt" 2>"$WORK/err.txt"
status=$?
[ $status -lt 128 ] || fail "shell died with status $status"
grep -q "still here" "$WORK/out.txt" "$WORK/err.txt" || fail "the shell stopped after an error value: $(cat "$WORK/err.txt")"
grep -qF "whose __tostring failed" "$WORK/out.txt" "$WORK/err.txt" || fail "the shell did not report the error value"
finish

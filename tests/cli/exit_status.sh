#!/usr/bin/env bash
# Exit statuses are part of the interface (README, "Exit status"): 0 success, 1 bad input or I/O failure,
# 2 wrong arguments, 130 interrupted. Each command's failure modes, with the exact status and the message.
source "$(dirname "$0")/common.sh"
write_octahedron "$WORK/octa.off"
"$STRATA" build "$WORK/octa.off" -o "$WORK/octa.hlod" -q || { echo "build failed"; exit 1; }
printf 'not a model\n' >"$WORK/bad.hlod"
out=$WORK/out.hlod

# The command line itself.
expect_usage "no command" "subcommand is required" "$STRATA"
expect_usage "unknown command" "unknown command 'nosuch'" "$STRATA" nosuch
expect_usage "unknown option" "bogus" "$STRATA" build "$WORK/octa.off" -o "$out" --bogus
expect_status "help" 0 "" "$STRATA" --help
expect_status "a command's help" 0 "" "$STRATA" render --help

# build: every setting out of range is a wrong argument, refused before the input is read.
expect_usage "build: no input" "input is required" "$STRATA" build
expect_usage "build: no output" "output is required" "$STRATA" build "$WORK/octa.off"
expect_usage "build: --block 6" "block must be a multiple of 4" "$STRATA" build "$WORK/octa.off" -o "$out" --block 6
expect_usage "build: --ratio 2" "ratio must lie strictly between 0 and 1" "$STRATA" build "$WORK/octa.off" -o "$out" --ratio 2
expect_usage "build: --sigma0 0.7" "sigma0 must lie in" "$STRATA" build "$WORK/octa.off" -o "$out" --sigma0 0.7
expect_usage "build: --levels 99" "levels must be auto or 0..15" "$STRATA" build "$WORK/octa.off" -o "$out" --levels 99
expect_usage "build: --levels many" "levels takes 'auto' or a number" "$STRATA" build "$WORK/octa.off" -o "$out" --levels many
expect_usage "build: --threads -1" "threads must be 0" "$STRATA" build "$WORK/octa.off" -o "$out" --threads -1
expect_usage "build: --error -3" "error must be positive" "$STRATA" build "$WORK/octa.off" -o "$out" --error -3
expect_usage "build: --ratio abc" "ratio" "$STRATA" build "$WORK/octa.off" -o "$out" --ratio abc
expect_usage "build: --memory 2X" "--memory: '2X' is not a size in bytes" "$STRATA" build "$WORK/octa.off" -o "$out" --memory 2X
expect_usage "build: --memory 0" "'0' is not a size in bytes" "$STRATA" build "$WORK/octa.off" -o "$out" --memory 0
expect_usage "build: --memory before a missing input" "memory" "$STRATA" build "$WORK/missing.off" -o "$out" --memory -1G
expect_usage "build: --memory below what the buffers need" "memory must be at least 16M" "$STRATA" build "$WORK/octa.off" -o "$out" --memory 1k
expect_success "build: under --memory" "$STRATA" build "$WORK/octa.off" -o "$WORK/fits.hlod" -q --memory 1.5G
expect_usage "build: settings before a missing input" "block" "$STRATA" build "$WORK/missing.off" -o "$out" --block 6
expect_failure "build: missing input" "missing.off: cannot open" "$STRATA" build "$WORK/missing.off" -o "$out"
expect_failure "build: unwritable output" "cannot create the output file" "$STRATA" build "$WORK/octa.off" -o "$WORK/no/dir/x.hlod"
checks=$((checks + 1)); [ ! -e "$out" ] || fail "a refused build left $out"

# info and verify.
expect_usage "info: no file" "file is required" "$STRATA" info
expect_usage "info: two files" "not expected" "$STRATA" info "$WORK/octa.hlod" "$WORK/octa.hlod"
expect_failure "info: missing file" "missing.hlod: cannot open" "$STRATA" info "$WORK/missing.hlod"
expect_failure "info: not a model" "bad.hlod: too short to be a .hlod file" "$STRATA" info "$WORK/bad.hlod"
expect_usage "verify: no file" "file is required" "$STRATA" verify
expect_failure "verify: not a model" "bad.hlod: too short" "$STRATA" verify "$WORK/bad.hlod"
expect_status "verify: a good model" 0 "" "$STRATA" verify -q "$WORK/octa.hlod"

# render.
png=$WORK/x.png
expect_usage "render: no output" "output is required" "$STRATA" render "$WORK/octa.hlod"
expect_usage "render: bad extension" ".png, .exr or .tif" "$STRATA" render "$WORK/octa.hlod" -o "$WORK/x.jpg"
expect_usage "render: --size 0x0" "WIDTHxHEIGHT" "$STRATA" render "$WORK/octa.hlod" -o "$png" --size 0x0
expect_usage "render: --size 12by3" "WIDTHxHEIGHT" "$STRATA" render "$WORK/octa.hlod" -o "$png" --size 12by3
expect_usage "render: --eye of two numbers" "eye" "$STRATA" render "$WORK/octa.hlod" -o "$png" --eye 1,2
expect_usage "render: --fov 500" "fov" "$STRATA" render "$WORK/octa.hlod" -o "$png" --fov 500
expect_usage "render: --samples 3" "samples" "$STRATA" render "$WORK/octa.hlod" -o "$png" --samples 3
expect_usage "render: --pixel-error -1" "must be a number above 0, not '-1'" "$STRATA" render "$WORK/octa.hlod" -o "$png" --pixel-error -1
expect_usage "render: --debug foo" "debug" "$STRATA" render "$WORK/octa.hlod" -o "$png" --debug foo
expect_usage "render: unknown channel" "Q" "$STRATA" render "$WORK/octa.hlod" -o "$WORK/x.exr" --channels RGBA,Q
expect_usage "render: unknown compression" "unknown EXR compression" "$STRATA" render "$WORK/octa.hlod" -o "$WORK/x.exr" --compression foo
expect_failure "render: missing model" "missing.hlod: cannot open" "$STRATA" render "$WORK/missing.hlod" -o "$png"
expect_failure "render: not a model" "bad.hlod: too short" "$STRATA" render "$WORK/bad.hlod" -o "$png"
checks=$((checks + 1)); [ ! -e "$png" ] || fail "a refused render left $png"

# view (no window opens for these: the arguments or the files are refused first, or there is no display).
expect_usage "view: no file" "files is required" "$STRATA" view
expect_usage "view: --size 0x0" "WIDTHxHEIGHT" "$STRATA" view "$WORK/octa.hlod" --size 0x0
expect_usage "view: --frames 0" "must be a number above 0" "$STRATA" view "$WORK/octa.hlod" --frames 0
expect_failure "view: no display" "no display" env -u DISPLAY -u WAYLAND_DISPLAY "$STRATA" view "$WORK/octa.hlod" --frames 1

# run and shell: a failing script is bad input; os.exit keeps the script's own status.
printf 'error("boom")\n' >"$WORK/boom.lua"
printf 'error({})\n' >"$WORK/table_error.lua"
printf 'os.exit(3)\n' >"$WORK/exit3.lua"
printf 'local x = \n' >"$WORK/syntax.lua"
expect_usage "run: no script" "script is required" "$STRATA" run
expect_failure "run: missing script" "missing.lua" "$STRATA" run "$WORK/missing.lua"
expect_failure "run: a runtime error" "boom.lua:1: boom" "$STRATA" run "$WORK/boom.lua"
expect_failure "run: a syntax error" "syntax.lua:2:" "$STRATA" run "$WORK/syntax.lua"
expect_failure "run: an error that is a table" "table_error.lua" "$STRATA" run "$WORK/table_error.lua"
expect_status "run: os.exit(3)" 3 "" "$STRATA" run "$WORK/exit3.lua"
expect_failure "shell: missing scene" "missing.lua" "$STRATA" shell "$WORK/missing.lua"
finish

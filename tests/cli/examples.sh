#!/usr/bin/env bash
# The example scripts in scripts/ on the bundled sample, small: they finish, write what they say, and
# batch_build skips what is up to date.
source "$(dirname "$0")/common.sh"
root=$2
[ -s "$root/data/bunny.off" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
mkdir -p "$WORK/scans" && cp "$root/data/bunny.off" "$WORK/scans/" && write_octahedron "$WORK/scans/octa.off"

expect_success "batch_build" "$STRATA" run "$root/scripts/batch_build.lua" "$WORK/scans" "$WORK/models"
checks=$((checks + 1)); grep -q "2 built, 0 up to date" "$WORK/out.txt" || fail "batch_build: $(tail -1 "$WORK/out.txt")"
expect_success "batch_build again" "$STRATA" run "$root/scripts/batch_build.lua" "$WORK/scans" "$WORK/models"
checks=$((checks + 1)); grep -q "0 built, 2 up to date" "$WORK/out.txt" || fail "batch_build rerun: $(tail -1 "$WORK/out.txt")"

expect_success "lod_sweep" "$STRATA" run "$root/scripts/lod_sweep.lua" "$WORK/models/bunny.hlod" "$WORK/sweep.csv" 160x90
checks=$((checks + 1)); [ "$(wc -l <"$WORK/sweep.csv")" -eq 7 ] || fail "lod_sweep: $(cat "$WORK/sweep.csv")"

expect_success "orbit_capture" "$STRATA" run "$root/scripts/orbit_capture.lua" "$WORK/models/bunny.hlod" "$WORK/orbit" 8 96x64 8
checks=$((checks + 1)); [ -s "$WORK/orbit/orbit00007.exr" ] && [ -s "$WORK/orbit/orbit.mp4" ] || fail "orbit_capture wrote no frames or video"
expect_success "museum_flythrough" "$STRATA" run "$root/scripts/museum_flythrough.lua" "$WORK/models/bunny.hlod" \
    "$WORK/models/octa.hlod" "$WORK/museum" 1 96x54 8
checks=$((checks + 1)); [ -s "$WORK/museum/frame00008.exr" ] && [ -s "$WORK/museum/flythrough.mp4" ] && [ -s "$WORK/museum/tour.json" ] \
    || fail "museum_flythrough wrote no frames, video or path"
if command -v exrheader >/dev/null; then  # the frames hold exactly RGBA and Z
    checks=$((checks + 1))
    channels=$(exrheader "$WORK/museum/frame00000.exr" | grep -E "^ +[A-Z]+, " | awk -F, '{print $1}' | tr -d ' ' | sort | tr '\n' ' ')
    [ "$channels" = "A B G R Z " ] || fail "museum frame channels: '$channels'"
fi
finish

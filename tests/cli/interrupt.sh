#!/usr/bin/env bash
# Ctrl-C (SIGINT) during a build: exit status 130, a message, and no output file or temporary left.
# A build killed outright (SIGKILL) leaves no output either; `strata build --clean` removes what it left.
source "$(dirname "$0")/common.sh"
# 2 M triangles: big enough to still be building when the signal comes.
write_grid 1000 "$WORK/grid.off"
checks=$((checks + 1))
# One SIGINT to the process, as Ctrl-C sends it (timeout(1) would signal its whole group a second time).
"$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" >"$WORK/out.txt" 2>"$WORK/err.txt" &
pid=$!
# Signalled once it catches SIGINT (bit 2 of SigCgt in /proc): earlier, the default action would kill it
# (also status 130, but by the signal, with no message and no clean-up to test).
catches_sigint() { local mask; mask=$(awk '/^SigCgt:/ { print $2 }' /proc/$pid/status 2>/dev/null) && [ $((0x$mask & 2)) -ne 0 ]; }
for _ in $(seq 600); do catches_sigint && break; sleep 0.05; done
kill -INT $pid
wait $pid
status=$?
[ $status -eq 130 ] || fail "interrupted build exited $status, not 130: $(cat "$WORK/err.txt")"
checks=$((checks + 1))
grep -q "interrupted" "$WORK/err.txt" || fail "no 'interrupted' message"
checks=$((checks + 1))
[ -z "$(ls "$WORK" | grep grid.hlod)" ] || fail "left $(ls "$WORK" | grep grid.hlod)"

# SIGKILL once the build has its work folder: nothing can clean up, but no grid.hlod appears, and the
# work folder stays for --resume (tests/cli/resume.sh).
kill_when "$WORK/grid.hlod.build/lock" "$STRATA" build "$WORK/grid.off" -o "$WORK/grid.hlod" -q
checks=$((checks + 1))
[ -d "$WORK/grid.hlod.build" ] || fail "a killed build should leave its work folder: $(ls "$WORK")"
checks=$((checks + 1))
[ ! -e "$WORK/grid.hlod" ] || fail "a killed build left an output file"
# Another build's leftovers, still running (this shell), are kept.
touch "$WORK/grid.hlod.tmp-$$"
expect_success "clean after a kill" "$STRATA" build --clean "$WORK/grid.hlod"
checks=$((checks + 1))
[ "$(ls "$WORK" | grep grid.hlod)" = "grid.hlod.tmp-$$" ] || fail "--clean left or removed the wrong files: $(ls "$WORK")"
checks=$((checks + 1))
grep -q "removed $WORK/grid.hlod.build" "$WORK/out.txt" || fail "--clean does not say what it removed: $(cat "$WORK/out.txt")"
expect_usage "clean with an input" "takes the output's path alone" "$STRATA" build "$WORK/grid.off" --clean "$WORK/grid.hlod"
finish

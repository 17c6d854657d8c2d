# Shared by the CLI tests: $STRATA is the executable, $WORK a scratch directory removed on exit.
set -u
STRATA=$1
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
checks=0

fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect_failure NAME PATTERN CMD...: CMD exits non-zero (not by a signal) and says PATTERN on stderr.
expect_failure() {
    local name=$1 pattern=$2
    shift 2
    checks=$((checks + 1))
    "$@" >"$WORK/out.txt" 2>"$WORK/err.txt"
    local status=$?
    if [ $status -eq 0 ]; then fail "$name: exited 0"; return; fi
    if [ $status -ge 128 ]; then fail "$name: died with status $status"; cat "$WORK/err.txt"; return; fi
    if ! grep -q -- "$pattern" "$WORK/err.txt"; then fail "$name: stderr lacks '$pattern':"; cat "$WORK/err.txt"; fi
}

expect_success() {
    local name=$1
    shift
    checks=$((checks + 1))
    if ! "$@" >"$WORK/out.txt" 2>"$WORK/err.txt"; then fail "$name: exited non-zero"; cat "$WORK/err.txt"; fi
}

# A closed octahedron in OFF.
write_octahedron() {
    printf 'OFF\n6 8 0\n1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n' >"$1"
}

finish() {
    echo "$((checks - failures)) passed, $failures failed"
    [ $failures -eq 0 ]
}

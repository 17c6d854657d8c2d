# Shared by the CLI tests: $STRATA is the executable, $WORK a scratch directory removed on exit.
set -u
STRATA=$1
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
failures=0
checks=0

# with_x WxH CMD...: CMD on a private virtual X server of that size, whose display no other test shares.
WITH_XVFB="$(cd "$(dirname "${BASH_SOURCE[0]}")/../support" && pwd)/with_xvfb.sh"
with_x() {
    local size=$1
    shift
    bash "$WITH_XVFB" "${size}x24" "$@"
}

fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect_status NAME STATUS PATTERN CMD...: CMD exits with exactly STATUS and says PATTERN on stderr (if not "").
# Exit statuses are part of the interface (README): 1 bad input, 2 wrong arguments, 130 interrupted.
expect_status() {
    local name=$1 expected=$2 pattern=$3
    shift 3
    checks=$((checks + 1))
    "$@" >"$WORK/out.txt" 2>"$WORK/err.txt"
    local status=$?
    if [ $status -ne "$expected" ]; then
        fail "$name: exited $status, not $expected"
        cat "$WORK/err.txt"
        return
    fi
    [ -z "$pattern" ] && return
    if ! grep -q -- "$pattern" "$WORK/err.txt"; then fail "$name: stderr lacks '$pattern':"; cat "$WORK/err.txt"; fi
}

# expect_failure NAME PATTERN CMD...: CMD fails as on bad input (status 1) and says PATTERN on stderr.
expect_failure() {
    local name=$1
    shift
    expect_status "$name" 1 "$@"
}

# expect_usage NAME PATTERN CMD...: CMD refuses its arguments (status 2) and says PATTERN on stderr.
expect_usage() {
    local name=$1
    shift
    expect_status "$name" 2 "$@"
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

# write_grid N FILE: an N×N grid of quads (2·N² triangles) over a gentle wave, as OFF: a mesh of any size
# made in a second, for tests that need a build to take a while or to write a lot.
write_grid() {
    awk -v n="$1" 'BEGIN {
        print "OFF"; print (n + 1) * (n + 1), 2 * n * n, 0
        for (y = 0; y <= n; y++) for (x = 0; x <= n; x++) printf "%d %d %.4f\n", x, y, sin(x / 37) * cos(y / 23)
        for (y = 0; y < n; y++) for (x = 0; x < n; x++) {
            a = y * (n + 1) + x; printf "3 %d %d %d\n3 %d %d %d\n", a, a + 1, a + n + 2, a, a + n + 2, a + n + 1
        }
    }' >"$2"
}

# write_patch FILE [AMPLITUDE]: a bumpy square patch 400 m wide (40 × 40 quads of 10 m) around its own
# origin, bumps of AMPLITUDE metres (2), as OFF: a site with an open boundary to embed in a terrain.
write_patch() {
    awk -v amplitude="${2:-2}" 'BEGIN {
        n = 40; print "OFF"; print (n + 1) * (n + 1), 2 * n * n, 0
        for (y = 0; y <= n; y++) for (x = 0; x <= n; x++) printf "%d %d %.4f\n", 10 * x - 200, 10 * y - 200, amplitude * sin(x / 3) * cos(y / 4)
        for (y = 0; y < n; y++) for (x = 0; x < n; x++) {
            a = y * (n + 1) + x; printf "3 %d %d %d\n3 %d %d %d\n", a, a + 1, a + n + 2, a, a + n + 2, a + n + 1
        }
    }' >"$1"
}

# kill_when FILE CMD...: runs CMD in the background and kills it (SIGKILL) once FILE exists (or after
# a minute without it; the caller checks what it expects to find).
kill_when() {
    local file=$1
    shift
    "$@" >"$WORK/out.txt" 2>"$WORK/err.txt" &
    local pid=$!
    for _ in $(seq 3000); do [ -e "$file" ] && break; sleep 0.02; done
    kill -KILL $pid
    wait $pid 2>/dev/null
}

finish() {
    echo "$((checks - failures)) passed, $failures failed"
    [ $failures -eq 0 ]
}

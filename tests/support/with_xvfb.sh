#!/usr/bin/env bash
# with_xvfb.sh WxHxD CMD...: runs CMD with DISPLAY set to a private Xvfb, then stops the server and exits
# with CMD's status. The server picks a free display number itself (-displayfd) and says which once it
# accepts clients, so tests running side by side never race for one display: `xvfb-run -a` takes the first
# number without a lock file, and two runs started together take the same one (and one test's input then
# reaches the other's window, or its server fails to start).
set -u
command -v Xvfb >/dev/null || { echo "with_xvfb: Xvfb missing: run scripts/setup.sh" >&2; exit 1; }
geometry=$1
shift
dir=$(mktemp -d)
server=
cleanup() {
    [ -n "$server" ] && kill "$server" 2>/dev/null && wait "$server" 2>/dev/null
    rm -rf "$dir"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
mkfifo "$dir/display"
Xvfb -displayfd 3 -screen 0 "$geometry" -nolisten tcp 3>"$dir/display" 2>"$dir/log" &
server=$!
# The number arrives when the server is ready; end of file (no number) means it failed to start.
display=
read -r -t 120 display <"$dir/display"
if [ -z "$display" ]; then
    echo "with_xvfb: Xvfb did not start:" >&2
    cat "$dir/log" >&2
    exit 1
fi
DISPLAY=":$display" "$@"

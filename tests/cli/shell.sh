#!/usr/bin/env bash
# strata shell, typed into for real: in a tmux terminal (line editing, completion, multi-line input,
# errors that leave the prompt live, history kept across sessions), and fed from a pipe.
source "$(dirname "$0")/common.sh"
sample=$2/data/bunny.off
[ -s "$sample" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
command -v tmux >/dev/null || { echo "tmux missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$sample" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }

# Piped input: no prompt, expressions printed, an error reported and the rest still run.
printf 'x = 6 * 7\nx\nfunction sq(v)\n  return v * v\nend\nsq(9)\n{1, 2, k = {"v"}}\nerror("boom")\nprint("after")\n' \
    | "$STRATA" shell >"$WORK/piped.txt" 2>&1
checks=$((checks + 1))
[ "$(grep -v -e '^stack traceback' -e '^	' "$WORK/piped.txt")" = "$(printf '42\n81\n{ 1, 2, k = { "v" } }\nstdin:1: boom\nafter')" ] \
    || { fail "piped session printed:"; cat "$WORK/piped.txt"; }

# A scene script run first; its globals stay.
printf 'scene = strata.scene()\nbunny = strata.load("%s")\nbunny:name("bunny")\nscene:add(bunny)\n' \
    "$WORK/bunny.hlod" >"$WORK/scene.lua"
checks=$((checks + 1))
echo 'scene' | "$STRATA" shell "$WORK/scene.lua" 2>&1 | grep -q "strata.group 'scene' (1 child)" \
    || fail "the scene script's globals are not there"
expect_failure "bad scene script" "missing.lua" "$STRATA" shell "$WORK/missing.lua"

# The terminal session. tmux runs on its own socket so it never touches a user's server.
socket="strata-test-$$"
tmux_() { tmux -L "$socket" "$@"; }
trap 'tmux_ kill-server 2>/dev/null; rm -rf "$WORK"' EXIT
# A session that lives as long as the test keeps the server up: killing the last session makes tmux
# exit asynchronously, and a new-session that reaches the dying server fails ("server exited
# unexpectedly"), as CI saw.
tmux_ new-session -d -s hold -x 20 -y 5 cat
screen() { tmux_ capture-pane -p -t shell; }
# wait_for TEXT: polls the screen for a line containing TEXT, up to a minute (a busy machine is slow).
wait_for() {
    local i
    for i in $(seq 600); do
        screen | grep -qF -- "$1" && return 0
        sleep 0.1
    done
    return 1
}
# expect_screen NAME TEXT: TEXT shows on the screen within a minute.
expect_screen() {
    local name=$1 expected=$2
    checks=$((checks + 1))
    wait_for "$expected" || { fail "$name: the screen lacks '$expected':"; screen; }
}

tmux_ new-session -d -s shell -x 100 -y 40 "env STRATA_HISTORY=$WORK/history $STRATA shell $WORK/scene.lua; sleep 30"
expect_screen "banner" "Tab completes"
tmux_ send-keys -t shell '1 + 2' Enter
expect_screen "expression" "3"
# Completion of the API: strata.loa<Tab> → strata.load
tmux_ send-keys -t shell 'f = strata.loa' Tab
expect_screen "API completion" "strata> f = strata.load"
tmux_ send-keys -t shell C-u
# Completing runs no __index of the user's: one that fails leaves the shell alive.
tmux_ send-keys -t shell 't = setmetatable({}, { __index = function(_, k) error(k) end })' Enter
tmux_ send-keys -t shell 't.x.y' Tab C-u 'print(40 + 2)' Enter
expect_screen "completion past a failing __index" "42"
# Completion of a method on a node, then of a node name inside find("…").
tmux_ send-keys -t shell 'scene:fi' Tab '("bu' Tab '"):name()' Enter
expect_screen "node name completion" 'scene:find("bunny"):name()'
expect_screen "the found node" '"bunny"'
# Multi-line input: a continuation prompt until the function is closed.
tmux_ send-keys -t shell 'function cube(v)' Enter
expect_screen "continuation prompt" "...>"
tmux_ send-keys -t shell 'return v * v * v' Enter
# -l: literally, or tmux reads "end" as the End key.
tmux_ send-keys -t shell -l 'end'
tmux_ send-keys -t shell Enter 'cube(5)' Enter
expect_screen "multi-line function" "125"
# An error is shown and the prompt stays live.
tmux_ send-keys -t shell 'nosuch.field = 1' Enter
expect_screen "error shown" "attempt to index a nil value (global 'nosuch')"
tmux_ send-keys -t shell 'bunny' Enter
expect_screen "node printed" "strata.hlod 'bunny' ("
tmux_ send-keys -t shell C-d
checks=$((checks + 1))
for i in $(seq 600); do [ -s "$WORK/history" ] && break; sleep 0.1; done
grep -q "cube(5)" "$WORK/history" || fail "history not saved"
tmux_ kill-session -t shell

# History comes back: the up arrow recalls the last session's line.
tmux_ new-session -d -s shell -x 100 -y 40 "env STRATA_HISTORY=$WORK/history $STRATA shell $WORK/scene.lua; sleep 30"
expect_screen "second banner" "Tab completes"
tmux_ send-keys -t shell Up Enter
expect_screen "history recalled" "strata.hlod 'bunny' ("
tmux_ kill-session -t shell

# view() opens the editor on the scene while the prompt stays live: the window draws frames between
# keystrokes (its frame count grows while nothing is typed) and the REPL still answers.
# Each answer is awaited before the next line is typed, and the frame count is asked until it has grown.
if command -v Xvfb >/dev/null; then
    tmux_ new-session -d -s shell -x 100 -y 40 \
        "bash $WITH_XVFB 1400x900x24 env STRATA_HISTORY=$WORK/history $STRATA shell $WORK/scene.lua; sleep 30"
    expect_screen "banner with a display" "Tab completes"
    tmux_ send-keys -t shell 'ed = view()' Enter
    tmux_ send-keys -t shell 'print("opened: " .. tostring(ed:is_open()) .. " " .. tostring(ed:scene():find("bunny") ~= nil))' Enter
    expect_screen "the editor opened" "opened: true true"
    tmux_ send-keys -t shell 'n0 = ed:stats().frames' Enter
    checks=$((checks + 1))
    grown=
    for i in $(seq 120); do
        # The answer is told from the echoed line by its text: "grown 3: true" is not typed.
        tmux_ send-keys -t shell "print('grown ' .. $i .. ': ' .. tostring(ed:stats().frames - n0 > 5))" Enter
        wait_for "grown $i: " || break
        screen | grep -qF "grown $i: true" && { grown=1; break; }
        sleep 0.5
    done
    [ -n "$grown" ] || { fail "no frames drawn while the prompt waits:"; screen; }
    tmux_ send-keys -t shell 'print(6 * 7 .. "!")' Enter
    expect_screen "the prompt still answers" "42!"
    tmux_ send-keys -t shell 'ed:close()' Enter C-d
fi
finish

#!/usr/bin/env bash
# The editor driven by real input: xdotool sends clicks, a drag, keys and typing through the X server
# (Xvfb) to the GLFW window, so the whole path (X events → GLFW callbacks → ImGui or the navigator and
# picking) is what is tested. tests/editor/drive_input.lua checks each effect and paces the stages.
# The editor and xdotool must share one display, of their own: the script reruns itself on a private one.
if [ -z "${EDITOR_INPUT_UNDER_X:-}" ]; then
    command -v Xvfb >/dev/null || { echo "Xvfb missing: run scripts/setup.sh"; exit 1; }
    exec env EDITOR_INPUT_UNDER_X=1 bash "$(dirname "$0")/../support/with_xvfb.sh" 1400x900x24 bash "$0" "$@"
fi
source "$(dirname "$0")/common.sh"
root=$2
command -v xdotool >/dev/null || { echo "xdotool missing: run scripts/setup.sh"; exit 1; }
[ -s "$root/data/bunny.off" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$root/data/bunny.off" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }
cp "$root/tests/editor/scene.lua" "$WORK/scene.lua"
export WORK

"$STRATA" view "$WORK/scene.lua" --size 1280x720 --script "$root/tests/editor/drive_input.lua" \
    >"$WORK/out.txt" 2>"$WORK/err.txt" &
editor=$!

# await STAGE: the drive script is ready for the stage's input (false if the editor ended first).
await() {
    for _ in $(seq 600); do
        [ -e "$WORK/$1" ] && return 0
        kill -0 $editor 2>/dev/null || return 1
        sleep 0.1
    done
    return 1
}

# step STAGE CMD...: once the script is ready for STAGE, send its input.
step() {
    local stage=$1
    shift
    checks=$((checks + 1))
    if ! await "$stage"; then fail "the editor never got to the $stage stage"; return 1; fi
    "$@" || { fail "$stage: xdotool failed or the editor ended"; return 1; }
}

# frames_drawn: how many frames the drive script has drawn so far.
frames_drawn() { cat "$WORK/frames" 2>/dev/null || echo 0; }
# after_frames N: returns once the editor has drawn N more frames (input between them is seen apart).
after_frames() {
    local until=$(($(frames_drawn) + $1))
    for _ in $(seq 3000); do
        [ "$(frames_drawn)" -ge "$until" ] && return 0
        kill -0 $editor 2>/dev/null || return 1
        sleep 0.02
    done
    return 1
}

click_model() { xdotool mousemove --window "$window" 640 360 click 1; }
drag() {
    xdotool mousemove --window "$window" 640 200 mousedown 1 && after_frames 2 || return 1
    for x in 660 680 700 720; do xdotool mousemove --window "$window" "$x" 200 && after_frames 2 || return 1; done
    xdotool mouseup 1
}
fly_forward() { xdotool mousemove --window "$window" 640 300 key f keydown w && after_frames 3 && xdotool keyup w; }
type_line() {
    xdotool mousemove --window "$window" 640 700 click 1 && after_frames 2 &&
        xdotool type --delay 10 'nested_ok, nested_error = pcall(editor.frame, editor); typed = editor:selected():name()' &&
        xdotool key Return
}

window=$(timeout 60 xdotool search --sync --onlyvisible --name '^strata$' | head -1)
checks=$((checks + 1))
if [ -z "$window" ]; then
    fail "no editor window appeared"
else
    step click click_model && step drag drag && step fly fly_forward &&
        step tab xdotool key Tab && step "tab again" xdotool key Tab && step type type_line
fi
checks=$((checks + 1))
wait $editor || { fail "the editor exited non-zero:"; cat "$WORK/err.txt"; }
checks=$((checks + 1))
grep -q "editor input: ok" "$WORK/out.txt" || { fail "the input script did not finish"; cat "$WORK/out.txt"; }
finish

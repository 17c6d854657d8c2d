#!/usr/bin/env bash
# The editor (strata view) in a real GLFW window under Xvfb, driven by the Lua scripts in tests/editor
# through the `editor` object: panels and scene on screen, outliner, inspector, bookmarks, the path
# editor, the console; strata.view from a script; bad scene scripts.
source "$(dirname "$0")/common.sh"
root=$2
[ -s "$root/data/bunny.off" ] || { echo "sample missing: run scripts/setup.sh"; exit 1; }
command -v Xvfb >/dev/null || { echo "Xvfb missing: run scripts/setup.sh"; exit 1; }
"$STRATA" build "$root/data/bunny.off" -o "$WORK/bunny.hlod" -q || { echo "build failed"; exit 1; }
cp "$root/tests/editor/scene.lua" "$WORK/scene.lua"
export WORK
xvfb() { with_x 1400x900 "$@"; }

expect_success "panels" xvfb "$STRATA" view "$WORK/scene.lua" --script "$root/tests/editor/drive_panels.lua"
checks=$((checks + 1)); grep -q "editor panels: ok" "$WORK/out.txt" || { fail "the panel script did not finish"; cat "$WORK/out.txt"; }
checks=$((checks + 1)); [ -s "$WORK/editor.png" ] || fail "no screenshot"

# Picking and saving; the saved scene script reopens to the same state, and saves to the same text.
expect_success "pick and save" xvfb "$STRATA" view "$WORK/scene.lua" --script "$root/tests/editor/drive_save.lua"
checks=$((checks + 1)); grep -q "editor save: ok" "$WORK/out.txt" || { fail "the save script did not finish"; cat "$WORK/out.txt"; }
expect_success "reload" xvfb "$STRATA" view "$WORK/saved.lua" --script "$root/tests/editor/drive_reload.lua"
checks=$((checks + 1)); grep -q "editor reload: ok" "$WORK/out.txt" || { fail "the reload script did not finish"; cat "$WORK/out.txt"; }
checks=$((checks + 1)); cmp -s "$WORK/saved.lua" "$WORK/saved_again.lua" || { fail "saving the reloaded scene changed it:"; diff "$WORK/saved.lua" "$WORK/saved_again.lua"; }
# The saved script runs headless too.
printf 'dofile(arg[1])\nassert(scene:find("bunny3") and #bookmarks == 2 and paths.path)\nprint("headless reload: ok")\n' >"$WORK/headless.lua"
expect_success "headless reload" "$STRATA" run "$WORK/headless.lua" "$WORK/saved.lua"
checks=$((checks + 1)); grep -q "headless reload: ok" "$WORK/out.txt" || fail "the saved scene does not run headless"

# Files on the command line, a fixed number of frames, a screenshot of the window.
expect_success "files" xvfb "$STRATA" view "$WORK/bunny.hlod" --size 640x480 --frames 3 --screenshot "$WORK/files.png"
checks=$((checks + 1)); [ -s "$WORK/files.png" ] || fail "no screenshot of the files view"

# strata.view from `strata run`: the editor opens on the script's globals and the script drives it.
printf 'dofile(os.getenv("WORK") .. "/scene.lua")\nlocal ed = strata.view()\nassert(ed:frame(2))\nassert(ed:scene():find("bunny3"))\ned:close()\nprint("run view: ok")\n' >"$WORK/run_view.lua"
expect_success "strata.view from a script" xvfb "$STRATA" run "$WORK/run_view.lua"
checks=$((checks + 1)); grep -q "run view: ok" "$WORK/out.txt" || fail "strata.view from a script did not finish"

# Every editor method handed what it must refuse (tests/editor/abuse_editor.lua): Lua errors, no crash.
expect_success "editor abuse" xvfb "$STRATA" view "$WORK/scene.lua" --script "$root/tests/editor/abuse_editor.lua"
checks=$((checks + 1)); grep -q "abuse_editor: ok" "$WORK/out.txt" || { fail "the editor abuse script did not finish"; cat "$WORK/err.txt"; }

# A scene 100 000 groups deep, the model at the bottom: the outliner shows its first levels, frames
# draw and a click picks the model, on a few frames of C stack.
cat >"$WORK/deep.lua" <<LUA
scene = strata.scene()
local node = scene
for i = 1, 100000 do local g = strata.group{ name = "g" .. i }; node:add(g); node = g end
local bunny = strata.load("$WORK/bunny.hlod")
bunny:name("deep bunny")
node:add(bunny)
LUA
# The model streams in while the editor draws (it never waits): click each frame until the pick finds it.
printf 'editor:camera():frame(scene)\nlocal picked = false\nfor _ = 1, 1000 do\n  assert(editor:frame(1))\n  editor:click(320, 240)\n  picked = editor:selected() ~= nil and editor:selected():name() == "deep bunny"\n  if picked then break end\nend\nassert(picked, "the click did not pick the deep model")\nprint("deep: ok")\neditor:close()\n' >"$WORK/deep_drive.lua"
expect_success "a scene 100 000 levels deep" xvfb "$STRATA" view "$WORK/deep.lua" --size 640x480 --script "$WORK/deep_drive.lua"
checks=$((checks + 1)); grep -q "deep: ok" "$WORK/out.txt" || { fail "the deep scene's drive script did not finish"; cat "$WORK/out.txt" "$WORK/err.txt"; }

# Bad input: a scene script that fails, one without a scene, a driving script that fails.
printf 'scene = strata.scene()\nerror("broken scene")\n' >"$WORK/broken.lua"
expect_failure "failing scene script" "broken.lua:2: broken scene" xvfb "$STRATA" view "$WORK/broken.lua" --frames 1
printf 'local x = 1\n' >"$WORK/noscene.lua"
expect_failure "no scene global" "noscene.lua: 'scene' must be a strata node" xvfb "$STRATA" view "$WORK/noscene.lua" --frames 1
printf 'editor:close()\n' >"$WORK/closing.lua"
expect_failure "screenshot of a closed window" "shot.png: not written, the window was closed" xvfb "$STRATA" view "$WORK/scene.lua" --script "$WORK/closing.lua" --frames 1 --screenshot "$WORK/shot.png"
printf 'editor:select("missing")\n' >"$WORK/baddrive.lua"
expect_failure "failing drive script" "no node named 'missing'" xvfb "$STRATA" view "$WORK/scene.lua" --script "$WORK/baddrive.lua"
# The geographic read-out over a real DEM: the camera above a sample reads where GDAL puts it.
dem=$root/data/olinda_dem.tif
if [ -s "$dem" ]; then
    "$STRATA" build "$dem" -o "$WORK/olinda.hlod" -q || fail "terrain build failed"
    place=$(echo "60.5 20.5" | gdaltransform -t_srs EPSG:4326 "$dem" | awk '{printf "%.12f %.12f", $1, $2}')
    GEO_SAMPLE="$place $(echo "60 20" | GDAL_PAM_ENABLED=NO gdallocationinfo -valonly "$dem")" \
        expect_success "geographic read-out" xvfb "$STRATA" view "$WORK/olinda.hlod" --size 800x600 --script "$root/tests/editor/drive_geo.lua"
    checks=$((checks + 1)); grep -q "editor geo: ok" "$WORK/out.txt" || { fail "the geo script did not finish"; cat "$WORK/out.txt" "$WORK/err.txt"; }
    # Embeddings placed, moved and removed in the editor, on that terrain.
    write_patch "$WORK/patch.off"
    "$STRATA" build -q "$WORK/patch.off" --lock-boundary -o "$WORK/patch.hlod" || fail "site build failed"
    printf 'scene = strata.scene()\n' >"$WORK/empty.lua"
    expect_success "embeddings in the editor" xvfb "$STRATA" view "$WORK/empty.lua" --size 1280x720 --script "$root/tests/editor/drive_embed.lua"
    checks=$((checks + 1)); grep -q "editor embed: ok" "$WORK/out.txt" || { fail "the embedding script did not finish"; cat "$WORK/out.txt" "$WORK/err.txt"; }
fi
finish

-- Runs in `strata view saved.lua`: the scene drive_save.lua saved comes back as it was.
assert(editor:frame())
local loaded_pose = editor:camera():pose()
local scene = editor:scene()
for i = 1, 3 do assert(scene:find("bunny" .. i):type() == "hlod", "bunny" .. i) end
assert(scene:find("bunny1"):info().pixel_error == 2.5 and scene:find("bunny1"):info().morph == false)
assert(scene:find("place3"):visible() == false and scene:find("place1"):visible() == true)
local marks = editor:bookmarks()
assert(#marks == 2 and marks[1] == "overview" and marks[2] == "left side")
assert(editor:keys() == 3, "keys: " .. editor:keys())
assert(editor:duration() > 3.5)
assert(editor:go("overview"))
local pose = editor:camera():pose()
assert(math.abs(pose.position[1] - 0.3) < 1e-12 and math.abs(pose.position[3] - 0.5) < 1e-12)
-- Saving the reloaded state again gives the same script: nothing was lost or changed.
-- Keys that make no path are not saved silently dropped: saving fails and says why.
assert(editor:go("left side"))
editor:scrub(editor:duration())
editor:add_key()
editor:add_key()
local ok, message = pcall(editor.save, editor, os.getenv("WORK") .. "/never.lua")
assert(not ok and message:find("the path 'path' cannot be saved"), message)
editor:remove_key(5)
editor:remove_key(4)
local again = os.getenv("WORK") .. "/saved_again.lua"
editor:camera():set_pose(loaded_pose)
editor:save(again)
editor:close()
print("editor reload: ok")

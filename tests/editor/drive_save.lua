-- Picking, then an edited scene saved as a scene script (reopened by drive_reload.lua).
assert(editor:frame(2))
local cam = editor:camera()
local _, width, height = editor:screenshot()

-- Aim at the middle model with the others hidden: a click in the middle of the window picks it; a
-- click on the sky picks nothing.
local scene = editor:scene()
scene:find("place1"):visible(false)
scene:find("place3"):visible(false)
cam:look_at({ 0, 0.2, 2.5 }, { 0, 0, 0 })
assert(editor:frame())
-- Interactive frames converge as the streamed cubes arrive (bounded by frames drawn, not by time);
-- a click then hits what a full-detail frame draws.
local frames = 0
while not editor:stats().converged do
  assert(frames < 20000, "the view never converged: " .. editor:stats().frames_unconverged .. " frames")
  assert(editor:frame())
  frames = frames + 1
end
assert(editor:stats().frames_unconverged == 0)
local node, point, provisional = editor:click(width / 2, height / 2)
assert(node and node:name() == "bunny2", "picked " .. tostring(node))
assert(provisional == false, "a click on a converged view is final")
assert(editor:selected() == node)
assert(#point == 3)
assert(editor:stats().pick_ms >= 0)
cam:look_at({ 0, 0.2, 2.5 }, { 0, 3, 10 })  -- away from the models, up at the sky: nothing there
assert(editor:frame())
local sky = editor:click(10, 10)
assert(sky == nil and editor:selected() == nil, "picked " .. tostring(sky))
scene:find("place1"):visible(true)
scene:find("place3"):visible(true)
assert(not pcall(editor.click, editor, -1, 5), "a click outside the window must fail")

-- Edits: a setting, a hidden node, bookmarks, a path with a fixed segment.
editor:scene():find("bunny1"):set_lod{ pixel_error = 2.5, morph = false }
editor:scene():find("place3"):visible(false)
cam:look_at({ 0.3, 0.3, 0.5 }, { 0, 0.1, 0 })
editor:bookmark("overview")
editor:add_key()
cam:look_at({ -0.3, 0.2, 0.5 }, { 0, 0.1, 0 })
editor:bookmark("left side")
editor:add_key()
cam:look_at({ 0, 0.4, 0.1 }, { 0, 0.1, 0 })
editor:add_key()
editor:set_duration(2, 3.5)
assert(editor:frame())
local file = os.getenv("WORK") .. "/saved.lua"
editor:save(file)
assert(not pcall(editor.save, editor, "/nonexistent-folder/x.lua"))
editor:close()
print("editor save: ok")

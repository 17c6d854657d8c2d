-- Cameras and rendering from Lua: poses, look-at, framing, a rendered frame's pixels and statistics,
-- PNG and EXR output. arg[1] is a .hlod, arg[2] a folder to write in.
local strata = require "strata"
local hlod_path, out = assert(arg[1]), assert(arg[2])

local scene = strata.scene()
local model = strata.load(hlod_path)
scene:add(model)

local cam = strata.camera{ width = 200, height = 150, fov = 45 }
local b = scene:bounds()
cam:look_at({ b.center[1], b.center[2], b.center[3] + 1 }, b.center)
local f = cam:forward()
assert(math.abs(f[3] + 1) < 1e-9, "look_at points down -z")
cam:frame(scene)
local pose = cam:pose()
assert(#pose.orientation == 4 and pose.fov == 45)

-- The pose round-trips, and a target sets the orientation.
local other = strata.camera{ width = 200, height = 150 }
other:set_pose(pose)
local p2 = other:pose()
for i = 1, 3 do assert(math.abs(p2.position[i] - pose.position[i]) < 1e-12) end
other:set_pose{ position = { 0, 0, 5 }, target = { 0, 0, 0 } }
assert(math.abs(other:forward()[3] + 1) < 1e-9)

local frame = strata.render(scene, cam, { channels = "RGBA,Z,id", background = { 0, 0, 0, 0 } })
local w, h = frame:size()
assert(w == 200 and h == 150)
-- The middle of the frame is the model: opaque, at a finite depth, with the model's id; a corner is empty.
local r, g, bl, a, depth, id = frame:pixel(100, 75)
assert(a == 1 and depth > 0 and depth < 10 and id > 0, ("centre: a=%g depth=%g id=%d"):format(a, depth, id))
local _, _, _, a0, depth0, id0 = frame:pixel(0, 0)
assert(a0 == 0 and depth0 == math.huge and id0 == 0, "corner should be background")
local stats = frame:stats()
assert(stats.triangles > 0 and stats.cubes > 0 and stats.draw_calls >= 1 and stats.cull_ms >= 0)

-- A finer pixel error draws more triangles.
model:set_lod{ pixel_error = 8 }
local coarse = strata.render(scene, cam):stats().triangles
model:set_lod{ pixel_error = 0.25 }
local fine = strata.render(scene, cam):stats().triangles
assert(fine > coarse, ("fine %d, coarse %d"):format(fine, coarse))

frame:write(out .. "/frame.png")
frame:write(out .. "/frame.exr", { channels = { "RGBA", "Z" }, compression = "piz" })
assert(io.open(out .. "/frame.png", "rb") and io.open(out .. "/frame.exr", "rb"))
-- Written in the background: there after flush; a failure surfaces at flush.
frame:write(out .. "/async.exr", { channels = "RGBA,Z", async = true })
frame:write(out .. "/missing-dir/async.png", { async = true })
local flushed, flush_err = pcall(strata.flush)
assert(not flushed and flush_err:find("missing%-dir"), flush_err)
assert(io.open(out .. "/async.exr", "rb"), "the async frame was not written")
local ok, err = pcall(frame.write, frame, out .. "/frame.jpg")
assert(not ok and err:find("%.png or %.exr"), err)
ok, err = pcall(frame.write, frame, out .. "/x.exr", { channels = "RGBA,N" })
assert(not ok and err:find("N"), err)
print("render_api: ok")

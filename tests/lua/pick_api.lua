-- Picking from Lua: strata.pick(scene, camera, x, y) names the node drawn at a pixel, with the world
-- point, normal and distance, where the rendered frame has the same depth; the background and hidden
-- nodes give nil; bad arguments raise errors. Run by tests/cli/lua_api.sh: arg[1] is a .hlod.
local strata = require "strata"
local hlod_path = assert(arg[1], "usage: pick_api.lua MODEL.hlod")

local scene = strata.scene()
local model = strata.load(hlod_path, { pixel_error = 1, name = "bunny" })
local place = strata.transform{ translate = {1, 0, 0}, rotate = {0, 30, 10}, scale = 2 }
scene:add(place:add(model))
local cam = strata.camera{ width = 200, height = 150, fov = 45 }
local b = scene:bounds()
cam:look_at({ b.center[1] + 0.2, b.center[2] + 0.1, b.center[3] + 1 }, b.center)
cam:frame(scene)

local function dot(a, c) return a[1] * c[1] + a[2] * c[2] + a[3] * c[3] end
local function minus(a, c) return { a[1] - c[1], a[2] - c[2], a[3] - c[3] } end

-- The middle of the frame is the model: the pick is on it, at the frame's depth, facing the camera.
local frame = strata.render(scene, cam, { samples = 1, channels = "RGBA,Z,id" })
local _, _, _, _, depth, id = frame:pixel(100, 75)
assert(id > 0, "the model should cover the centre")
local hit = strata.pick(scene, cam, 100, 75)
assert(hit and hit.node == model and hit.node:name() == "bunny", "the centre picks the model")
local eye = cam:pose().position
local to_point = minus(hit.point, eye)
local view_depth = dot(to_point, cam:forward())
assert(math.abs(view_depth - depth) < 1e-4 * depth, ("pick depth %.9g, frame depth %.9g"):format(view_depth, depth))
assert(math.abs(math.sqrt(dot(to_point, to_point)) - hit.distance) < 1e-9 * hit.distance, "distance from the eye")
assert(math.abs(dot(hit.normal, hit.normal) - 1) < 1e-9 and dot(hit.normal, to_point) < 0, "a unit normal facing the eye")

-- The corner shows the background; a hidden model is not picked.
assert(strata.pick(scene, cam, 0, 0) == nil, "the corner is background")
model:visible(false)
assert(strata.pick(scene, cam, 100, 75) == nil, "hidden nodes are not picked")
model:visible(true)
assert(strata.pick(scene, cam, 100.9, 75.2).node == model, "a cursor position picks the pixel it is over")

-- Bad arguments.
local ok, err = pcall(strata.pick, scene, cam, 200, 75)
assert(not ok and err:find("bad argument #3 to '[%w.]*pick' %(outside the image%)"), err)
ok, err = pcall(strata.pick, cam, scene, 1, 1)
assert(not ok and err:find("bad argument #1 to '[%w.]*pick' %(strata.Node expected"), err)
ok, err = pcall(strata.pick, scene, cam, 1)
assert(not ok and err:find("bad argument #4 to '[%w.]*pick' %(number expected, got no value%)"), err)
print("pick_api: ok")

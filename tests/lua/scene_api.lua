-- The scene API from Lua: building graphs, transforms, names, visibility, user values, bounds,
-- finding and iterating nodes, HLOD settings. Run by tests/cli/lua_api.sh: arg[1] is a .hlod.
local strata = require "strata"
local hlod_path = assert(arg[1], "usage: scene_api.lua MODEL.hlod")

local scene = strata.scene()
assert(scene:type() == "group" and scene:name() == "scene" and scene:count() == 0)

local model = strata.load(hlod_path, { pixel_error = 2, name = "statue" })
assert(model:type() == "hlod" and model:name() == "statue")
local info = model:info()
assert(info.levels >= 2 and info.cubes >= 1 and info.triangles > 70000, "info: " .. info.triangles)
assert(info.pixel_error == 2 and info.morph == true)
model:set_lod{ kappa0 = 3, morph = false, debug = "levels", boxes = true }
assert(model:info().morph == false)
model:set_lod{ pixel_error = 0.5, morph = true, debug = "none", boxes = false }
assert(model:info().pixel_error == 0.5)

-- Transforms: translate · rotate · scale; the matrix is column-major.
local moved = strata.transform{ name = "moved", translate = {10, 0, 0}, rotate = {0, 90, 0}, scale = 2 }
moved:add(model)
scene:add(moved, strata.plane{ width = 4, depth = 4 }, strata.light{ direction = {0, -1, 0} }, strata.ambient{})
assert(scene:count() == 4)
local m = moved:matrix()
assert(math.abs(m[13] - 10) < 1e-12 and math.abs(m[1]) < 1e-12 and math.abs(m[3] + 2) < 1e-12, "matrix")

-- Bounds follow the transform: the model's box, turned, doubled and moved 10 along x.
local local_box, world_box = model:bounds(), moved:bounds()
assert(math.abs((world_box.max[1] - world_box.min[1]) - 2 * (local_box.max[3] - local_box.min[3])) < 1e-9)
assert(world_box.center[1] > 9 and world_box.center[1] < 11)
moved:set_transform{ translate = {0, 5, 0} }
assert(math.abs(moved:bounds().min[2] - (local_box.min[2] + 5)) < 1e-9)

-- Finding and iterating.
assert(scene:find("statue") == model, "find by name")
assert(scene:find("nothing") == nil)
local types = {}
for i, child in scene:children() do types[i] = child:type() end
assert(table.concat(types, ",") == "transform,geometry,light,ambient", table.concat(types, ","))
assert(scene:remove(moved) == true and scene:remove(moved) == false and scene:count() == 3)

-- Visibility and user values.
model:visible(false)
assert(model:visible() == false)
model:set("site", "Pompeii"); model:set("year", 79); model:set("scanned", true)
assert(model:get("site") == "Pompeii" and model:get("year") == 79 and model:get("scanned") == true)
assert(model:get("missing") == nil)

-- A cycle is refused with an error, not a hang.
local ok, err = pcall(function() moved:add(moved) end)
assert(not ok and err:find("contain itself"), err)
print("scene_api: ok")

-- strata.build of a terrain from Lua: a DEM takes `strata build DEM`'s options (the same model as the
-- CLI builds), draped imagery, the progress callback and cancelling; the options of the other kind of
-- input are refused by name. arg[2] is a folder to write in, arg[3] the bundled sample scan.
local strata = require "strata"
local out = assert(arg[2])
local scan = assert(arg[3], "usage: build_terrain_api.lua MODEL.hlod OUT_DIR SCAN")
local here = debug.getinfo(1, "S").source:match("^@(.*)/[^/]*$")
local dem, image = here .. "/../../data/olinda_dem.tif", here .. "/../../data/olinda_l7.tif"
if not io.open(dem) then error("data/olinda_dem.tif missing: run scripts/setup.sh") end

local stages = {}
local built = strata.build{
    input = dem, output = out .. "/olinda.hlod", cube_cells = 16, height_tolerance = 0.5, threads = 1,
    on_progress = function(stage) stages[stage:match("^%a+")] = true end,
}
assert(stages.read and stages.tiles, "no progress from the terrain's stages")
assert(built.output == out .. "/olinda.hlod" and built.triangles > 0 and built.levels >= 2)
-- The heights' lattice: the largest power-of-two step within twice the tolerance.
assert(built.height_quantum > 0.5 and built.height_quantum <= 1.0, built.height_quantum)
local model = strata.load(built.output)
local info = model:info()
assert(info.terrain and info.crs and info.triangles == built.triangles and info.texture_size == nil)
-- The raster's own heights stay exact whatever the tolerance: the centre's sample, found back.
local centre = model:to_local(model:to_geo{0, 0, 0})
assert(model:height_at{centre[1], centre[2]} ~= nil)

-- The defaults: heights within 1/128 of the spacing (90 m), on a lattice at most twice that.
local defaults = strata.build{ input = dem, output = out .. "/olinda_defaults.hlod" }
assert(defaults.texture_size == 0 and defaults.height_quantum > 89.99 / 128 and defaults.height_quantum <= 2 * 89.995 / 128,
       defaults.height_quantum)

-- Imagery draped, its bands and texture size as the CLI takes them.
local textured = strata.build{ input = dem, output = out .. "/olinda_textured.hlod", texture = image,
                               texture_bands = {3, 2, 1}, texture_size = 64, cube_cells = 16 }
assert(textured.texture_size == 64 and strata.load(textured.output):info().texture_size == 64)

-- Cancelling from the callback leaves nothing.
local ok, err = pcall(strata.build, { input = dem, output = out .. "/cancelled.hlod", on_progress = function() return false end })
assert(not ok and err:find("cancelled"), err)
assert(io.open(out .. "/cancelled.hlod") == nil, "a cancelled terrain build left its output")

-- Options of the other kind, and bad values, are refused by name.
local function refused(options, ...)
    local ok, err = pcall(strata.build, options)
    assert(not ok, "accepted")
    for _, part in ipairs{...} do assert(err:find(part, 1, true), err) end
end
refused({ input = dem, output = out .. "/x.hlod", levels = 3 }, "option 'levels' builds meshes", "olinda_dem.tif")
refused({ input = dem, output = out .. "/x.hlod", lock_boundary = true }, "option 'lock_boundary' builds meshes", "olinda_dem.tif")
refused({ input = scan, output = out .. "/x.hlod", cube_cells = 16 }, "option 'cube_cells' builds terrains", "bunny.off")
refused({ input = dem, output = out .. "/x.hlod", height_tolerance = 0 / 0 }, "height_tolerance")
refused({ input = dem, output = out .. "/x.hlod", height_tolerance = -1 }, "height_tolerance")
refused({ input = dem, output = out .. "/x.hlod", texture_size = 100, texture = image }, "texture_size", "power of two")
refused({ input = dem, output = out .. "/x.hlod", texture_bands = {3, 2} , texture = image }, "texture_bands")
refused({ input = dem, output = out .. "/x.hlod", texture_size = 64 }, "need 'texture'")
refused({ input = dem, output = out .. "/x.hlod", cube_cells = 33 }, "even")
refused({ input = dem, output = out .. "/x.hlod", frame = "utm" }, "utm")
refused({ input = dem, output = out .. "/x.hlod", texture = out .. "/missing.tif" }, "missing.tif")
assert(io.open(out .. "/x.hlod") == nil, "a refused build left its output")
print("build_terrain_api: ok")

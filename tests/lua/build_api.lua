-- strata.build from Lua: options, the progress callback, the returned statistics, cancelling from the
-- callback, and bad input. arg[2] is a folder to write in, arg[3] the bundled sample scan.
local strata = require "strata"
local out = assert(arg[2])
local scan = assert(arg[3], "usage: build_api.lua MODEL.hlod OUT_DIR SCAN")

local calls, stages = 0, {}
local stats = strata.build{
    input = scan, output = out .. "/built.hlod", levels = 2, threads = 1,
    on_progress = function(stage, done, total, unit)
        calls = calls + 1
        stages[stage:match("^%a+")] = true
        assert(type(done) == "number" and type(total) == "number" and type(unit) == "string")
    end,
}
assert(stats.output == out .. "/built.hlod" and stats.levels == 3 and stats.triangles == 75408, stats.triangles)
assert(stats.bytes > 0 and stats.seconds > 0 and stats.sigma0 > 0 and #stats.per_level == 3)
assert(stats.per_level[1].triangles == 75408 and stats.per_level[3].cubes == 1)
assert(calls > 0, "on_progress was never called")
local model = strata.load(stats.output)
assert(model:info().levels == 3)

-- resume = true with a complete output and no killed build to go on from: the output is left as it is.
local function read_all(path) local f = assert(io.open(path, "rb")); local s = f:read("a"); f:close(); return s end
local before = read_all(stats.output)
local again = strata.build{ input = scan, output = stats.output, levels = 2, threads = 1, resume = true }
assert(again.resumed == true and read_all(stats.output) == before, "resume rebuilt a complete output")
assert(stats.resumed == false)

-- lock_boundary: an open 16 × 16 grid keeps its 64 boundary points at every level, and says so; a
-- closed scan has none.
local grid = assert(io.open(out .. "/grid.off", "w"))
grid:write("OFF\n289 512 0\n")
for y = 0, 16 do for x = 0, 16 do grid:write(x / 16, " ", y / 16, " ", 0.05 * math.sin(x) * math.cos(y), "\n") end end
for y = 0, 15 do
    for x = 0, 15 do
        local a = y * 17 + x
        grid:write("3 ", a, " ", a + 1, " ", a + 18, "\n3 ", a, " ", a + 18, " ", a + 17, "\n")
    end
end
grid:close()
local locked = strata.build{ input = out .. "/grid.off", output = out .. "/grid.hlod", levels = 2, lock_boundary = true }
assert(locked.boundary_points == 64, tostring(locked.boundary_points))
assert(strata.build{ input = scan, output = out .. "/closed.hlod", levels = 2, lock_boundary = true }.boundary_points == 0)
assert(stats.boundary_points == nil, "a build without lock_boundary reports boundary points")

-- Returning false cancels: an error, and no file.
local ok, err = pcall(strata.build, { input = scan, output = out .. "/cancelled.hlod",
                                      on_progress = function() return false end })
assert(not ok and err:find("cancelled"), err)
assert(io.open(out .. "/cancelled.hlod") == nil, "a cancelled build left its output")

-- An error in the callback cancels too, and names the callback.
ok, err = pcall(strata.build, { input = scan, output = out .. "/failed.hlod",
                                on_progress = function() error("stop here") end })
assert(not ok and err:find("on_progress") and err:find("stop here"), err)
assert(io.open(out .. "/failed.hlod") == nil)

-- Bad input names the file; bad options name the option.
ok, err = pcall(strata.build, { input = out .. "/missing.ply" })
assert(not ok and err:find("missing.ply"), err)
ok, err = pcall(strata.build, { input = scan, levles = 3 })
assert(not ok and err:find("levles"), err)
ok, err = pcall(strata.build, { output = "x.hlod" })
assert(not ok and err:find("input"), err)
-- What the reader reads past is a warning, returned (and printed): Blender 2.47's free-text header line.
assert(#stats.warnings == 0, "the sample has no warnings")
local here = debug.getinfo(1, "S").source:match("^@(.*)/[^/]*$")
local blender = strata.build{ input = here .. "/../data/meshes/blender247_free_text_header.ply",
                              output = out .. "/blender.hlod" }
assert(#blender.warnings == 1 and blender.warnings[1]:find("blender247_free_text_header.ply: PLY header line %d+: skipped 'Created by Blender3D 247"),
       tostring(blender.warnings[1]))
print("build_api: ok")

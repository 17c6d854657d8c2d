-- A flight over a terrain built from a DEM (`strata build DEM.tif -o TERRAIN.hlod`): a loop around its
-- centre that keeps a height above the ground under it and ahead of it, read from the model's own heights
-- (model:height_at), never below the clearance asked for. Each frame is written as EXR (RGBA + Z) and PNG,
-- the PNGs make an MP4, and the flight is saved as a path (flight.json) with its start and end in
-- longitude and latitude.
--   strata run scripts/terrain_flythrough.lua TERRAIN.hlod OUT_DIR [SECONDS=8] [WxH=1280x720] [FPS=30] [CLEARANCE_M]
local strata = require "strata"
local terrain, out = arg[1], arg[2]
assert(terrain and out, "usage: strata run scripts/terrain_flythrough.lua TERRAIN.hlod OUT_DIR [SECONDS] [WxH] [FPS] [CLEARANCE_M]")
local seconds = tonumber(arg[3] or "8")
local width, height = (arg[4] or "1280x720"):match("^(%d+)x(%d+)$")
assert(width, "WxH must look like 1280x720, not " .. tostring(arg[4]))
local fps = tonumber(arg[5] or "30")
strata.mkdir(out)

local model = strata.load(terrain, { pixel_error = 1 })
assert(model:info().terrain, terrain .. ": not a terrain built from an elevation raster (strata build DEM.tif)")
local scene = strata.scene()
scene:add(model, strata.light{ direction = { -1, 0.5, -0.45 }, intensity = 1.1 }, strata.ambient{ color = { 0.12, 0.12, 0.14 } })

-- The loop: an ellipse at 30 % of the terrain's extent around its centre, in the model's frame (x east,
-- y north, z up, metres).
local b = model:bounds()
local cx, cy = b.center[1], b.center[2]
local rx, ry = 0.3 * (b.max[1] - b.min[1]), 0.3 * (b.max[2] - b.min[2])
local clearance = tonumber(arg[6] or tostring(math.max(30, (rx + ry) / 40)))
local frames = math.max(2, math.floor(seconds * fps + 0.5))
local function ground(x, y) return model:height_at{ x, y } end
local function around(t)  -- t in [0, 1): a point of the loop
    local a = 2 * math.pi * t
    return cx + rx * math.cos(a), cy + ry * math.sin(a)
end

-- The ground under each frame's point, the highest of it within a second of flight
-- either side (so the camera climbs before a ridge, not into it), smoothed, and never below the
-- clearance over the ground right under it (the low sun comes from the east, to bring the relief out). Where the raster has no height (nodata, off its edge), the
-- last height known stands.
local under, known = {}, b.min[3]
for i = 1, frames do
    local x, y = around((i - 1) / frames)
    local h = ground(x, y)
    if h then known = h end
    under[i] = known
end
local window = math.max(1, math.floor(fps))
local target_z = {}
for i = 1, frames do
    local highest = -math.huge
    for k = i - window, i + window do highest = math.max(highest, under[(k - 1) % frames + 1]) end
    target_z[i] = highest + clearance
end
local z = {}
for i = 1, frames do
    local sum = 0
    for k = i - window, i + window do sum = sum + target_z[(k - 1) % frames + 1] end
    z[i] = math.max(sum / (2 * window + 1), under[i] + clearance)
end

local cam = strata.camera{ width = tonumber(width), height = tonumber(height), fov = 55 }
local keys, lowest = {}, math.huge
for i = 1, frames do
    local x, y = around((i - 1) / frames)
    local ax, ay = around((i - 1) / frames + 0.06)  -- looking ahead along the loop and down at the ground there
    local ahead = ground(ax, ay) or under[i]
    cam:look_at({ x, y, z[i] }, { ax, ay, ahead }, { 0, 0, 1 })
    local frame = strata.render(scene, cam, { channels = "RGBA,Z", background = { 0.55, 0.68, 0.85, 1 } })
    frame:write(("%s/frame%05d.exr"):format(out, i - 1), { channels = "RGBA,Z", async = true })
    frame:write(("%s/frame%05d.png"):format(out, i - 1), { async = true })
    lowest = math.min(lowest, z[i] - under[i])
    if (i - 1) % fps == 0 then
        local pose = cam:pose()
        keys[#keys + 1] = { position = pose.position, orientation = pose.orientation, fov = pose.fov }
    end
end
strata.flush()  -- every frame on disk before the encoder reads them
strata.video{ frames = out .. "/frame%05d.png", output = out .. "/flythrough.mp4", fps = fps }
if #keys >= 2 then
    strata.path{ keys = keys, spline = "catmull-rom", orientation = "squad", duration = seconds, up = { 0, 0, 1 } }:save(out .. "/flight.json")
end

local function where(t)
    local x, y = around(t)
    local g = model:to_geo{ x, y, 0 }
    return ("%.6f°, %.6f°"):format(g[1], g[2])
end
print(("terrain_flythrough: %d frames in %s (frameNNNNN.exr: RGBA + Z), video %s/flythrough.mp4; "):format(frames, out, out) ..
      ("a loop from longitude, latitude %s round and back, at least %.1f m above the ground (asked %.1f m)"):format(where(0), lowest, clearance))

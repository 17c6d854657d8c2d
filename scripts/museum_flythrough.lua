-- A museum-style flythrough: two scans on plinths over a floor, a camera gliding around them along a
-- smooth constant-speed path that eases in and out, each frame written as EXR (RGBA + Z) for
-- publication and PNG for the MP4 made of them.
--   strata run scripts/museum_flythrough.lua SCAN_A.hlod SCAN_B.hlod OUT_DIR [SECONDS=8] [WxH=1280x720] [FPS=30]
local strata = require "strata"
local scan_a, scan_b, out = arg[1], arg[2], arg[3]
assert(scan_a and scan_b and out,
       "usage: strata run scripts/museum_flythrough.lua SCAN_A.hlod SCAN_B.hlod OUT_DIR [SECONDS] [WxH] [FPS]")
local seconds = tonumber(arg[4] or "8")
local width, height = (arg[5] or "1280x720"):match("(%d+)x(%d+)")
local fps = tonumber(arg[6] or "30")
strata.mkdir(out)

-- Each scan stands on the floor (y = 0), scaled to about one unit tall, one to each side.
local scene = strata.scene()
local function exhibit(path, x, turn)
    local model = strata.load(path, { pixel_error = 0.75 })
    local b = model:bounds()
    local scale = 1 / (b.max[2] - b.min[2])
    local place = strata.transform{ translate = { x, 0, 0 }, rotate = { 0, turn, 0 }, scale = scale }
    local centre = strata.transform{ translate = { -b.center[1], -b.min[2], -b.center[3] } }
    centre:add(model)
    place:add(centre)
    scene:add(place)
    return model
end
exhibit(scan_a, -1.1, 20)
exhibit(scan_b, 1.1, -35)
scene:add(strata.plane{ center = { 0, 0, 0 }, width = 8, depth = 8, color = { 0.35, 0.33, 0.3 } },
          strata.light{ direction = { -0.5, -1, -0.4 }, intensity = 1.1 },
          strata.ambient{ color = { 0.18, 0.18, 0.2 } })

-- The tour: in from the front, around the right exhibit, behind both, back round the left one.
local target = { 0, 0.5, 0 }
local path = strata.path{
    keys = {
        { position = { 0, 1.2, 4.0 }, target = target, fov = 45 },
        { position = { 2.6, 0.9, 1.6 }, target = { 1.1, 0.5, 0 }, fov = 40 },
        { position = { 1.5, 1.4, -2.6 }, target = target, fov = 45 },
        { position = { -2.4, 0.8, -1.2 }, target = { -1.1, 0.5, 0 }, fov = 38 },
        { position = { -1.2, 1.1, 3.2 }, target = target, fov = 45 },
    },
    spline = "catmull-rom", orientation = "look-at", speed = "constant", easing = "ease-in-out", duration = seconds,
}
path:save(out .. "/tour.json")

local cam = strata.camera{ width = tonumber(width), height = tonumber(height) }
local frames = 0
for i, pose in path:frames{ fps = fps } do
    cam:set_pose(pose)
    local frame = strata.render(scene, cam, { channels = "RGBA,Z", background = { 0.04, 0.04, 0.05, 1 } })
    frame:write(("%s/frame%05d.exr"):format(out, i - 1), { channels = "RGBA,Z", async = true })
    frame:write(("%s/frame%05d.png"):format(out, i - 1), { async = true })
    frames = i
end
strata.flush()  -- every frame on disk before the encoder reads them
strata.video{ frames = out .. "/frame%05d.png", output = out .. "/flythrough.mp4", fps = fps }
print(("museum_flythrough: %d frames in %s (frameNNNNN.exr: RGBA + Z), video %s/flythrough.mp4, path %s/tour.json")
      :format(frames, out, out, out))

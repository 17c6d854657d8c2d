-- Orbits a model and captures the frames: EXR (RGBA + Z) for publication, PNG for the MP4 made of them.
--   strata run scripts/orbit_capture.lua MODEL.hlod OUT_DIR [FRAMES] [WIDTHxHEIGHT] [FPS]
local strata = require "strata"
local path, out = arg[1], arg[2]
assert(path and out, "usage: strata run scripts/orbit_capture.lua MODEL.hlod OUT_DIR [FRAMES] [WIDTHxHEIGHT] [FPS]")
local frames = tonumber(arg[3] or "120")
local width, height = (arg[4] or "1280x720"):match("(%d+)x(%d+)")
local fps = tonumber(arg[5] or "30")
strata.mkdir(out)

local scene = strata.scene()
scene:add(strata.load(path, { pixel_error = 0.5 }))
scene:add(strata.light{ direction = { -0.4, -1, -0.6 } }, strata.ambient{ color = { 0.2, 0.2, 0.22 } })
local cam = strata.camera{ width = tonumber(width), height = tonumber(height), fov = 40 }
local b = scene:bounds()
local distance = 2.2 * b.radius

for i = 0, frames - 1 do
    local a = 2 * math.pi * i / frames
    cam:look_at({ b.center[1] + distance * math.sin(a), b.center[2] + 0.35 * distance, b.center[3] + distance * math.cos(a) },
                b.center)
    local frame = strata.render(scene, cam, { channels = "RGBA,Z", background = { 0.05, 0.05, 0.06, 1 } })
    frame:write(("%s/orbit%05d.exr"):format(out, i), { async = true })  -- written while the next frame renders
    frame:write(("%s/orbit%05d.png"):format(out, i), { async = true })
end
strata.flush()  -- every frame on disk before the encoder reads them
strata.video{ frames = out .. "/orbit%05d.png", output = out .. "/orbit.mp4", fps = fps }
print(("orbit_capture: %d frames and %s/orbit.mp4"):format(frames, out))

-- The capture benchmark (issue 4 §5): a flythrough of the sample scene written as EXR (RGBA half + Z),
-- per frame: the time inside strata.render (cull, draw, read-back) and the time outside it (Lua, and
-- handing the frame to the background writer, which encodes EXR while the next frame renders), with the
-- share outside rendering against its target (≤ 30 %).
--   strata run tests/bench/capture.lua MODEL.hlod OUT_DIR [FRAMES=300] [WIDTHxHEIGHT=1920x1080]
local strata = require "strata"
local path, out = arg[1], arg[2]
assert(path and out, "usage: strata run tests/bench/capture.lua MODEL.hlod OUT_DIR [FRAMES] [WIDTHxHEIGHT]")
local frames = tonumber(arg[3] or "300")
local width, height = (arg[4] or "1920x1080"):match("(%d+)x(%d+)")
strata.mkdir(out)

local scene = strata.scene()
scene:add(strata.load(path), strata.light{ direction = { -0.4, -1, -0.6 } })
local b = scene:bounds()
scene:add(strata.plane{ center = { b.center[1], b.min[2], b.center[3] }, width = 6 * b.radius, depth = 6 * b.radius })
local cam = strata.camera{ width = tonumber(width), height = tonumber(height), fov = 45 }

local render_s, outside_s, total_s = {}, {}, {}
local start = strata.now()
for i = 0, frames - 1 do
    local t0 = strata.now()
    local a = 2 * math.pi * i / frames
    local d = b.radius * (2.2 + 0.8 * math.cos(3 * a))
    cam:look_at({ b.center[1] + d * math.sin(a), b.center[2] + 0.4 * d, b.center[3] + d * math.cos(a) }, b.center)
    local t1 = strata.now()
    local frame = strata.render(scene, cam, { channels = "RGBA,Z" })
    local t2 = strata.now()
    -- Encoded and written on a background thread while the next frame renders.
    frame:write(("%s/f%05d.exr"):format(out, i), { channels = "RGBA,Z", async = true })
    local t3 = strata.now()
    render_s[#render_s + 1] = t2 - t1
    outside_s[#outside_s + 1] = (t1 - t0) + (t3 - t2)
    total_s[#total_s + 1] = t3 - t0
end
strata.flush()
local wall = strata.now() - start
local r, o, t = strata.summary(render_s), strata.summary(outside_s), strata.summary(total_s)
print(("frames: %d at %sx%s, %.1f s in all"):format(frames, width, height, wall))
print(("per frame: %.1f ms median (render %.1f ms, outside rendering %.1f ms), p95 %.1f ms"):format(
    t.median * 1e3, r.median * 1e3, o.median * 1e3, t.p95 * 1e3))
print(("outside rendering: %.0f %% of the frame time (target ≤ 30 %%)"):format(100 * o.mean / t.mean))

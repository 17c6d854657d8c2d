-- Sweeps the screen-space error of a model: for each pixel error, the triangles drawn and the frame
-- time (GPU) along an orbit, medians written to a CSV.
--   strata run scripts/lod_sweep.lua MODEL.hlod [OUT.csv] [WIDTHxHEIGHT]
local strata = require "strata"
local path = assert(arg[1], "usage: strata run scripts/lod_sweep.lua MODEL.hlod [OUT.csv] [WIDTHxHEIGHT]")
local csv = arg[2] or "lod_sweep.csv"
local width, height = (arg[3] or "1280x720"):match("(%d+)x(%d+)")

local scene = strata.scene()
local model = strata.load(path)
scene:add(model)
local cam = strata.camera{ width = tonumber(width), height = tonumber(height), fov = 50 }
local b = scene:bounds()
local views = 12

local rows = {}
for _, pixel_error in ipairs{ 0.5, 1, 2, 4, 8, 16 } do
    model:set_lod{ pixel_error = pixel_error }
    local triangles, gpu_ms, cull_ms = {}, {}, {}
    for i = 1, views do
        local a = 2 * math.pi * i / views
        local d = b.radius * (1.2 + 0.8 * math.cos(a))
        cam:look_at({ b.center[1] + d * math.sin(a), b.center[2] + 0.3 * b.radius, b.center[3] + d * math.cos(a) }, b.center)
        local stats = strata.render(scene, cam, { gpu_time = true, samples = 1 }):stats()
        triangles[i], gpu_ms[i], cull_ms[i] = stats.triangles, stats.gpu_ms, stats.cull_ms
    end
    local row = { pixel_error = pixel_error, triangles = strata.summary(triangles).median,
                  gpu_ms = strata.summary(gpu_ms).median, cull_ms = strata.summary(cull_ms).median }
    rows[#rows + 1] = row
    print(("pixel error %5.2f: %9d triangles, %7.2f ms GPU, %.3f ms cull"):format(pixel_error, row.triangles, row.gpu_ms, row.cull_ms))
end
strata.write_csv(csv, rows, { "pixel_error", "triangles", "gpu_ms", "cull_ms" })
print("lod_sweep: wrote " .. csv)

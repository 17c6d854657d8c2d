-- Measurements: per-frame statistics with GPU time, summaries (min, median, p95), CSV output.
local strata = require "strata"
local hlod, out = assert(arg[1]), assert(arg[2])

local s = strata.summary{ 5, 1, 4, 2, 3 }
assert(s.count == 5 and s.min == 1 and s.max == 5 and s.mean == 3 and s.median == 3, "summary")
assert(math.abs(strata.summary{ 0, 10 }.p95 - 9.5) < 1e-12, "p95 interpolates")
assert(not pcall(strata.summary, {}) and not pcall(strata.summary, { 1, "x" }))

local scene = strata.scene()
local model = strata.load(hlod)
scene:add(model)
local cam = strata.camera{ width = 128, height = 96 }
local c = scene:bounds().center
local rows = {}
for i = 1, 5 do
    cam:look_at({ c[1], c[2] + 0.02 * i, c[3] + 0.15 + 0.1 * i }, c)
    local stats = strata.render(scene, cam, { gpu_time = true }):stats()
    assert(stats.gpu_ms > 0 and stats.cull_ms >= 0 and stats.bytes_resident > 0, "stats")
    stats.frame = i
    rows[i] = stats
end
assert(strata.render(scene, cam):stats().gpu_ms == -1, "no GPU time unless asked")
local triangles = {}
for i, r in ipairs(rows) do triangles[i] = r.triangles end
local t = strata.summary(triangles)
assert(t.max >= t.median and t.median >= t.min and t.min > 0)

strata.write_csv(out .. "/frames.csv", rows, { "frame", "triangles", "cubes", "gpu_ms", "cull_ms" })
local lines = {}
for line in io.lines(out .. "/frames.csv") do lines[#lines + 1] = line end
assert(#lines == 6 and lines[1] == "frame,triangles,cubes,gpu_ms,cull_ms", lines[1])
assert(lines[2]:match("^1,%d+,%d+,[%d.e+-]+,[%d.e+-]+$"), lines[2])
strata.write_csv(out .. "/all.csv", rows)  -- every key of the first row, sorted
assert(io.open(out .. "/all.csv"):read("l"):find("bytes_resident,converged,cubes,cull_ms"))
local ok, err = pcall(strata.write_csv, out .. "/missing/dir/x.csv", rows)
assert(not ok and err:find("cannot write"), err)
strata.write_json(out .. "/summary.json", { triangles = t, frames = rows, note = "sweep", ok = true })
local text = io.open(out .. "/summary.json"):read("a")
assert(text:find('"median"') and text:find('"frames": %[') and text:find('"ok": true'), text:sub(1, 200))
ok, err = pcall(strata.write_json, out .. "/bad.json", { f = print })
assert(not ok and err:find("function"), err)
print("measure_api: ok")

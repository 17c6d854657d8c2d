-- The streaming budget from Lua (README, "Streaming"): strata.memory sets and reports it, a render
-- waits for its view by default (full_detail) and reports what streamed models hold; an interactive
-- frame (full_detail = false) from a cold model draws what is there and says what is still loading.
-- arg[1] is a .hlod, arg[2] a folder to write in.
local strata = require "strata"
local hlod_path = assert(arg[1])

local limits = strata.memory{ total = "64M" }
assert(limits.total == 64 * 2 ^ 20, "the budget as set: " .. tostring(limits.total))
assert(strata.memory{ total = 48 * 2 ^ 20 }.total == 48 * 2 ^ 20, "a number of bytes")
for _, bad in ipairs{ "1M", "2X", -5, 0 } do
  local ok, message = pcall(strata.memory, { total = bad })
  assert(not ok and message:find("strata.memory: total", 1, true), tostring(message))
end
assert(not pcall(strata.memory, { cpu = "1G" }), "unknown keys are refused")
assert(strata.memory().total == 48 * 2 ^ 20, "a refused call changes nothing")
-- The GPU's share capped on its own: set, refused below 16M (naming it, changing neither), removed.
assert(strata.memory().gpu == 0, "no GPU cap unless asked")
assert(strata.memory{ gpu = "32M" }.gpu == 32 * 2 ^ 20)
local ok, message = pcall(strata.memory, { total = "64M", gpu = "1M" })
assert(not ok and message:find("strata.memory: gpu", 1, true), tostring(message))
assert(strata.memory().total == 48 * 2 ^ 20 and strata.memory().gpu == 32 * 2 ^ 20, "a refused call changes nothing")
assert(strata.memory{ gpu = false }.gpu == 0)
strata.memory{ gpu = "24M" }

local scene = strata.scene()
scene:add(strata.load(hlod_path))
local cam = strata.camera{ width = 160, height = 120, fov = 45 }
cam:frame(scene)

-- A cold model, drawn at once: cubes are still loading.
local first = strata.render(scene, cam, { full_detail = false, samples = 1 }):stats()
assert(first.loads_pending > 0, "a cold frame has loads pending")
assert(first.converged == false and first.frames_unconverged >= 1, "a cold frame has not converged")

-- Full detail (the default) waits for the view: nothing pending, nothing standing in.
local full = strata.render(scene, cam, { samples = 1 }):stats()
assert(full.loads_pending == 0 and full.stand_ins == 0, "a full-detail frame waits for its cubes")
assert(full.memory_resident > 0 and full.memory_resident <= 48 * 2 ^ 20)
assert(full.converged == true and full.frames_unconverged == 0, "a full-detail frame has converged")
assert(full.loaded >= 0 and full.evicted == 0, "nothing left a budget that holds the view")
local hit = assert(strata.pick(scene, cam, 80, 60), "the model covers the middle of the image")
assert(hit.provisional == false, "a pick on a converged view is final")
local held = strata.memory()
assert(held.resident == full.memory_resident and held.resident <= held.total)
-- The open model's per-cube tables count in the budget beside its cubes.
assert(held.tables == full.memory_tables and held.tables > 0 and held.resident + held.reserved + held.tables <= held.total,
       "the tables, in the budget")
assert(held.gpu_tables > 0 and held.gpu_tables < held.tables, "of the tables, the GPU's share")
assert(held.gpu_resident == full.memory_resident_gpu and held.gpu_resident > 0 and held.gpu_resident < held.resident
       and held.gpu_resident <= held.gpu, "the GPU's share, within its cap")
assert(held.loaded >= held.cubes and held.cubes > 0 and held.failed == 0)
assert(strata.render(scene, cam, { samples = 1, full_detail = { timeout = 30 } }):stats().loads_pending == 0)
for _, bad in ipairs{ { timeout = 0 }, { timeout = "soon" }, { wait = 1 }, "yes" } do
  assert(not pcall(strata.render, scene, cam, { full_detail = bad }), "full_detail refuses " .. tostring(bad))
end
print("memory_api: ok")

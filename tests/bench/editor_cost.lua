-- The editor's own cost per frame, apart from the scene: building and drawing the panels, and picking.
-- Run: strata view MODEL.hlod --size 1280x720 --script tests/bench/editor_cost.lua
-- (STRATA_BENCH_FRAMES sets the frame count, default 200). With measuring on, the editor waits for the
-- GPU between the scene and the panels, so the two are timed apart.
local frames = tonumber(os.getenv("STRATA_BENCH_FRAMES") or "200")
local ed = editor
ed:measure(true)
for _, child in ed:scene():children() do ed:select(child) break end  -- the inspector shows a model
ed:console("print('measuring')")
ed:frame(10)  -- warm up: shaders, buffers, the font atlas

local ui, build, scene_ms, picks = {}, {}, {}, {}
local _, width, height = ed:screenshot()
math.randomseed(7)
for i = 1, frames do
    ed:frame()
    local stats = ed:stats()
    ui[#ui + 1] = stats.ui_ms
    build[#build + 1] = stats.ui_build_ms
    scene_ms[#scene_ms + 1] = stats.scene_ms
    -- A click every frame at a random pixel of the view's middle (where the model is).
    ed:click(width * (0.25 + 0.5 * math.random()), height * (0.25 + 0.5 * math.random()))
    picks[#picks + 1] = ed:stats().pick_ms
end
local function report(name, values, target)
    local s = strata.summary(values)
    print(("%-22s median %7.3f ms   p95 %7.3f ms   max %7.3f ms%s"):format(name, s.median, s.p95, s.max,
          target and ("   (target ≤ %g ms)"):format(target) or ""))
end
-- With the panels hidden (Tab): the stats overlay alone.
ed:panels(false)
local hidden = {}
for i = 1, frames do
    ed:frame()
    hidden[#hidden + 1] = ed:stats().ui_ms
end

print(("editor cost over %d frames at %dx%d, %d triangles drawn"):format(frames, width, height, ed:stats().triangles))
report("panels (build + draw)", ui, 1)
report("  of which build (CPU)", build)
report("panels hidden (Tab)", hidden, 1)
report("pick (a click)", picks, 5)
report("scene (for scale)", scene_ms)
ed:close()

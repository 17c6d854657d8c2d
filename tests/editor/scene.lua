-- The editor tests' scene: three copies of the sample model (bunny.hlod beside this script) under
-- different transforms, on a floor, with a camera.
local here = arg[0]:match("^(.*)/") or "."
scene = strata.scene()
for i, x in ipairs({ -0.2, 0, 0.2 }) do
    local place = strata.transform{ name = "place" .. i, translate = { x, 0, 0 }, rotate = { 0, 30 * i, 0 } }
    local model = strata.load(here .. "/bunny.hlod")
    model:name("bunny" .. i)
    place:add(model)
    scene:add(place)
end
scene:add(strata.plane{ name = "floor", center = { 0, 0.033, 0 }, width = 1, depth = 1 })
camera = strata.camera{ width = 1280, height = 720 }
camera:look_at({ 0, 0.25, 0.6 }, { 0, 0.1, 0 })

-- The editor tests' scene: three copies of the sample model (bunny.hlod beside this script) under
-- different transforms, on a floor, with a camera.
local here = arg[0]:match("^(.*)/") or "."
scene = strata.scene()
for i, x in ipairs({ -1.4, 0, 1.4 }) do
    local place = strata.transform{ name = "place" .. i, translate = { x, 0, 0 }, rotate = { 0, 30 * i, 0 } }
    local model = strata.load(here .. "/bunny.hlod")
    model:name("bunny" .. i)
    place:add(model)
    scene:add(place)
end
scene:add(strata.plane{ name = "floor", center = { 0, -0.5, 0 }, width = 5, depth = 3 })
camera = strata.camera{ width = 1280, height = 720 }
camera:look_at({ 0, 1.2, 4.5 }, { 0, 0, 0 })

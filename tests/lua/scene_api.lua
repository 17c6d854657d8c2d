-- The scene API from Lua: building graphs, transforms, names, visibility, user values, bounds,
-- finding and iterating nodes, HLOD settings. Run by tests/cli/lua_api.sh: arg[1] is a .hlod.
local strata = require "strata"
local hlod_path = assert(arg[1], "usage: scene_api.lua MODEL.hlod")

local scene = strata.scene()
assert(scene:type() == "group" and scene:name() == "scene" and scene:count() == 0)

local model = strata.load(hlod_path, { pixel_error = 2, name = "statue" })
assert(model:type() == "hlod" and model:name() == "statue")
local info = model:info()
assert(info.levels >= 2 and info.cubes >= 1 and info.triangles > 70000, "info: " .. info.triangles)
assert(info.pixel_error == 2 and info.morph == true)
model:set_lod{ kappa0 = 3, morph = false, debug = "levels", boxes = true }
assert(model:info().morph == false)
model:set_lod{ pixel_error = 0.5, morph = true, debug = "none", boxes = false }
assert(model:info().pixel_error == 0.5)

-- Each LOD setting shows in a rendered frame. With no light in the scene the renderer lights it white,
-- so a pixel's linear colour is its base colour times a grey shade: the stone grey of untextured
-- models, or in the levels view the palette colour of its cube's level (nodes/hlod_model_draw.cpp).
do
    local view = strata.scene()
    view:add(model)
    local cam = strata.camera{ width = 160, height = 120, fov = 45 }
    local b = model:bounds()
    -- From this close (the model is about 1 across) the view draws two levels and morphs between them.
    local function look_from(distance)
        local n = math.sqrt(0.3 ^ 2 + 0.2 ^ 2 + 1)
        cam:look_at({ b.center[1] + 0.3 * distance / n, b.center[2] + 0.2 * distance / n, b.center[3] + distance / n }, b.center)
    end
    look_from(1.3)
    local function snapshot()
        local f = strata.render(view, cam, { samples = 1, background = { 0, 0, 0, 0 } })
        local w, h = f:size()
        local pixels = {}
        for y = 0, h - 1 do
            for x = 0, w - 1 do pixels[#pixels + 1] = { f:pixel(x, y) } end
        end
        return pixels, f:stats().triangles
    end
    local palette = { { 0.90, 0.25, 0.20 }, { 0.95, 0.60, 0.15 }, { 0.90, 0.85, 0.20 }, { 0.35, 0.75, 0.30 },
                      { 0.20, 0.70, 0.75 }, { 0.25, 0.40, 0.85 }, { 0.55, 0.30, 0.80 }, { 0.85, 0.35, 0.65 } }
    local stone = { 0.6, 0.57, 0.52 }
    local function shaded(p, base)  -- p is base times one grey shade
        local s = (p[1] + p[2] + p[3]) / (base[1] + base[2] + base[3])
        for k = 1, 3 do
            if math.abs(p[k] - s * base[k]) > 2e-3 + 1e-2 * p[k] then return false end
        end
        return true
    end
    local function exactly(p, base)
        return p[4] == 1 and math.abs(p[1] - base[1]) < 2e-3 and math.abs(p[2] - base[2]) < 2e-3 and math.abs(p[3] - base[3]) < 2e-3
    end
    local function same(a, c)
        for i = 1, #a do
            for k = 1, 4 do
                if a[i][k] ~= c[i][k] then return false end
            end
        end
        return true
    end

    model:set_lod{ pixel_error = 2 }
    local plain, plain_triangles = snapshot()
    local covered = 0
    for i, p in ipairs(plain) do
        if p[4] > 0 then
            covered = covered + 1
            assert(shaded(p, stone), ("shaded pixel %d: %g %g %g is not stone grey"):format(i, p[1], p[2], p[3]))
        end
    end
    assert(covered > 1000, "the model covers " .. covered .. " pixels")

    model:set_lod{ debug = "levels" }
    local levels_seen = {}
    for i, p in ipairs(snapshot()) do
        assert((p[4] > 0) == (plain[i][4] > 0), "the levels view covers other pixels than the shaded one")
        if p[4] > 0 then
            local level
            for l, colour in ipairs(palette) do
                if l <= info.levels and shaded(p, colour) then level = l end
            end
            assert(level, ("levels pixel %d: %g %g %g is no level's colour"):format(i, p[1], p[2], p[3]))
            levels_seen[level] = true
        end
    end
    local distinct = 0
    for _ in pairs(levels_seen) do distinct = distinct + 1 end
    assert(distinct >= 2, "the view mixes levels, the levels view shows " .. distinct)
    model:set_lod{ debug = "none" }
    assert(same(snapshot(), plain), "debug = none is not the shaded view again")

    -- Boxes: lines in the exact (unshaded) palette colours, some where there was background.
    model:set_lod{ boxes = true }
    local changed, on_background = 0, 0
    for i, p in ipairs(snapshot()) do
        if not same({ p }, { plain[i] }) then
            changed = changed + 1
            if plain[i][4] == 0 then on_background = on_background + 1 end
            local is_line = false
            for l = 1, info.levels do is_line = is_line or exactly(p, palette[l]) end
            assert(is_line, ("box pixel %d: %g %g %g %g is no level's colour"):format(i, p[1], p[2], p[3], p[4]))
        end
    end
    assert(on_background > 50, ("boxes changed %d pixels, %d of background"):format(changed, on_background))
    model:set_lod{ boxes = false }
    assert(same(snapshot(), plain), "boxes = false leaves lines")

    -- Without the morph the same cubes draw unmorphed vertices: the same triangles, other pixels.
    model:set_lod{ morph = false }
    local unmorphed, unmorphed_triangles = snapshot()
    assert(unmorphed_triangles == plain_triangles and not same(unmorphed, plain), "morph = false changes nothing")
    model:set_lod{ morph = true }
    assert(same(snapshot(), plain), "morph = true is not the morphed view again")

    -- A finer pixel error, or from farther away a larger κ0, selects finer cubes: more triangles.
    model:set_lod{ pixel_error = 0.1 }
    local _, fine_triangles = snapshot()
    assert(fine_triangles > plain_triangles, ("pixel error 0.1: %d triangles, 2: %d"):format(fine_triangles, plain_triangles))
    look_from(4)
    local triangles = {}
    for _, kappa0 in ipairs{ 3, 5, 8 } do
        model:set_lod{ kappa0 = kappa0 }
        triangles[#triangles + 1] = select(2, snapshot())
    end
    assert(triangles[1] < triangles[2] and triangles[2] < triangles[3], "κ0 3, 5, 8: " .. table.concat(triangles, ", ") .. " triangles")
    view:remove(model)
end

-- Transforms: translate · rotate · scale; the matrix is column-major.
local moved = strata.transform{ name = "moved", translate = {10, 0, 0}, rotate = {0, 90, 0}, scale = 2 }
moved:add(model)
scene:add(moved, strata.plane{ width = 4, depth = 4 }, strata.light{ direction = {0, -1, 0} }, strata.ambient{})
assert(scene:count() == 4)
local m = moved:matrix()
assert(math.abs(m[13] - 10) < 1e-12 and math.abs(m[1]) < 1e-12 and math.abs(m[3] + 2) < 1e-12, "matrix")

-- Bounds follow the transform: the model's box, turned, doubled and moved 10 along x.
local local_box, world_box = model:bounds(), moved:bounds()
assert(math.abs((world_box.max[1] - world_box.min[1]) - 2 * (local_box.max[3] - local_box.min[3])) < 1e-9)
assert(world_box.center[1] > 9 and world_box.center[1] < 11)
moved:set_transform{ translate = {0, 5, 0} }
assert(math.abs(moved:bounds().min[2] - (local_box.min[2] + 5)) < 1e-9)

-- Finding and iterating.
assert(scene:find("statue") == model, "find by name")
assert(scene:find("nothing") == nil)
local types = {}
for i, child in scene:children() do types[i] = child:type() end
assert(table.concat(types, ",") == "transform,geometry,light,ambient", table.concat(types, ","))
assert(scene:remove(moved) == true and scene:remove(moved) == false and scene:count() == 3)

-- Visibility and user values.
model:visible(false)
assert(model:visible() == false)
model:set("site", "Pompeii"); model:set("year", 79); model:set("scanned", true)
assert(model:get("site") == "Pompeii" and model:get("year") == 79 and model:get("scanned") == true)
assert(model:get("missing") == nil)

-- A cycle is refused with an error, not a hang.
local ok, err = pcall(function() moved:add(moved) end)
assert(not ok and err:find("contain itself"), err)
print("scene_api: ok")

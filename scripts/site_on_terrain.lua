-- A site on a terrain (issue 18): SITE placed at the centre of TERRAIN, scaled to a tenth of the
-- terrain's width and set on the ground, then three views of it, 1280×720, over pure magenta (a colour
-- no terrain imagery has: any magenta inside the ground is a crack): view1.png close and oblique,
-- view2.png grazing, view3.png from above. A site built with `strata build --lock-boundary` is stitched
-- into the ground (its embedding file, OUTDIR/site_on_terrain.hlod, is made once and reused); a closed
-- site stands on it.
--
--   strata run scripts/site_on_terrain.lua TERRAIN.hlod SITE.hlod OUTDIR
local strata = require "strata"
local terrain_file, site_file, out = arg[1], arg[2], arg[3]
if not (terrain_file and site_file and out) then
    error("usage: strata run site_on_terrain.lua TERRAIN.hlod SITE.hlod OUTDIR", 0)
end

local ground = strata.load(terrain_file)
if not ground:info().terrain then error(terrain_file .. ": not a terrain built from an elevation raster", 0) end
local t = ground:bounds()
local width = math.max(t.max[1] - t.min[1], t.max[2] - t.min[2])
local cx, cy = t.center[1], t.center[2]
local centre = ground:to_geo{ cx, cy, t.center[3] }
local s = strata.load(site_file):bounds()
local size = 0.1 * width  -- the site's width on the ground
local terrain = strata.terrain{ model = ground, embed = { {
    site = site_file, at = { centre[1], centre[2] }, scale = size / math.max(s.max[1] - s.min[1], s.max[2] - s.min[2]),
    output = out .. "/site_on_terrain.hlod",
} } }
local scene = strata.scene()
scene:add(terrain)

local function ground_at(x, y) return ground:height_at{ x, y } or t.center[3] end
local base = ground_at(cx, cy)
local camera = strata.camera{ width = 1280, height = 720, fov = 50 }
local views = {
    -- close and oblique, grazing from well outside the site (the ground it replaces reaches past it),
    -- and from high above (the whole terrain, the background around it)
    { eye = { cx + 1.1 * size, cy - 1.1 * size, base + 0.8 * size }, at = { cx, cy, base + 0.1 * size } },
    { eye = { cx + 2.5 * size, cy + 0.6 * size, ground_at(cx + 2.5 * size, cy + 0.6 * size) + 0.04 * size }, at = { cx, cy, base + 0.1 * size } },
    { eye = { cx, cy - 0.02 * size, base + 12 * size }, at = { cx, cy, base } },
}
for i, view in ipairs(views) do
    camera:look_at(view.eye, view.at, { 0, 0, 1 })
    strata.render(scene, camera, { background = { 1, 0, 1, 1 } }):write(("%s/view%d.png"):format(out, i))
end
print(("site_on_terrain: %s on %s, %.0f m wide; wrote %s/view1.png … view3.png"):format(site_file, terrain_file, size, out))

-- The geographic read-out over a real DEM (strata view olinda.hlod): the camera placed above a
-- sample reads that sample's longitude and latitude (gdaltransform's, in GEO_SAMPLE) and its height
-- above the ground (gdallocationinfo's height, in GEO_SAMPLE); a click on the ground reads a point on
-- the terrain, within the cube's error of the raster's height there; panels and overlay show it all.
local want = {}
for v in os.getenv("GEO_SAMPLE"):gmatch("%S+") do want[#want + 1] = tonumber(v) end
local lon, lat, ground = want[1], want[2], want[3]
assert(editor:frame())
local model = editor:scene():find("olinda")
assert(model, "no olinda model in the scene")
local geo = editor:geo()
assert(geo and geo.model == "olinda", "no read-out for a georeferenced model")
assert(geo.crs:find("UTM Zone 25, Southern Hemisphere", 1, true), "crs: " .. geo.crs)

-- 500 m above the sample, looking north-east and down.
local at = model:to_local{ lon, lat, 0 }
local cam = editor:camera()
cam:look_at({ at[1], at[2], ground + 500 }, { at[1] + 800, at[2] + 800, ground }, { 0, 0, 1 })
assert(editor:frame())
geo = editor:geo()
assert(math.abs(geo.camera[1] - lon) < 1e-8 and math.abs(geo.camera[2] - lat) < 1e-8,
       ("camera at %.9f, %.9f, not %.9f, %.9f"):format(geo.camera[1], geo.camera[2], lon, lat))
assert(math.abs(geo.camera[3] - (ground + 500)) < 1e-6, "camera height " .. geo.camera[3])
assert(math.abs(geo.camera.above_ground - 500) < 1e-3, "above the ground: " .. tostring(geo.camera.above_ground))

-- A click in the middle of the window lands on the ground.
local frames = 0
while not editor:stats().converged do
  assert(frames < 20000, "the view never converged")
  assert(editor:frame())
  frames = frames + 1
end
local _, width, height = editor:screenshot()
local node, point = editor:click(width / 2, height / 2)
assert(node and node:name() == "olinda", "the click missed the terrain")
geo = editor:geo()
assert(geo.cursor, "no cursor reading after a click on the terrain")
local back = model:to_local{ geo.cursor[1], geo.cursor[2], geo.cursor[3] }
assert(math.abs(back[1] - point[1]) < 1e-6 and math.abs(back[2] - point[2]) < 1e-6, "the cursor is not the clicked point")
-- The drawn surface lies within its cubes' error bounds of the raster (at most ε_q of a level-0 cube),
-- the click within a pixel's depth of it.
print(("editor geo: the clicked point is %.3f m off the raster's ground"):format(geo.cursor.above_ground))
assert(math.abs(geo.cursor.above_ground) < 2, "the clicked point is " .. geo.cursor.above_ground .. " m off the ground")
assert(editor:frame(3))
editor:close()
print("editor geo: ok")

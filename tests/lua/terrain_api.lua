-- Terrains with embedded sites from Lua: strata.embed makes an embedding file once, strata.terrain
-- loads a terrain with embeddings (files, or sites to embed), its methods and node types; a rendered
-- view draws the site; bad arguments are refused by name. arg[2] is a folder to write in.
local strata = require "strata"
local out = assert(arg[2])
local here = debug.getinfo(1, "S").source:match("^@(.*)/[^/]*$")
local dem = here .. "/../../data/olinda_dem.tif"
if not io.open(dem) then error("data/olinda_dem.tif missing: run scripts/setup.sh") end

-- The terrain, and an open site 300 m wide (a bumpy grid) built with its boundary locked.
local terrain_file = strata.build{ input = dem, output = out .. "/terrain_api_olinda.hlod", cube_cells = 16 }.output
local off = assert(io.open(out .. "/terrain_api_site.off", "w"))
local n = 30
off:write("OFF\n", (n + 1) * (n + 1), " ", 2 * n * n, " 0\n")
for y = 0, n do for x = 0, n do off:write(("%d %d %.3f\n"):format(10 * x - 150, 10 * y - 150, 3 * math.sin(x / 3) * math.cos(y / 4))) end end
for y = 0, n - 1 do
    for x = 0, n - 1 do
        local a = y * (n + 1) + x
        off:write(("3 %d %d %d\n3 %d %d %d\n"):format(a, a + 1, a + n + 2, a, a + n + 2, a + n + 1))
    end
end
off:close()
local site_file = strata.build{ input = out .. "/terrain_api_site.off", output = out .. "/terrain_api_site.hlod", lock_boundary = true }.output
local loose_file = strata.build{ input = out .. "/terrain_api_site.off", output = out .. "/terrain_api_loose.hlod" }.output
local ground = strata.load(terrain_file)
local b = ground:bounds()
local centre = ground:to_geo{ b.center[1], b.center[2], b.center[3] }
local at = { centre[1], centre[2] }

-- strata.embed writes the file; strata.terrain loads it.
local file = strata.embed{ terrain = terrain_file, site = site_file, at = at, output = out .. "/terrain_api_embedding.hlod" }
assert(file == out .. "/terrain_api_embedding.hlod" and io.open(file, "rb"), "no embedding file")
local t = strata.terrain{ model = terrain_file, embed = { file }, name = "olinda" }
assert(t:type() == "terrain" and t:name() == "olinda", t:type())
assert(t:ground():type() == "hlod" and t:ground():info().terrain)
local list = t:embeddings()
assert(#list == 1 and list[1]:type() == "embedding", #list)
local e = list[1]
local info = e:info()
assert(info.zone_level >= 1 and info.boundary_vertices == 4 * n and info.border_steps > 0, info.boundary_vertices)
assert(e:site():type() == "hlod" and e:skirt():type() == "hlod")
assert(tostring(t):find("1 embedded", 1, true), tostring(t))

-- Drawn from close by: the site is drawn, its skirt around it.
local scene = strata.scene()
scene:add(t)
local camera = strata.camera{ width = 160, height = 90, fov = 50 }
local h = ground:height_at{ b.center[1], b.center[2] }
camera:look_at({ b.center[1] + 300, b.center[2] - 300, h + 250 }, { b.center[1], b.center[2], h }, { 0, 0, 1 })
local frame = strata.render(scene, camera, { channels = "RGBA,Z,id", background = { 1, 0, 1, 1 } })
assert(e:drawn(), "the embedding is not drawn from 470 m")
local r, g, bl, _, _, id = frame:pixel(80, 45)
assert(id > 0 and not (r > 0.9 and g < 0.1 and bl > 0.9), ("the centre shows the background: %g %g %g id %d"):format(r, g, bl, id))

-- Refused by name (here and below).
local function refused(f, ...)
    local ok, err = pcall(f)
    assert(not ok, "accepted")
    for _, part in ipairs{...} do assert(tostring(err):find(part, 1, true), err) end
end

-- A site given to embed is embedded once (the file beside the site unless output says where), then
-- reused; removing takes it out.
local away = ground:to_geo{ b.center[1] + 2000, b.center[2], b.center[3] }
local second = t:embed{ site = site_file, at = { away[1], away[2] }, heading = 30 }
assert(second:type() == "embedding" and io.open(out .. "/terrain_api_site_on_terrain_api_olinda.hlod", "rb"))
assert(#t:embeddings() == 2)

-- Where an embedding stands, as at, scale and heading; moving one makes its file again there and
-- reloads it; a move that cannot be embedded leaves the embedding and its file as they were.
local function near(a, b, tolerance) return math.abs(a - b) <= (tolerance or 1e-9) end
local p = t:placement(e)
assert(near(p.at[1], at[1]) and near(p.at[2], at[2]) and near(p.scale, 1) and near(p.heading, 0), ("%.12g %.12g %g %g"):format(p.at[1], p.at[2], p.scale, p.heading))
assert(near(t:placement(second).heading, 30))
local second_file = out .. "/terrain_api_site_on_terrain_api_olinda.hlod"
local moved = t:move(second, { heading = 60, scale = 0.5 })
assert(moved:type() == "embedding" and #t:embeddings() == 2 and not t:remove(second), "the moved embedding did not replace the old one")
p = t:placement(moved)
assert(near(p.heading, 60) and near(p.scale, 0.5) and near(p.at[1], away[1]) and near(p.at[2], away[2]), ("%g %g"):format(p.heading, p.scale))
local reloaded = strata.terrain{ model = terrain_file, embed = { second_file } }
assert(near(reloaded:placement(reloaded:embeddings()[1]).heading, 60), "the file was not made again for the move")
refused(function() t:move(moved, { at = at }) end, "overlaps the zone of terrain_api_embedding")
refused(function() t:move(moved, { at = { 0, 0 } }) end, "off the terrain's raster")
refused(function() t:move(moved, { heading = 0 / 0 }) end, "heading")
refused(function() t:move(moved, { spin = 1 }) end, "spin")
refused(function() t:placement(t:ground()) end, "not an embedding")
assert(#t:embeddings() == 2 and near(t:placement(moved).heading, 60), "a refused move changed the embedding")
reloaded = strata.terrain{ model = terrain_file, embed = { second_file } }
assert(near(reloaded:placement(reloaded:embeddings()[1]).heading, 60), "a refused move changed the file")
assert(not io.open(second_file .. ".before-move"), "a refused move left its copy behind")
second = moved

-- Placed by a matrix (the site's model coordinates → the terrain's), as given: the first embedding's own
-- matrix moved 2 km west and tilted by 3° about x. placement() gives it back bit for bit; a move by
-- matrix keeps it so, and one by heading places the site by at, scale and heading again. A table from
-- placement() with one part edited moves by that part; one with both edited is refused.
local function same_matrix(a, b) for i = 1, 16 do if a[i] ~= b[i] then return false end end return true end
local m = t:placement(e).matrix
assert(#m == 16 and m[16] == 1 and near(m[1], 1) and near(m[13] - b.center[1], 0, 200), ("%g %g"):format(m[1], m[13]))
local tilt = math.rad(3)
local tilted = { m[1], m[2], m[3], 0, m[5], m[6] * math.cos(tilt), m[6] * math.sin(tilt), 0, m[9], -m[11] * math.sin(tilt), m[11] * math.cos(tilt), 0,
                 m[13] - 2000, m[14], m[15], 1 }
local by_matrix = t:embed{ site = site_file, matrix = tilted, output = out .. "/terrain_api_matrix.hlod" }
assert(by_matrix:type() == "embedding" and by_matrix:info().boundary_vertices == 4 * n and #t:embeddings() == 3)
assert(same_matrix(t:placement(by_matrix).matrix, tilted), "the matrix was not kept as given")
tilted[14] = tilted[14] + 150
by_matrix = t:move(by_matrix, { matrix = tilted })
assert(same_matrix(t:placement(by_matrix).matrix, tilted), "a move by matrix did not keep it as given")
p = t:placement(by_matrix)
tilted[14] = tilted[14] + 50
p.matrix = tilted
by_matrix = t:move(by_matrix, p)
assert(same_matrix(t:placement(by_matrix).matrix, tilted), "placement() with its matrix edited did not move by it")
p = t:placement(by_matrix)
p.heading = 45
by_matrix = t:move(by_matrix, p)
p = t:placement(by_matrix)
assert(near(p.heading, 45) and near(p.scale, 1) and math.abs(p.matrix[7]) < 1e-12, "a move by heading kept the tilt")
refused(function() t:embed{ site = site_file, matrix = tilted, at = at } end, "option 'matrix' cannot be combined with 'at'")
p.heading, p.matrix = 1, tilted
refused(function() t:move(by_matrix, p) end, "option 'matrix' cannot be combined with 'at', 'scale' or 'heading'")
refused(function() t:embed{ site = site_file, matrix = { 1, 2, 3 } } end, "option 'matrix' must be a matrix (16 finite numbers")
local mirrored = { -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, m[13], m[14], m[15], 1 }
refused(function() t:embed{ site = site_file, matrix = mirrored } end, "option 'matrix'", "mirror")
local projective = { 1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, m[13], m[14], m[15], 1 }
refused(function() t:embed{ site = site_file, matrix = projective } end, "option 'matrix'", "affine")
local far = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1e7, m[14], m[15], 1 }
refused(function() t:embed{ site = site_file, matrix = far, output = out .. "/terrain_api_far.hlod" } end, "placed by its matrix it lies wholly off")
assert(not io.open(out .. "/terrain_api_far.hlod"), "a refused embedding left its file")
assert(t:remove(by_matrix) and #t:embeddings() == 2)

-- A plain mesh as the site: built with its boundary locked into "<embedding file>_site.hlod", then embedded.
local south = ground:to_geo{ b.center[1], b.center[2] - 2000, b.center[3] }
local from_mesh = t:embed{ site = out .. "/terrain_api_site.off", at = { south[1], south[2] }, output = out .. "/terrain_api_mesh.hlod" }
assert(from_mesh:type() == "embedding" and from_mesh:info().boundary_vertices == 4 * n, "the mesh was not embedded")
assert(io.open(out .. "/terrain_api_mesh_site.hlod", "rb"), "no model of the mesh beside the embedding file")
refused(function() t:embed{ site = out .. "/terrain_api_nothing.off", at = at } end, "terrain_api_nothing.off")
assert(t:remove(from_mesh) and #t:embeddings() == 2)

assert(t:remove(second) and #t:embeddings() == 1 and not t:remove(second))
assert(not t:remove(t:ground()), "the ground is not an embedding")

-- A saved scene rebuilds the terrain from its files, embeddings included (not its children again).
strata.save_scene(out .. "/terrain_api_scene.lua", { scene = scene, camera = false, bookmarks = {}, paths = {} })
dofile(out .. "/terrain_api_scene.lua")
local back = _G.scene:find("olinda")
assert(back and back:type() == "terrain" and #back:embeddings() == 1 and back:count() == 2, back and back:count())

refused(function() strata.terrain{ model = out .. "/missing.hlod" } end, "missing.hlod")
refused(function() strata.terrain{ model = site_file } end, "terrain_api_site.hlod", "not a terrain")
refused(function() strata.terrain{ model = 42 } end, "option 'model'")
refused(function() strata.terrain{ model = terrain_file, embed = 7 } end, "option 'embed'")
refused(function() strata.terrain{ model = terrain_file, embed = { 7 } } end, "an embedding is a file name")
refused(function() strata.terrain{ model = terrain_file, colour = 1 } end, "colour")
refused(function() t:embed{ site = loose_file, at = at } end, "terrain_api_loose.hlod", "not locked")
refused(function() t:embed{ site = site_file, at = at, heading = 30, output = out .. "/terrain_api_turned.hlod" } end,
        "overlaps the zone of terrain_api_embedding")
refused(function() t:embed{ site = site_file, at = { 1 } } end, "{lon, lat}")
refused(function() t:embed{ site = site_file, at = at, scale = -1 } end, "scale")
refused(function() t:embed{ site = site_file, at = { 0 / 0, 1 } } end, "{lon, lat}")
refused(function() t:embed{ at = at } end, "option 'site'")
refused(function() t:embed(out .. "/terrain_api_site.hlod") end, "terrain_api_site.hlod")
refused(function() strata.embed{ site = site_file, at = at } end, "option 'terrain'")
refused(function() t.embed(strata.group(), file) end, "bad argument #1")
print("terrain_api: ok")

-- Saving scenes: strata.save_scene writes a script that, run with dofile (or `strata run`, see lua_api.sh),
-- sets the globals scene, camera, bookmarks and paths back to what they were, to the bit; saving again
-- writes the same text; bad parts and destinations are errors that leave no file.
-- arg[1] is a .hlod, arg[2] a folder to write in, arg[3] a mesh file.
local strata = require "strata"
local model_file, out, mesh_file = assert(arg[1]), assert(arg[2]), assert(arg[3])
local folder = out .. "/scene_project"
strata.mkdir(folder)

local function read(file)
    local f = assert(io.open(file, "rb"))
    local text = f:read("a")
    f:close()
    return text
end

-- Exact text of numbers (hexadecimal floats keep every bit and the sign of zero).
local function exact(t)
    local parts = {}
    for i, v in ipairs(t) do parts[i] = ("%a"):format(v) end
    return table.concat(parts, " ")
end

-- The tree as text: types, names, visibility, matrices and level of detail.
local function describe(node, lines)
    lines = lines or {}
    local line = node:type() .. " '" .. node:name() .. "' " .. tostring(node:visible())
    if node:type() == "transform" then line = line .. " " .. exact(node:matrix()) end
    if node:type() == "hlod" then line = line .. " " .. ("%a %s"):format(node:info().pixel_error, node:info().morph) end
    lines[#lines + 1] = line
    if node:type() == "group" or node:type() == "transform" then
        for _, child in node:children() do describe(child, lines) end
        lines[#lines + 1] = "end"
    end
    return table.concat(lines, "\n")
end

local function pose_text(pose) return exact(pose.position) .. " " .. exact(pose.orientation) .. (" %a"):format(pose.fov) end

-- A scene of two models (one hidden), a mesh under a non-uniform matrix, a floor and lights.
scene = strata.scene()
local left = strata.transform{ name = "left", translate = { 2, 0, 0 } }
local tilted = strata.transform{ name = "tilted", rotate = { 10, 20, 30 }, scale = 2.5 }
local squashed = strata.transform{ name = "squashed", matrix = { 2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0.5, 0, 1, 2, 3, 1 } }
local bunny = strata.load(model_file, { name = "bunny", pixel_error = 2 })
bunny:set_lod{ debug = "levels", boxes = true }
bunny:set("note", 'say "hi"\n')
bunny:set("rank", 0.1)
left:add(bunny)
local second = strata.load(model_file, { name = "bunny 2", kappa0 = 4, morph = false })
second:visible(false)
tilted:add(second)
squashed:add(strata.load(mesh_file, { name = "mesh" }))
scene:add(left, tilted, squashed, strata.plane{ name = "floor", width = 40, depth = 30, color = { 0.4, 0.4, 0.4 } },
          strata.light{ name = "sun", direction = { -1, -2, -1 }, intensity = 0.8 }, strata.ambient{ name = "sky" })
scene:set("title", "hall")
camera = strata.camera{ fov = 40, width = 640, height = 480, near = 0.1 }
camera:look_at({ 3, 1.6, 4 }, { 0, 1, 0 })
bookmarks = { { name = "front", position = { 0, 1, 5 }, target = { 0, 0.5, 0 }, fov = 45 } }
bookmarks[2] = camera:pose()
bookmarks[2].name = "start"
paths = {
    tour = strata.path{ keys = { { position = { 0, 1, 5 }, target = { 0, 0.5, 0 }, duration = 4 },
                                 { position = { 5, 2, 0 }, target = { 0, 0.5, 0 }, fov = 40 } },
                        orientation = "look-at", easing = "ease-in-out" },
    back = strata.path{ keys = { { position = { 5, 2, 0 }, orientation = { 1, 0, 0, 0 } },
                                 { position = { 0, 1, 5 }, orientation = { 0, 0, 1, 0 } } }, duration = 3 },
}

strata.save_scene(folder .. "/scene.lua")
local saved = { scene = describe(scene), camera = pose_text(camera:pose()), tour = paths.tour:json(),
                back = paths.back:json(), start = pose_text(camera:pose()) }

-- Reloaded into fresh globals.
scene, camera, bookmarks, paths = nil, nil, nil, nil
dofile(folder .. "/scene.lua")
assert(describe(scene) == saved.scene, describe(scene) .. "\n---\n" .. saved.scene)
assert(scene:get("title") == "hall")
assert(scene:find("bunny"):get("note") == 'say "hi"\n' and scene:find("bunny"):get("rank") == 0.1)
assert(scene:find("mesh"):type() == "geometry" and scene:find("floor"):type() == "geometry")
assert(pose_text(camera:pose()) == saved.camera)
assert(#bookmarks == 2 and bookmarks[1].name == "front" and bookmarks[2].name == "start")
assert(paths.tour:json() == saved.tour and paths.back:json() == saved.back)
-- A bookmark is a pose: a camera takes it as it is.
local cam = strata.camera()
cam:set_pose(bookmarks[2])
assert(pose_text(cam:pose()) == saved.start)

-- A fixed point: saving the reloaded scene writes the same text.
strata.save_scene(folder .. "/again.lua")
assert(read(folder .. "/again.lua") == read(folder .. "/scene.lua"), "the second save differs")

-- Parts given explicitly; camera = false leaves the camera out.
strata.save_scene(out .. "/bare.lua", { scene = strata.group{ name = "empty" }, camera = false, bookmarks = {}, paths = {} })
local bare = read(out .. "/bare.lua")
assert(bare:find("camera = nil", 1, true) and bare:find("bookmarks = {}", 1, true), bare)

-- Errors: the destination named, no file left; bad parts named.
local ok, err = pcall(strata.save_scene, out .. "/missing/scene.lua")
assert(not ok and err:find(out .. "/missing/scene.lua", 1, true), err)
ok, err = pcall(strata.save_scene, out .. "/bad.lua", { scene = 42 })
assert(not ok and err:find("'scene' must be a strata node", 1, true), err)
ok, err = pcall(strata.save_scene, out .. "/bad.lua", { bookmarks = { { position = { 0, 0, 0 } } } })
assert(not ok and err:find("bookmark 1 needs a 'name'", 1, true), err)
ok, err = pcall(strata.save_scene, out .. "/bad.lua", { paths = { tour = "tour.json" } })
assert(not ok and err:find('paths["tour"] must be a strata path', 1, true), err)
ok, err = pcall(strata.save_scene, out .. "/bad.lua", { scenery = scene })
assert(not ok and err:find("unknown option 'scenery'", 1, true), err)
assert(io.open(out .. "/bad.lua") == nil, "a failed save left a file")

-- The matrix option: 16 numbers, alone.
ok, err = pcall(strata.transform, { matrix = { 1, 2, 3 } })
assert(not ok and err:find("16 finite numbers", 1, true), err)
ok, err = pcall(strata.transform, { matrix = squashed:matrix(), scale = 2 })
assert(not ok and err:find("cannot be combined with 'scale'", 1, true), err)
print("save_scene_api: ok")

-- strata.pick and strata.save_scene refuse what they cannot use (abuse_lib.lua); a scene too deep for
-- a scene script is refused with a message instead of a stack overflow. arg[1] is a .hlod, arg[2] a
-- folder to write in.
local strata = require "strata"
local t = require "abuse_lib"
local hlod_path, out = assert(arg[1]), assert(arg[2])

local scene = strata.scene()
scene:add(strata.load(hlod_path))
local cam = strata.camera{ width = 40, height = 30 }
cam:frame(scene)

-- pick
t.refuses("strata.Node expected, got no value", strata.pick)
t.refuses("strata.Camera expected, got number", strata.pick, scene, 1, 0, 0)
for _, bad in ipairs({ 0 / 0, -1, 40, math.huge, -math.huge, 1e300 }) do
    t.refuses("outside the image", strata.pick, scene, cam, bad, 0)
    t.refuses("outside the image", strata.pick, scene, cam, 0, bad == 40 and 30 or bad)
end
t.refuses("number expected, got string", strata.pick, scene, cam, "x", 0)
assert(strata.pick(strata.group(), cam, 20, 15) == nil, "an empty scene picks nothing")

-- save_scene
local file = out .. "/abuse_scene.lua"
t.refuses("bad argument #1", strata.save_scene)
t.refuses("unknown option 'scenery'", strata.save_scene, file, { scenery = scene })
t.refuses("'scene' must be a strata node", strata.save_scene, file, { scene = 1 })
t.refuses("'camera' must be a strata camera, got userdata", strata.save_scene, file, { scene = scene, camera = scene })
t.refuses("'bookmarks' must be an array", strata.save_scene, file, { scene = scene, bookmarks = 1 })
t.refuses("bookmark 1 must be a table", strata.save_scene, file, { scene = scene, bookmarks = { 1 } })
t.refuses("bookmark 1 needs a 'name'", strata.save_scene, file, { scene = scene, bookmarks = { {} } })
t.refuses("needs a 'position'", strata.save_scene, file, { scene = scene, bookmarks = { { name = "%s%n" } } })
t.refuses("3 finite numbers", strata.save_scene, file, { scene = scene, bookmarks = { { name = "b", position = { 0 / 0, 0, 0 } } } })
t.refuses("'paths' must be keyed by name, not by number", strata.save_scene, file, { scene = scene, paths = { 1 } })
t.refuses("paths[\"%s\"] must be a strata path", strata.save_scene, file, { scene = scene, paths = { ["%s"] = 1 } })
local released = strata.group()
debug.getmetatable(released).__gc(released)
t.refuses("'scene' must be a strata node", strata.save_scene, file, { scene = released })

-- A scene deeper than a script can nest is refused, and the file is not written.
local deep = strata.group{ name = "deep" }
local g = deep
for i = 1, 100000 do
    local c = strata.group{ name = "d" .. i }
    g:add(c)
    g = c
end
t.refuses("levels deep: a scene script cannot nest that deep", strata.save_scene, file, { scene = deep })
assert(not io.open(file), "a refused scene left its file")
strata.save_scene(file, { scene = scene, camera = cam })  -- a shallow one saves
print("abuse_pick: ok")

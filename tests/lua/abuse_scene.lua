-- The scene bindings refuse what they cannot use (abuse_lib.lua), and deep graphs built from Lua
-- (200 000 nested groups, from the root down and from the leaf up) build, measure, find, render and
-- go away quickly, without overflowing the stack. arg[1] is a .hlod.
local strata = require "strata"
local t = require "abuse_lib"
local hlod_path = assert(arg[1])

-- Constructors: options of the wrong type or out of range, unknown options.
t.refuses("unknown option 'nme'", strata.group, { nme = "x" })
t.refuses("option 'name' must be a string, got number", strata.group, { name = 1 })
t.each_junk_refused("bad argument #1", strata.group, 1, {}, function(v) return v == nil or type(v) == "table" end)
t.refuses("option 'scale' must be positive", strata.transform, { scale = 0 / 0 })
t.refuses("option 'scale' must be positive", strata.transform, { scale = math.huge })
t.refuses("3 finite numbers", strata.transform, { translate = { 0 / 0, 0, 0 } })
t.refuses("3 finite numbers", strata.transform, { translate = { 1, 2 } })
t.refuses("option 'matrix' must be a matrix (16 finite numbers", strata.transform, { matrix = { 1, 2, 3 } })
t.refuses("the quaternion has length 0", strata.transform, { quaternion = { 0, 0, 0, 0 } })
t.refuses("options 'width' and 'depth' must be positive", strata.plane, { width = 0 / 0 })
t.refuses("options 'width' and 'depth' must be positive", strata.plane, { depth = -1 })
t.refuses("does not fit float coordinates", strata.plane, { center = { 1e300, 0, 0 } })
t.refuses("option 'up' must not be {0, 0, 0}", strata.plane, { up = { 0, 0, 0 } })
t.refuses("within float range", strata.plane, { color = { 1e300, 0, 0 } })
t.refuses("within float range", strata.light, { intensity = 1e300 })
t.refuses("within float range", strata.light, { color = { 0, -1e40, 0 } })
t.refuses("within float range", strata.ambient, { color = { 0, 0, 1e39 } })
t.each_junk_refused("bad argument #1 to", strata.load, 1, {}, function(v) return type(v) == "number" or type(v) == "string" end)
t.refuses("missing.hlod", strata.load, "missing.hlod")
t.refuses("option 'pixel_error' must be a number", strata.load, hlod_path, { pixel_error = "fine" })

-- Methods: every one refuses another self, and each refuses bad arguments.
local g = strata.group{ name = "g" }
local tr = strata.transform{ name = "t" }
local model = strata.load(hlod_path)
t.methods_refuse_other_selves(g, "strata.Node")
t.refuses("group or transform expected, got node", g.add, model, g)
t.refuses("strata.Node expected, got number", g.add, g, 1)
t.refuses("strata.Node expected, got table", g.add, g, {})
t.refuses("would contain itself", g.add, g, g)
t.refuses("strata.Node expected", g.remove, g, "x")
t.refuses("number, string or boolean", g.set, g, "k", {})
t.refuses("bad argument #2", g.set, g, {}, 1)
t.refuses("bad argument #2", g.get, g, nil)
t.refuses("bad argument #2", g.find, g, {})
t.refuses("bad argument #2", g.visible, g, 1)
t.refuses("bad argument #2", g.name, g, {})
t.refuses("transform expected", tr.matrix, g)
t.refuses("transform expected", tr.set_transform, g, {})
t.refuses("bad argument #2", tr.set_transform, tr, nil)
t.refuses("unknown option", tr.set_transform, tr, { skew = 1 })
t.refuses("cannot be combined", tr.set_transform, tr, { matrix = { 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1 }, scale = 2 })
t.refuses("HLOD model expected", model.set_lod, g, {})
t.refuses("HLOD model expected", model.info, tr)
t.refuses("option 'debug' must be none", model.set_lod, model, { debug = "%s%s%s%n" })
t.refuses("must be positive", model.set_lod, model, { kappa0 = 0 / 0 })
t.refuses("the pixel error must be positive", model.set_lod, model, { pixel_error = -math.huge })
-- Names with format directives are text, never formats.
g:name("%s%s%n%d")
assert(tostring(g) == "strata.group '%s%s%n%d' (0 children)", tostring(g))
local odd = strata.load(hlod_path, { name = "%s%n" })
t.refuses("got node '%s%n'", g.add, odd, g)

-- Protection and finalization: the node goes from the Lua value, not from the graph holding it.
local parent, child = strata.group(), strata.group{ name = "kept" }
parent:add(child)
t.protected_and_finalizable(child, "strata.Node")
assert(parent:count() == 1 and parent:find("kept"), "the graph still holds a finalized handle's node")
t.refuses("strata.Node has been released", tostring, child)
t.refuses("strata.Node has been released", parent.add, parent, child)
t.refuses("strata.Node has been released", function() return child == parent end)

-- Deep graphs: a chain of 200 000 groups, from the root down and from the leaf up.
local depth = 200000
local start = os.clock()
local root = strata.group{ name = "root" }
local g = root
for i = 1, depth do
    local c = strata.group{ name = "n" .. i }
    g:add(c)
    g = c
end
local leaf = g
leaf:add(strata.plane{ name = "floor", center = { 0, 0, 0 } })
local down_seconds = os.clock() - start
start = os.clock()
local top = strata.group{ name = "l0" }
local first = top
for i = 1, depth do
    local c = strata.group{ name = "l" .. i }
    c:add(top)
    top = c
end
local up_seconds = os.clock() - start
print(("abuse_scene: %d nested groups built root-down in %.2f s, leaf-up in %.2f s"):format(depth, down_seconds, up_seconds))
-- About a second each on a plain build (was minutes: every add walked every ancestor); slack for sanitizers.
assert(down_seconds < 30 and up_seconds < 30)
-- A cycle is still refused at the far end of each chain.
t.refuses("would contain itself", leaf.add, leaf, root)
t.refuses("would contain itself", first.add, first, top)

-- Bounds, find, render and pick walk the whole depth.
local b = root:bounds()
assert(b and b.radius > 0, "the chain's bound is the plane's")
assert(root:find("floor"), "find reaches the bottom")
assert(root:find("n" .. depth) == leaf)
assert(not top:find("nothing"))
local cam = strata.camera{ width = 64, height = 48 }
cam:look_at({ 0, 5, 5 }, { 0, 0, 0 })
local frame = strata.render(root, cam, { samples = 1, channels = "RGBA,Z" })
local _, _, _, _, depth_drawn = frame:pixel(32, 24)
assert(depth_drawn < math.huge, "the plane at the bottom of the chain is drawn")
local hit = strata.pick(root, cam, 32, 24)
assert(hit and hit.node:name() == "floor", "the pick reaches the bottom")

-- Dropped, the chains go at the next collection (a recursive destructor would overflow the stack).
root, g, leaf, top, first, hit = nil, nil, nil, nil, nil, nil
collectgarbage()
collectgarbage()
print("abuse_scene: ok")

-- Camera paths refuse what they cannot use (abuse_lib.lua): keys, options, times and frame rates.
-- arg[2] is a folder to write in.
local strata = require "strata"
local t = require "abuse_lib"
local out = assert(arg[2])

local keys = { { position = { 0, 0, 10 }, target = { 0, 0, 0 } }, { position = { 10, 0, 0 }, target = { 0, 0, 0 } } }
t.refuses("bad argument #1", strata.path)
t.each_junk_refused("bad argument #1", strata.path, 1, {}, function(v) return type(v) == "table" end)
t.refuses("strata.path needs 'keys'", strata.path, {})
t.refuses("key 1 is not a table", strata.path, { keys = { 1 } })
t.refuses("a key needs a 'position'", strata.path, { keys = { {} } })
t.refuses("3 finite numbers", strata.path, { keys = { { position = { 0 / 0, 0, 0 } }, keys[2] } })
t.refuses("duration must be a positive number", strata.path, { keys = { { position = { 0, 0, 1 }, target = { 0, 0, 0 }, duration = 0 / 0 }, keys[2] } })
t.refuses("total_duration must be a positive number", strata.path, { keys = keys, duration = math.huge })
t.refuses("option 'spline' must be catmull-rom", strata.path, { keys = keys, spline = "%s%n" })
t.refuses("option 'easing' must be none", strata.path, { keys = keys, easing = "x" })
t.refuses("bad argument #1", strata.load_path, {})
t.refuses("missing.json", strata.load_path, out .. "/missing.json")
t.refuses("missing.path", strata.import_osg_path, out .. "/missing.path")

local path = strata.path{ keys = keys, duration = 2 }
t.methods_refuse_other_selves(path, "strata.Path")
t.refuses("a finite time in seconds expected", path.sample, path, 0 / 0)
t.refuses("a finite time in seconds expected", path.sample, path, math.huge)
t.refuses("number expected, got string", path.sample, path, "soon")
t.refuses("no such key", path.key_time, path, 3)
t.refuses("no such key", path.key_time, path, math.mininteger)
t.refuses("number has no integer representation", path.key_time, path, 0 / 0)
for _, fps in ipairs({ 0, -1, 0 / 0, math.huge, 1e300 }) do
    t.refuses("option 'fps' must be positive", path.frame_count, path, { fps = fps })
    t.refuses("option 'fps' must be positive", path.frames, path, { fps = fps })
    t.refuses("option 'fps' must be positive", path.export_osg, path, out .. "/p.path", { fps = fps })
end
-- The frames iterator, called by hand with any control value, ends or refuses.
local step, state, control = path:frames{ fps = 10 }
assert(step(state, control) == 1)
assert(step(state, math.maxinteger) == nil)
assert(step(state, -5) == nil)
t.refuses("number has no integer representation", step, state, 0 / 0)
t.refuses("bad argument #2", path.save, path, nil)
t.protected_and_finalizable(strata.path{ keys = keys }, "strata.Path")
print("abuse_path: ok")

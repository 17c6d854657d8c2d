-- The editor's Lua face refuses what it cannot use (tests/lua/abuse_lib.lua): every method on a wrong
-- self, wrong argument types, NaN and huge numbers, keys that do not exist, files that cannot be read or
-- written, a closed window, then a finalized handle. Driven by tests/cli/editor.sh under Xvfb.
local here = debug.getinfo(1, "S").source:match("^@(.*)/[^/]*$")
package.path = here .. "/../lua/?.lua;" .. package.path
local t = require "abuse_lib"
local ed = editor
local work = assert(os.getenv("WORK"), "WORK must name the test's scratch directory")

t.methods_refuse_other_selves(ed, "strata.Editor")
assert(ed:frame(1))

-- Arguments of the wrong kind.
-- Lua's own rule: a number passes where a string is asked for (it is converted).
local is_string = function(v) return type(v) == "string" or math.type(v) ~= nil end
local is_finite = function(v) return math.type(v) ~= nil and v == v and math.abs(v) ~= math.huge end
t.each_junk_refused("bad argument #2", ed.add, 2, { ed }, is_string)
t.each_junk_refused("bad argument #2", ed.remove, 2, { ed })
t.each_junk_refused("bad argument #2", ed.scrub, 2, { ed }, is_finite)
t.each_junk_refused("bad argument #2", ed.bookmark, 2, { ed }, is_string)
t.each_junk_refused("bad argument #2", ed.go, 2, { ed }, is_string)
t.each_junk_refused("bad argument #2", ed.console, 2, { ed }, is_string)
t.each_junk_refused("bad argument #2", ed.save_path, 2, { ed }, is_string)
t.each_junk_refused("bad argument #2", ed.load_path, 2, { ed }, is_string)
t.each_junk_refused("bad argument #2", ed.save, 2, { ed }, is_string)
local in_window = function(v) return is_finite(v) and v >= 0 and v < 100 end  -- the window is larger
t.each_junk_refused("bad argument #2", ed.click, 2, { ed, nil, 10 }, in_window)
t.each_junk_refused("bad argument #3", ed.click, 3, { ed, 10 }, in_window)
t.each_junk_refused("bad argument #2", ed.frame, 2, { ed }, function(v) return v == nil or math.type(v) == "integer" end)
t.refuses("number has no integer representation", ed.frame, ed, 0 / 0)
t.refuses("number has no integer representation", ed.frame, ed, 1.5)

-- Numbers out of range, keys that are not there, and the path's own checks.
t.refuses("a finite time in seconds expected", ed.scrub, ed, 0 / 0)
t.refuses("a finite time in seconds expected", ed.scrub, ed, -math.huge)
t.refuses("outside the window", ed.click, ed, 0 / 0, 10)
t.refuses("outside the window", ed.click, ed, 10, 1e300)
t.refuses("outside the window", ed.click, ed, -1, 10)
for _, key in ipairs({ 0, 1, -1, math.maxinteger, math.mininteger }) do
    t.refuses("no such key", ed.move_key, ed, key)
    t.refuses("no such key", ed.remove_key, ed, key)
    t.refuses("no such key", ed.set_duration, ed, key, 1)
end
t.refuses("number has no integer representation", ed.move_key, ed, 0 / 0)
t.refuses("number has no integer representation", ed.remove_key, ed, 1e300)
ed:add_key()
ed:camera():look_at({ 1, 1, 3 }, { 0, 0, 0 })
ed:add_key()
for _, seconds in ipairs({ 0, -1, 0 / 0, math.huge }) do
    t.refuses("a duration must be a finite number > 0", ed.set_duration, ed, 1, seconds)
end
t.refuses("the last key has no segment after it", ed.set_duration, ed, 2, 1)
t.refuses("no node named", ed.select, ed, "no such node")
t.refuses("missing.hlod", ed.add, ed, work .. "/missing.hlod")
t.refuses("missing.json", ed.load_path, ed, work .. "/missing.json")
t.refuses("no/such/folder", ed.save, ed, work .. "/no/such/folder/scene.lua")
t.refuses("no/such/folder", ed.save_path, ed, work .. "/no/such/folder/path.json")
t.refuses("no/such/folder", ed.screenshot, ed, work .. "/no/such/folder/shot.png")
-- A console line that fails, with an error of any kind, is shown in the console; the editor lives on.
for _, line in ipairs({ "error()", "error({})", "error(setmetatable({}, { __tostring = function() error('x') end }))",
                        "getmetatable(editor).__gc(1)", "editor:frame()" }) do
    assert(type(ed:console(line)) == "string", line)
end
assert(ed:frame(1) and ed:is_open(), "the editor did not survive its console")

-- A closed window: the methods that need it say so; then the handle is finalized.
ed:close()
assert(not ed:is_open() and not ed:frame(1))
t.refuses("the editor's window is closed", ed.select, ed, "bunny1")
t.refuses("the editor's window is closed", ed.add_key, ed)
t.refuses("the editor's window is closed", ed.scrub, ed, 1)
-- The handle: a protected metatable, a finalizer that checks its argument and may run twice. A finalized
-- handle holds no editor, as one whose editor a later strata.view() replaced: its methods say so.
assert(getmetatable(ed) == "strata.Editor")
t.refuses("not available in strata", debug.setmetatable, ed, {})
local gc = debug.getmetatable(ed).__gc
t.refuses("strata.Editor expected, got number", gc, 1)
t.refuses("strata.Editor expected, got no value", gc)
gc(ed)
gc(ed)
t.refuses("the editor's window is closed", ed.select, ed, "bunny1")
t.refuses("the editor's window is closed", ed.scene, ed)
assert(not ed:is_open() and not ed:frame(1))
print("abuse_editor: ok")

-- Measurements and files refuse what they cannot use (abuse_lib.lua): summaries of NaN, CSV rows
-- that are not tables, JSON of functions and cycles, folders that are not there. arg[2] is a folder
-- to write in.
local strata = require "strata"
local t = require "abuse_lib"
local out = assert(arg[2])

-- summary
t.each_junk_refused("bad argument #1", strata.summary, 1, {}, function(v) return type(v) == "table" and #v > 0 end)
t.refuses("no values", strata.summary, {})
t.refuses("value 2 is not a number", strata.summary, { 1, "x" })
t.refuses("value 2 is NaN", strata.summary, { 1, 0 / 0, 3 })
local s = strata.summary({ 1, math.huge, -math.huge, 1e300 })
assert(s.count == 4 and s.max == math.huge and s.min == -math.huge)

-- write_csv
t.refuses("bad argument #1", strata.write_csv, nil, {})
t.refuses("bad argument #2", strata.write_csv, out .. "/a.csv", 1)
t.refuses("row 2 is not a table", strata.write_csv, out .. "/a.csv", { { a = 1 }, 2 })
t.refuses("bad argument #3", strata.write_csv, out .. "/a.csv", { { a = 1 } }, 5)
t.refuses("'__tostring' must return a string", strata.write_csv, out .. "/a.csv",
          { { a = setmetatable({}, { __tostring = function() return {} end }) } })
t.refuses("raised in __tostring", strata.write_csv, out .. "/a.csv",
          { { a = setmetatable({}, { __tostring = function() error("raised in __tostring") end }) } })
t.refuses("cannot", strata.write_csv, out .. "/missing/a.csv", { { a = 1 } })

-- write_json
t.refuses("bad argument #2", strata.write_json, out .. "/a.json")
t.refuses("a function has no JSON form", strata.write_json, out .. "/a.json", { f = print })
t.refuses("a userdata has no JSON form", strata.write_json, out .. "/a.json", { io.stdout })
local cycle = {}
cycle.self = cycle
t.refuses("the table nests too deep", strata.write_json, out .. "/a.json", cycle)
t.refuses("'__tostring' must return a string", strata.write_json, out .. "/a.json",
          { [setmetatable({}, { __tostring = function() return {} end })] = 1 })
strata.write_json(out .. "/odd.json", { ["%s%n"] = 0 / 0, [1.5] = math.huge })  -- no JSON NaN: null

-- files, modified, mkdir
t.each_junk_refused("bad argument #1", strata.files, 1, {}, function(v) return type(v) == "string" or type(v) == "number" end)
t.refuses("cannot list " .. out .. "/missing", strata.files, out .. "/missing")
t.refuses("bad argument #2", strata.files, out, 5)
t.refuses("string expected, got table", strata.files, out, { {} })
t.refuses("bad argument #1", strata.modified, {})
assert(strata.modified(out .. "/%s%n") == nil)
t.refuses("bad argument #1", strata.mkdir)
t.refuses("cannot make folder " .. out .. "/odd.json/x", strata.mkdir, out .. "/odd.json/x")
print("abuse_measure: ok")

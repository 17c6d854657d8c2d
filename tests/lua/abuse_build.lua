-- strata.build refuses bad options, and an on_progress callback that raises anything (no value, nil,
-- a table, a table whose __tostring raises or returns no string) cancels the build with a Lua error
-- that reads as text, leaving no output. arg[2] is a folder to write in, arg[3] a scan (.off).
local strata = require "strata"
local t = require "abuse_lib"
local out, scan = assert(arg[2]), assert(arg[3])
local output = out .. "/abuse.hlod"

t.refuses("bad argument #1", strata.build)
t.each_junk_refused("bad argument #1", strata.build, 1, {}, function(v) return type(v) == "table" end)
t.refuses("option 'input' (the scan to build) is required", strata.build, {})
t.refuses("unknown option 'inptu'", strata.build, { inptu = scan })
for _, key in ipairs({ "levels", "block", "threads" }) do
    t.refuses(("option '%s': number has no integer representation"):format(key), strata.build, { input = scan, output = output, [key] = 0 / 0 })
    t.refuses(("option '%s': number has no integer representation"):format(key), strata.build, { input = scan, output = output, [key] = 1e300 })
    t.refuses(("option '%s': number has no integer representation"):format(key), strata.build, { input = scan, output = output, [key] = 2.5 })
    t.refuses(("option '%s' must be"):format(key), strata.build, { input = scan, output = output, [key] = -5 })
end
t.refuses("option 'threads' must be 0 to 1024", strata.build, { input = scan, output = output, threads = 1e9 })
t.refuses("option 'resume' must be a boolean", strata.build, { input = scan, output = output, resume = "yes" })
t.refuses("option 'lock_boundary' must be a boolean", strata.build, { input = scan, output = output, lock_boundary = 1 })
for _, key in ipairs({ "ratio", "sigma0", "error" }) do
    t.refuses(("option '%s' must be a finite number within float range"):format(key), strata.build, { input = scan, output = output, [key] = 1e300 })
end
t.refuses("option 'ratio' must be a finite number within float range, got", strata.build, { input = scan, output = output, ratio = 0 / 0 })
t.refuses("--ratio must lie strictly between 0 and 1", strata.build, { input = scan, output = output, ratio = 1 })
t.refuses("--block must be a multiple of 4", strata.build, { input = scan, output = output, block = 6 })
t.refuses("option 'on_progress'", strata.build, { input = scan, output = output, on_progress = 1 })
t.refuses("missing.off", strata.build, { input = out .. "/missing.off", output = output })

-- Whatever the callback raises, the build stops with a message and writes nothing.
local raised = {
    { function() error() end, "(error object is a nil value)" },
    { function() error(nil) end, "(error object is a nil value)" },
    { function() error({}) end, "(error object is a table value)" },
    { function() error(setmetatable({}, { __tostring = function() return {} end })) end, "(error object is a table value whose __tostring failed)" },
    { function() error(setmetatable({}, { __tostring = function() error("again") end })) end, "(error object is a table value whose __tostring failed)" },
    { function() error(setmetatable({}, { __tostring = function() return "a readable object" end })) end, "a readable object" },
    { function() error("%s%s%s%n", 0) end, "%s%s%s%n" },
    { function() error(42) end, "42" },
}
for i, case in ipairs(raised) do
    local message = t.refuses("on_progress: " .. case[2], strata.build, { input = scan, output = output, on_progress = case[1] })
    local f = io.open(output)
    assert(not f, "a cancelled build left " .. output)
end
print("abuse_build: ok")

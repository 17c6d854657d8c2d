-- Shared by the abuse_*.lua scripts, which hand every binding what it must refuse (wrong types, nil,
-- NaN, huge numbers, released objects, tampered metatables) and check that each call ends in a Lua
-- error with a message that says something specific, never a crash. Run as a script it checks itself.
local M = {}

-- Calls f(...) and returns its error message; fails unless the call raised a string containing
-- `expected` (plain text, not a pattern).
function M.refuses(expected, f, ...)
    local ok, message = pcall(f, ...)
    if ok then error(("expected an error saying '%s', the call succeeded"):format(expected), 2) end
    if type(message) ~= "string" then error(("the error is a %s, not a message"):format(type(message)), 2) end
    if not message:find(expected, 1, true) then
        error(("expected '%s' in the error, got: %s"):format(expected, message), 2)
    end
    return message
end

-- Values of every kind a binding may be handed by mistake (nil is given separately: a table has no
-- nil entries).
M.junk = { false, true, 0, -1, 0.5, 0 / 0, math.huge, -math.huge, 1e300, math.mininteger, math.maxinteger,
           "", "x", {}, { 1, 2, 3 }, print, coroutine.create(print), io.stdout }

-- What a junk value looks like in an error.
function M.show(value) return type(value) == "string" and ("%q"):format(value) or tostring(value) end

-- Every method of `object` (read through debug.getmetatable: getmetatable answers only the type's
-- name), called on each junk value and nil as self: a type error naming the expected type.
function M.methods_refuse_other_selves(object, type_name)
    local methods = debug.getmetatable(object).__index
    local count = 0
    for name, method in pairs(methods) do
        M.refuses(type_name .. " expected, got no value", method)
        for _, value in ipairs(M.junk) do M.refuses(type_name .. " expected", method, value) end
        count = count + 1
    end
    assert(count > 0, "no methods found")
    return methods
end

-- The metatable is protected: getmetatable gives the name, setmetatable and debug.setmetatable fail,
-- the registry is out of reach; the finalizer checks its argument and may run twice; afterwards every
-- method says the object has been released. `object` is finalized by this check.
function M.protected_and_finalizable(object, type_name)
    assert(getmetatable(object) == type_name, "getmetatable gives " .. M.show(getmetatable(object)))
    M.refuses("table expected, got " .. type_name, setmetatable, object, {})  -- userdata take none from Lua
    M.refuses("cannot change a protected metatable", setmetatable, setmetatable({}, { __metatable = type_name }), {})
    M.refuses("not available in strata", debug.setmetatable, object, {})
    M.refuses("not available in strata", debug.getregistry)
    local gc = debug.getmetatable(object).__gc
    M.refuses(type_name .. " expected, got number", gc, 1)
    M.refuses(type_name .. " expected, got no value", gc)
    M.refuses(type_name .. " expected, got FILE*", gc, io.stdout)
    gc(object)
    gc(object)  -- twice: harmless
    for name, method in pairs(debug.getmetatable(object).__index) do
        if name ~= "release" then M.refuses(type_name .. " has been released", method, object) end
    end
end

-- Each value of M.junk and nil as argument `position` of f (the others as in `args`): an error that
-- mentions `expected` for every one except those `accepts` allows.
function M.each_junk_refused(expected, f, position, args, accepts)
    for _, value in ipairs({ "nil", table.unpack(M.junk) }) do
        if value == "nil" then value = nil end
        if not (accepts and accepts(value)) then
            local call = { table.unpack(args, 1, math.max(#args, position)) }
            call[position] = value
            local ok, message = pcall(f, table.unpack(call, 1, math.max(#args, position)))
            if ok then error(("argument %d = %s was accepted"):format(position, M.show(value)), 2) end
            if type(message) ~= "string" or not message:find(expected, 1, true) then
                error(("argument %d = %s: expected '%s', got: %s"):format(position, M.show(value), expected, tostring(message)), 2)
            end
        end
    end
end

-- The process's resident memory now, in MB (Linux).
function M.rss_mb()
    for line in io.lines("/proc/self/status") do
        local kb = line:match("^VmRSS:%s+(%d+) kB")
        if kb then return tonumber(kb) / 1024 end
    end
    error("no VmRSS in /proc/self/status")
end

if ... ~= "abuse_lib" then  -- run as a script: the checks check
    assert(not pcall(M.refuses, "x", function() end), "refuses accepts a call that succeeds")
    assert(not pcall(M.refuses, "x", error, {}), "refuses accepts a non-string error")
    assert(not pcall(M.refuses, "wanted", error, "other"), "refuses ignores the message")
    assert(M.refuses("wanted", error, "it is wanted here") == "it is wanted here")
    assert(M.rss_mb() > 1)
    print("abuse_lib: ok")
end
return M

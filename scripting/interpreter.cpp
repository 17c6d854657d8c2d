#include "scripting/interpreter.h"

#include <cstdio>
#include <stdexcept>

#include <lua.hpp>

#include "scripting/lua_util.h"

namespace strata {

namespace {

// Readable printing of results: tables (sorted keys, nested, depth-limited), strings quoted.
const char* const kPrinter = R"(
local function show(value, indent, seen)
    if type(value) == "string" then return string.format("%q", value) end
    if type(value) ~= "table" then return tostring(value) end
    if seen[value] then return "{...}" end
    if indent > 3 then return "{…}" end
    seen[value] = true
    local keys = {}
    for k in pairs(value) do keys[#keys + 1] = k end
    table.sort(keys, function(a, b)
        if type(a) == type(b) and (type(a) == "number" or type(a) == "string") then return a < b end
        return type(a) < type(b)
    end)
    local parts, pad = {}, string.rep("  ", indent + 1)
    for i, k in ipairs(keys) do
        local key = (type(k) == "number" and k == i) and "" or
                    (type(k) == "string" and k:match("^[%a_][%w_]*$") and k .. " = " or "[" .. show(k, indent + 1, seen) .. "] = ")
        parts[#parts + 1] = pad .. key .. show(value[k], indent + 1, seen)
    end
    seen[value] = nil
    if #parts == 0 then return "{}" end
    local flat = "{ " .. table.concat(parts, ", "):gsub("\n%s*", " "):gsub("^%s+", ""):gsub(",%s+", ", ") .. " }"
    if #flat <= 72 and not flat:find("\n") then return flat end
    return "{\n" .. table.concat(parts, ",\n") .. "\n" .. string.rep("  ", indent) .. "}"
end
return function(...)
    local out = {}
    for i = 1, select("#", ...) do out[i] = show(select(i, ...), 0, {}) end
    if #out > 0 then print(table.concat(out, "\t")) end
end
)";

// Whether `source` compiles, as Lua's own REPL decides: as an expression ("return " + source), else as
// statements; when neither compiles and the statements stop short (the error is at <eof>), more lines
// are expected.
enum class Chunk { complete, incomplete, invalid };

bool compiles(lua_State* L, const std::string& source, std::string* error = nullptr) {
    const bool ok = luaL_loadbuffer(L, source.data(), source.size(), "=stdin") == LUA_OK;
    if (!ok && error) *error = lua_tostring(L, -1);
    lua_pop(L, 1);
    return ok;
}

Chunk classify(lua_State* L, const std::string& source) {
    std::string error;
    if (compiles(L, "return " + source) || compiles(L, source, &error)) return Chunk::complete;
    const bool at_end = error.size() >= 5 && error.compare(error.size() - 5, 5, "<eof>") == 0;
    return at_end ? Chunk::incomplete : Chunk::invalid;
}

}  // namespace

Interpreter::Interpreter(Runtime& runtime) : runtime_(runtime) {
    lua_State* L = runtime.state();
    if (luaL_loadstring(L, kPrinter) != LUA_OK) throw std::logic_error(lua_tostring(L, -1));
    lua_call(L, 0, 1);
    printer_ = luaL_ref(L, LUA_REGISTRYINDEX);
}

Interpreter::~Interpreter() { luaL_unref(runtime_.state(), LUA_REGISTRYINDEX, printer_); }

bool Interpreter::feed(const std::string& line) {
    buffer_ += buffer_.empty() ? line : "\n" + line;
    if (classify(runtime_.state(), buffer_) == Chunk::incomplete) return false;
    last_chunk_ = std::move(buffer_);
    buffer_.clear();
    evaluate(last_chunk_);
    return true;
}

void Interpreter::finish() {
    if (buffer_.empty()) return;
    evaluate(buffer_);
    buffer_.clear();
}

// Runs `source` as an expression whose values are printed, or else as statements.
void Interpreter::evaluate(const std::string& source) {
    lua_State* L = runtime_.state();
    const int base = lua_gettop(L);
    const std::string expression = "return " + source;
    if (luaL_loadbuffer(L, expression.data(), expression.size(), "=stdin") != LUA_OK) {
        lua_pop(L, 1);
        if (luaL_loadbuffer(L, source.data(), source.size(), "=stdin") != LUA_OK) {
            runtime_.write_output(lua::error_text(L, -1) + "\n", true);
            lua_settop(L, base);
            return;
        }
    }
    if (runtime_.protected_call(0, LUA_MULTRET)) {
        const int results = lua_gettop(L) - base;
        lua_rawgeti(L, LUA_REGISTRYINDEX, printer_);
        lua_insert(L, base + 1);
        runtime_.protected_call(results, 0);
    }
    lua_settop(L, base);
    std::fflush(stdout);
}

}  // namespace strata

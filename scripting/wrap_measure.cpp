// Measurements from Lua: strata.summary(values) → count, min, max, mean, median, p95;
// strata.write_csv(path, rows[, columns]) and strata.write_json(path, value) for per-frame statistics
// (frame:stats() tables) and summaries; strata.now().
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include <lua.hpp>
#include <nlohmann/json.hpp>

#include "preprocess/atomic_file.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"

namespace strata {

namespace {

// Writes `text` to `path` through a temporary file; a Lua error naming the path if it cannot.
int write_text(lua_State* L, const std::string& path, const std::string& text) {
    try {
        AtomicOutputFile file(path);
        file.write(text.data(), text.size());
        file.commit();
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 0;
}

// The value at quantile q of sorted `v`, interpolating between neighbours.
double quantile(const std::vector<double>& v, double q) {
    const double position = q * double(v.size() - 1);
    const size_t below = size_t(std::floor(position));
    const size_t above = std::min(below + 1, v.size() - 1);
    return v[below] + (v[above] - v[below]) * (position - double(below));
}

int summary(lua_State* L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    std::vector<double> values;
    for (lua_Integer i = 1; i <= lua_Integer(lua_rawlen(L, 1)); ++i) {
        lua_rawgeti(L, 1, i);
        int is_number = 0;
        const double v = lua_tonumberx(L, -1, &is_number);
        lua_pop(L, 1);
        if (!is_number) return luaL_argerror(L, 1, lua_pushfstring(L, "value %I is not a number", i));
        // NaN has no place in a sorted order (std::sort would read past the values).
        if (std::isnan(v)) return luaL_argerror(L, 1, lua_pushfstring(L, "value %I is NaN", i));
        values.push_back(v);
    }
    if (values.empty()) return luaL_argerror(L, 1, "no values");
    std::sort(values.begin(), values.end());
    double sum = 0;
    for (double v : values) sum += v;
    const std::pair<const char*, double> fields[] = {{"count", double(values.size())}, {"min", values.front()},
                                                     {"max", values.back()},           {"mean", sum / double(values.size())},
                                                     {"median", quantile(values, 0.5)}, {"p95", quantile(values, 0.95)}};
    lua::push_numbers(L, fields);
    return 1;
}

std::string csv_field(lua_State* L, int index) {
    if (lua_isnil(L, index)) return "";
    if (lua_type(L, index) == LUA_TNUMBER) {
        if (lua_isinteger(L, index)) return std::to_string(lua_tointeger(L, index));
        char text[32];
        std::snprintf(text, sizeof text, "%.9g", lua_tonumber(L, index));
        return text;
    }
    std::string s = luaL_tolstring(L, index, nullptr);
    lua_pop(L, 1);
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string quoted = "\"";
    for (char c : s) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

int write_csv(lua_State* L) {
    const std::string path = luaL_checkstring(L, 1);
    luaL_checktype(L, 2, LUA_TTABLE);
    const lua_Integer rows = lua_Integer(lua_rawlen(L, 2));
    std::vector<std::string> columns;
    if (!lua_isnoneornil(L, 3)) {
        luaL_checktype(L, 3, LUA_TTABLE);
        for (lua_Integer i = 1; i <= lua_Integer(lua_rawlen(L, 3)); ++i) {
            lua_rawgeti(L, 3, i);
            columns.push_back(luaL_checkstring(L, -1));
            lua_pop(L, 1);
        }
    } else if (rows > 0) {  // the first row's keys, sorted
        lua_rawgeti(L, 2, 1);
        luaL_checktype(L, -1, LUA_TTABLE);
        lua_pushnil(L);
        while (lua_next(L, -2)) {
            lua_pop(L, 1);
            if (lua_type(L, -1) == LUA_TSTRING) columns.push_back(lua_tostring(L, -1));
        }
        lua_pop(L, 1);
        std::sort(columns.begin(), columns.end());
    }
    std::string text;
    for (size_t c = 0; c < columns.size(); ++c) text += (c ? "," : "") + columns[c];
    text += "\n";
    for (lua_Integer r = 1; r <= rows; ++r) {
        lua_rawgeti(L, 2, r);
        if (!lua_istable(L, -1)) return luaL_argerror(L, 2, lua_pushfstring(L, "row %d is not a table", int(r)));
        for (size_t c = 0; c < columns.size(); ++c) {
            lua_getfield(L, -1, columns[c].c_str());
            text += (c ? "," : "") + csv_field(L, -1);
            lua_pop(L, 1);
        }
        text += "\n";
        lua_pop(L, 1);
    }
    return write_text(L, path, text);
}

int now(lua_State* L) {  // seconds on a steady clock, for timing parts of a script
    lua_pushnumber(L, std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count());
    return 1;
}

// A Lua value as JSON: tables with keys 1…n are arrays, other tables objects (keys as strings);
// numbers, strings, booleans; nil is null. Functions and userdata have no JSON form: an error.
nlohmann::json to_json(lua_State* L, int index, int depth) {
    if (depth > 64) luaL_error(L, "strata.write_json: the table nests too deep (a cycle?)");
    // Each level holds a key, a value and a copy on the stack: a C function is given 20 slots only.
    luaL_checkstack(L, 4, "strata.write_json: the table nests too deep");
    switch (lua_type(L, index)) {
    case LUA_TNIL: return nullptr;
    case LUA_TBOOLEAN: return bool(lua_toboolean(L, index));
    case LUA_TNUMBER:
        if (lua_isinteger(L, index)) return lua_tointeger(L, index);
        if (!std::isfinite(lua_tonumber(L, index))) return nullptr;  // JSON has no inf or NaN
        return lua_tonumber(L, index);
    case LUA_TSTRING: return std::string(lua_tostring(L, index));
    case LUA_TTABLE: break;
    default: luaL_error(L, "strata.write_json: a %s has no JSON form", luaL_typename(L, index));
    }
    index = lua_absindex(L, index);
    const lua_Integer length = lua_Integer(lua_rawlen(L, index));
    size_t keys = 0;
    lua_pushnil(L);
    while (lua_next(L, index)) {
        lua_pop(L, 1);
        ++keys;
    }
    if (length > 0 && keys == size_t(length)) {
        nlohmann::json array = nlohmann::json::array();
        for (lua_Integer i = 1; i <= length; ++i) {
            lua_rawgeti(L, index, i);
            array.push_back(to_json(L, -1, depth + 1));
            lua_pop(L, 1);
        }
        return array;
    }
    nlohmann::json object = nlohmann::json::object();
    lua_pushnil(L);
    while (lua_next(L, index)) {
        lua_pushvalue(L, -2);
        const std::string key = luaL_tolstring(L, -1, nullptr);
        lua_pop(L, 2);
        object[key] = to_json(L, -1, depth + 1);
        lua_pop(L, 1);
    }
    return object;
}

int write_json(lua_State* L) {
    const std::string path = luaL_checkstring(L, 1);
    luaL_checkany(L, 2);
    const std::string text = to_json(L, 2, 0).dump(2) + "\n";
    return write_text(L, path, text);
}

}  // namespace

void register_measure(lua_State* L) {
    const luaL_Reg functions[] = {{"write_json", write_json}, {"now", now}, {"summary", summary}, {"write_csv", write_csv},
                                  {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata

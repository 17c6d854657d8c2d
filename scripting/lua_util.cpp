#include "scripting/lua_util.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>

namespace strata::lua {

namespace {

bool table_of_numbers(lua_State* L, int index, int count, double* out) {
    if (!lua_istable(L, index) || lua_rawlen(L, index) != size_t(count)) return false;
    for (int i = 0; i < count; ++i) {
        lua_rawgeti(L, index, i + 1);
        int is_number = 0;
        out[i] = lua_tonumberx(L, -1, &is_number);
        lua_pop(L, 1);
        if (!is_number || !std::isfinite(out[i])) return false;
    }
    return true;
}

// Converting a double beyond float's range to float is undefined behaviour, not infinity.
bool fits_float(double value) { return std::abs(value) <= std::numeric_limits<float>::max(); }

bool absent(lua_State* L, int index) { return lua_isnoneornil(L, index); }

[[noreturn]] void option_error(lua_State* L, const char* key, const char* expected) {
    luaL_error(L, "option '%s' must be %s, got %s", key, expected, luaL_typename(L, -1));
    std::abort();  // luaL_error does not return
}

// Runs a guarded function (set_functions): the real one is upvalue 1.
int guarded_call(lua_State* L) {
    const lua_CFunction function = lua_tocfunction(L, lua_upvalueindex(1));
    try {
        return function(L);
    } catch (const std::exception& e) {  // not Lua's own errors: those are no std::exception
        return luaL_error(L, "%s", e.what());
    }
}

// luaL_tolstring in a protected call: a __tostring may raise, or return something not a string.
int to_text(lua_State* L) {
    luaL_tolstring(L, 1, nullptr);
    return 1;
}

}  // namespace

void released_error(lua_State* L, int index, const char* type_name) {
    luaL_argerror(L, index, lua_pushfstring(L, "%s has been released", type_name));
    std::abort();  // luaL_argerror does not return
}

void set_functions(lua_State* L, const luaL_Reg* functions) {
    for (; functions->name; ++functions) {
        lua_pushcfunction(L, functions->func);
        lua_pushcclosure(L, guarded_call, 1);
        lua_setfield(L, -2, functions->name);
    }
}

void account_external(lua_State* L, size_t bytes) {
    const size_t kilobytes = std::min<size_t>(bytes / 1024, size_t(std::numeric_limits<int>::max()));
    if (kilobytes > 0) lua_gc(L, LUA_GCSTEP, int(kilobytes));
}

std::string error_text(lua_State* L, int index) {
    index = lua_absindex(L, index);
    const bool readable = lua_type(L, index) == LUA_TSTRING || lua_type(L, index) == LUA_TNUMBER;
    if (!readable) {
        if (luaL_getmetafield(L, index, "__tostring") == LUA_TNIL)
            return std::string("(error object is a ") + luaL_typename(L, index) + " value)";
        lua_pop(L, 1);
    }
    lua_pushcfunction(L, to_text);
    lua_pushvalue(L, index);
    const bool converted = lua_pcall(L, 1, 1, 0) == LUA_OK && lua_type(L, -1) == LUA_TSTRING;
    std::string text = converted ? lua_tostring(L, -1) : "";
    lua_pop(L, 1);
    if (!converted) return std::string("(error object is a ") + luaL_typename(L, index) + " value whose __tostring failed)";
    return text;
}

lua_Integer opt_integer(lua_State* L, int index, const char* key, lua_Integer fallback) {
    if (!get_option(L, index, key)) {
        lua_pop(L, 1);
        return fallback;
    }
    if (lua_type(L, -1) != LUA_TNUMBER) option_error(L, key, "a number");
    int is_integer = 0;
    const lua_Integer value = lua_tointegerx(L, -1, &is_integer);
    if (!is_integer) luaL_error(L, "option '%s': number has no integer representation (%s)", key, lua_tostring(L, -1));
    lua_pop(L, 1);
    return value;
}

float to_float(lua_State* L, double value, const char* what) {
    if (!fits_float(value)) luaL_error(L, "%s must be a finite number within float range, got %f", what, value);
    return float(value);
}

float opt_float(lua_State* L, int index, const char* key, float fallback) {
    const double value = opt_number(L, index, key, fallback);
    if (fits_float(value)) return float(value);
    return to_float(L, value, lua_pushfstring(L, "option '%s'", key));  // raises, naming the option
}

glm::vec3 check_color(lua_State* L, int index) {
    const glm::dvec3 color = check_vec3(L, index);
    for (int i = 0; i < 3; ++i)
        if (!fits_float(color[i])) luaL_argerror(L, index, "a color's components must be within float range");
    return glm::vec3(color);
}

lua_Integer opt_integer_in(lua_State* L, int index, const char* key, lua_Integer fallback, lua_Integer lo, lua_Integer hi) {
    const lua_Integer value = opt_integer(L, index, key, fallback);
    if (value < lo || value > hi) luaL_error(L, "option '%s' must be %I to %I, got %I", key, lo, hi, value);
    return value;
}

// "{x, y, z} expected, got a table of 2 values" (or "got nil", …).
[[noreturn]] void shape_error(lua_State* L, int index, const char* expected) {
    const char* got = lua_istable(L, index) ? lua_pushfstring(L, "a table of %d values", int(lua_rawlen(L, index)))
                                            : luaL_typename(L, index);
    luaL_argerror(L, index, lua_pushfstring(L, "%s expected, got %s", expected, got));
    std::abort();  // luaL_argerror does not return
}

glm::dvec3 check_vec3(lua_State* L, int index) {
    double v[3];
    if (!table_of_numbers(L, index, 3, v)) shape_error(L, index, "{x, y, z} (3 finite numbers)");
    return {v[0], v[1], v[2]};
}

glm::dquat check_quat(lua_State* L, int index) {
    double v[4];
    if (!table_of_numbers(L, index, 4, v)) shape_error(L, index, "quaternion {w, x, y, z}");
    const glm::dquat q(v[0], v[1], v[2], v[3]);
    if (glm::length(q) == 0) luaL_argerror(L, index, "the quaternion has length 0");
    return is_unit(q) ? q : glm::normalize(q);
}

// 1e-12: what computed rotations (look-at, products of rotations) leave, far below anything a view shows.
bool is_unit(const glm::dquat& q) { return std::abs(glm::length(q) - 1) <= 1e-12; }

glm::dmat4 check_mat4(lua_State* L, int index) {
    glm::dmat4 m;
    if (!table_of_numbers(L, index, 16, &m[0][0])) shape_error(L, index, "a matrix (16 finite numbers, column-major)");
    return m;
}

std::optional<glm::dmat4> opt_mat4(lua_State* L, int index, const char* key) {
    glm::dmat4 m;
    if (!get_option(L, index, key)) {
        lua_pop(L, 1);
        return std::nullopt;
    }
    if (!table_of_numbers(L, lua_gettop(L), 16, &m[0][0])) option_error(L, key, "a matrix (16 finite numbers, column-major)");
    lua_pop(L, 1);
    return m;
}

void push_mat4(lua_State* L, const glm::dmat4& m) {
    lua_createtable(L, 16, 0);
    for (int i = 0; i < 16; ++i) {
        lua_pushnumber(L, m[i / 4][i % 4]);
        lua_rawseti(L, -2, i + 1);
    }
}

void push_vec3(lua_State* L, const glm::dvec3& v) {
    lua_createtable(L, 3, 0);
    for (int i = 0; i < 3; ++i) {
        lua_pushnumber(L, v[i]);
        lua_rawseti(L, -2, i + 1);
    }
}

void push_quat(lua_State* L, const glm::dquat& q) {
    lua_createtable(L, 4, 0);
    const double values[4] = {q.w, q.x, q.y, q.z};
    for (int i = 0; i < 4; ++i) {
        lua_pushnumber(L, values[i]);
        lua_rawseti(L, -2, i + 1);
    }
}

void push_numbers(lua_State* L, std::span<const std::pair<const char*, double>> fields) {
    lua_createtable(L, 0, int(fields.size()));
    for (const auto& [name, value] : fields) {
        lua_pushnumber(L, value);
        lua_setfield(L, -2, name);
    }
}

void push_pose(lua_State* L, const glm::dvec3& position, const glm::dquat& orientation, double fov_degrees) {
    lua_createtable(L, 0, 3);
    push_vec3(L, position);
    lua_setfield(L, -2, "position");
    push_quat(L, orientation);
    lua_setfield(L, -2, "orientation");
    lua_pushnumber(L, fov_degrees);
    lua_setfield(L, -2, "fov");
}

namespace {

// What is wrong with the point at `index` (a message pushed on the stack), or null with `point` read.
const char* point_problem(lua_State* L, int index, int least, int most, bool with_crs, const char* shape, Point& point) {
    if (!lua_istable(L, index)) return lua_pushfstring(L, "%s expected, got %s", shape, luaL_typename(L, index));
    lua_pushnil(L);
    while (lua_next(L, index)) {
        lua_pop(L, 1);
        const bool crs_key = lua_type(L, -1) == LUA_TSTRING && std::string_view(lua_tostring(L, -1)) == "crs";
        const lua_Integer position = lua_isinteger(L, -1) ? lua_tointeger(L, -1) : 0;
        if (!(crs_key && with_crs) && !(position >= 1 && position <= most)) return lua_pushfstring(L, "%s expected (an unknown key)", shape);
    }
    const int count = int(lua_rawlen(L, index));
    if (count < least) return lua_pushfstring(L, "%s expected (%d numbers)", shape, count);
    for (int i = 0; i < count; ++i) {
        lua_rawgeti(L, index, i + 1);
        int is_number = 0;
        point.v[size_t(i)] = lua_tonumberx(L, -1, &is_number);
        lua_pop(L, 1);
        if (!is_number || !std::isfinite(point.v[size_t(i)])) return lua_pushfstring(L, "%s expected (entry %d is not a finite number)", shape, i + 1);
    }
    if (with_crs) {
        lua_pushliteral(L, "crs");
        lua_rawget(L, index);
        if (!lua_isnil(L, -1) && lua_type(L, -1) != LUA_TSTRING) return "option 'crs' must be a string (EPSG:N, WKT or PROJ)";
        if (!lua_isnil(L, -1)) point.crs = lua_tostring(L, -1);
        lua_pop(L, 1);
    }
    return nullptr;
}

}  // namespace

Point check_point(lua_State* L, int index, int least, int most, bool with_crs, const char* shape) {
    Point point;
    if (const char* problem = point_problem(L, index, least, most, with_crs, shape, point)) luaL_argerror(L, index, problem);
    return point;
}

std::optional<Point> opt_point(lua_State* L, int index, const char* key, int least, int most, bool with_crs, const char* shape) {
    if (!get_option(L, index, key)) {
        lua_pop(L, 1);
        return std::nullopt;
    }
    Point point;
    if (const char* problem = point_problem(L, lua_gettop(L), least, most, with_crs, shape, point)) luaL_error(L, "option '%s': %s", key, problem);
    lua_pop(L, 1);
    return point;
}

bool get_option(lua_State* L, int index, const char* key) {
    if (absent(L, index)) {
        lua_pushnil(L);
        return false;
    }
    luaL_checktype(L, index, LUA_TTABLE);
    lua_getfield(L, index, key);
    return !lua_isnil(L, -1);
}

double opt_number(lua_State* L, int index, const char* key, double fallback) {
    if (!get_option(L, index, key)) {
        lua_pop(L, 1);
        return fallback;
    }
    if (lua_type(L, -1) != LUA_TNUMBER) option_error(L, key, "a number");
    const double value = lua_tonumber(L, -1);
    lua_pop(L, 1);
    return value;
}

bool opt_boolean(lua_State* L, int index, const char* key, bool fallback) {
    if (!get_option(L, index, key)) {
        lua_pop(L, 1);
        return fallback;
    }
    if (lua_type(L, -1) != LUA_TBOOLEAN) option_error(L, key, "a boolean");
    const bool value = lua_toboolean(L, -1);
    lua_pop(L, 1);
    return value;
}

std::string opt_string(lua_State* L, int index, const char* key, const std::string& fallback) {
    if (!get_option(L, index, key)) {
        lua_pop(L, 1);
        return fallback;
    }
    if (lua_type(L, -1) != LUA_TSTRING) option_error(L, key, "a string");
    std::string value = lua_tostring(L, -1);
    lua_pop(L, 1);
    return value;
}

void check_keys(lua_State* L, int index, std::initializer_list<const char*> keys) {
    if (absent(L, index)) return;
    luaL_checktype(L, index, LUA_TTABLE);
    lua_pushnil(L);
    while (lua_next(L, index)) {
        lua_pop(L, 1);  // the value; the key stays for lua_next
        const char* key = lua_type(L, -1) == LUA_TSTRING ? lua_tostring(L, -1) : nullptr;
        if (!key || std::none_of(keys.begin(), keys.end(), [&](const char* k) { return std::strcmp(k, key) == 0; })) {
            std::string valid;
            for (const char* k : keys) valid += std::string(valid.empty() ? "" : ", ") + k;
            luaL_argerror(L, index, lua_pushfstring(L, "unknown option '%s' (valid: %s)", key ? key : "?", valid.c_str()));
        }
    }
}

}  // namespace strata::lua

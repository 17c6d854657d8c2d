// Small helpers shared by the wrap_*.cpp files: userdata holding shared pointers, and argument and
// option checks whose errors name the function, the argument and what was expected (Lua's own
// luaL_argerror wording: "bad argument #2 to 'look_at' (table of 3 numbers expected, got nil)").
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <lua.hpp>

namespace strata::lua {

// The name a type's userdata carry (set by register_type): what finalizers and checks compare with.
template <class T>
const char*& type_name_of() {
    static const char* name = nullptr;
    return name;
}

// A full userdata holding a std::shared_ptr<T>, with the metatable register_type<T> made.
template <class T>
void push_shared(lua_State* L, std::shared_ptr<T> object) {
    void* memory = lua_newuserdatauv(L, sizeof(std::shared_ptr<T>), 0);
    new (memory) std::shared_ptr<T>(std::move(object));
    luaL_setmetatable(L, type_name_of<T>());
}

// The slot of the T userdata at `index`, empty once released (or finalized); an argument error
// ("strata.Node expected, got number") for any other value.
template <class T>
std::shared_ptr<T>& check_slot(lua_State* L, int index) {
    return *static_cast<std::shared_ptr<T>*>(luaL_checkudata(L, index, type_name_of<T>()));
}

[[noreturn]] void released_error(lua_State* L, int index, const char* type_name);

// The object at `index`, or an argument error: another value, or one released ("strata.Frame has
// been released").
template <class T>
std::shared_ptr<T>& check_shared(lua_State* L, int index) {
    std::shared_ptr<T>& slot = check_slot<T>(L, index);
    if (!slot) released_error(L, index, type_name_of<T>());
    return slot;
}

// The object at `index` if it is a live T userdata, else nullptr (for errors worded by the caller).
template <class T>
std::shared_ptr<T> test_shared(lua_State* L, int index) {
    const auto* held = static_cast<std::shared_ptr<T>*>(luaL_testudata(L, index, type_name_of<T>()));
    return held ? *held : nullptr;
}

// Drops the object a T userdata holds: its __gc, and where a type offers it, release() and __close.
// Idempotent (the slot is left empty, and an empty shared_ptr owns nothing to destroy); any other
// argument is an argument error, so a finalizer called by hand cannot run on foreign memory.
template <class T>
int release_shared(lua_State* L) {
    check_slot<T>(L, 1).reset();
    return 0;
}

// Sets `functions` into the table on top of the stack, each guarded: a C++ exception escaping one
// (std::bad_alloc, std::length_error, …) becomes a Lua error with its message. (Lua built as C++
// would catch it too, but report whatever value was on top of the stack as the error.)
void set_functions(lua_State* L, const luaL_Reg* functions);

// Makes the metatable of userdata holding std::shared_ptr<T>, named `type_name`: `methods` as
// __index, a finalizer (release_shared), `metamethods` (__tostring, __eq, __close, …), and a
// __metatable field, so scripts see the name instead of the metatable and cannot replace it.
template <class T>
void register_type(lua_State* L, const char* type_name, const luaL_Reg* methods, const luaL_Reg* metamethods = nullptr) {
    type_name_of<T>() = type_name;
    luaL_newmetatable(L, type_name);
    lua_newtable(L);
    set_functions(L, methods);
    lua_setfield(L, -2, "__index");
    const luaL_Reg finalizer[] = {{"__gc", release_shared<T>}, {nullptr, nullptr}};
    set_functions(L, finalizer);
    if (metamethods) set_functions(L, metamethods);
    lua_pushstring(L, type_name);
    lua_setfield(L, -2, "__metatable");
    lua_pop(L, 1);
}

// Tells the collector about `bytes` held outside Lua's heap by the userdata just made (a frame's
// pixels, a model's meshes): Lua sees only the userdata's few bytes, and would let thousands of
// unreachable frames pile up before it collects. Adds the size to the collector's debt, so it runs
// as far as that allocation would have made it run.
void account_external(lua_State* L, size_t bytes);

// A number option that must fit a float (a finite number within ±3.4e38), else an error naming it.
float opt_float(lua_State* L, int index, const char* key, float fallback);
// `value` as a float, or an error naming `what` when it does not fit one.
float to_float(lua_State* L, double value, const char* what);
// {r, g, b} at `index` (check_vec3, each within float range).
glm::vec3 check_color(lua_State* L, int index);

// The error value at `index` as text, never null and never raising: a string or number as it is, a
// value whose __tostring gives a string through that, anything else as "(error object is a table
// value)".
std::string error_text(lua_State* L, int index);

// A number option or argument that must be an integer: Lua's own error for 1.5, NaN or 1e300
// ("number has no integer representation").
lua_Integer opt_integer(lua_State* L, int index, const char* key, lua_Integer fallback);
// The same, within [lo, hi], else an error naming the option and the range.
lua_Integer opt_integer_in(lua_State* L, int index, const char* key, lua_Integer fallback, lua_Integer lo, lua_Integer hi);

// {x, y, z} at `index`, or an argument error.
glm::dvec3 check_vec3(lua_State* L, int index);
// A point given as {a, b[, c][, crs = "..."]} (c: 0 when absent): finite numbers at 1…`most`, at
// least `least` of them, and a CRS when `with_crs`; anything else is an argument error naming the
// expected `shape` ("{lon, lat[, h][, crs = ...]}").
struct Point {
    std::array<double, 3> v{};
    std::string crs;
};
Point check_point(lua_State* L, int index, int least, int most, bool with_crs, const char* shape);
// The same as the option `key` of the table at `index`: nothing when absent, an error naming the
// option otherwise.
std::optional<Point> opt_point(lua_State* L, int index, const char* key, int least, int most, bool with_crs, const char* shape);
// {w, x, y, z} at `index`, normalized unless is_unit already, or an argument error.
glm::dquat check_quat(lua_State* L, int index);
// Of unit length up to rounding (1e-12): check_quat keeps such a quaternion as it is, because normalizing
// it again would move its last bits and a saved pose or scene would not reload bit for bit.
bool is_unit(const glm::dquat& q);
// 16 finite numbers at `index`, column-major (as OpenGL and GLM), or an argument error.
glm::dmat4 check_mat4(lua_State* L, int index);
void push_mat4(lua_State* L, const glm::dmat4& m);  // as check_mat4 reads it
// The option `key` of the table at `index` as check_mat4 reads it: nothing when absent, an error naming
// the option otherwise.
std::optional<glm::dmat4> opt_mat4(lua_State* L, int index, const char* key);
void push_vec3(lua_State* L, const glm::dvec3& v);
void push_quat(lua_State* L, const glm::dquat& q);
// A camera pose as scripts see it: {position = {x,y,z}, orientation = {w,x,y,z}, fov = degrees}.
void push_pose(lua_State* L, const glm::dvec3& position, const glm::dquat& orientation, double fov_degrees);
// A table of named numbers ({triangles = 12, cull_ms = 0.4, ...}): statistics, summaries, limits.
void push_numbers(lua_State* L, std::span<const std::pair<const char*, double>> fields);

// Options tables: `table.key` if present (of the right type, else an error naming the option), else
// `fallback`. The table is at `index` and may be absent (none or nil).
double opt_number(lua_State* L, int index, const char* key, double fallback);
bool opt_boolean(lua_State* L, int index, const char* key, bool fallback);
std::string opt_string(lua_State* L, int index, const char* key, const std::string& fallback);
// Pushes the option's value (or nil) and says whether it was present.
bool get_option(lua_State* L, int index, const char* key);
// Raises an error unless the table at `index` holds only the listed keys (catches typos early).
void check_keys(lua_State* L, int index, std::initializer_list<const char*> keys);

}  // namespace strata::lua

// Small helpers shared by the wrap_*.cpp files: userdata holding shared pointers, and argument and
// option checks whose errors name the function, the argument and what was expected (Lua's own
// luaL_argerror wording: "bad argument #2 to 'look_at' (table of 3 numbers expected, got nil)").
#pragma once

#include <memory>
#include <string>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <lua.hpp>

namespace strata::lua {

// A full userdata holding a std::shared_ptr<T>, with metatable `type_name`.
template <class T>
void push_shared(lua_State* L, std::shared_ptr<T> object, const char* type_name) {
    void* memory = lua_newuserdatauv(L, sizeof(std::shared_ptr<T>), 0);
    new (memory) std::shared_ptr<T>(std::move(object));
    luaL_setmetatable(L, type_name);
}

template <class T>
std::shared_ptr<T>& check_shared(lua_State* L, int index, const char* type_name) {
    return *static_cast<std::shared_ptr<T>*>(luaL_checkudata(L, index, type_name));
}

// The object at `index` if it is a `type_name` userdata, else nullptr (for errors worded by the caller).
template <class T>
std::shared_ptr<T> test_shared(lua_State* L, int index, const char* type_name) {
    const auto* held = static_cast<std::shared_ptr<T>*>(luaL_testudata(L, index, type_name));
    return held ? *held : nullptr;
}

// __gc for push_shared userdata.
template <class T>
int collect_shared(lua_State* L) {
    static_cast<std::shared_ptr<T>*>(lua_touserdata(L, 1))->~shared_ptr();
    return 0;
}

// {x, y, z} at `index`, or an argument error.
glm::dvec3 check_vec3(lua_State* L, int index);
// {w, x, y, z} at `index`, normalized unless is_unit already, or an argument error.
glm::dquat check_quat(lua_State* L, int index);
// Of unit length up to rounding (1e-12): check_quat keeps such a quaternion as it is, because normalizing
// it again would move its last bits and a saved pose or scene would not reload bit for bit.
bool is_unit(const glm::dquat& q);
// 16 finite numbers at `index`, column-major (as OpenGL and GLM), or an argument error.
glm::dmat4 check_mat4(lua_State* L, int index);
void push_vec3(lua_State* L, const glm::dvec3& v);
void push_quat(lua_State* L, const glm::dquat& q);
// A camera pose as scripts see it: {position = {x,y,z}, orientation = {w,x,y,z}, fov = degrees}.
void push_pose(lua_State* L, const glm::dvec3& position, const glm::dquat& orientation, double fov_degrees);

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

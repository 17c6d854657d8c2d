// What every node has in Lua: the type "node" (name, visibility, bounds, user values, type, find)
// and strata.load, which makes a node of the type its file holds. Nodes are userdata holding a shared
// pointer (node_types.cpp): a node lives while Lua or a parent holds it.
#include <filesystem>
#include <string>

#include <lua.hpp>

#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "scripting/lua_util.h"
#include "scripting/node_types.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::opt_number;
using lua::opt_string;

int load(lua_State* L) {
    const std::string path = luaL_checkstring(L, 1);
    check_keys(L, 2, {"name", "pixel_error", "kappa0", "morph"});
    NodePtr node;
    try {
        if (path.size() > 5 && path.substr(path.size() - 5) == ".hlod") {
            auto model = HlodModel::open(path);
            model->set_pixel_error(opt_number(L, 2, "pixel_error", 1.0));
            if (lua::get_option(L, 2, "kappa0")) model->set_kappa0(opt_number(L, 2, "kappa0", 2.0));
            lua_pop(L, 1);
            model->set_morph(lua::opt_boolean(L, 2, "morph", true));
            node = model;
        } else {
            node = Geometry::load(path);
        }
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    node->set_name(opt_string(L, 2, "name", node->name()));
    push_node(L, node);
    // Models load whole: about their file's size lies outside Lua's heap.
    std::error_code unknown;
    const std::uintmax_t bytes = std::filesystem::file_size(path, unknown);
    if (!unknown) lua::account_external(L, size_t(bytes));
    return 1;
}

// ---- every node ------------------------------------------------------------------------------

int node_name(lua_State* L) {
    const NodePtr& node = check_node(L, 1);
    if (lua_gettop(L) >= 2) node->set_name(luaL_checkstring(L, 2));
    lua_pushstring(L, node->name().c_str());
    return 1;
}

int node_visible(lua_State* L) {
    const NodePtr& node = check_node(L, 1);
    if (lua_gettop(L) >= 2) {
        luaL_checktype(L, 2, LUA_TBOOLEAN);
        node->set_visible(lua_toboolean(L, 2));
    }
    lua_pushboolean(L, node->visible());
    return 1;
}

int node_bounds(lua_State* L) {
    const Box& box = check_node(L, 1)->bound();
    if (!box.valid()) return 0;
    lua_createtable(L, 0, 4);
    lua::push_vec3(L, box.lo);
    lua_setfield(L, -2, "min");
    lua::push_vec3(L, box.hi);
    lua_setfield(L, -2, "max");
    lua::push_vec3(L, box.center());
    lua_setfield(L, -2, "center");
    lua_pushnumber(L, box.radius());
    lua_setfield(L, -2, "radius");
    return 1;
}

int node_set(lua_State* L) {  // node:set(key, value): a user value (number, string or boolean)
    const NodePtr& node = check_node(L, 1);
    const std::string key = luaL_checkstring(L, 2);
    switch (lua_type(L, 3)) {
    case LUA_TNUMBER: node->set_user_value(key, lua_tonumber(L, 3)); break;
    case LUA_TSTRING: node->set_user_value(key, std::string(lua_tostring(L, 3))); break;
    case LUA_TBOOLEAN: node->set_user_value(key, bool(lua_toboolean(L, 3))); break;
    default: return luaL_typeerror(L, 3, "number, string or boolean");
    }
    return 0;
}

int node_get(lua_State* L) {
    const UserValue* value = check_node(L, 1)->user_value(luaL_checkstring(L, 2));
    if (!value) return 0;
    std::visit([&](const auto& v) {
        using V = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<V, double>) lua_pushnumber(L, v);
        else if constexpr (std::is_same_v<V, std::string>) lua_pushstring(L, v.c_str());
        else lua_pushboolean(L, v);
    }, *value);
    return 1;
}

int node_type(lua_State* L) {
    lua_pushstring(L, node_type_of(*check_node(L, 1)).name);
    return 1;
}

int node_find(lua_State* L) {
    const NodePtr& root = check_node(L, 1);  // first: a wrong self is the error to report
    NodePtr found = find_node(root, luaL_checkstring(L, 2));
    if (!found) return 0;
    push_node(L, found);
    return 1;
}

// ---- transforms ------------------------------------------------------------------------------

// translate · rotate · scale, from {translate = {x,y,z}, rotate = {x°,y°,z°} (applied x, then y,
// then z) or quaternion = {w,x,y,z}, scale = s}; or any matrix = {16 numbers} (what a saved scene
// writes when those cannot give the matrix bit for bit).
const luaL_Reg kNodeMethods[] = {{"name", node_name}, {"visible", node_visible}, {"bounds", node_bounds},
                                 {"set", node_set},   {"get", node_get},         {"type", node_type},
                                 {"find", node_find}, {nullptr, nullptr}};

const luaL_Reg kFunctions[] = {{"load", load}, {nullptr, nullptr}};

}  // namespace

const NodeType kNodeBaseType = {
    .name = "node",
    .base = nullptr,
    .is = [](const Node&) { return true; },
    .methods = kNodeMethods,
};

void register_scene(lua_State* L) {
    register_node_types(L);
    lua::set_functions(L, kFunctions);
}

}  // namespace strata

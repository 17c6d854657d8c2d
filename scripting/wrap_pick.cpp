// strata.pick(scene, camera, x, y): what pixel (x, y) of the camera's image of the scene shows. nil for
// the background, else { node = <node>, point = {x,y,z}, normal = {x,y,z}, distance = d, provisional = b }
// in the world frame: the nearest surface as drawn (an HLOD model's selection and morph for that
// camera); provisional when a streamed model drew a stand-in there, finer data still to come.
#include <optional>

#include <lua.hpp>

#include "engine/scene/pick.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"
#include "scripting/wrap_camera.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

int pick(lua_State* L) {
    const NodePtr& scene = check_node(L, 1);
    const Camera& camera = *check_camera(L, 2);
    const double x = luaL_checknumber(L, 3), y = luaL_checknumber(L, 4);
    luaL_argcheck(L, x >= 0 && x < camera.width, 3, "outside the image");
    luaL_argcheck(L, y >= 0 && y < camera.height, 4, "outside the image");
    std::optional<PickHit> hit;
    try {
        hit = strata::pick(*scene, camera, x, y);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    if (!hit) {
        lua_pushnil(L);
        return 1;
    }
    lua_createtable(L, 0, 5);
    push_node(L, find_node(scene, hit->node));  // a hit names its node by address
    lua_setfield(L, -2, "node");
    lua::push_vec3(L, hit->point);
    lua_setfield(L, -2, "point");
    lua::push_vec3(L, hit->normal);
    lua_setfield(L, -2, "normal");
    lua_pushnumber(L, hit->distance);
    lua_setfield(L, -2, "distance");
    lua_pushboolean(L, hit->provisional);
    lua_setfield(L, -2, "provisional");
    return 1;
}

}  // namespace

void register_pick(lua_State* L) {
    const luaL_Reg functions[] = {{"pick", pick}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata

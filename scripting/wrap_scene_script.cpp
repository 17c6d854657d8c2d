// strata.save_scene(path, { scene =, camera =, bookmarks =, paths = }): the scene as a script that
// rebuilds it (scene_script.h), each part defaulting to the global of its name, which is where a scene
// script leaves it; and read_scene_globals, the same reading for C++ after a scene script ran.
#include <algorithm>

#include <lua.hpp>

#include "scripting/lua_util.h"
#include "scripting/runtime.h"
#include "scripting/scene_script.h"
#include "scripting/wrap_camera.h"
#include "scripting/wrap_path.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

// Pushes the option `key` of the table at `index` when given (false included), else the global `key`.
void push_part(lua_State* L, int index, const char* key) {
    if (lua::get_option(L, index, key)) return;
    lua_pop(L, 1);
    lua_getglobal(L, key);
}

NodePtr check_scene(lua_State* L, int index) {
    push_part(L, index, "scene");
    NodePtr scene = test_node(L, -1);
    if (!scene) luaL_error(L, "'scene' must be a strata node (the root of the scene), got %s", luaL_typename(L, -1));
    lua_pop(L, 1);
    return scene;
}

// nil or false: none.
std::shared_ptr<Camera> check_camera_part(lua_State* L, int index) {
    push_part(L, index, "camera");
    std::shared_ptr<Camera> camera;
    if (lua_toboolean(L, -1)) {
        camera = lua::test_shared<Camera>(L, -1);
        if (!camera) luaL_error(L, "'camera' must be a strata camera, got %s", luaL_typename(L, -1));
    }
    lua_pop(L, 1);
    return camera;
}

// { name = "…", position = …, orientation = … or target = … (and up), fov = … }, read as camera:set_pose does.
Bookmark check_bookmark(lua_State* L, int index, int number) {
    if (!lua_istable(L, index)) luaL_error(L, "bookmark %d must be a table, got %s", number, luaL_typename(L, index));
    lua::check_keys(L, index, {"name", "position", "orientation", "target", "up", "fov"});
    const std::string name = lua::opt_string(L, index, "name", "");
    if (name.empty()) luaL_error(L, "bookmark %d needs a 'name'", number);
    if (!lua::get_option(L, index, "position")) luaL_error(L, "bookmark %d ('%s') needs a 'position'", number, name.c_str());
    lua_pop(L, 1);
    Camera pose;
    apply_pose(L, index, pose);
    return {name, pose.position, pose.orientation, pose.fov_y_degrees};
}

std::vector<Bookmark> check_bookmarks(lua_State* L, int index) {
    push_part(L, index, "bookmarks");
    std::vector<Bookmark> bookmarks;
    if (lua_toboolean(L, -1)) {
        if (!lua_istable(L, -1)) luaL_error(L, "'bookmarks' must be an array of bookmarks, got %s", luaL_typename(L, -1));
        const int list = lua_gettop(L);
        for (int i = 1; i <= int(lua_rawlen(L, list)); ++i) {
            lua_rawgeti(L, list, i);
            bookmarks.push_back(check_bookmark(L, lua_gettop(L), i));
            lua_pop(L, 1);
        }
    }
    lua_pop(L, 1);
    return bookmarks;
}

std::vector<std::pair<std::string, std::shared_ptr<CameraPath>>> check_paths(lua_State* L, int index) {
    push_part(L, index, "paths");
    std::vector<std::pair<std::string, std::shared_ptr<CameraPath>>> paths;
    if (lua_toboolean(L, -1)) {
        if (!lua_istable(L, -1)) luaL_error(L, "'paths' must be a table of name = strata path, got %s", luaL_typename(L, -1));
        lua_pushnil(L);
        while (lua_next(L, -2)) {
            if (lua_type(L, -2) != LUA_TSTRING) luaL_error(L, "'paths' must be keyed by name, not by %s", luaL_typename(L, -2));
            std::shared_ptr<CameraPath> path = lua::test_shared<CameraPath>(L, -1);
            if (!path) luaL_error(L, "paths[\"%s\"] must be a strata path, got %s", lua_tostring(L, -2), luaL_typename(L, -1));
            paths.emplace_back(lua_tostring(L, -2), std::move(path));
            lua_pop(L, 1);
        }
        // A table has no order: by name, so that saving twice writes the same text.
        std::sort(paths.begin(), paths.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    }
    lua_pop(L, 1);
    return paths;
}

SceneState check_state(lua_State* L, int index) {
    return {check_scene(L, index), check_camera_part(L, index), check_bookmarks(L, index), check_paths(L, index)};
}

int save_scene(lua_State* L) {
    const char* file = luaL_checkstring(L, 1);
    lua::check_keys(L, 2, {"scene", "camera", "bookmarks", "paths"});
    const SceneState state = check_state(L, 2);
    try {
        save_scene_script(state, file);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    return 0;
}

int read_globals(lua_State* L) {  // (SceneState*): fills it from the globals (no options table at 2)
    *static_cast<SceneState*>(lua_touserdata(L, 1)) = check_state(L, 2);
    return 0;
}

}  // namespace

SceneState read_scene_globals(lua_State* L) {
    SceneState state;
    lua_pushcfunction(L, read_globals);
    lua_pushlightuserdata(L, &state);
    if (lua_pcall(L, 1, 0, 0) != LUA_OK) {
        std::string message = lua::error_text(L, -1);
        lua_pop(L, 1);
        throw std::runtime_error(message);
    }
    return state;
}

void register_scene_script(lua_State* L) {
    const luaL_Reg functions[] = {{"save_scene", save_scene}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata

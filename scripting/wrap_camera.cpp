// strata.camera{…} and its methods: pose (position, orientation, fov), look-at, framing a node,
// perspective or orthographic projection, clip planes (fitted to the scene unless set), image size.
#include <cmath>

#include <lua.hpp>

#include "engine/scene/camera.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"
#include "scripting/wrap_camera.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::check_vec3;

constexpr lua_Integer kMaxPixels = 16384;  // the largest framebuffer edge GL implementations offer

double check_fov(lua_State* L, int index, double fallback);

// Applies the projection and size options of a table at `index` (those present).
void apply_settings(lua_State* L, int index, Camera& c) {
    c.fov_y_degrees = check_fov(L, index, c.fov_y_degrees);
    c.width = int(lua::opt_integer_in(L, index, "width", c.width, 1, kMaxPixels));
    c.height = int(lua::opt_integer_in(L, index, "height", c.height, 1, kMaxPixels));
    const bool ortho = lua::opt_boolean(L, index, "orthographic", c.projection == ProjectionKind::orthographic);
    c.projection = ortho ? ProjectionKind::orthographic : ProjectionKind::perspective;
    c.ortho_height = lua::opt_number(L, index, "ortho_height", c.ortho_height);
    if (!(std::isfinite(c.ortho_height) && c.ortho_height > 0)) luaL_error(L, "option 'ortho_height' must be a positive number");
    c.near_clip = lua::opt_number(L, index, "near", c.near_clip);
    c.far_clip = lua::opt_number(L, index, "far", c.far_clip);
    // An infinite far plane is one (reversed depth draws to infinity).
    if (!(std::isfinite(c.near_clip) && c.near_clip >= 0 && c.far_clip >= 0))
        luaL_error(L, "options 'near' and 'far' must be distances, 0 or more (both 0: fitted to the scene), 'near' finite");
}

// The fov option of a pose or the camera's settings, in degrees.
double check_fov(lua_State* L, int index, double fallback) {
    const double fov = lua::opt_number(L, index, "fov", fallback);
    if (!(fov > 0 && fov < 180)) luaL_error(L, "option 'fov' must be between 0 and 180 degrees");
    return fov;
}

int new_camera(lua_State* L) {
    check_keys(L, 1, {"fov", "width", "height", "orthographic", "ortho_height", "near", "far", "position",
                      "orientation", "target", "up"});
    auto camera = std::make_shared<Camera>();
    camera->set_name("camera");
    apply_settings(L, 1, *camera);
    if (!lua_isnoneornil(L, 1)) apply_pose(L, 1, *camera);
    push_camera(L, camera);
    return 1;
}

int camera_look_at(lua_State* L) {
    Camera& c = *check_camera(L, 1);
    c.look_at(check_vec3(L, 2), check_vec3(L, 3), lua_isnoneornil(L, 4) ? glm::dvec3(0, 1, 0) : check_vec3(L, 4));
    lua_settop(L, 1);
    return 1;
}

int camera_frame(lua_State* L) {  // camera:frame(node): moves back along the view until the node fits
    Camera& c = *check_camera(L, 1);
    const Box& box = check_node(L, 2)->bound();
    if (!box.valid()) return luaL_argerror(L, 2, "the node has no bounds (nothing in it)");
    c.frame(box);
    lua_settop(L, 1);
    return 1;
}

int camera_pose(lua_State* L) {
    const Camera& c = *check_camera(L, 1);
    lua::push_pose(L, c.position, c.orientation, c.fov_y_degrees);
    return 1;
}

int camera_set_pose(lua_State* L) {
    Camera& c = *check_camera(L, 1);
    luaL_checktype(L, 2, LUA_TTABLE);
    // A bookmark ({name=, position=, …}, scene scripts) is a pose too: its name is ignored.
    check_keys(L, 2, {"position", "orientation", "target", "up", "fov", "name"});
    apply_pose(L, 2, c);
    lua_settop(L, 1);
    return 1;
}

int camera_set(lua_State* L) {
    Camera& c = *check_camera(L, 1);
    luaL_checktype(L, 2, LUA_TTABLE);
    check_keys(L, 2, {"fov", "width", "height", "orthographic", "ortho_height", "near", "far"});
    apply_settings(L, 2, c);
    lua_settop(L, 1);
    return 1;
}

int camera_forward(lua_State* L) {
    lua::push_vec3(L, check_camera(L, 1)->forward());
    return 1;
}

int camera_tostring(lua_State* L) {
    const Camera& c = *check_camera(L, 1);
    lua_pushfstring(L, "strata camera at (%f, %f, %f)", c.position.x, c.position.y, c.position.z);
    return 1;
}

const luaL_Reg kMethods[] = {{"look_at", camera_look_at}, {"frame", camera_frame}, {"pose", camera_pose},
                             {"set_pose", camera_set_pose}, {"set", camera_set},   {"forward", camera_forward},
                             {nullptr, nullptr}};

}  // namespace

void apply_pose(lua_State* L, int index, Camera& c) {
    if (lua::get_option(L, index, "position")) c.position = check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    if (lua::get_option(L, index, "orientation")) c.orientation = lua::check_quat(L, lua_gettop(L));
    lua_pop(L, 1);
    glm::dvec3 up{0, 1, 0};
    if (lua::get_option(L, index, "up")) up = check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    if (lua::get_option(L, index, "target")) c.look_at(c.position, check_vec3(L, lua_gettop(L)), up);
    lua_pop(L, 1);
    c.fov_y_degrees = check_fov(L, index, c.fov_y_degrees);
}

void push_camera(lua_State* L, std::shared_ptr<Camera> camera) { lua::push_shared(L, std::move(camera)); }

const std::shared_ptr<Camera>& check_camera(lua_State* L, int index) { return lua::check_shared<Camera>(L, index); }

void register_camera(lua_State* L) {
    const luaL_Reg metamethods[] = {{"__tostring", camera_tostring}, {nullptr, nullptr}};
    lua::register_type<Camera>(L, kCameraType, kMethods, metamethods);
    const luaL_Reg functions[] = {{"camera", new_camera}, {nullptr, nullptr}};
    lua::set_functions(L, functions);
}

}  // namespace strata

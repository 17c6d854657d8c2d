// Cameras as Lua values, for the other wrap_*.cpp files (render takes one, bookmarks are poses).
#pragma once

#include <memory>

#include <lua.hpp>

#include "engine/scene/camera.h"

namespace strata {

inline constexpr const char* kCameraType = "strata.Camera";

void push_camera(lua_State* L, std::shared_ptr<Camera> camera);
const std::shared_ptr<Camera>& check_camera(lua_State* L, int index);
// Sets the pose parts present in the table at `index`: position = {x,y,z}, orientation = {w,x,y,z} or
// target = {x,y,z} (with up, default +Y), fov = degrees.
void apply_pose(lua_State* L, int index, Camera& camera);

}  // namespace strata

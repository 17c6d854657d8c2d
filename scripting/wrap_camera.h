// Cameras as Lua values, for the other wrap_*.cpp files (render takes one).
#pragma once

#include <memory>

#include <lua.hpp>

#include "engine/scene/camera.h"

namespace strata {

inline constexpr const char* kCameraType = "strata.Camera";

void push_camera(lua_State* L, std::shared_ptr<Camera> camera);
const std::shared_ptr<Camera>& check_camera(lua_State* L, int index);

}  // namespace strata

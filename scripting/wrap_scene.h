// Nodes as Lua values, for the other wrap_*.cpp files (render takes a scene, camera:frame a node) and
// the scene-script writer, which writes what these bindings read back.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <lua.hpp>

#include "engine/scene/node.h"

namespace strata {

inline constexpr const char* kNodeType = "strata.Node";

void push_node(lua_State* L, NodePtr node);
// The node at `index`, or an argument error ("strata.Node expected, got …").
const NodePtr& check_node(lua_State* L, int index);
// The matrix of strata.transform{translate=, quaternion=, scale=}: translate · rotate · scale.
glm::dmat4 compose_transform(const glm::dvec3& translate, const glm::dquat& rotation, double scale);

}  // namespace strata

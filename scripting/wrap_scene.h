// Nodes as Lua values, for the other wrap_*.cpp files (render takes a scene, camera:frame a node) and
// the scene-script writer, which writes what these bindings read back.
#pragma once

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <lua.hpp>

#include "engine/scene/node.h"

namespace strata {

inline constexpr const char* kNodeTypeName = "strata.Node";

// The node as a Lua value with its type's methods (nil for a null node).
void push_node(lua_State* L, NodePtr node);
// The node at `index`, or an argument error ("strata.Node expected, got …").
const NodePtr& check_node(lua_State* L, int index);
// The node at `index`, or null for any other value (a released node's is null too).
NodePtr test_node(lua_State* L, int index);
// The node at `index` as a T, or an argument error naming `what` ("transform expected, got node 'x'").
template <class T>
T& check_node_as(lua_State* L, int index, const char* what) {
    const NodePtr& node = check_node(L, index);
    auto* typed = dynamic_cast<T*>(node.get());
    if (!typed) luaL_argerror(L, index, lua_pushfstring(L, "%s expected, got node '%s'", what, node->name().c_str()));
    return *typed;
}
// The matrix of strata.transform{translate=, quaternion=, scale=}: translate · rotate · scale.
glm::dmat4 compose_transform(const glm::dvec3& translate, const glm::dquat& rotation, double scale);

}  // namespace strata

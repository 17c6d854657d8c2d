// Nodes as Lua values, for the other wrap_*.cpp files (render takes a scene, camera:frame a node).
#pragma once

#include <lua.hpp>

#include "engine/scene/node.h"

namespace strata {

inline constexpr const char* kNodeType = "strata.Node";

void push_node(lua_State* L, NodePtr node);
// The node at `index`, or an argument error ("strata.Node expected, got …").
const NodePtr& check_node(lua_State* L, int index);

}  // namespace strata

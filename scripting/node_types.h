// The node types as scripts, saved scenes and the editor see them. Each is declared once, in its
// wrap_*.cpp: its name (node:type(), tostring's "strata.<name> 'x' (…)", the editor's outliner and
// inspector), its Lua methods (a metatable of its own whose methods fall back to its base type's), the
// inspector's fields, and the Lua that rebuilds it in a saved scene script. node_types.cpp lists them.
#pragma once

#include <span>
#include <string>
#include <vector>

#include <lua.hpp>

#include "engine/scene/node.h"
#include "scripting/inspector.h"
#include "scripting/script_text.h"

namespace strata {

struct NodeType {
    const char* name;
    const NodeType* base;                // whose methods and fields it has too; null for "node"
    bool (*is)(const Node& node);        // the node is of this type, or of one derived from it
    const luaL_Reg* methods = nullptr;   // its own methods, null-terminated (null: none)
    const luaL_Reg* functions = nullptr; // what it adds to the strata module (its constructors)
    // tostring's parenthesis after the name ("(3 children)"), without it; "" for none.
    std::string (*summary)(const Node& node) = nullptr;
    // Its own inspector fields; the editor shows the base types' first.
    void (*inspect)(Node& node, Inspector& fields) = nullptr;
    // The expression that rebuilds the node in a scene script (null: the type cannot be saved), and
    // the statements after it, on `var`, that set what its constructor does not take.
    std::string (*constructor)(const Node& node, const script::Place& place) = nullptr;
    void (*settings)(const Node& node, const std::string& var, std::vector<std::string>& lines) = nullptr;
    // Its constructor rebuilds its children too (a terrain's ground and embeddings): a scene script does
    // not write them.
    bool builds_children = false;
};

// NodeType::is for the nodes of C++ class T and those derived from it.
template <class T>
bool is_a(const Node& node) {
    return dynamic_cast<const T*>(&node) != nullptr;
}

// The types, most derived first: node_type_of takes the first that matches.
std::span<const NodeType* const> node_types();
const NodeType& node_type_of(const Node& node);
// The type and its bases, the root ("node") first.
std::vector<const NodeType*> type_chain(const NodeType& type);

// Every type's metatable and constructors into the strata module (on top of the stack). Every node's
// metatable says "strata.Node" to getmetatable and in argument errors.
void register_node_types(lua_State* L);

// The types, each declared in its own file.
extern const NodeType kNodeBaseType;      // wrap_scene.cpp
extern const NodeType kGroupType;         // wrap_group.cpp
extern const NodeType kTransformType;     // wrap_group.cpp
extern const NodeType kHlodType;          // wrap_hlod.cpp
extern const NodeType kTerrainType;       // wrap_terrain.cpp
extern const NodeType kEmbeddingType;     // wrap_terrain.cpp
extern const NodeType kGeometryType;      // wrap_geometry.cpp
extern const NodeType kDirectionalLightType;  // wrap_light.cpp
extern const NodeType kAmbientLightType;      // wrap_light.cpp

}  // namespace strata

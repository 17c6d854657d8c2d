// The list of node types, and what every node's Lua value shares: the userdata holding its shared
// pointer, the check that a value is one, tostring and ==, and a metatable per type.
#include "scripting/node_types.h"

#include <array>
#include <new>

#include "scripting/lua_util.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

const std::array<const NodeType*, 9> kNodeTypes = {&kHlodType,      &kGeometryType,         &kTerrainType,      &kEmbeddingType,
                                                   &kTransformType, &kGroupType,            &kDirectionalLightType, &kAmbientLightType,
                                                   &kNodeBaseType};

// Marks a metatable as a node's (a key no script can name: the address of this variable).
const char kNodeTag = 0;

// The slot of the node userdata at `index`, or null for any other value.
NodePtr* node_slot(lua_State* L, int index) {
    if (lua_type(L, index) != LUA_TUSERDATA || !lua_getmetatable(L, index)) return nullptr;
    const bool is_node = lua_rawgetp(L, -1, &kNodeTag) == LUA_TBOOLEAN;
    lua_pop(L, 2);
    return is_node ? static_cast<NodePtr*>(lua_touserdata(L, index)) : nullptr;
}

NodePtr& check_slot(lua_State* L, int index) {
    NodePtr* slot = node_slot(L, index);
    if (!slot) luaL_typeerror(L, index, kNodeTypeName);
    return *slot;
}

// The finalizer: drops the Lua value's hold on the node (idempotent; a parent may still hold it).
int node_gc(lua_State* L) {
    check_slot(L, 1).reset();
    return 0;
}

// strata.hlod 'bunny' (data/bunny.hlod, 12 levels), strata.group 'scene' (3 children), …
int node_tostring(lua_State* L) {
    const Node& node = *check_node(L, 1);
    const NodeType& type = node_type_of(node);
    std::string text = std::string("strata.") + type.name + " '" + node.name() + "'";
    if (const std::string summary = type.summary ? type.summary(node) : ""; !summary.empty()) text += " (" + summary + ")";
    lua_pushlstring(L, text.data(), text.size());
    return 1;
}

int node_eq(lua_State* L) {
    lua_pushboolean(L, check_node(L, 1).get() == check_node(L, 2).get());
    return 1;
}

// A type's metatable, kept in the registry under the NodeType's address (a push finds it without
// building a name): its methods as __index, whose own metatable sends what they lack to the base type's
// methods; every one protected, named "strata.Node" to scripts.
void register_type(lua_State* L, const NodeType& type) {
    lua_newtable(L);
    lua_pushvalue(L, -1);
    lua_rawsetp(L, LUA_REGISTRYINDEX, &type);
    lua_pushstring(L, kNodeTypeName);
    lua_setfield(L, -2, "__name");  // luaL_typeerror's "got strata.Node"
    lua_pushboolean(L, 1);
    lua_rawsetp(L, -2, &kNodeTag);
    lua_newtable(L);
    if (type.methods) lua::set_functions(L, type.methods);
    if (type.base) {
        lua_createtable(L, 0, 2);
        if (lua_rawgetp(L, LUA_REGISTRYINDEX, type.base) != LUA_TTABLE || lua_getfield(L, -1, "__index") != LUA_TTABLE)
            luaL_error(L, "node type '%s' registered before its base", type.name);
        lua_setfield(L, -3, "__index");
        lua_pop(L, 1);
        lua_pushstring(L, kNodeTypeName);
        lua_setfield(L, -2, "__metatable");
        lua_setmetatable(L, -2);
    }
    lua_setfield(L, -2, "__index");
    const luaL_Reg metamethods[] = {{"__gc", node_gc}, {"__tostring", node_tostring}, {"__eq", node_eq}, {nullptr, nullptr}};
    lua::set_functions(L, metamethods);
    lua_pushstring(L, kNodeTypeName);
    lua_setfield(L, -2, "__metatable");
    lua_pop(L, 1);
}

}  // namespace

std::span<const NodeType* const> node_types() { return kNodeTypes; }

const NodeType& node_type_of(const Node& node) {
    for (const NodeType* type : kNodeTypes)
        if (type->is(node)) return *type;
    return kNodeBaseType;
}

std::vector<const NodeType*> type_chain(const NodeType& type) {
    std::vector<const NodeType*> chain;
    for (const NodeType* t = &type; t; t = t->base) chain.insert(chain.begin(), t);
    return chain;
}

void register_node_types(lua_State* L) {
    for (auto type = kNodeTypes.rbegin(); type != kNodeTypes.rend(); ++type) {  // bases first
        register_type(L, **type);
        if ((*type)->functions) lua::set_functions(L, (*type)->functions);
    }
}

void push_node(lua_State* L, NodePtr node) {
    if (!node) return lua_pushnil(L);
    const NodeType& type = node_type_of(*node);
    new (lua_newuserdatauv(L, sizeof(NodePtr), 0)) NodePtr(std::move(node));
    lua_rawgetp(L, LUA_REGISTRYINDEX, &type);
    lua_setmetatable(L, -2);
}

const NodePtr& check_node(lua_State* L, int index) {
    const NodePtr& node = check_slot(L, index);
    if (!node) lua::released_error(L, index, kNodeTypeName);
    return node;
}

NodePtr test_node(lua_State* L, int index) {
    const NodePtr* slot = node_slot(L, index);
    return slot ? *slot : nullptr;
}

}  // namespace strata

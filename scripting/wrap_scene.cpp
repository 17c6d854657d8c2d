// strata.scene / group / transform / load / plane / light / ambient, and the methods of nodes.
// Nodes are userdata holding a shared pointer (type "strata.Node"): a node lives while Lua or a
// parent holds it. Methods that only some node types have say so when called on another type.
#include <array>
#include <cmath>
#include <filesystem>
#include <optional>
#include <string_view>
#include <limits>
#include <string>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtx/euler_angles.hpp>
#include <lua.hpp>

#include "engine/scene/light.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "preprocess/cube_textures.h"
#include "preprocess/georeference.h"
#include "scripting/lua_util.h"
#include "scripting/runtime.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::check_vec3;
using lua::opt_number;
using lua::opt_string;

template <class T>
T& check_node_as(lua_State* L, int index, const char* what) {
    const NodePtr& node = check_node(L, index);
    auto* typed = dynamic_cast<T*>(node.get());
    if (!typed) luaL_argerror(L, index, lua_pushfstring(L, "%s expected, got node '%s'", what, node->name().c_str()));
    return *typed;
}

// ---- constructors ----------------------------------------------------------------------------

void apply_transform_options(lua_State* L, int index, Transform& t);

int new_scene(lua_State* L) {
    auto group = std::make_shared<Group>();
    group->set_name("scene");
    push_node(L, group);
    return 1;
}

int new_group(lua_State* L) {
    check_keys(L, 1, {"name"});
    auto group = std::make_shared<Group>();
    group->set_name(opt_string(L, 1, "name", "group"));
    push_node(L, group);
    return 1;
}

int new_transform(lua_State* L) {
    check_keys(L, 1, {"name", "translate", "rotate", "quaternion", "scale", "matrix"});
    auto transform = std::make_shared<Transform>();
    transform->set_name(opt_string(L, 1, "name", "transform"));
    apply_transform_options(L, 1, *transform);
    push_node(L, transform);
    return 1;
}

int load(lua_State* L) {
    const std::string path = luaL_checkstring(L, 1);
    check_keys(L, 2, {"name", "pixel_error", "kappa0", "morph"});
    NodePtr node;
    try {
        if (path.size() > 5 && path.substr(path.size() - 5) == ".hlod") {
            auto model = HlodModel::open(path);
            model->set_pixel_error(opt_number(L, 2, "pixel_error", 1.0));
            if (lua::get_option(L, 2, "kappa0")) model->set_kappa0(opt_number(L, 2, "kappa0", 2.0));
            lua_pop(L, 1);
            model->set_morph(lua::opt_boolean(L, 2, "morph", true));
            node = model;
        } else {
            node = Geometry::load(path);
        }
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    node->set_name(opt_string(L, 2, "name", node->name()));
    push_node(L, node);
    // Models load whole: about their file's size lies outside Lua's heap.
    std::error_code unknown;
    const std::uintmax_t bytes = std::filesystem::file_size(path, unknown);
    if (!unknown) lua::account_external(L, size_t(bytes));
    return 1;
}

int new_plane(lua_State* L) {
    check_keys(L, 1, {"name", "center", "up", "width", "depth", "color"});
    glm::dvec3 center{0, 0, 0}, up{0, 1, 0};
    if (lua::get_option(L, 1, "center")) center = check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    if (lua::get_option(L, 1, "up")) up = check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    const double width = opt_number(L, 1, "width", 10), depth = opt_number(L, 1, "depth", 10);
    if (!(width > 0 && depth > 0 && std::isfinite(width) && std::isfinite(depth)))
        return luaL_error(L, "options 'width' and 'depth' must be positive numbers");
    if (glm::length(up) == 0) return luaL_error(L, "option 'up' must not be {0, 0, 0}");
    // Its corners are stored as floats.
    for (int i = 0; i < 3; ++i)
        if (!(std::abs(center[i]) + width + depth <= std::numeric_limits<float>::max()))
            return luaL_error(L, "the plane does not fit float coordinates (center and size up to 3.4e38)");
    auto plane = Geometry::plane(center, up, width, depth);
    if (lua::get_option(L, 1, "color")) plane->material.base_color = glm::vec4(lua::check_color(L, lua_gettop(L)), 1.0f);
    lua_pop(L, 1);
    plane->set_name(opt_string(L, 1, "name", "plane"));
    push_node(L, plane);
    return 1;
}

int new_light(lua_State* L) {
    check_keys(L, 1, {"name", "direction", "color", "intensity"});
    auto light = std::make_shared<DirectionalLight>();
    light->set_name(opt_string(L, 1, "name", "light"));
    if (lua::get_option(L, 1, "direction")) light->direction = check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    if (lua::get_option(L, 1, "color")) light->color = lua::check_color(L, lua_gettop(L));
    lua_pop(L, 1);
    light->intensity = lua::opt_float(L, 1, "intensity", 1.0f);
    push_node(L, light);
    return 1;
}

int new_ambient(lua_State* L) {
    check_keys(L, 1, {"name", "color"});
    auto light = std::make_shared<AmbientLight>();
    light->set_name(opt_string(L, 1, "name", "ambient"));
    if (lua::get_option(L, 1, "color")) light->color = lua::check_color(L, lua_gettop(L));
    lua_pop(L, 1);
    push_node(L, light);
    return 1;
}

// ---- every node ------------------------------------------------------------------------------

int node_name(lua_State* L) {
    const NodePtr& node = check_node(L, 1);
    if (lua_gettop(L) >= 2) node->set_name(luaL_checkstring(L, 2));
    lua_pushstring(L, node->name().c_str());
    return 1;
}

int node_visible(lua_State* L) {
    const NodePtr& node = check_node(L, 1);
    if (lua_gettop(L) >= 2) {
        luaL_checktype(L, 2, LUA_TBOOLEAN);
        node->set_visible(lua_toboolean(L, 2));
    }
    lua_pushboolean(L, node->visible());
    return 1;
}

int node_bounds(lua_State* L) {
    const Box& box = check_node(L, 1)->bound();
    if (!box.valid()) return 0;
    lua_createtable(L, 0, 4);
    lua::push_vec3(L, box.lo);
    lua_setfield(L, -2, "min");
    lua::push_vec3(L, box.hi);
    lua_setfield(L, -2, "max");
    lua::push_vec3(L, box.center());
    lua_setfield(L, -2, "center");
    lua_pushnumber(L, box.radius());
    lua_setfield(L, -2, "radius");
    return 1;
}

int node_set(lua_State* L) {  // node:set(key, value): a user value (number, string or boolean)
    const NodePtr& node = check_node(L, 1);
    const std::string key = luaL_checkstring(L, 2);
    switch (lua_type(L, 3)) {
    case LUA_TNUMBER: node->set_user_value(key, lua_tonumber(L, 3)); break;
    case LUA_TSTRING: node->set_user_value(key, std::string(lua_tostring(L, 3))); break;
    case LUA_TBOOLEAN: node->set_user_value(key, bool(lua_toboolean(L, 3))); break;
    default: return luaL_typeerror(L, 3, "number, string or boolean");
    }
    return 0;
}

int node_get(lua_State* L) {
    const UserValue* value = check_node(L, 1)->user_value(luaL_checkstring(L, 2));
    if (!value) return 0;
    std::visit([&](const auto& v) {
        using V = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<V, double>) lua_pushnumber(L, v);
        else if constexpr (std::is_same_v<V, std::string>) lua_pushstring(L, v.c_str());
        else lua_pushboolean(L, v);
    }, *value);
    return 1;
}

const char* type_name(const Node* node) {
    return dynamic_cast<const HlodModel*>(node)        ? "hlod"
           : dynamic_cast<const Geometry*>(node)       ? "geometry"
           : dynamic_cast<const Transform*>(node)      ? "transform"
           : dynamic_cast<const Group*>(node)          ? "group"
           : dynamic_cast<const DirectionalLight*>(node) ? "light"
           : dynamic_cast<const AmbientLight*>(node)   ? "ambient"
                                                       : "node";
}

int node_type(lua_State* L) {
    lua_pushstring(L, type_name(check_node(L, 1).get()));
    return 1;
}

// strata.hlod 'bunny' (data/bunny.hlod, 12 levels), strata.group 'scene' (3 children), …
int node_tostring(lua_State* L) {
    const Node* node = check_node(L, 1).get();
    lua_pushfstring(L, "strata.%s '%s'", type_name(node), node->name().c_str());
    if (const auto* model = dynamic_cast<const HlodModel*>(node))
        lua_pushfstring(L, " (%s, %d levels)", model->path().c_str(), int(model->header().max_level + 1));
    else if (const auto* geometry = dynamic_cast<const Geometry*>(node))
        lua_pushfstring(L, " (%d triangles)", int(geometry->mesh().triangle_count()));
    else if (const auto* group = dynamic_cast<const Group*>(node))
        lua_pushfstring(L, group->child_count() == 1 ? " (%d child)" : " (%d children)", int(group->child_count()));
    else
        lua_pushliteral(L, "");
    lua_concat(L, 2);
    return 1;
}

int node_eq(lua_State* L) {
    lua_pushboolean(L, check_node(L, 1).get() == check_node(L, 2).get());
    return 1;
}

// ---- groups ----------------------------------------------------------------------------------

int group_add(lua_State* L) {
    Group& group = check_node_as<Group>(L, 1, "group or transform");
    for (int i = 2; i <= lua_gettop(L); ++i) {
        const NodePtr& child = check_node(L, i);
        try {
            group.add(child);
        } catch (const std::exception& e) {
            return luaL_error(L, "%s", e.what());
        }
    }
    lua_settop(L, 1);
    return 1;  // the group, so calls chain
}

int group_remove(lua_State* L) {
    Group& group = check_node_as<Group>(L, 1, "group or transform");
    lua_pushboolean(L, group.remove(check_node(L, 2).get()));
    return 1;
}

int group_children(lua_State* L) {  // for i, child in group:children() do … end
    Group& group = check_node_as<Group>(L, 1, "group or transform");
    lua_createtable(L, int(group.child_count()), 0);
    for (size_t i = 0; i < group.child_count(); ++i) {
        push_node(L, group.child(i));
        lua_rawseti(L, -2, lua_Integer(i + 1));
    }
    lua_getglobal(L, "ipairs");
    lua_insert(L, -2);
    lua_call(L, 1, 3);
    return 3;
}

int group_count(lua_State* L) {
    lua_pushinteger(L, lua_Integer(check_node_as<Group>(L, 1, "group or transform").child_count()));
    return 1;
}

int node_find(lua_State* L) {
    const NodePtr& root = check_node(L, 1);  // first: a wrong self is the error to report
    NodePtr found = find_node(root, luaL_checkstring(L, 2));
    if (!found) return 0;
    push_node(L, found);
    return 1;
}

// ---- transforms ------------------------------------------------------------------------------

// translate · rotate · scale, from {translate = {x,y,z}, rotate = {x°,y°,z°} (applied x, then y,
// then z) or quaternion = {w,x,y,z}, scale = s}; or any matrix = {16 numbers} (what a saved scene
// writes when those cannot give the matrix bit for bit).
void apply_transform_options(lua_State* L, int index, Transform& t) {
    if (lua::get_option(L, index, "matrix")) {
        const glm::dmat4 matrix = lua::check_mat4(L, lua_gettop(L));
        lua_pop(L, 1);
        for (const char* key : {"translate", "rotate", "quaternion", "scale"}) {
            if (lua::get_option(L, index, key)) luaL_error(L, "option 'matrix' cannot be combined with '%s'", key);
            lua_pop(L, 1);
        }
        t.set_matrix(matrix);
        return;
    }
    lua_pop(L, 1);
    glm::dvec3 translate{0, 0, 0};
    glm::dquat rotation{1, 0, 0, 0};
    double scale = 1;
    if (lua::get_option(L, index, "translate")) translate = check_vec3(L, lua_gettop(L));
    lua_pop(L, 1);
    if (lua::get_option(L, index, "rotate")) {
        const glm::dvec3 degrees = check_vec3(L, lua_gettop(L));
        rotation = glm::angleAxis(glm::radians(degrees.z), glm::dvec3(0, 0, 1)) *
                   glm::angleAxis(glm::radians(degrees.y), glm::dvec3(0, 1, 0)) *
                   glm::angleAxis(glm::radians(degrees.x), glm::dvec3(1, 0, 0));
    }
    lua_pop(L, 1);
    if (lua::get_option(L, index, "quaternion")) rotation = lua::check_quat(L, lua_gettop(L));
    lua_pop(L, 1);
    scale = opt_number(L, index, "scale", 1.0);
    if (!(scale > 0 && std::isfinite(scale))) luaL_error(L, "option 'scale' must be positive (the HLOD selection assumes uniform scale)");
    t.set_matrix(compose_transform(translate, rotation, scale));
}

int transform_set(lua_State* L) {  // transform:set_transform{translate=…, rotate=…, scale=…}: replaces the matrix
    Transform& t = check_node_as<Transform>(L, 1, "transform");
    luaL_checktype(L, 2, LUA_TTABLE);
    check_keys(L, 2, {"translate", "rotate", "quaternion", "scale", "matrix"});
    apply_transform_options(L, 2, t);
    return 0;
}

int transform_matrix(lua_State* L) {  // 16 numbers, column-major (as OpenGL and GLM)
    const glm::dmat4& m = check_node_as<Transform>(L, 1, "transform").matrix();
    lua_createtable(L, 16, 0);
    for (int i = 0; i < 16; ++i) {
        lua_pushnumber(L, m[i / 4][i % 4]);
        lua_rawseti(L, -2, i + 1);
    }
    return 1;
}

// ---- HLOD models -----------------------------------------------------------------------------

int hlod_set(lua_State* L) {  // model:set_lod{pixel_error=…} / {kappa0=…, morph=…, debug=…, boxes=…}
    HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    luaL_checktype(L, 2, LUA_TTABLE);
    check_keys(L, 2, {"pixel_error", "kappa0", "morph", "debug", "boxes"});
    try {
        if (lua::get_option(L, 2, "pixel_error")) model.set_pixel_error(opt_number(L, 2, "pixel_error", 1));
        lua_pop(L, 1);
        if (lua::get_option(L, 2, "kappa0")) model.set_kappa0(opt_number(L, 2, "kappa0", 2));
        lua_pop(L, 1);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    model.set_morph(lua::opt_boolean(L, 2, "morph", model.morph()));
    model.set_show_cube_boxes(lua::opt_boolean(L, 2, "boxes", model.show_cube_boxes()));
    const std::string debug = opt_string(L, 2, "debug", "");
    if (const auto view = debug_view_named(debug)) model.set_debug_view(*view);
    else if (!debug.empty()) return luaL_error(L, "option 'debug' must be %s, not '%s'", kHlodDebugViewNames, debug.c_str());
    return 0;
}

int hlod_info(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const HlodHeader& h = model.header();
    uint64_t triangles = 0;
    for (const HlodCube& c : model.cubes()) triangles += c.node.level == h.max_level ? c.node.triangle_count : 0;
    lua_createtable(L, 0, 11);
    lua_pushinteger(L, h.max_level + 1);
    lua_setfield(L, -2, "levels");
    lua_pushinteger(L, lua_Integer(model.cubes().size()));
    lua_setfield(L, -2, "cubes");
    lua_pushinteger(L, lua_Integer(triangles));
    lua_setfield(L, -2, "triangles");
    lua_pushnumber(L, h.sigma0);
    lua_setfield(L, -2, "sigma0");
    lua_pushnumber(L, h.error_q);
    lua_setfield(L, -2, "error_q");
    lua_pushnumber(L, model.pixel_error());
    lua_setfield(L, -2, "pixel_error");
    lua_pushboolean(L, model.morph());
    lua_setfield(L, -2, "morph");
    lua_pushstring(L, model.path().c_str());
    lua_setfield(L, -2, "path");
    if (!h.crs.empty()) {
        lua_pushstring(L, h.crs.c_str());
        lua_setfield(L, -2, "crs");
    }
    lua_pushboolean(L, h.terrain.has_value());
    lua_setfield(L, -2, "terrain");
    if (const CubeTextures* textures = model.textures()) {
        lua_pushinteger(L, textures->layout().size);
        lua_setfield(L, -2, "texture_size");
    }
    return 1;
}

// ---- georeference ----------------------------------------------------------------------------

// A point given as {a, b[, c][, crs = "..."]} (c: 0 when absent): finite numbers at 1…`most`, at
// least `least` of them, and a CRS when `with_crs`; anything else is an argument error naming the
// expected shape.
struct PointArgument {
    std::array<double, 3> v{};
    std::string crs;
};
PointArgument check_point(lua_State* L, int index, int least, int most, bool with_crs, const char* shape) {
    if (!lua_istable(L, index)) luaL_argerror(L, index, lua_pushfstring(L, "%s expected, got %s", shape, luaL_typename(L, index)));
    PointArgument p;
    lua_pushnil(L);
    while (lua_next(L, index)) {
        lua_pop(L, 1);
        const bool crs_key = lua_type(L, -1) == LUA_TSTRING && std::string_view(lua_tostring(L, -1)) == "crs";
        const lua_Integer position = lua_isinteger(L, -1) ? lua_tointeger(L, -1) : 0;
        if (!(crs_key && with_crs) && !(position >= 1 && position <= most)) luaL_argerror(L, index, lua_pushfstring(L, "%s expected (an unknown key)", shape));
    }
    const int count = int(lua_rawlen(L, index));
    if (count < least) luaL_argerror(L, index, lua_pushfstring(L, "%s expected (%d numbers)", shape, count));
    for (int i = 0; i < count; ++i) {
        lua_rawgeti(L, index, i + 1);
        int is_number = 0;
        p.v[size_t(i)] = lua_tonumberx(L, -1, &is_number);
        lua_pop(L, 1);
        if (!is_number || !std::isfinite(p.v[size_t(i)])) luaL_argerror(L, index, lua_pushfstring(L, "%s expected (entry %d is not a finite number)", shape, i + 1));
    }
    if (with_crs) {
        lua_pushliteral(L, "crs");
        lua_rawget(L, index);
        if (!lua_isnil(L, -1) && lua_type(L, -1) != LUA_TSTRING) luaL_argerror(L, index, "option 'crs' must be a string (EPSG:N, WKT or PROJ)");
        if (!lua_isnil(L, -1)) p.crs = lua_tostring(L, -1);
        lua_pop(L, 1);
    }
    return p;
}

const Georeference& check_georeference(lua_State* L, const HlodModel& model) {
    const Georeference* geo = model.georeference();
    if (!geo) luaL_error(L, "%s: the model has no georeference (it was built from a file without a CRS)", model.path().c_str());
    return *geo;
}

glm::dvec3 as_vec3(const std::array<double, 3>& v) { return {v[0], v[1], v[2]}; }

// model:to_local{lon, lat[, h][, crs = ...]} → {x, y, z}
int hlod_to_local(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const PointArgument p = check_point(L, 2, 2, 3, true, "{lon, lat[, h][, crs = ...]}");
    lua::push_vec3(L, as_vec3(check_georeference(L, model).to_local(p.v, p.crs)));
    return 1;
}

// model:to_geo{x, y, z[, crs = ...]} → {lon, lat, h}
int hlod_to_geo(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const PointArgument p = check_point(L, 2, 3, 3, true, "{x, y, z[, crs = ...]}");
    lua::push_vec3(L, as_vec3(check_georeference(L, model).to_geo(p.v, p.crs)));
    return 1;
}

// model:height_at{x, y} → the ground's height, or nil outside the raster or on nodata
int hlod_height_at(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const PointArgument p = check_point(L, 2, 2, 2, false, "{x, y}");
    const std::optional<double> h = model.height_at(p.v[0], p.v[1]);
    if (h) lua_pushnumber(L, *h);
    else lua_pushnil(L);
    return 1;
}

const luaL_Reg kNodeMethods[] = {
    {"name", node_name},         {"visible", node_visible},   {"bounds", node_bounds},
    {"set", node_set},           {"get", node_get},           {"type", node_type},
    {"find", node_find},         {"add", group_add},          {"remove", group_remove},
    {"children", group_children}, {"count", group_count},     {"set_transform", transform_set},
    {"matrix", transform_matrix}, {"set_lod", hlod_set},      {"info", hlod_info},
    {"to_local", hlod_to_local}, {"to_geo", hlod_to_geo},     {"height_at", hlod_height_at},
    {nullptr, nullptr}};

const luaL_Reg kFunctions[] = {{"scene", new_scene}, {"group", new_group},   {"transform", new_transform},
                               {"load", load},       {"plane", new_plane},   {"light", new_light},
                               {"ambient", new_ambient}, {nullptr, nullptr}};

}  // namespace

glm::dmat4 compose_transform(const glm::dvec3& translate, const glm::dquat& rotation, double scale) {
    return glm::translate(glm::dmat4(1.0), translate) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1.0), glm::dvec3(scale));
}

void push_node(lua_State* L, NodePtr node) { lua::push_shared(L, std::move(node)); }

const NodePtr& check_node(lua_State* L, int index) { return lua::check_shared<Node>(L, index); }

void register_scene(lua_State* L) {
    const luaL_Reg metamethods[] = {{"__tostring", node_tostring}, {"__eq", node_eq}, {nullptr, nullptr}};
    lua::register_type<Node>(L, kNodeType, kNodeMethods, metamethods);
    lua::set_functions(L, kFunctions);
}

}  // namespace strata

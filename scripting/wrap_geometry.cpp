// The node type "geometry": a mesh loaded by strata.load (OBJ, PLY, OFF, STL) or made by strata.plane,
// drawn as it is; its inspector fields and scene-script line.
#include <cmath>
#include <filesystem>
#include <limits>

#include "nodes/geometry.h"
#include "scripting/lua_util.h"
#include "scripting/node_types.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::check_vec3;
using lua::opt_number;
using lua::opt_string;

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

std::string geometry_summary(const Node& node) {
    return std::to_string(static_cast<const Geometry&>(node).mesh().triangle_count()) + " triangles";
}

void inspect_geometry(Node& node, Inspector& fields) {
    const Mesh& mesh = static_cast<const Geometry&>(node).mesh();
    fields.text(std::to_string(mesh.vertex_count()) + " vertices, " + std::to_string(mesh.triangle_count()) + " triangles");
}

// A plane by its parameters, a loaded mesh by its file; a mesh built in code cannot be saved.
std::string geometry_constructor(const Node& node, const script::Place& place) {
    const auto& g = static_cast<const Geometry&>(node);
    const std::string name = "name = " + script::string(g.name());
    const glm::vec4& color = g.material.base_color;
    if (color.a != 1) script::cannot_write(g, "has a colour with alpha, which the Lua API cannot set");
    if (const auto* plane = std::get_if<PlaneSource>(&g.source()))
        return "strata.plane{ " + name + ", center = " + script::numbers(plane->center) + ", up = " + script::numbers(plane->up) +
               ", width = " + script::number(plane->width) + ", depth = " + script::number(plane->depth) +
               ", color = " + script::numbers(glm::vec3(color)) + " }";
    if (color != Material{}.base_color) script::cannot_write(g, "is a loaded mesh with a colour, which the Lua API cannot set");
    if (const auto* path = std::get_if<std::filesystem::path>(&g.source()))
        return "strata.load(" + place.file(*path) + ", { " + name + " })";
    script::cannot_write(g, "is a mesh built in code, with no file or plane to rebuild it from");
}

const luaL_Reg kGeometryFunctions[] = {{"plane", new_plane}, {nullptr, nullptr}};

}  // namespace

const NodeType kGeometryType = {
    .name = "geometry",
    .base = &kNodeBaseType,
    .is = is_a<Geometry>,
    .functions = kGeometryFunctions,
    .summary = geometry_summary,
    .inspect = inspect_geometry,
    .constructor = geometry_constructor,
};

}  // namespace strata

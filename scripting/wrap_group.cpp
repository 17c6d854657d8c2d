// The node types "group" and "transform": strata.scene / group / transform, their methods, inspector
// fields and scene-script lines.
#include <cstring>
#include <optional>

#include <glm/gtc/matrix_transform.hpp>

#include "scripting/lua_util.h"
#include "scripting/node_types.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::check_vec3;
using lua::opt_number;
using lua::opt_string;

// ---- groups ----------------------------------------------------------------------------------

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

std::string group_summary(const Node& node) {
    const size_t count = static_cast<const Group&>(node).child_count();
    return std::to_string(count) + (count == 1 ? " child" : " children");
}

std::string group_constructor(const Node& node, const script::Place&) {
    return "strata.group{ name = " + script::string(node.name()) + " }";
}

const luaL_Reg kGroupMethods[] = {{"add", group_add},           {"remove", group_remove},
                                  {"children", group_children}, {"count", group_count},
                                  {nullptr, nullptr}};
const luaL_Reg kGroupFunctions[] = {{"scene", new_scene}, {"group", new_group}, {nullptr, nullptr}};

// ---- transforms ------------------------------------------------------------------------------

// translate · rotate · scale, from {translate = {x,y,z}, rotate = {x°,y°,z°} (applied x, then y,
// then z) or quaternion = {w,x,y,z}, scale = s}; or any matrix = {16 numbers} (what a saved scene
// writes when those cannot give the matrix bit for bit).
void apply_transform_options(lua_State* L, int index, Transform& t) {
    if (const std::optional<glm::dmat4> matrix = lua::opt_mat4(L, index, "matrix")) {
        for (const char* key : {"translate", "rotate", "quaternion", "scale"}) {
            if (lua::get_option(L, index, key)) luaL_error(L, "option 'matrix' cannot be combined with '%s'", key);
            lua_pop(L, 1);
        }
        t.set_matrix(*matrix);
        return;
    }
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

int new_transform(lua_State* L) {
    check_keys(L, 1, {"name", "translate", "rotate", "quaternion", "scale", "matrix"});
    auto transform = std::make_shared<Transform>();
    transform->set_name(opt_string(L, 1, "name", "transform"));
    apply_transform_options(L, 1, *transform);
    push_node(L, transform);
    return 1;
}

int transform_set(lua_State* L) {  // transform:set_transform{translate=…, rotate=…, scale=…}: replaces the matrix
    Transform& t = check_node_as<Transform>(L, 1, "transform");
    luaL_checktype(L, 2, LUA_TTABLE);
    check_keys(L, 2, {"translate", "rotate", "quaternion", "scale", "matrix"});
    apply_transform_options(L, 2, t);
    return 0;
}

int transform_matrix(lua_State* L) {  // 16 numbers, column-major (as OpenGL and GLM)
    lua::push_mat4(L, check_node_as<Transform>(L, 1, "transform").matrix());
    return 1;
}

// Translation, rotation (Euler degrees, XYZ) and uniform scale, as the Lua API composes them. Another
// matrix (a stretch, a shear, a mirror from a scene script) would be lost by rebuilding it from these:
// only its translation is edited.
void inspect_transform(Node& node, Inspector& fields) {
    auto& transform = static_cast<Transform&>(node);
    const glm::dmat4& m = transform.matrix();
    glm::dvec3 translation(m[3]);
    if (!is_rotation_and_uniform_scale(m)) {
        if (fields.vector("translate", translation, "%.4f")) {
            glm::dmat4 moved = m;
            moved[3] = glm::dvec4(translation, m[3][3]);
            transform.set_matrix(moved);
        }
        fields.note("general matrix: translation only");
        return;
    }
    const double scale = glm::length(glm::dvec3(m[0]));
    glm::dvec3 euler = glm::degrees(glm::eulerAngles(glm::quat_cast(glm::dmat3(m) / scale)));
    double s = scale;
    bool changed = fields.vector("translate", translation, "%.4f");
    changed |= fields.vector("rotate °", euler, "%.2f");
    changed |= fields.number("scale", s, "%.4f");
    if (changed && s > 0 && std::isfinite(s)) {
        const glm::dmat4 rotation = glm::mat4_cast(glm::dquat(glm::radians(euler)));
        transform.set_matrix(glm::translate(glm::dmat4(1.0), translation) * rotation * glm::scale(glm::dmat4(1.0), glm::dvec3(s)));
    }
}

struct Trs {
    glm::dvec3 translate;
    glm::dquat rotation;
    double scale;
};

// translate, quaternion and scale when strata.transform rebuilds exactly `m` from them (the readable
// form), else nothing. The quaternion must be one check_quat keeps as it is.
std::optional<Trs> exact_trs(const glm::dmat4& m) {
    const double scale = glm::length(glm::dvec3(m[0]));
    if (!(scale > 0)) return std::nullopt;
    const Trs trs{glm::dvec3(m[3]), glm::normalize(glm::quat_cast(glm::dmat3(m) / scale)), scale};
    const glm::dmat4 rebuilt = compose_transform(trs.translate, trs.rotation, trs.scale);
    if (!lua::is_unit(trs.rotation) || std::memcmp(&rebuilt, &m, sizeof m) != 0) return std::nullopt;  // bits, −0 too
    return trs;
}

std::string transform_constructor(const Node& node, const script::Place& place) {
    const auto& t = static_cast<const Transform&>(node);
    std::string options = "name = " + script::string(t.name());
    if (const std::optional<Trs> trs = exact_trs(t.matrix())) {
        if (trs->translate != glm::dvec3(0)) options += ", translate = " + script::numbers(trs->translate);
        if (trs->rotation != glm::dquat(1, 0, 0, 0)) options += ", quaternion = " + script::numbers(trs->rotation);
        if (trs->scale != 1) options += ", scale = " + script::number(trs->scale);
        return "strata.transform{ " + options + " }";
    }
    // A general matrix, one column a line.
    options += ", matrix = {\n";
    for (int column = 0; column < 4; ++column) {
        const glm::dvec4& c = t.matrix()[column];
        options += place.indent(1) + script::number(c.x) + ", " + script::number(c.y) + ", " + script::number(c.z) + ", " +
                   script::number(c.w) + ",\n";
    }
    return "strata.transform{ " + options + place.indent() + "} }";
}

const luaL_Reg kTransformMethods[] = {{"set_transform", transform_set}, {"matrix", transform_matrix}, {nullptr, nullptr}};
const luaL_Reg kTransformFunctions[] = {{"transform", new_transform}, {nullptr, nullptr}};

}  // namespace

glm::dmat4 compose_transform(const glm::dvec3& translate, const glm::dquat& rotation, double scale) {
    return glm::translate(glm::dmat4(1.0), translate) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1.0), glm::dvec3(scale));
}

const NodeType kGroupType = {
    .name = "group",
    .base = &kNodeBaseType,
    .is = is_a<Group>,
    .methods = kGroupMethods,
    .functions = kGroupFunctions,
    .summary = group_summary,
    .constructor = group_constructor,
};

const NodeType kTransformType = {
    .name = "transform",
    .base = &kGroupType,
    .is = is_a<Transform>,
    .methods = kTransformMethods,
    .functions = kTransformFunctions,
    .summary = group_summary,
    .inspect = inspect_transform,
    .constructor = transform_constructor,
};

}  // namespace strata

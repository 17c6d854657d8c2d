// The node types "light" (directional) and "ambient": strata.light and strata.ambient, and their
// scene-script lines.
#include "engine/scene/light.h"
#include "scripting/lua_util.h"
#include "scripting/node_types.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::check_vec3;
using lua::opt_string;

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


std::string light_constructor(const Node& node, const script::Place&) {
    const auto& light = static_cast<const DirectionalLight&>(node);
    return "strata.light{ name = " + script::string(light.name()) + ", direction = " + script::numbers(light.direction) +
           ", color = " + script::numbers(light.color) + ", intensity = " + script::number(light.intensity) + " }";
}

std::string ambient_constructor(const Node& node, const script::Place&) {
    const auto& ambient = static_cast<const AmbientLight&>(node);
    return "strata.ambient{ name = " + script::string(ambient.name()) + ", color = " + script::numbers(ambient.color) + " }";
}

const luaL_Reg kLightFunctions[] = {{"light", new_light}, {nullptr, nullptr}};
const luaL_Reg kAmbientFunctions[] = {{"ambient", new_ambient}, {nullptr, nullptr}};

}  // namespace

const NodeType kDirectionalLightType = {
    .name = "light",
    .base = &kNodeBaseType,
    .is = is_a<DirectionalLight>,
    .functions = kLightFunctions,
    .constructor = light_constructor,
};

const NodeType kAmbientLightType = {
    .name = "ambient",
    .base = &kNodeBaseType,
    .is = is_a<AmbientLight>,
    .functions = kAmbientFunctions,
    .constructor = ambient_constructor,
};

}  // namespace strata

// The node type "hlod": an HLOD model (a scan or a terrain) loaded by strata.load, its methods
// (level of detail, info, the georeference), inspector fields and scene-script lines.
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

#include "nodes/hlod_model.h"
#include "preprocess/cube_textures.h"
#include "preprocess/georeference.h"
#include "scripting/lua_util.h"
#include "scripting/node_types.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

using lua::check_keys;
using lua::opt_number;
using lua::opt_string;

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

const Georeference& check_georeference(lua_State* L, const HlodModel& model) {
    const Georeference* geo = model.georeference();
    if (!geo) luaL_error(L, "%s: the model has no georeference (it was built from a file without a CRS)", model.path().c_str());
    return *geo;
}

glm::dvec3 as_vec3(const std::array<double, 3>& v) { return {v[0], v[1], v[2]}; }

// model:to_local{lon, lat[, h][, crs = ...]} → {x, y, z}
int hlod_to_local(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const lua::Point p = lua::check_point(L, 2, 2, 3, true, "{lon, lat[, h][, crs = ...]}");
    lua::push_vec3(L, as_vec3(check_georeference(L, model).to_local(p.v, p.crs)));
    return 1;
}

// model:to_geo{x, y, z[, crs = ...]} → {lon, lat, h}
int hlod_to_geo(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const lua::Point p = lua::check_point(L, 2, 3, 3, true, "{x, y, z[, crs = ...]}");
    lua::push_vec3(L, as_vec3(check_georeference(L, model).to_geo(p.v, p.crs)));
    return 1;
}

// model:height_at{x, y} → the ground's height, or nil outside the raster or on nodata
int hlod_height_at(lua_State* L) {
    const HlodModel& model = check_node_as<HlodModel>(L, 1, "HLOD model");
    const lua::Point p = lua::check_point(L, 2, 2, 2, false, "{x, y}");
    const std::optional<double> h = model.height_at(p.v[0], p.v[1]);
    if (h) lua_pushnumber(L, *h);
    else lua_pushnil(L);
    return 1;
}

std::string hlod_summary(const Node& node) {
    const auto& model = static_cast<const HlodModel&>(node);
    return model.path().string() + ", " + std::to_string(model.header().max_level + 1) + " levels";
}

// Detail by a screen-space error in pixels (Eq. 4.5 sets κ0 per view), or by κ0 itself.
void inspect_hlod(Node& node, Inspector& fields) {
    auto& model = static_cast<HlodModel&>(node);
    const std::array<const char*, 2> detail_by = {"pixel error", "kappa0"};
    int by_kappa0 = model.pixel_error() > 0 ? 0 : 1;
    if (fields.choice("detail by", by_kappa0, detail_by)) {
        if (by_kappa0 == 0) model.set_pixel_error(1.0);
        else model.set_kappa0(model.kappa0());
    }
    if (by_kappa0 == 0) {
        double pixels = model.pixel_error();
        if (fields.slider("pixel error", pixels, 0.1, 16.0, "%.2f px") && pixels > 0 && std::isfinite(pixels)) model.set_pixel_error(pixels);
    } else {
        double kappa0 = model.kappa0();
        if (fields.slider("kappa0", kappa0, model.min_kappa0(), 32.0, "%.2f") && kappa0 > 0 && std::isfinite(kappa0)) model.set_kappa0(kappa0);
    }
    bool morph = model.morph();
    if (fields.toggle("morph", morph)) model.set_morph(morph);
    bool boxes = model.show_cube_boxes();
    if (fields.toggle("cube boxes", boxes)) model.set_show_cube_boxes(boxes);
    const std::array<const char*, 4> views = {"shaded", "colour by level", "wireframe", "residency"};
    int view = int(model.debug_view());
    if (fields.choice("view", view, views)) model.set_debug_view(HlodDebugView(view));
    fields.text(model.path().string());
    fields.text(std::to_string(model.header().max_level + 1) + " levels, " + std::to_string(model.cubes().size()) + " cubes");
}

std::string hlod_constructor(const Node& node, const script::Place& place) {
    const auto& model = static_cast<const HlodModel&>(node);
    return "strata.load(" + place.file(model.path()) + ", { name = " + script::string(model.name()) + " })";
}

void hlod_settings(const Node& node, const std::string& var, std::vector<std::string>& lines) {
    const auto& model = static_cast<const HlodModel&>(node);
    const std::string detail = model.pixel_error() > 0 ? "pixel_error = " + script::number(model.pixel_error())
                                                       : "kappa0 = " + script::number(model.kappa0());
    lines.push_back(var + ":set_lod{ " + detail + ", morph = " + script::boolean(model.morph()) +
                    ", debug = " + script::string(debug_view_name(model.debug_view())) +
                    ", boxes = " + script::boolean(model.show_cube_boxes()) + " }");
}

const luaL_Reg kHlodMethods[] = {{"set_lod", hlod_set},           {"info", hlod_info},
                                 {"to_local", hlod_to_local},     {"to_geo", hlod_to_geo},
                                 {"height_at", hlod_height_at},   {nullptr, nullptr}};

}  // namespace

const NodeType kHlodType = {
    .name = "hlod",
    .base = &kNodeBaseType,
    .is = is_a<HlodModel>,
    .methods = kHlodMethods,
    .summary = hlod_summary,
    .inspect = inspect_hlod,
    .constructor = hlod_constructor,
    .settings = hlod_settings,
};

}  // namespace strata

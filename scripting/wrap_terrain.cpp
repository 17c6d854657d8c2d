// The node types "terrain" and "embedding" (nodes/terrain.h): strata.terrain{ model =, embed = }, which
// embeds sites in a terrain built from an elevation raster, strata.embed{}, which makes an embedding file
// once (what `strata embed` does), and their methods, inspector fields and scene-script lines.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "nodes/terrain.h"
#include "preprocess/embedding.h"
#include "preprocess/embedding_file.h"
#include "scripting/lua_util.h"
#include "scripting/node_types.h"
#include "scripting/wrap_scene.h"
#include "scripting/wrap_terrain.h"

namespace strata {

SitePlacement check_placement(lua_State* L, int index, SitePlacement placement) {
    const std::optional<glm::dmat4> matrix = lua::opt_mat4(L, index, "matrix");
    const auto at = lua::opt_point(L, index, "at", 2, 2, false, "{lon, lat} in degrees");
    SitePlacement by_fields = placement;  // placed by at, scale and heading
    by_fields.matrix.reset();
    if (at) by_fields.at = {at->v[0], at->v[1]};
    by_fields.scale = lua::opt_number(L, index, "scale", placement.scale);
    by_fields.heading = lua::opt_number(L, index, "heading", placement.heading);
    if (!(by_fields.scale > 0) || !std::isfinite(by_fields.scale) || !std::isfinite(by_fields.heading))
        luaL_error(L, "options 'scale' (above 0) and 'heading' (degrees) must be finite numbers");
    const bool fields_given = at || by_fields.scale != placement.scale || by_fields.heading != placement.heading;
    const bool fields_changed = by_fields.at != placement.at || by_fields.scale != placement.scale || by_fields.heading != placement.heading;
    if (!matrix) return fields_given ? by_fields : placement;
    if (placement.matrix && *matrix == *placement.matrix) return fields_changed ? by_fields : placement;  // the matrix as it was
    if (fields_changed)  // both changed: which one places the site?
        luaL_error(L, "option 'matrix' cannot be combined with 'at', 'scale' or 'heading': a site is placed by one or the other");
    if (const std::string problem = placement_matrix_problem(*matrix); !problem.empty()) luaL_error(L, "option 'matrix': %s", problem.c_str());
    placement.matrix = matrix;
    return placement;
}

namespace {

namespace fs = std::filesystem;
using lua::check_keys;
using lua::opt_number;
using lua::opt_string;

// An embedding as a script gives it: a file name, or {site =, at =, scale =, heading =, output =} (or
// matrix = {16 numbers} for at, scale and heading).
struct EmbedSpec {
    fs::path file;  // given, or to make from the rest
    fs::path site, output;
    SitePlacement placement;
};

// The spec at the top of the stack (Lua errors for a wrong one, before any work).
EmbedSpec check_embed_spec(lua_State* L) {
    EmbedSpec spec;
    if (lua_type(L, -1) == LUA_TSTRING) {
        spec.file = lua_tostring(L, -1);
        return spec;
    }
    if (!lua_istable(L, -1)) luaL_error(L, "an embedding is a file name or {site =, at = {lon, lat}, scale =, heading =, matrix =, output =}");
    const int index = lua_gettop(L);
    check_keys(L, index, {"site", "at", "scale", "heading", "matrix", "output"});
    spec.site = opt_string(L, index, "site", "");
    if (spec.site.empty()) luaL_error(L, "an embedding needs option 'site' (a .hlod built with --lock-boundary, or a mesh file)");
    spec.placement = check_placement(L, index, {});
    spec.output = opt_string(L, index, "output", "");
    return spec;
}

// The spec's embedding file, made where it must be; what a mesh site's reader read past is printed, as
// strata.build prints it.
fs::path file_of(const EmbedSpec& spec, const fs::path& terrain) {
    if (!spec.file.empty()) return spec.file;
    std::vector<std::string> warnings;
    const fs::path file = embedding_file_for(terrain, spec.site, spec.placement, spec.output, {}, &warnings);
    for (const std::string& warning : warnings) std::fprintf(stderr, "strata.embed: warning: %s\n", warning.c_str());
    return file;
}

// Embeds the spec at the top of the stack in `terrain`; the node it adds.
NodePtr embed_spec(lua_State* L, Terrain& terrain) {
    const EmbedSpec spec = check_embed_spec(L);
    std::string error;
    try {
        return terrain.load_embedding(file_of(spec, terrain.ground()->path()));
    } catch (const std::exception& e) {
        error = e.what();
    }
    luaL_error(L, "%s", error.c_str());
    return nullptr;
}

// strata.terrain{ model = "terrain.hlod" or an hlod node, embed = { spec, … }, name = }
int new_terrain(lua_State* L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    check_keys(L, 1, {"model", "embed", "name"});
    lua_getfield(L, 1, "model");
    std::shared_ptr<HlodModel> ground;
    if (lua_type(L, -1) == LUA_TSTRING) {
        const std::string path = lua_tostring(L, -1);
        std::string error;
        try {
            ground = HlodModel::open(path);
            ground->set_pixel_error(1.0);
        } catch (const std::exception& e) {
            error = e.what();
        }
        if (!ground) return luaL_error(L, "%s", error.c_str());
    } else if (NodePtr node = test_node(L, -1)) {
        ground = std::dynamic_pointer_cast<HlodModel>(node);
    }
    if (!ground) return luaL_error(L, "option 'model' must be a terrain's .hlod file or its hlod node");
    lua_pop(L, 1);
    std::shared_ptr<Terrain> terrain;
    try {
        terrain = std::make_shared<Terrain>(ground);
    } catch (const std::exception& e) {
        return luaL_error(L, "%s", e.what());
    }
    terrain->set_name(opt_string(L, 1, "name", ground->path().stem().string()));
    lua_getfield(L, 1, "embed");
    if (!lua_isnil(L, -1)) {
        if (!lua_istable(L, -1)) return luaL_error(L, "option 'embed' must be a list of embeddings");
        const int list = lua_gettop(L);
        for (lua_Integer i = 1; i <= lua_Integer(lua_rawlen(L, list)); ++i) {
            lua_rawgeti(L, list, i);
            embed_spec(L, *terrain);
            lua_pop(L, 1);
        }
    }
    lua_pop(L, 1);
    push_node(L, terrain);
    return 1;
}

// strata.embed{ terrain =, site =, at =, scale =, heading = (or matrix =), output = } → the embedding file's path
int embed_file(lua_State* L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    check_keys(L, 1, {"terrain", "site", "at", "scale", "heading", "matrix", "output"});
    const std::string terrain = opt_string(L, 1, "terrain", "");
    if (terrain.empty()) return luaL_error(L, "strata.embed needs option 'terrain' (a terrain's .hlod)");
    lua_createtable(L, 0, 6);  // the options but 'terrain', as a spec
    for (const char* key : {"site", "at", "scale", "heading", "matrix", "output"}) {
        lua_getfield(L, 1, key);
        lua_setfield(L, -2, key);
    }
    const EmbedSpec spec = check_embed_spec(L);
    std::string error, path;
    try {
        path = file_of(spec, terrain).string();
    } catch (const std::exception& e) {
        error = e.what();
    }
    if (path.empty()) return luaL_error(L, "%s", error.c_str());
    lua_pushstring(L, path.c_str());
    return 1;
}

int terrain_ground(lua_State* L) {
    push_node(L, check_node_as<Terrain>(L, 1, "terrain").ground());
    return 1;
}

int terrain_embed(lua_State* L) {  // terrain:embed(spec) → the embedding's node
    Terrain& terrain = check_node_as<Terrain>(L, 1, "terrain");
    luaL_checkany(L, 2);
    lua_settop(L, 2);
    push_node(L, embed_spec(L, terrain));
    return 1;
}

int terrain_embeddings(lua_State* L) {  // the embeddings and standing sites, in order
    const Terrain& terrain = check_node_as<Terrain>(L, 1, "terrain");
    lua_createtable(L, int(terrain.child_count()), 0);
    lua_Integer n = 0;
    for (const NodePtr& child : terrain.children())
        if (child != terrain.ground()) push_node(L, child), lua_rawseti(L, -2, ++n);
    return 1;
}

int terrain_remove(lua_State* L) {
    Terrain& terrain = check_node_as<Terrain>(L, 1, "terrain");
    lua_pushboolean(L, terrain.remove_embedding(check_node(L, 2).get()));
    return 1;
}

void push_placement(lua_State* L, const SitePlacement& placement) {
    lua_createtable(L, 0, 4);
    lua_createtable(L, 2, 0);
    for (int i = 0; i < 2; ++i) lua_pushnumber(L, (*placement.at)[size_t(i)]), lua_rawseti(L, -2, i + 1);
    lua_setfield(L, -2, "at");
    lua_pushnumber(L, placement.scale);
    lua_setfield(L, -2, "scale");
    lua_pushnumber(L, placement.heading);
    lua_setfield(L, -2, "heading");
    lua::push_mat4(L, *placement.matrix);
    lua_setfield(L, -2, "matrix");
}

// C++ exceptions here become Lua errors with their message (lua::set_functions), after the stack unwinds.
int terrain_placement(lua_State* L) {  // terrain:placement(child) → {at = {lon, lat}, scale =, heading =, matrix =}
    const Terrain& terrain = check_node_as<Terrain>(L, 1, "terrain");
    const Node* child = check_node(L, 2).get();  // the argument keeps it
    push_placement(L, terrain.placement(child));
    return 1;
}

// terrain:move(child, {at =, scale =, heading =} or {matrix =}) → the child's new node (what is not
// given stays)
int terrain_move(lua_State* L) {
    Terrain& terrain = check_node_as<Terrain>(L, 1, "terrain");
    const Node* child = check_node(L, 2).get();
    luaL_checktype(L, 3, LUA_TTABLE);
    check_keys(L, 3, {"at", "scale", "heading", "matrix"});
    push_node(L, terrain.move_embedding(child, check_placement(L, 3, terrain.placement(child))));
    return 1;
}

int embedding_site(lua_State* L) {
    push_node(L, check_node_as<Embedding>(L, 1, "embedding").site());
    return 1;
}

int embedding_skirt(lua_State* L) {
    push_node(L, check_node_as<Embedding>(L, 1, "embedding").skirt());
    return 1;
}

int embedding_drawn(lua_State* L) {  // whether the last view drew it
    lua_pushboolean(L, check_node_as<Embedding>(L, 1, "embedding").drawn());
    return 1;
}

int embedding_info(lua_State* L) {
    const Embedding& e = check_node_as<Embedding>(L, 1, "embedding");
    lua_createtable(L, 0, 4);
    lua_pushinteger(L, lua_Integer(e.stitch().models().drawn_from));
    lua_setfield(L, -2, "zone_level");
    lua_pushinteger(L, lua_Integer(e.stitch().border_steps()));
    lua_setfield(L, -2, "border_steps");
    lua_pushinteger(L, lua_Integer(e.stitch().boundary_vertices()));
    lua_setfield(L, -2, "boundary_vertices");
    lua_pushboolean(L, e.drawn());
    lua_setfield(L, -2, "drawn");
    return 1;
}

std::string terrain_summary(const Node& node) {
    const auto& terrain = static_cast<const Terrain&>(node);
    return terrain.ground()->path().string() + ", " + std::to_string(terrain.child_count() - 1) + " embedded";
}

void inspect_terrain(Node& node, Inspector& fields) {
    const auto& terrain = static_cast<const Terrain&>(node);
    fields.text(terrain.ground()->path().string());
    for (const NodePtr& child : terrain.children())
        if (const auto* file = terrain.embedding_file(child.get())) fields.text("embeds " + file->string());
}

void inspect_embedding(Node& node, Inspector& fields) {
    const auto& e = static_cast<const Embedding&>(node);
    fields.text("drawn from level " + std::to_string(e.stitch().models().drawn_from) + (e.drawn() ? ", drawn" : ", not drawn in the last view"));
    fields.text(std::to_string(e.stitch().boundary_vertices()) + " boundary vertices, " + std::to_string(e.stitch().border_steps()) + " border steps");
}

// strata.terrain{ model = …, embed = { files } }: the embeddings come back from their files.
std::string terrain_constructor(const Node& node, const script::Place& place) {
    const auto& terrain = static_cast<const Terrain&>(node);
    std::string embed;
    for (const NodePtr& child : terrain.children()) {
        if (const auto* file = terrain.embedding_file(child.get())) embed += (embed.empty() ? "" : ", ") + place.file(*file);
    }
    return "strata.terrain{ model = " + place.file(terrain.ground()->path()) + ", name = " + script::string(terrain.name()) +
           (embed.empty() ? "" : ", embed = { " + embed + " }") + " }";
}

const luaL_Reg kTerrainMethods[] = {{"ground", terrain_ground},
                                    {"embed", terrain_embed},
                                    {"embeddings", terrain_embeddings},
                                    {"remove", terrain_remove},
                                    {"placement", terrain_placement},
                                    {"move", terrain_move},
                                    {nullptr, nullptr}};
const luaL_Reg kTerrainFunctions[] = {{"terrain", new_terrain}, {"embed", embed_file}, {nullptr, nullptr}};
const luaL_Reg kEmbeddingMethods[] = {{"site", embedding_site},
                                      {"skirt", embedding_skirt},
                                      {"drawn", embedding_drawn},
                                      {"info", embedding_info},
                                      {nullptr, nullptr}};

}  // namespace

const NodeType kTerrainType = {
    .name = "terrain",
    .base = &kGroupType,
    .is = is_a<Terrain>,
    .methods = kTerrainMethods,
    .functions = kTerrainFunctions,
    .summary = terrain_summary,
    .inspect = inspect_terrain,
    .constructor = terrain_constructor,
    .builds_children = true,
};

const NodeType kEmbeddingType = {
    .name = "embedding",
    .base = &kGroupType,
    .is = is_a<Embedding>,
    .methods = kEmbeddingMethods,
    .summary = nullptr,
    .inspect = inspect_embedding,
};

}  // namespace strata

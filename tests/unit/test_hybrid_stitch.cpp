// The stitch of an embedding at run time (nodes/embedding_stitch.h), checked on the CPU twin: a site
// with a wiggly, bumpy boundary embedded in a DEM terrain, its skirt and the site built as HLODs with
// locked boundaries, viewed from eyes near and far. Where the embedding is drawn, the terrain with its
// zone hidden, the skirt, the site and the seams form one surface whose only open edges are the raster's
// own border, at whatever levels the grid along the zone's border is drawn (thesis 003's T1, T2), with
// no edge used thrice (T3); without the seams, or without hiding the zone, it is not. The boundary seam
// is the same bits at every level of the site (T8). Drawn with real OpenGL: no background through the
// join in any view, and no pop at the join across a grid-level switch.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <optional>
#include <random>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/io/image.h"
#include "engine/render/renderer.h"
#include "engine/scene/light.h"
#include "nodes/embedding_stitch.h"
#include "nodes/terrain.h"
#include "preprocess/cube_textures.h"
#include "preprocess/embedding.h"
#include "preprocess/embedding_file.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/support/geotiff.h"
#include "tests/support/pop_check.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

namespace fs = std::filesystem;

constexpr int kSize = 97;  // samples per side, 30 m apart (the TiffSpec default)

double dem_height(int c, int r) { return 400 + 25 * std::sin(c * 0.11) * std::cos(r * 0.07) + 0.8 * c; }

// A site as a scan would give it: a disc of rings around (cx, cy) whose outer ring wiggles, bumps of a
// metre over the ground, `above` metres up.
Mesh site_mesh(const TerrainSite& t, double cx, double cy, double radius, double above) {
    std::mt19937 random(11);
    std::uniform_real_distribution<double> unit(0, 1);
    Mesh mesh;
    mesh.origin = {cx, cy, 0};
    const int spokes = 240, rings = 16;
    std::vector<double> reach(spokes);
    for (int s = 0; s < spokes; ++s) {
        const double angle = 2 * M_PI * s / spokes;
        reach[size_t(s)] = radius * (1 + 0.15 * std::sin(5 * angle) + 0.05 * std::sin(13 * angle) + 0.02 * unit(random));
    }
    auto add = [&](double x, double y) {
        const auto cell = t.georeference->raster_position(x, y, 0);
        const double ground = t.heights->at((*cell)[0], (*cell)[1]).value_or(0);
        const double bump = 0.2 * std::sin(x * 0.21) * std::cos(y * 0.17);
        mesh.positions.insert(mesh.positions.end(), {float(x - cx), float(y - cy), float(ground + above + bump)});
    };
    add(cx, cy);
    for (int k = 1; k <= rings; ++k)
        for (int s = 0; s < spokes; ++s) {
            const double angle = 2 * M_PI * s / spokes, r = reach[size_t(s)] * k / rings;
            add(cx + r * std::cos(angle), cy + r * std::sin(angle));
        }
    auto at = [&](int k, int s) { return k == 0 ? 0u : uint32_t(1 + (k - 1) * spokes + (s % spokes)); };
    for (int s = 0; s < spokes; ++s) mesh.indices.insert(mesh.indices.end(), {at(0, 0), at(1, s), at(1, s + 1)});
    for (int k = 1; k < rings; ++k)
        for (int s = 0; s < spokes; ++s)
            mesh.indices.insert(mesh.indices.end(), {at(k, s), at(k + 1, s), at(k + 1, s + 1), at(k, s), at(k + 1, s + 1), at(k, s + 1)});
    return mesh;
}

// One model as a view draws it: its selection and how it morphs, from the world eye.
struct ViewOf {
    std::vector<uint32_t> cubes;
    HlodModel::MorphInputs inputs;
    ModelView view() const { return {cubes, &inputs}; }
};

ViewOf view_of(const HlodModel& model, const Camera& camera, const glm::dmat4& world_from_node, const glm::dvec3& eye) {
    ViewOf out;
    const glm::dvec3 local = glm::dvec3(glm::inverse(world_from_node) * glm::dvec4(eye, 1.0));
    model.select(model.view_for(camera, local), out.cubes, &out.inputs.kappa);
    out.inputs.anchor = model.anchor_for(world_from_node, eye);
    out.inputs.morph = model.morphs_for(camera);
    return out;
}

// The test DEM (kSize² samples, 30 m apart) as a terrain, dir/dem.hlod.
void build_test_dem(const fs::path& dir) {
    test::TiffSpec spec;
    spec.width = spec.height = kSize;
    spec.type = GDT_Float32;
    for (int r = 0; r < kSize; ++r)
        for (int c = 0; c < kSize; ++c) spec.values.push_back(dem_height(c, r));
    test::write_tiff(dir / "dem.tif", spec);
    TerrainSettings terrain_settings;
    terrain_settings.cube_cells = 8;
    build_terrain({dir / "dem.tif"}, dir / "dem.hlod", terrain_settings, "dem.tif");
}

// A site_mesh embedded in dir/dem.hlod: the site (3 levels) and its skirt (`skirt_levels`, −1 as the
// build picks: its cells are 30 m, so a small skirt cannot have as many as the site without σ0 past its
// bound) built as HLODs with their boundaries locked, in dir, and their stitch.
struct StitchedSite {
    std::shared_ptr<HlodModel> terrain, skirt, site;
    EmbeddedModels models;
    std::unique_ptr<EmbeddingStitch> stitch;
};
std::unique_ptr<StitchedSite> stitch_site(const fs::path& dir, glm::dvec2 centre, double radius, double above, int skirt_levels) {
    const TerrainSite t = TerrainSite::open(dir / "dem.hlod");
    Mesh site = site_mesh(t, centre.x, centre.y, radius, above);
    const EmbeddingPlan plan = plan_embedding(t, site, glm::dmat4(1.0), "site");
    BuildSettings settings;
    settings.lock_boundary = true;
    settings.levels = 3;
    build_hlod(std::move(site), dir / "site.hlod", settings, "site");
    settings.levels = skirt_levels;
    build_hlod(Mesh(plan.skirt_mesh), dir / "skirt.hlod", settings, "skirt");

    auto out = std::make_unique<StitchedSite>();
    out->models.terrain = out->terrain = HlodModel::load(dir / "dem.hlod");
    out->models.skirt = out->skirt = HlodModel::load(dir / "skirt.hlod");
    out->models.site = out->site = HlodModel::load(dir / "site.hlod");
    out->models.drawn_from = plan.zone_level;
    out->models.zone = plan.zone;
    out->stitch = std::make_unique<EmbeddingStitch>(out->models, "site");
    return out;
}

// Eyes around `centre`, from a few metres off the ground to kilometres away, and from far off, where the
// grid over the zone is coarser than m.
std::vector<glm::dvec3> eyes_around(glm::dvec2 centre, int count) {
    std::mt19937 rng(2026);
    std::uniform_real_distribution<double> unit(0, 1);
    std::vector<glm::dvec3> out;
    for (int i = 0; i < count; ++i) {
        const double distance = 50 * std::pow(60.0, unit(rng)), angle = 2 * M_PI * unit(rng);
        const double height = 450 + 5 + distance * 0.6 * unit(rng);
        out.push_back({centre.x + distance * std::cos(angle), centre.y + distance * std::sin(angle), height});
    }
    for (const double distance : {9000.0, 20000.0}) out.push_back({centre.x + distance, centre.y, 450 + distance / 3});
    return out;
}

class HybridStitch : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        build_test_dem(dir_->path());
        stitched_ = stitch_site(dir_->path(), {1400, 1500}, 150, 8.0, 2);
        terrain_ = stitched_->terrain, skirt_ = stitched_->skirt, site_ = stitched_->site;
        stitch_ = stitched_->stitch.get();
        models_ = stitched_->models;
    }
    static void TearDownTestSuite() {
        stitched_.reset();
        models_ = {};
        terrain_.reset(), skirt_.reset(), site_.reset();
        dir_.reset();
    }

    static std::vector<glm::dvec3> eyes(int count) { return eyes_around({1400, 1500}, count); }

    static inline std::unique_ptr<test::TempDir> dir_ = std::make_unique<test::TempDir>();
    static inline std::unique_ptr<StitchedSite> stitched_;
    static inline std::shared_ptr<HlodModel> terrain_, skirt_, site_;
    static inline EmbeddingStitch* stitch_ = nullptr;
    static inline EmbeddedModels models_;
};

// A drawn vertex: its owner and its float bits (as the owner's shader computes it from its anchor).
using Key = std::array<uint32_t, 4>;
Key key_of(StitchOwner owner, const glm::vec3& p) {
    Key k{uint32_t(owner), 0, 0, 0};
    for (int a = 0; a < 3; ++a) {
        const float v = p[a] + 0.0f;  // −0 as +0
        std::memcpy(&k[size_t(a) + 1], &v, 4);
    }
    return k;
}

struct Surface {
    std::map<std::pair<Key, Key>, int> edges;
    std::map<Key, glm::dvec3> where;  // node frame of the terrain
    void add(const StitchTriangle& t, const std::array<glm::dvec3, 3>& at) {
        Key k[3];
        for (int i = 0; i < 3; ++i) k[i] = key_of(t[size_t(i)].owner, t[size_t(i)].position), where[k[i]] = at[size_t(i)];
        if (k[0] == k[1] || k[1] == k[2] || k[0] == k[2]) return;  // collapsed by the morph
        for (int e = 0; e < 3; ++e) ++edges[std::minmax(k[e], k[(e + 1) % 3])];
    }
};

struct Drawn {
    bool embedded = false;
    size_t open_inside = 0;  // edges one triangle uses, away from the raster's border
    size_t thrice = 0;       // edges more than two triangles use
    std::set<uint32_t> border_levels;
    size_t seam_triangles = 0;
};

enum class Omit { nothing, seams, mask };

Drawn draw(const EmbeddingStitch& stitch, const Camera& camera, const glm::dvec3& eye, Omit omit) {
    const EmbeddedModels& m = stitch.models();
    const glm::dmat4 identity(1.0);
    const ViewOf terrain = view_of(*m.terrain, camera, identity, eye), skirt = view_of(*m.skirt, camera, identity, eye),
                 site = view_of(*m.site, camera, m.site_to_terrain, eye);
    Drawn out;
    out.embedded = stitch.drawn_with(terrain.cubes);
    Surface surface;
    std::vector<glm::vec3> positions;
    auto node_of = [](const HlodModel& model, const HlodModel::MorphInputs& inputs, const glm::dmat4& to_terrain, const glm::vec3& p) {
        return glm::dvec3(to_terrain * model.lattice_to_node() * glm::dvec4(inputs.anchor.origin + glm::dvec3(p), 1.0));
    };
    auto add_model = [&](const HlodModel& model, const ViewOf& view, StitchOwner owner, const glm::dmat4& to_terrain, bool masked) {
        for (const uint32_t c : view.cubes) {
            model.drawn_positions(c, view.inputs, positions);
            const auto& indices = model.cubes()[c].data->indices;
            std::vector<std::array<uint32_t, 2>> runs{{0, uint32_t(indices.size())}};
            if (masked) runs = stitch.terrain_cube(c).kept;
            if (owner == StitchOwner::terrain && stitch.terrain_cube(c).near_zone) out.border_levels.insert(model.cubes()[c].node.level);
            for (const auto& run : runs)
                for (uint32_t t = run[0]; t < run[0] + run[1]; t += 3) {
                    StitchTriangle tri;
                    std::array<glm::dvec3, 3> at;
                    for (int k = 0; k < 3; ++k) {
                        tri[size_t(k)] = {owner, positions[indices[t + uint32_t(k)]]};
                        at[size_t(k)] = node_of(model, view.inputs, to_terrain, tri[size_t(k)].position);
                    }
                    surface.add(tri, at);
                }
        }
    };
    add_model(*m.terrain, terrain, StitchOwner::terrain, identity, out.embedded && omit != Omit::mask);
    if (out.embedded) {
        add_model(*m.skirt, skirt, StitchOwner::skirt, identity, false);
        add_model(*m.site, site, StitchOwner::site, m.site_to_terrain, false);
        std::vector<StitchTriangle> seams;
        stitch.seams(terrain.view(), skirt.view(), site.view(), seams);
        out.seam_triangles = seams.size();
        if (omit != Omit::seams)
            for (const StitchTriangle& t : seams) {
                std::array<glm::dvec3, 3> at;
                for (int k = 0; k < 3; ++k) {
                    const StitchVertex& v = t[size_t(k)];
                    const HlodModel& model = v.owner == StitchOwner::terrain ? *m.terrain : v.owner == StitchOwner::skirt ? *m.skirt : *m.site;
                    const ViewOf& view = v.owner == StitchOwner::terrain ? terrain : v.owner == StitchOwner::skirt ? skirt : site;
                    at[size_t(k)] = node_of(model, view.inputs, v.owner == StitchOwner::site ? m.site_to_terrain : identity, v.position);
                }
                surface.add(t, at);
            }
    }
    const Georeference& geo = *m.terrain->georeference();
    auto on_raster_border = [&](const glm::dvec3& p) {
        const auto r = geo.raster_position(p.x, p.y, p.z);
        const double tolerance = 1e-3;
        return r && ((*r)[0] < tolerance || (*r)[1] < tolerance || (*r)[0] > kSize - 1 - tolerance || (*r)[1] > kSize - 1 - tolerance);
    };
    for (const auto& [edge, uses] : surface.edges) {
        // (The site's and the skirt's own folds, where their morph lays two triangles on one edge, are
        // theirs: the terrain's edges are the zone's.)
        if (uses > 2 && edge.first[0] == uint32_t(StitchOwner::terrain) && edge.second[0] == uint32_t(StitchOwner::terrain)) ++out.thrice;
        if (uses == 1 && !(on_raster_border(surface.where[edge.first]) && on_raster_border(surface.where[edge.second]))) ++out.open_inside;
    }
    return out;
}

// How many views drew the embedding (or not), with grid levels mixed along the zone's border, and in
// how many the controls failed: without the seams the join open, without the mask the zone drawn twice.
// Every view's surface is checked (T1, T3) on the way.
struct Tally {
    size_t embedded = 0, hidden = 0, mixed = 0, without_seams_open = 0, without_mask_thrice = 0;
};
Tally tally_views(StitchedSite& s, const std::vector<glm::dvec3>& eyes) {
    Camera camera;
    camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
    Tally tally;
    for (const double pixels : {0.5, 2.0, 8.0}) {
        s.terrain->set_pixel_error(pixels), s.skirt->set_pixel_error(pixels), s.site->set_pixel_error(pixels);
        for (const glm::dvec3& eye : eyes) {
            const Drawn drawn = draw(*s.stitch, camera, eye, Omit::nothing);
            EXPECT_EQ(drawn.open_inside, 0u) << "eye " << eye.x << ", " << eye.y << ", " << eye.z << " at " << pixels << " px";
            EXPECT_EQ(drawn.thrice, 0u) << "eye " << eye.x << ", " << eye.y << ", " << eye.z << " at " << pixels << " px";
            if (!drawn.embedded) {
                ++tally.hidden;
                continue;
            }
            ++tally.embedded;
            EXPECT_GT(drawn.seam_triangles, 0u);
            if (drawn.border_levels.size() > 1) ++tally.mixed;
            if (draw(*s.stitch, camera, eye, Omit::seams).open_inside > 0) ++tally.without_seams_open;
            if (draw(*s.stitch, camera, eye, Omit::mask).thrice > 0) ++tally.without_mask_thrice;
        }
    }
    s.terrain->set_kappa0(2.0), s.skirt->set_kappa0(2.0), s.site->set_kappa0(2.0);
    return tally;
}

TEST_F(HybridStitch, TheGroundTheSkirtTheSiteAndTheSeamsAreOneSurfaceAtEveryLevelAlongTheBorder) {
    ASSERT_GT(stitch_->border_steps(), 0u);
    ASSERT_GT(stitch_->boundary_vertices(), 100u);
    const Tally tally = tally_views(*stitched_, eyes(32));
    // Both cases happen, and grid levels mix along the border.
    EXPECT_GT(tally.embedded, 20u);
    EXPECT_GT(tally.hidden, 0u);
    EXPECT_GT(tally.mixed, 5u);
    // The controls: without the seams the join is open, without the mask the zone is drawn twice.
    EXPECT_EQ(tally.without_seams_open, tally.embedded);
    EXPECT_EQ(tally.without_mask_thrice, tally.embedded);
}

// One terrain node under two transforms (a scene that shows a site twice): each instance draws the
// seams its own view asks for. Seen from between them, the first instance's pixels are the very ones it
// shows alone, the second drawn beside it.
TEST_F(HybridStitch, EachInstanceOfATerrainDrawsItsOwnSeams) {
    const auto context = gl::create_headless_context();
    auto ground = HlodModel::load(dir_->path() / "dem.hlod");
    auto terrain = std::make_shared<Terrain>(ground);
    const auto embedding = terrain->embed(HlodModel::load(dir_->path() / "skirt.hlod"), HlodModel::load(dir_->path() / "site.hlod"),
                                          glm::dmat4(1.0), models_.drawn_from, models_.zone, "site");
    for (const auto& model : {ground, embedding->skirt(), embedding->site()}) model->set_pixel_error(0.5);
    auto scene = [&](bool twice) {
        auto root = std::make_shared<Group>();
        root->add(std::make_shared<DirectionalLight>());
        auto first = std::make_shared<Transform>(), second = std::make_shared<Transform>();
        first->add(terrain);
        root->add(first);
        second->set_matrix(glm::translate(glm::dmat4(1.0), glm::dvec3(3000, 0, 0)));
        second->add(terrain);
        if (twice) root->add(second);
        return root;
    };
    Renderer renderer;
    gl::Framebuffer target({.width = 320, .height = 200, .samples = 1, .node_id = true});
    Camera camera;
    camera.width = 320, camera.height = 200, camera.fov_y_degrees = 70;
    const auto alone = scene(false), both = scene(true);
    size_t covered = 0, differing = 0, views = 0;
    for (const double side : {-500.0, 0.0, 500.0}) {
        // Between the two sites (at x = 1400 and 4400), looking north: the first on the left.
        camera.look_at({2900, 1500 + side - 900, 900}, {2900, 1500 + side, 450}, {0, 0, 1});
        renderer.render(*alone, camera, target);
        const Image one = renderer.read_image(target);
        const bool drawn_alone = embedding->drawn();
        renderer.render(*both, camera, target);
        const Image two = renderer.read_image(target);
        if (!drawn_alone) continue;
        ++views;
        for (int y = 1; y + 1 < camera.height; ++y)
            for (int x = 1; x + 1 < camera.width; ++x) {
                bool inside = true;  // the first instance covers the pixel and its neighbours
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) inside = inside && one.node_id[size_t((y + dy) * camera.width + x + dx)] != 0;
                if (!inside) continue;
                ++covered;
                const size_t p = size_t(y * camera.width + x);
                differing += !std::equal(&one.rgba[4 * p], &one.rgba[4 * p + 4], &two.rgba[4 * p]);
            }
    }
    EXPECT_EQ(views, 3u) << "the embedding should be drawn in every view";
    EXPECT_GT(covered, 10000u);
    EXPECT_EQ(differing, 0u) << "of " << covered << " pixels of the first instance";
}

// A mesh smaller than one raster cell (a monument in a 30 m DEM): its skirt is the cell with a hole,
// and ground, skirt, site and seams are one surface all the same, the controls failing as before.
TEST(HybridStitchSmall, AMeshInsideOneRasterCellIsOneSurfaceWithTheGround) {
    test::TempDir dir;
    build_test_dem(dir.path());
    const glm::dvec2 centre{1395, 1515};  // the middle of the cell from (1380, 1500) to (1410, 1530)
    const std::unique_ptr<StitchedSite> small = stitch_site(dir.path(), centre, 9, 2.0, -1);
    ASSERT_GT(small->stitch->boundary_vertices(), 100u);
    const Tally tally = tally_views(*small, eyes_around(centre, 16));
    EXPECT_GT(tally.embedded, 10u);
    EXPECT_EQ(tally.without_seams_open, tally.embedded);
    EXPECT_EQ(tally.without_mask_thrice, tally.embedded);
}

// T8: the boundary seam does not depend on the level the site is drawn at: its site side is the same
// floats (the locked boundary's, which the morph leaves where they are) whatever the site's pixel error.
TEST_F(HybridStitch, TheBoundarySeamIsTheSameAtEveryLevelOfTheSite) {
    Camera camera;
    camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
    const glm::dvec3 eye{1400 + 700, 1500 + 300, 700};
    const glm::dmat4 identity(1.0);
    terrain_->set_pixel_error(0.05);  // the ground fine enough around the zone to draw the embedding
    const ViewOf terrain = view_of(*terrain_, camera, identity, eye), skirt = view_of(*skirt_, camera, identity, eye);
    ASSERT_TRUE(stitch_->drawn_with(terrain.cubes));
    std::vector<std::vector<Key>> sides;
    std::set<std::set<uint32_t>> levels_drawn;
    for (const double pixels : {0.01, 0.1, 1.0, 10.0, 100.0, 1000.0}) {
        site_->set_pixel_error(pixels);
        const ViewOf site = view_of(*site_, camera, identity, eye);
        std::set<uint32_t> levels;
        for (const uint32_t c : site.cubes) levels.insert(site_->cubes()[c].node.level);
        levels_drawn.insert(levels);
        std::vector<StitchTriangle> seams;
        stitch_->seams(terrain.view(), skirt.view(), site.view(), seams);
        std::vector<Key> side;
        for (const StitchTriangle& t : seams)
            for (const StitchVertex& v : t)
                if (v.owner == StitchOwner::site) side.push_back(key_of(v.owner, v.position));
        std::sort(side.begin(), side.end());
        side.erase(std::unique(side.begin(), side.end()), side.end());
        EXPECT_EQ(side.size(), stitch_->boundary_vertices());
        sides.push_back(std::move(side));
    }
    site_->set_kappa0(2.0), terrain_->set_kappa0(2.0);
    EXPECT_GE(levels_drawn.size(), 3u) << "the site should be drawn at different levels; it has " << site_->header().max_level + 1;
    for (size_t k = 1; k < sides.size(); ++k) EXPECT_EQ(sides[k], sides[0]);
}

// Drawn with real OpenGL, a magenta clear colour behind: over 60 views around the site, near and far,
// grazing and from above, no pixel that the ground alone covers shows the background with the
// embedding in it (the seams weld on the GPU as on the CPU twin); without the seams it shows through.
TEST_F(HybridStitch, NoBackgroundShowsThroughTheJoinInAnyView) {
    const auto context = gl::create_headless_context();
    auto scene = [&](bool embedded) {
        auto root = std::make_shared<Group>();
        auto light = std::make_shared<DirectionalLight>();
        root->add(light);
        auto ground = HlodModel::load(dir_->path() / "dem.hlod");
        auto terrain = std::make_shared<Terrain>(ground);
        if (embedded)
            terrain->embed(HlodModel::load(dir_->path() / "skirt.hlod"), HlodModel::load(dir_->path() / "site.hlod"), glm::dmat4(1.0),
                           models_.drawn_from, models_.zone, "site");
        root->add(terrain);
        for (const auto& model : {ground}) model->set_pixel_error(2.0);
        for (const auto& e : terrain->embeddings()) e->skirt()->set_pixel_error(2.0), e->site()->set_pixel_error(2.0);
        return std::make_pair(root, terrain);
    };
    const auto [plain, plain_terrain] = scene(false);
    const auto [joined, joined_terrain] = scene(true);
    const auto embedding = joined_terrain->embeddings().at(0);
    const NodePtr seams = embedding->children().back();
    RenderSettings settings;
    settings.background = {1.0f, 0.0f, 1.0f, 1.0f};
    Renderer renderer;
    gl::Framebuffer target({.width = 320, .height = 200, .samples = 1, .node_id = true});
    Camera camera;
    camera.width = 320, camera.height = 200, camera.fov_y_degrees = 50;
    auto background = [&](Node& root) {
        renderer.render(root, camera, target, settings);
        const Image image = renderer.read_image(target);
        std::vector<uint8_t> out(image.pixel_count());
        for (size_t p = 0; p < out.size(); ++p) out[p] = image.node_id[p] == 0;
        return out;
    };
    std::mt19937 rng(99);
    std::uniform_real_distribution<double> unit(0, 1);
    size_t views = 0, drawn = 0, through = 0, through_without_seams = 0;
    for (int i = 0; i < 64; ++i) {
        // From 60 m to 1.5 km off, from grazing (2 m over the ground) to steep, looking at the site's
        // border.
        const double distance = 60 * std::pow(25.0, unit(rng)), angle = 2 * M_PI * unit(rng);
        const double height = i % 4 == 0 ? 2.0 : distance * (0.05 + 0.8 * unit(rng));
        const glm::dvec3 target_at{1400 + 150 * std::cos(angle + 2.0), 1500 + 150 * std::sin(angle + 2.0), 460};
        glm::dvec3 eye = target_at + glm::dvec3(distance * std::cos(angle), distance * std::sin(angle), 0);
        // A grazing eye stays off the zone: 2 m over the ground there is under the site.
        if (i % 4 == 0 && glm::length(glm::dvec2(eye) - glm::dvec2(1400, 1500)) < 450)
            eye = glm::dvec3(1400, 1500, 0) + 450.0 * glm::dvec3(std::cos(angle), std::sin(angle), 0);
        camera.look_at({eye.x, eye.y, *terrain_->height_at(eye.x, eye.y) + height}, target_at, {0, 0, 1});
        const std::vector<uint8_t> alone = background(*plain);
        // Background where the ground alone covers a pixel and its eight neighbours (a pixel on the
        // ground's outline may fall either way: the zone's finer skirt is not the grid's silhouette).
        auto through_join = [&](const std::vector<uint8_t>& with) {
            size_t count = 0;
            for (int y = 1; y + 1 < camera.height; ++y)
                for (int x = 1; x + 1 < camera.width; ++x) {
                    bool covered = true;
                    for (int dy = -1; dy <= 1; ++dy)
                        for (int dx = -1; dx <= 1; ++dx) covered = covered && !alone[size_t((y + dy) * camera.width + x + dx)];
                    count += covered && with[size_t(y * camera.width + x)];
                }
            return count;
        };
        const size_t shown = through_join(background(*joined));
        ++views;
        if (!embedding->drawn()) continue;
        ++drawn;
        EXPECT_EQ(shown, 0u) << "view " << i << ": background through the join";
        through += shown;
        seams->set_visible(false);
        through_without_seams += through_join(background(*joined));
        seams->set_visible(true);
    }
    EXPECT_GE(views, 60u);
    EXPECT_GT(drawn, 40u);
    EXPECT_EQ(through, 0u);
    EXPECT_GT(through_without_seams, 0u);
}

// No pop at the join, on Olinda's terrain with its imagery (what shows under ambient light alone): a
// ground cube beside a site's zone drawn just outside its switch distance and its children just inside
// it give the same image, the embedding drawn both times and the seams following the grid's morph;
// without the morph the switch shows.
const fs::path kData = fs::path(STRATA_SOURCE_DIR) / "data";
bool olinda_missing() { return !fs::exists(kData / "olinda_dem.tif") || !fs::exists(kData / "olinda_l7.tif"); }

// Olinda's DEM under its Landsat image (bands 3, 2, 1: natural colours) as a terrain of 16-cell cubes.
void build_textured_olinda(const fs::path& out) {
    TerrainSettings terrain_settings;
    terrain_settings.cube_cells = 16;
    terrain_settings.texture = TextureSettings{kData / "olinda_l7.tif", {3, 2, 1}, 0};
    build_terrain({kData / "olinda_dem.tif"}, out, terrain_settings, "olinda_dem.tif");
}

// The middle of Olinda's raster (sample 55, 55), in its model frame.
glm::dvec2 olinda_middle(const TerrainSite& t) {
    const auto centre = t.georeference->sample_position(55, 55, 0);
    return {(*centre)[0], (*centre)[1]};
}

// A site 600 m wide, 120 m above the middle of Olinda's textured terrain (high enough that its zone
// level m is coarser than the finest), embedded with a one-level skirt, under ambient light alone.
struct HighSite {
    NodePtr root;
    std::shared_ptr<HlodModel> ground;
    std::shared_ptr<Embedding> embedding;
    EmbeddingPlan plan;
};

HighSite embed_high_site(const fs::path& dir) {
    build_textured_olinda(dir / "olinda.hlod");
    const TerrainSite t = TerrainSite::open(dir / "olinda.hlod");
    const glm::dvec2 middle = olinda_middle(t);
    Mesh site = site_mesh(t, middle.x, middle.y, 600, 120.0);
    HighSite out;
    out.plan = plan_embedding(t, site, glm::dmat4(1.0), "site");
    BuildSettings settings;
    settings.lock_boundary = true;
    settings.levels = 3;
    build_hlod(std::move(site), dir / "site.hlod", settings, "site");
    settings.levels = 1;
    build_hlod(Mesh(out.plan.skirt_mesh), dir / "skirt.hlod", settings, "skirt");
    auto root = std::make_shared<Group>();
    auto ambient = std::make_shared<AmbientLight>();
    ambient->color = {1, 1, 1};
    root->add(ambient);
    out.ground = HlodModel::load(dir / "olinda.hlod");
    auto terrain = std::make_shared<Terrain>(out.ground);
    out.embedding = terrain->embed(HlodModel::load(dir / "skirt.hlod"), HlodModel::load(dir / "site.hlod"), glm::dmat4(1.0),
                                   out.plan.zone_level, out.plan.zone, "site");
    root->add(terrain);
    out.root = root;
    return out;
}

TEST(HybridRender, NoPopAtTheJoinAcrossAGridLevelSwitch) {
    if (olinda_missing()) GTEST_SKIP() << "data/olinda_* missing: run scripts/setup.sh";
    const test::TempDir dir;
    const auto context = gl::create_headless_context();
    const HighSite high = embed_high_site(dir.path());
    const auto& [root, ground, embedding, plan] = high;
    for (const auto& model : {ground, embedding->skirt(), embedding->site()}) model->set_kappa0(2.5);
    const double kappa0 = ground->kappa0();  // as clamped
    // A cube of level m or finer beside the zone (the border runs through its cell), with children.
    uint32_t chosen = kNoCube;
    for (uint32_t c = 0; c < ground->cubes().size() && chosen == kNoCube; ++c) {
        const HlodCube& cube = ground->cubes()[c];
        const bool has_children = std::any_of(cube.children.begin(), cube.children.end(), [](uint32_t child) { return child != kNoCube; });
        if (cube.node.level >= plan.zone_level && has_children && !embedding->stitch().terrain_cube(c).steps.empty()) chosen = c;
    }
    ASSERT_NE(chosen, kNoCube) << "zone level " << plan.zone_level << " of " << ground->header().max_level;
    const test::PopFrames morphed = test::pop_frames(*root, *ground, chosen, kappa0, true);
    ASSERT_TRUE(morphed.before_selected) << "just outside the switch distance the cube itself is drawn";
    ASSERT_FALSE(morphed.after_selected) << "just inside it its children are";
    ASSERT_TRUE(embedding->drawn());
    EXPECT_LE(test::differing(morphed.before, morphed.after, 1.0f / 255), 0.001);
    const test::PopFrames plain = test::pop_frames(*root, *ground, chosen, kappa0, false);
    EXPECT_GT(test::differing(plain.before, plain.after, 1.0f / 255), 0.001);
}

// The seams are morphed on the GPU (a compute pass running each owner's own morph on its own records)
// to the very bits of their CPU twin, over views near and far where the grid, the skirt and the site
// morph at several levels.
TEST(HybridRender, TheSeamsMorphedOnTheGpuAreTheCpuTwinsToTheBit) {
    if (olinda_missing()) GTEST_SKIP() << "data/olinda_* missing: run scripts/setup.sh";
    const test::TempDir dir;
    const auto context = gl::create_headless_context();
    const HighSite high = embed_high_site(dir.path());
    const TerrainSite t = TerrainSite::open(dir.path() / "olinda.hlod");
    const glm::dvec2 middle = olinda_middle(t);
    const double ground = *t.heights->at(55, 55);
    EmbeddingSeams& seams = high.embedding->seams();
    seams.set_capture(true);
    Camera camera;
    camera.width = 320, camera.height = 240, camera.fov_y_degrees = 50;
    Renderer renderer;
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
    size_t views_drawn = 0, compared = 0, morphing = 0;
    for (int v = 0; v < 24; ++v) {
        const double angle = 2 * M_PI * v / 24, distance = 700 * std::pow(1.5, v % 6);
        camera.look_at({middle.x + distance * std::cos(angle), middle.y + distance * std::sin(angle), ground + 0.3 * distance},
                       {middle.x, middle.y, ground}, {0, 0, 1});
        renderer.render(*high.root, camera, target);
        if (!high.embedding->drawn()) continue;
        ++views_drawn;
        // The CPU twin for the view's selections, each owner morphing as it drew.
        const Embedding::ViewSelections& s = high.embedding->selections();
        const HlodModel* owners[3] = {high.ground.get(), high.embedding->skirt().get(), high.embedding->site().get()};
        const Kappas kappas[3] = {s.terrain.kappa, s.skirt.kappa, s.site.kappa};
        HlodModel::MorphInputs inputs[3];
        const glm::dvec3 eye(glm::inverse(camera.view_matrix())[3]);  // the renderer's, to the bit
        for (int o = 0; o < 3; ++o) inputs[o] = {owners[o]->anchor_for(glm::dmat4(1.0), eye), kappas[o], owners[o]->morphs_for(camera)};
        std::vector<StitchTriangle> twin;
        high.embedding->stitch().seams({s.terrain.cubes, &inputs[0]}, {s.skirt.cubes, &inputs[1]}, {s.site.cubes, &inputs[2]}, twin);
        const std::vector<glm::vec4>& gpu = seams.captured();
        ASSERT_EQ(gpu.size(), 3 * twin.size()) << "view " << v;
        for (size_t k = 0; k < gpu.size(); ++k) {
            const StitchVertex& cpu = twin[k / 3][k % 3];
            ASSERT_EQ(gpu[k].w, float(int(cpu.owner))) << "view " << v << ", seam vertex " << k;
            ASSERT_EQ(std::memcmp(&gpu[k], &cpu.position, sizeof(glm::vec3)), 0)
                << "view " << v << ", seam vertex " << k << ": GPU " << gpu[k].x << " " << gpu[k].y << " " << gpu[k].z << ", CPU "
                << cpu.position.x << " " << cpu.position.y << " " << cpu.position.z;
            ++compared;
        }
        // How many of them the morph moved off their own position (a test of the morph, not of its ends).
        HlodModel::MorphInputs still = inputs[0];
        still.morph = false;
        std::vector<StitchTriangle> unmoved;
        high.embedding->stitch().seams({s.terrain.cubes, &still}, {s.skirt.cubes, &inputs[1]}, {s.site.cubes, &inputs[2]}, unmoved);
        for (size_t k = 0; k < gpu.size(); ++k)
            if (unmoved[k / 3][k % 3].position != twin[k / 3][k % 3].position) ++morphing;
    }
    std::printf("%zu seam vertices in %zu views equal to the bit, %zu of them moved by the grid's morph\n", compared, views_drawn, morphing);
    EXPECT_GE(views_drawn, 12u);
    EXPECT_GT(compared, 1000u);
    EXPECT_GT(morphing, 50u) << "views where the grid's morph is under way along the border";
}

// The seams on a textured terrain show its imagery: their pixels (those they draw in hot pink under the
// ground's levels view, which also checks that colour) match the plain textured terrain's there, where
// the grey they had would not.
TEST(HybridRender, TheSeamsShowTheGroundsImageryAndHotPinkUnderTheDebugViews) {
    if (olinda_missing()) GTEST_SKIP() << "data/olinda_* missing: run scripts/setup.sh";
    const test::TempDir dir;
    const auto context = gl::create_headless_context();
    const HighSite high = embed_high_site(dir.path());
    auto plain = std::make_shared<Group>();
    auto ambient = std::make_shared<AmbientLight>();
    ambient->color = {1, 1, 1};
    plain->add(ambient);
    plain->add(HlodModel::load(dir.path() / "olinda.hlod"));
    const TerrainSite t = TerrainSite::open(dir.path() / "olinda.hlod");
    const glm::dvec2 middle = olinda_middle(t);
    const double ground = *t.heights->at(55, 55);
    Camera camera;
    camera.width = 320, camera.height = 240, camera.fov_y_degrees = 50;
    Renderer renderer;
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1, .node_id = true});
    auto render = [&](Node& root) {
        renderer.render(root, camera, target);
        return renderer.read_image(target);
    };
    auto srgb_difference = [](const float* a, const float* b) {
        int most = 0;
        for (int c = 0; c < 3; ++c) most = std::max(most, std::abs(int(linear_to_srgb(a[c])) - int(linear_to_srgb(b[c]))));
        return double(most);
    };
    const float grey[3] = {0.6f, 0.57f, 0.52f};  // the seams' untextured colour (terrain_draw.cpp)
    std::vector<double> textured, untextured;
    int views_drawn = 0;
    for (int v = 0; v < 16; ++v) {
        const double angle = 2 * M_PI * v / 16, distance = 1200 + 600 * (v % 4);
        camera.look_at({middle.x + distance * std::cos(angle), middle.y + distance * std::sin(angle), ground + 0.25 * distance},
                       {middle.x, middle.y, ground}, {0, 0, 1});
        high.ground->set_debug_view(HlodDebugView::levels);
        const Image pink = render(*high.root);
        high.ground->set_debug_view(HlodDebugView::none);
        if (!high.embedding->drawn()) continue;
        ++views_drawn;
        const Image shown = render(*high.root), under = render(*plain);
        for (size_t p = 0; p < pink.pixel_count(); ++p) {
            const float* c = &pink.rgba[4 * p];
            if (!(c[0] > 0.9f && c[1] < 0.2f && c[2] > 0.4f && c[2] < 0.7f) || shown.node_id[p] != high.ground->id()) continue;
            textured.push_back(srgb_difference(&shown.rgba[4 * p], &under.rgba[4 * p]));
            untextured.push_back(srgb_difference(grey, &under.rgba[4 * p]));
        }
    }
    EXPECT_GE(views_drawn, 8);
    ASSERT_GE(textured.size(), 50u) << "seam pixels in hot pink under the levels view";
    auto median = [](std::vector<double> v) {
        std::nth_element(v.begin(), v.begin() + ptrdiff_t(v.size() / 2), v.end());
        return v[v.size() / 2];
    };
    std::printf("%zu seam pixels in %d views: median difference from the ground's imagery %.1f steps, %.1f for the grey they had\n",
                textured.size(), views_drawn, median(textured), median(untextured));
    EXPECT_LE(median(textured), 12.0);
    EXPECT_GT(median(untextured), 3 * std::max(median(textured), 4.0)) << "the control: grey seams would show";
}

// A site embedded by strata embed (build_embedding) in Olinda's textured terrain: its skirt carries
// textures resampled from the ground's (section TXTR), and the skirt and the seams show the ground's
// imagery where an untextured skirt shows a grey ring.
class HybridImagery : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        if (olinda_missing()) return;
        build_textured_olinda(terrain_file());
        const TerrainSite t = TerrainSite::open(terrain_file());
        const glm::dvec2 middle = olinda_middle(t);
        BuildSettings settings;
        settings.lock_boundary = true;
        settings.levels = 3;
        build_hlod(site_mesh(t, middle.x, middle.y, 600, 0.0), site_file(), settings, "site");
        const std::array<double, 3> at = t.georeference->to_geo({middle.x, middle.y, 0});
        EmbedSettings embed;
        embed.placement.at = {at[0], at[1]};
        report_ = build_embedding(terrain_file(), site_file(), embedding_file(), embed);
    }
    static void TearDownTestSuite() { dir_.reset(); }
    void SetUp() override {
        if (olinda_missing()) GTEST_SKIP() << "data/olinda_* missing: run scripts/setup.sh";
    }

    static fs::path terrain_file() { return dir_->path() / "olinda.hlod"; }
    static fs::path site_file() { return dir_->path() / "site.hlod"; }
    static fs::path embedding_file() { return dir_->path() / "site_on_olinda.hlod"; }

    static inline std::unique_ptr<test::TempDir> dir_ = std::make_unique<test::TempDir>();
    static inline EmbedReport report_;
};

// A model's textures, each cube's mip 0 decoded once.
class DecodedTextures {
public:
    explicit DecodedTextures(const fs::path& path)
        : file_(std::make_shared<const HlodFile>(path)), textures_(file_, *file_->find_section(kTexturesTag), file_->nodes().size()) {}
    const HlodFile& file() const { return *file_; }
    const TextureLayout& layout() const { return textures_.layout(); }
    const std::vector<uint8_t>& mip0(uint64_t index) {
        auto [it, fresh] = decoded_.try_emplace(index);
        if (fresh) {
            const std::vector<uint8_t> chain = textures_.read(index, file_->nodes()[index]);
            it->second = decode_bc1(std::span(chain).first(TextureLayout::bc1_bytes(layout().size)), layout().size);
        }
        return it->second;
    }
    // The node table's index of the cube at level `level` whose cell holds model (x, y), if any.
    std::optional<uint64_t> cube_at(uint32_t level, double x, double y) const {
        const HlodHeader& h = file_->header();
        const double s = h.cube_size(level), i = std::floor((x - h.origin[0]) / s), j = std::floor((y - h.origin[1]) / s);
        for (uint64_t n = 0; n < file_->nodes().size(); ++n) {
            const HlodNode& node = file_->nodes()[n];
            if (node.level == level && node.i == i && node.j == j) return n;
        }
        return std::nullopt;
    }

private:
    std::shared_ptr<const HlodFile> file_;
    CubeTextures textures_;
    std::map<uint64_t, std::vector<uint8_t>> decoded_;
};

// Every skirt texel of the skirt's finest cubes is the ground's imagery at its place: per channel between
// the four ground texels around that point (what a bilinear blend gives), within BC1's error, at the
// coarsest ground level whose texels are as dense (FORMAT.md §4.9's mapping, computed here on its own).
// Against the ground a few texels away it is not.
TEST_F(HybridImagery, EachSkirtTexelIsTheGroundsImageryAtItsPlace) {
    ASSERT_GT(report_.texture_bytes, 0u);
    DecodedTextures skirt(embedding_file()), ground(terrain_file());
    const HlodHeader &sh = skirt.file().header(), &gh = ground.file().header();
    const float skirt_margin = skirt.layout().margin, ground_margin = ground.layout().margin;
    EXPECT_EQ(skirt_margin, sh.sigma0);
    const double ground_finest = (1 + 2 * ground_margin) * gh.cube_size(gh.max_level) / ground.layout().size;
    const double skirt_finest = (1 + 2 * skirt_margin) * sh.cube_size(sh.max_level) / skirt.layout().size;
    EXPECT_LE(skirt_finest, ground_finest) << "the skirt's finest texels as dense as the ground's";
    constexpr int kBc1Steps = 8;
    auto matches = [&](double shift) {  // the share of texels within the ground's four around (x + shift, y)
        size_t checked = 0, within = 0;
        for (uint64_t n = 0; n < skirt.file().nodes().size(); ++n) {
            const HlodNode& node = skirt.file().nodes()[n];
            if (node.level != sh.max_level) continue;
            const uint32_t size = skirt.layout().size;
            const double s = sh.cube_size(node.level), spacing = (1 + 2 * skirt_margin) * s / size;
            uint32_t level = 0;
            while (level < gh.max_level && (1 + 2 * ground_margin) * gh.cube_size(level) / ground.layout().size > spacing) ++level;
            const double gs = gh.cube_size(level), ground_spacing = (1 + 2 * ground_margin) * gs / ground.layout().size;
            for (uint32_t r = 1; r < size; r += 3)
                for (uint32_t c = 1; c < size; c += 3) {
                    const double x = sh.origin[0] + (node.i - skirt_margin) * s + (c + 0.5) * spacing + shift * ground_spacing;
                    const double y = sh.origin[1] + (node.j - skirt_margin) * s + (r + 0.5) * spacing;
                    const std::optional<uint64_t> under = ground.cube_at(level, x, y);
                    if (!under) continue;
                    const HlodNode& g = ground.file().nodes()[*under];
                    const int gsize = int(ground.layout().size);
                    const double tx = ((x - gh.origin[0]) / gs - g.i + ground_margin) / (1 + 2 * ground_margin) * gsize - 0.5;
                    const double ty = ((y - gh.origin[1]) / gs - g.j + ground_margin) / (1 + 2 * ground_margin) * gsize - 0.5;
                    const std::vector<uint8_t>& ground_rgb = ground.mip0(*under);
                    const uint8_t* texel = &skirt.mip0(n)[(size_t(r) * size + c) * 3];
                    bool inside = true;
                    for (int channel = 0; channel < 3; ++channel) {
                        int lo = 255, hi = 0;
                        for (int dy = 0; dy <= 1; ++dy)
                            for (int dx = 0; dx <= 1; ++dx) {
                                const int gx = std::clamp(int(std::floor(tx)) + dx, 0, gsize - 1), gy = std::clamp(int(std::floor(ty)) + dy, 0, gsize - 1);
                                const int value = ground_rgb[(size_t(gy) * size_t(gsize) + size_t(gx)) * 3 + size_t(channel)];
                                lo = std::min(lo, value), hi = std::max(hi, value);
                            }
                        inside = inside && texel[channel] >= lo - kBc1Steps && texel[channel] <= hi + kBc1Steps;
                    }
                    ++checked;
                    within += inside;
                }
        }
        EXPECT_GT(checked, 1000u);
        return double(within) / double(std::max<size_t>(checked, 1));
    };
    const double here = matches(0), elsewhere = matches(8);
    EXPECT_GT(here, 0.99);
    EXPECT_LT(elsewhere, 0.8) << "the check tells places apart";
    std::printf("skirt texels within the ground's four around them: %.4f at their place, %.4f eight texels east\n", here, elsewhere);
}

// Drawn with real OpenGL under ambient light alone (so a pixel shows its texture's colour), seen from
// above: where the skirt is drawn, its pixels are the plain ground's there (median difference at most 3
// steps in 255: BC1 twice and a resampling); an untextured skirt, the embedding as it was drawn before, is a grey ring there.
TEST_F(HybridImagery, TheSkirtShowsTheGroundsImageryNotAGreyRing) {
    const auto context = gl::create_headless_context();
    const TerrainSite t = TerrainSite::open(terrain_file());
    const EmbeddingRecord record = read_embedding(HlodFile(embedding_file()));
    // The control: the same skirt built without textures, as before.
    const EmbeddingPlan plan = plan_embedding(t, open_site(site_file()).coarsest, record.placement, record.height_difference, "site");
    BuildSettings locked;
    locked.lock_boundary = true;
    build_hlod(Mesh(plan.skirt_mesh), dir_->path() / "grey_skirt.hlod", locked, "skirt");

    enum class Skirt { none, textured, grey };
    struct Scene {
        NodePtr root;
        std::shared_ptr<Embedding> embedding;
    };
    auto scene = [&](Skirt skirt) {
        auto root = std::make_shared<Group>();
        auto ambient = std::make_shared<AmbientLight>();
        ambient->color = {1, 1, 1};
        root->add(ambient);
        auto terrain = std::make_shared<Terrain>(HlodModel::load(terrain_file()));
        if (skirt == Skirt::textured) terrain->load_embedding(embedding_file());
        if (skirt == Skirt::grey)
            terrain->embed(HlodModel::load(dir_->path() / "grey_skirt.hlod"), HlodModel::load(site_file()), record.placement, record.zone_level,
                           record.zone, "site");
        root->add(terrain);
        return Scene{root, skirt == Skirt::none ? nullptr : terrain->embeddings().at(0)};
    };
    const glm::dvec2 middle = olinda_middle(t);
    const double ground = *t.heights->at(55, 55);
    Camera camera;
    camera.width = 320, camera.height = 240, camera.fov_y_degrees = 50;
    camera.look_at({middle.x, middle.y - 900, ground + 3000}, {middle.x, middle.y, ground}, {0, 0, 1});
    Renderer renderer;
    RenderSettings full_detail;
    full_detail.full_detail = true;  // the embedding file's models stream
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1, .node_id = true});
    auto render = [&](const Scene& s) {
        renderer.render(*s.root, camera, target, full_detail);
        return renderer.read_image(target);
    };
    const Image plain = render(scene(Skirt::none));
    // The median over the skirt's pixels of the largest channel difference from the plain ground, in
    // sRGB steps of 255.
    auto median_difference = [&](Skirt skirt) {
        const Scene s = scene(skirt);
        const Image image = render(s);
        EXPECT_TRUE(s.embedding->drawn());
        std::vector<double> differences;
        for (size_t p = 0; p < image.pixel_count(); ++p) {
            if (image.node_id[p] != s.embedding->skirt()->id()) continue;
            double most = 0;
            for (size_t c = 0; c < 3; ++c)
                most = std::max(most, double(std::abs(int(linear_to_srgb(image.rgba[4 * p + c])) - int(linear_to_srgb(plain.rgba[4 * p + c])))));
            differences.push_back(most);
        }
        EXPECT_GT(differences.size(), 2000u) << "the skirt's pixels";
        if (differences.empty()) return 255.0;
        std::nth_element(differences.begin(), differences.begin() + ptrdiff_t(differences.size() / 2), differences.end());
        return differences[differences.size() / 2];
    };
    const double textured = median_difference(Skirt::textured), grey = median_difference(Skirt::grey);
    EXPECT_LE(textured, 3.0);
    EXPECT_GT(grey, 20.0) << "the control: an untextured skirt is a grey ring";
    std::printf("skirt pixels against the plain ground: median %.2f steps textured, %.2f untextured\n", textured, grey);
}

}  // namespace
}  // namespace strata

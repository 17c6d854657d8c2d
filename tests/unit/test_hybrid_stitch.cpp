// The stitch of an embedding at run time (nodes/embedding_stitch.h), checked on the CPU twin: a site
// with a wiggly, bumpy boundary embedded in a DEM terrain, its skirt and the site built as HLODs with
// locked boundaries, viewed from eyes near and far. Where the embedding is drawn, the terrain with its
// zone hidden, the skirt, the site and the seams form one surface whose only open edges are the raster's
// own border, at whatever levels the grid along the zone's border is drawn (thesis 003's T1, T2), with
// no edge used thrice (T3); without the seams, or without hiding the zone, it is not.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <set>

#include "nodes/embedding_stitch.h"
#include "preprocess/embedding.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/support/geotiff.h"
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

class HybridStitch : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        test::TiffSpec spec;
        spec.width = spec.height = kSize;
        spec.type = GDT_Float32;
        for (int r = 0; r < kSize; ++r)
            for (int c = 0; c < kSize; ++c) spec.values.push_back(dem_height(c, r));
        test::write_tiff(dir_->path() / "dem.tif", spec);
        TerrainSettings terrain_settings;
        terrain_settings.cube_cells = 8;
        build_terrain({dir_->path() / "dem.tif"}, dir_->path() / "dem.hlod", terrain_settings, "dem.tif");
        const TerrainSite t = TerrainSite::open(dir_->path() / "dem.hlod");

        Mesh site = site_mesh(t, 1400, 1500, 150, 8.0);
        const EmbeddingPlan plan = plan_embedding(t, site, glm::dmat4(1.0), "site");
        BuildSettings settings;
        settings.lock_boundary = true;
        settings.levels = 3;
        build_hlod(std::move(site), dir_->path() / "site.hlod", settings, "site");
        settings.levels = 2;  // its cells are 30 m: a third level would need σ0 past its bound
        build_hlod(Mesh(plan.skirt_mesh), dir_->path() / "skirt.hlod", settings, "skirt");

        EmbeddedModels models;
        models.terrain = terrain_ = HlodModel::load(dir_->path() / "dem.hlod");
        models.skirt = skirt_ = HlodModel::load(dir_->path() / "skirt.hlod");
        models.site = site_ = HlodModel::load(dir_->path() / "site.hlod");
        models.drawn_from = plan.zone_level;
        models.zone = plan.zone;
        stitch_ = std::make_unique<EmbeddingStitch>(std::move(models), "site");
    }
    static void TearDownTestSuite() {
        stitch_.reset();
        terrain_.reset(), skirt_.reset(), site_.reset();
        dir_.reset();
    }

    // Eyes around the site, from a few metres off the ground to kilometres away.
    static std::vector<glm::dvec3> eyes(int count) {
        std::mt19937 rng(2026);
        std::uniform_real_distribution<double> unit(0, 1);
        std::vector<glm::dvec3> out;
        for (int i = 0; i < count; ++i) {
            const double distance = 50 * std::pow(60.0, unit(rng)), angle = 2 * M_PI * unit(rng);
            const double height = 450 + 5 + distance * 0.6 * unit(rng);
            out.push_back({1400 + distance * std::cos(angle), 1500 + distance * std::sin(angle), height});
        }
        // And from far off, where the grid over the zone is coarser than m.
        for (const double distance : {9000.0, 20000.0}) out.push_back({1400 + distance, 1500, 450 + distance / 3});
        return out;
    }

    static inline std::unique_ptr<test::TempDir> dir_ = std::make_unique<test::TempDir>();
    static inline std::shared_ptr<HlodModel> terrain_, skirt_, site_;
    static inline std::unique_ptr<EmbeddingStitch> stitch_;
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

TEST_F(HybridStitch, TheGroundTheSkirtTheSiteAndTheSeamsAreOneSurfaceAtEveryLevelAlongTheBorder) {
    ASSERT_GT(stitch_->border_steps(), 0u);
    ASSERT_GT(stitch_->boundary_vertices(), 100u);
    Camera camera;
    camera.width = 1920, camera.height = 1080, camera.fov_y_degrees = 60;
    size_t embedded = 0, hidden = 0, mixed = 0, without_seams_open = 0, without_mask_thrice = 0;
    for (const double pixels : {0.5, 2.0, 8.0}) {
        terrain_->set_pixel_error(pixels), skirt_->set_pixel_error(pixels), site_->set_pixel_error(pixels);
        for (const glm::dvec3& eye : eyes(32)) {
            const Drawn drawn = draw(*stitch_, camera, eye, Omit::nothing);
            EXPECT_EQ(drawn.open_inside, 0u) << "eye " << eye.x << ", " << eye.y << ", " << eye.z << " at " << pixels << " px";
            EXPECT_EQ(drawn.thrice, 0u) << "eye " << eye.x << ", " << eye.y << ", " << eye.z << " at " << pixels << " px";
            if (!drawn.embedded) {
                ++hidden;
                continue;
            }
            ++embedded;
            EXPECT_GT(drawn.seam_triangles, 0u);
            if (drawn.border_levels.size() > 1) ++mixed;
            if (draw(*stitch_, camera, eye, Omit::seams).open_inside > 0) ++without_seams_open;
            if (draw(*stitch_, camera, eye, Omit::mask).thrice > 0) ++without_mask_thrice;
        }
    }
    terrain_->set_kappa0(2.0), skirt_->set_kappa0(2.0), site_->set_kappa0(2.0);
    // Both cases happen, and grid levels mix along the border.
    EXPECT_GT(embedded, 20u);
    EXPECT_GT(hidden, 0u);
    EXPECT_GT(mixed, 5u);
    // The controls: without the seams the join is open, without the mask the zone is drawn twice.
    EXPECT_EQ(without_seams_open, embedded);
    EXPECT_EQ(without_mask_thrice, embedded);
}

}  // namespace
}  // namespace strata

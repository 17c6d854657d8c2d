// The fidelity check (DESIGN.md §6, §8): the bundled bunny's HLOD at 1 pixel of error against its full
// mesh, rendered with the same cameras through the real renderer (Mesa llvmpipe through EGL), and the
// screen-space error measured per covered pixel (tests/support/fidelity.h). Controls: the distance
// query (strata::TriangleTree) is exact where the answer is known and equals brute force on the scan,
// and the measurement catches a selection that is too coarse.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numeric>
#include <random>

#include "engine/gl/context.h"
#include "preprocess/mesh_io.h"
#include "tests/support/bunny_model.h"
#include "tests/support/dem_grid.h"
#include "tests/support/fidelity.h"

namespace strata::test {
namespace {

const std::filesystem::path kScan = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "bunny.off";

// The distance to the surface of a box is known in closed form, inside and out: the tree's nearest()
// is exact where the measurement leans on it (points on and near a closed surface, on either side).
TEST(FidelityDistance, DistanceToACubesSurfaceIsExact) {
    std::vector<float> corners;
    for (int k = 0; k < 8; ++k) corners.insert(corners.end(), {float(k & 1), float(k >> 1 & 1), float(k >> 2 & 1)});
    // Two triangles per face, each face as four corners in order around it.
    const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    std::vector<uint32_t> indices;
    for (const auto& f : faces) indices.insert(indices.end(), {uint32_t(f[0]), uint32_t(f[1]), uint32_t(f[2]),
                                                               uint32_t(f[0]), uint32_t(f[2]), uint32_t(f[3])});
    const MeasuredSurface cube(corners, indices, glm::dvec3(0.0));
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> coordinate(-1.5, 2.5);
    for (int i = 0; i < 2000; ++i) {
        const glm::dvec3 p(coordinate(rng), coordinate(rng), coordinate(rng));
        const glm::dvec3 from_centre = glm::abs(p - 0.5);
        const glm::dvec3 outside = glm::max(from_centre - 0.5, 0.0);
        const double expected = glm::length(outside) > 0 ? glm::length(outside)
                                                         : 0.5 - std::max({from_centre.x, from_centre.y, from_centre.z});
        ASSERT_NEAR(cube.nearest(p).distance, expected, 1e-14) << p.x << " " << p.y << " " << p.z;
    }
}

// The distance from p to triangle t of a mesh, by the same exact closest point the tree uses.
double distance_to_triangle(const Mesh& mesh, uint32_t t, const glm::dvec3& p) {
    double corner[3][3];
    for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) corner[k][a] = mesh.positions[3 * size_t(mesh.indices[3 * size_t(t) + k]) + a];
    const double q[3] = {p.x, p.y, p.z};
    return point_triangle_distance(q, corner[0], corner[1], corner[2]);
}

// The tree's pruning loses nothing, and neither does a first guess that bounds it (the measurement
// passes the previous pixel's triangle): on the real scan nearest() finds what testing every triangle
// finds, to the bit. Where several triangles are as near (a vertex or an edge nearest) any of them is
// a right answer, so the triangle is checked to be at that distance, not to be one of them in particular.
TEST(FidelityDistance, TheTreeFindsWhatBruteForceFindsWithAndWithoutAHint) {
    if (!std::filesystem::exists(kScan)) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    const Mesh mesh = read_mesh(kScan);
    const MeasuredSurface bunny(mesh.positions, mesh.indices, glm::dvec3(0.0));
    std::mt19937 rng(5);
    std::uniform_int_distribution<size_t> vertex(0, mesh.vertex_count() - 1);
    std::normal_distribution<double> offset(0.0, 0.002);
    for (int i = 0; i < 200; ++i) {
        // Near the surface, where the measurement asks, and some far from it.
        const double spread = i % 4 == 0 ? 50.0 : 1.0;
        const size_t v = vertex(rng);
        const glm::dvec3 p = glm::dvec3(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]) +
                             spread * glm::dvec3(offset(rng), offset(rng), offset(rng));
        double brute_force = std::numeric_limits<double>::infinity();
        uint32_t nearest_triangle = ~0u;
        for (uint32_t t = 0; t < mesh.triangle_count(); ++t) {
            const double d = distance_to_triangle(mesh, t, p);
            if (d < brute_force) brute_force = d, nearest_triangle = t;
        }
        // With no first guess, the right one, and one however far off.
        for (const uint32_t hint : {~0u, nearest_triangle, uint32_t(i * 97 % mesh.triangle_count())}) {
            const TriangleTree::Nearest fast = bunny.nearest(p, hint);
            ASSERT_EQ(fast.distance, brute_force) << "point " << i << ", hint " << hint;
            ASSERT_LT(fast.triangle, mesh.triangle_count());
            ASSERT_EQ(distance_to_triangle(mesh, fast.triangle, p), brute_force) << "point " << i << ", hint " << hint;
        }
    }
}

class Fidelity : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        if (bunny_hlod().empty()) return;
        context_ = gl::create_headless_context();
        mesh_ = std::make_unique<Mesh>(read_mesh(kScan));
        model_ = HlodModel::load(bunny_hlod());
        meter_ = std::make_unique<FidelityMeter>(model_, *mesh_);
    }
    static void TearDownTestSuite() {
        meter_.reset();
        model_.reset();
        mesh_.reset();
        context_.reset();
    }
    void SetUp() override {
        if (!meter_) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    }

    static std::vector<std::unique_ptr<Camera>> views(int count) { return fidelity_views(model_->bound(), *mesh_, count, 320, 240, 11); }

    static inline std::unique_ptr<gl::Context> context_;
    static inline std::unique_ptr<Mesh> mesh_;
    static inline std::shared_ptr<HlodModel> model_;
    static inline std::unique_ptr<FidelityMeter> meter_;
};

// --pixel-error 1 is kept where it counts, on the screen: over the views, at least 99.9 % of the pixels
// the HLOD covers lie within 1 pixel of the full mesh, and the other way round. The reconstruction's
// own error is far below.
void expect_within_one_pixel(HlodModel& model, FidelityMeter& meter, const std::vector<std::unique_ptr<Camera>>& cameras) {
    model.set_pixel_error(1.0);
    size_t forward_pixels = 0, forward_within = 0, backward_pixels = 0, backward_within = 0;
    double forward_max = 0, backward_max = 0, noise_max = 0, noise_p999 = 0;
    uint64_t hlod_triangles = 0, full_triangles = 0;
    std::vector<uint32_t> levels(model.header().max_level + 1, 0);
    for (const auto& camera : cameras) {
        const FidelityReport r = meter.measure(*camera, 1.0);
        ASSERT_GT(r.forward.pixels, 0u) << "a view that sees nothing measures nothing";
        forward_pixels += r.forward.pixels;
        forward_within += r.forward.within;
        backward_pixels += r.backward.pixels;
        backward_within += r.backward.within;
        forward_max = std::max(forward_max, r.forward.max);
        backward_max = std::max(backward_max, r.backward.max);
        noise_max = std::max(noise_max, r.noise.max);
        noise_p999 = std::max(noise_p999, r.noise.p999);
        hlod_triangles += r.hlod_triangles, full_triangles += r.full_triangles;
        uint64_t cubes = 0;
        for (size_t l = 0; l < levels.size(); ++l) {
            levels[l] += r.cubes_per_level[l];
            cubes += r.cubes_per_level[l];
        }
        EXPECT_EQ(cubes, r.hlod_cubes) << "the measured selection is the one drawn";
    }
    std::printf("%s: forward: %zu pixels, %.4f %% within 1 px, max %.3f px; backward: %zu pixels, %.4f %% within, "
                "max %.3f px; noise p99.9 %.1e max %.1e px; triangles %.3g of the full mesh's; cubes per level",
                model.name().c_str(), forward_pixels, 100.0 * forward_within / forward_pixels, forward_max,
                backward_pixels, 100.0 * backward_within / backward_pixels, backward_max, noise_p999, noise_max,
                double(hlod_triangles) / double(full_triangles));
    for (uint32_t n : levels) std::printf(" %u", n);
    std::printf("\n");
    EXPECT_GE(double(forward_within) / double(forward_pixels), 0.999) << "max " << forward_max << " px";
    // The bound is two-sided (DESIGN.md §8): the full mesh's pixels lie as close to what the HLOD draws.
    EXPECT_GE(double(backward_within) / double(backward_pixels), 0.999) << "max " << backward_max << " px";
    // Coarse levels are drawn, and where their error shows: the views put the bound to the test.
    EXPECT_GT(std::accumulate(levels.begin(), levels.end() - 1, 0u), 0u);
    EXPECT_GT(forward_max, 0.05);
    // The full mesh measured against itself: float depth (reversed Z) gives about 1e-5 px, the
    // rasterizer's subpixel snapping of triangles seen edge-on a few hundredths at some silhouettes.
    // Not the maximum: llvmpipe extrapolates the depth plane of a sliver far smaller than a pixel past
    // its corners (1 pixel in 18 M at 1280×720 came out 1.9 px off the mesh it was drawn from).
    EXPECT_LT(noise_p999, 5e-3);
}

TEST_F(Fidelity, AtOnePixelOfErrorTheHlodStaysWithinOnePixelOfTheFullMesh) {
    expect_within_one_pixel(*model_, *meter_, views(50));
}

// The same on a real terrain: 256 × 256 samples (3 arc-seconds, about 19 × 24 km) of the Sangre de
// Cristo range and the plain beside it, from data/trinidad.nc.
class FidelityTerrain : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        const auto dem = std::filesystem::path(STRATA_SOURCE_DIR) / "data" / "trinidad.nc";
        if (!std::filesystem::exists(dem)) return;
        context_ = gl::create_headless_context();
        mesh_ = std::make_unique<Mesh>(read_dem_grid(dem, {.first_column = 500, .first_row = 520, .columns = 256, .rows = 256},
                                                     {.variable = "", .unit = ElevationUnit::feet}));
        dir_ = std::make_unique<TempDir>();
        BuildSettings settings;
        settings.levels = 4;
        build_hlod(Mesh(*mesh_), *dir_ / "terrain.hlod", settings, "trinidad.nc");
        model_ = HlodModel::load(*dir_ / "terrain.hlod");
        meter_ = std::make_unique<FidelityMeter>(model_, *mesh_);
    }
    static void TearDownTestSuite() {
        meter_.reset();
        model_.reset();
        dir_.reset();
        mesh_.reset();
        context_.reset();
    }
    void SetUp() override {
        if (!meter_) GTEST_SKIP() << "data/trinidad.nc missing: run scripts/setup.sh";
    }

    static inline std::unique_ptr<gl::Context> context_;
    static inline std::unique_ptr<Mesh> mesh_;
    static inline std::unique_ptr<TempDir> dir_;
    static inline std::shared_ptr<HlodModel> model_;
    static inline std::unique_ptr<FidelityMeter> meter_;
};

TEST_F(FidelityTerrain, AtOnePixelOfErrorTheHlodStaysWithinOnePixelOfTheFullMesh) {
    expect_within_one_pixel(*model_, *meter_, fidelity_views(model_->bound(), *mesh_, 50, 320, 240, 12));
}

// The control: a selection made for 64 pixels (κ0 then at its minimum, 1 + 3σ0 + 0.25, the coarsest cut
// the morph allows), held to 1 pixel, fails the measurement.
TEST_F(Fidelity, ATooCoarseSelectionIsCaught) {
    model_->set_pixel_error(64.0);
    size_t pixels = 0, within = 0;
    double worst = 0;
    for (const auto& camera : views(10)) {
        const FidelityReport r = meter_->measure(*camera, 1.0);
        pixels += r.forward.pixels;
        within += r.forward.within;
        worst = std::max(worst, r.forward.max);
    }
    model_->set_pixel_error(1.0);
    std::printf("at 64 px: %.2f %% within 1 px, max %.1f px\n", 100.0 * within / pixels, worst);
    EXPECT_LT(double(within) / double(pixels), 0.99);
    EXPECT_GT(worst, 2.0);
}

}  // namespace
}  // namespace strata::test

// Rendering with real OpenGL (Mesa llvmpipe through EGL, no display): a scene of three HLOD models under
// different transforms and a Geometry floor against a golden image, its EXR channels read back with
// OpenEXR, and the pop check (DESIGN.md §6): images just before and just after a cube is replaced by
// its children match, and without the morph they do not.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <set>

#include <stb_image.h>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/io/image.h"
#include "engine/render/renderer.h"
#include "engine/scene/cull_visitor.h"
#include "engine/scene/light.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "tests/support/bunny_model.h"
#include "tests/support/pop_check.h"

namespace strata {
namespace {

const std::filesystem::path kGolden = std::filesystem::path(STRATA_SOURCE_DIR) / "tests/data/golden/three_bunnies.png";

class Render : public ::testing::Test {
protected:
    static void SetUpTestSuite() { context_ = gl::create_headless_context(); }
    static void TearDownTestSuite() { context_.reset(); }
    void SetUp() override {
        if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    }

    static inline std::unique_ptr<gl::Context> context_;
};

struct ThreeBunnies {
    std::shared_ptr<Group> root = std::make_shared<Group>();
    std::vector<std::shared_ptr<HlodModel>> models;
    std::shared_ptr<Geometry> floor;
    Camera camera;

    ThreeBunnies() {
        const double size = HlodModel::load(test::bunny_hlod())->header().root_size;
        const glm::dvec3 placements[3] = {{-1.2, 0, 0}, {0, 0, -0.6}, {1.2, 0, 0}};
        for (int i = 0; i < 3; ++i) {
            auto model = HlodModel::load(test::bunny_hlod());
            model->set_pixel_error(1.0);
            auto place = std::make_shared<Transform>();
            // Each bunny centred on its spot, turned differently, the last one smaller.
            glm::dmat4 m = glm::translate(glm::dmat4(1.0), placements[i] * size);
            m = glm::rotate(m, glm::radians(60.0 * (i - 1)), {0, 1, 0});
            m = glm::scale(m, glm::dvec3(i == 2 ? 0.7 : 1.0));
            m = glm::translate(m, -model->bound().center() + glm::dvec3(0, 0.5 * (model->bound().hi.y - model->bound().lo.y), 0));
            place->set_matrix(m);
            place->add(model);
            root->add(place);
            models.push_back(model);
        }
        floor = Geometry::plane({0, 0, 0}, {0, 1, 0}, 5 * size, 4 * size);
        floor->material.base_color = {0.45f, 0.42f, 0.38f, 1.0f};
        root->add(floor);
        auto sun = std::make_shared<DirectionalLight>();
        sun->direction = {-0.4, -1.0, -0.5};
        root->add(sun);
        auto sky = std::make_shared<AmbientLight>();
        sky->color = {0.2f, 0.2f, 0.22f};
        root->add(sky);
        camera.width = 320;
        camera.height = 240;
        camera.look_at(glm::dvec3(0.3, 1.2, 3.2) * size, glm::dvec3(0, 0.3, 0) * size);
    }
};

TEST_F(Render, ThreeModelsAndAFloorMatchTheGoldenImage) {
    ThreeBunnies scene;
    // One sample per pixel: multisample patterns differ between drivers, single samples much less.
    gl::Framebuffer target({.width = 320, .height = 240, .samples = 1});
    Renderer renderer;
    const FrameStats stats = renderer.render(*scene.root, scene.camera, target);
    EXPECT_EQ(stats.draw_items, 4u);
    EXPECT_GT(stats.cubes, 3u);
    const Image image = renderer.read_image(target);
    if (std::getenv("STRATA_UPDATE_GOLDEN")) {
        std::filesystem::create_directories(kGolden.parent_path());
        write_png(image, kGolden);
        GTEST_SKIP() << "wrote " << kGolden;
    }
    // The golden image is 8-bit sRGB; compare in the same encoding.
    test::TempDir dir;
    write_png(image, dir / "now.png");
    int w = 0, h = 0, n = 0, gw = 0, gh = 0;
    unsigned char* now = stbi_load((dir / "now.png").c_str(), &w, &h, &n, 4);
    unsigned char* golden = stbi_load(kGolden.c_str(), &gw, &gh, &n, 4);
    ASSERT_NE(golden, nullptr) << kGolden << " missing: run the test with STRATA_UPDATE_GOLDEN=1";
    ASSERT_EQ(gw, w);
    ASSERT_EQ(gh, h);
    // A pixel matches when the golden pixel or one of its eight neighbours is within 3/255 in every
    // channel: an edge a rasterizer puts one pixel over still matches, a wrong surface does not.
    auto close = [&](int x, int y, const unsigned char* pixel) {
        if (x < 0 || y < 0 || x >= w || y >= h) return false;
        const unsigned char* g = golden + 4 * (size_t(y) * w + x);
        for (int c = 0; c < 4; ++c)
            if (std::abs(int(pixel[c]) - int(g[c])) > 3) return false;
        return true;
    };
    size_t differ = 0, covered = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const unsigned char* pixel = now + 4 * (size_t(y) * w + x);
            bool matched = false;
            for (int dy = -1; dy <= 1 && !matched; ++dy)
                for (int dx = -1; dx <= 1 && !matched; ++dx) matched = close(x + dx, y + dy, pixel);
            differ += !matched;
            covered += golden[4 * (size_t(y) * w + x) + 3] > 0;
        }
    stbi_image_free(now);
    stbi_image_free(golden);
    EXPECT_LT(double(differ) / (w * h), 0.002) << differ << " pixels differ from " << kGolden;
    EXPECT_GT(double(covered) / (w * h), 0.3) << "the scene should cover much of the image";
}

TEST_F(Render, ExrChannelsHoldDepthNormalsLevelsAndIds) {
    ThreeBunnies scene;
    gl::Framebuffer target({.width = 160, .height = 120, .samples = 4, .normals = true, .level = true, .node_id = true});
    scene.camera.width = 160;
    scene.camera.height = 120;
    Renderer renderer;
    renderer.render(*scene.root, scene.camera, target);
    test::TempDir dir;
    write_exr(renderer.read_image(target), dir / "frame.exr", ImageChannels::all());
    const Image back = read_exr(dir / "frame.exr");
    ASSERT_EQ(back.width, 160);
    ASSERT_EQ(back.planes(), ImageChannels::all());
    std::set<uint32_t> model_ids;
    for (const auto& m : scene.models) model_ids.insert(m->id());
    size_t model_pixels = 0, floor_pixels = 0, background = 0;
    size_t bad_background = 0, bad_depth = 0, bad_normal = 0, bad_level = 0, bad_floor = 0;
    const double far_enough = 20 * scene.models[0]->header().root_size;
    for (size_t p = 0; p < back.pixel_count(); ++p) {
        const uint32_t id = back.node_id[p];
        const glm::vec3 n(back.normals[3 * p], back.normals[3 * p + 1], back.normals[3 * p + 2]);
        if (id == 0) {
            ++background;
            bad_background += !std::isinf(back.depth[p]) || back.level[p] != -1.0f;
            continue;
        }
        bad_depth += !(back.depth[p] > 0.0f && back.depth[p] < far_enough);
        bad_normal += std::abs(glm::length(n) - 1.0f) > 0.01f;
        if (model_ids.count(id)) {
            ++model_pixels;
            bad_level += !(back.level[p] >= 0.0f && back.level[p] <= 3.0f);
        } else {
            ++floor_pixels;
            bad_floor += id != scene.floor->id() || back.level[p] != -1.0f || n.y < 0.99f;  // the floor faces up
        }
    }
    EXPECT_EQ(bad_background, 0u) << "background pixels with a depth or a level";
    EXPECT_EQ(bad_depth, 0u) << "drawn pixels without a depth in range";
    EXPECT_EQ(bad_normal, 0u) << "drawn pixels without a unit normal";
    EXPECT_EQ(bad_level, 0u) << "model pixels without a level in 0 … 3";
    EXPECT_EQ(bad_floor, 0u) << "floor pixels with another id, a level, or a normal not facing up";
    EXPECT_GT(model_pixels, back.pixel_count() / 20);
    EXPECT_GT(floor_pixels, back.pixel_count() / 20);
    EXPECT_GT(background, 0u);
}

// The bunny from 1.2 radii off, at 160 × 120: a view that draws the finest level in places.
void look_from_aside(Camera& camera, Node& root) {
    camera.width = 160;
    camera.height = 120;
    const Box bound = root.bound();
    camera.look_at(bound.center() + 1.2 * bound.radius() * glm::normalize(glm::dvec3(1, 0.5, 2)), bound.center());
}

// Every cube resident but those of the finest level: its parents stand in where a view wants it.
std::vector<uint8_t> without_the_finest_level(const HlodModel& model) {
    std::vector<uint8_t> resident(model.cubes().size());
    for (uint32_t c = 0; c < resident.size(); ++c) resident[c] = model.cubes()[c].node.level < model.header().max_level;
    return resident;
}

// --debug residency: cubes that stand in for missing children (and those capped beside them) are
// orange, the rest blue-grey; with every cube resident nothing is orange, with the finest level
// missing the view that wants it shows orange.
TEST_F(Render, TheResidencyViewShowsStandInsInOrange) {
    auto model = HlodModel::load(test::bunny_hlod());
    model->set_pixel_error(1.0);
    model->set_debug_view(HlodDebugView::residency);
    auto root = std::make_shared<Group>();
    root->add(model);
    Camera camera;
    look_from_aside(camera, *root);
    Renderer renderer;
    auto count = [&](size_t& orange, size_t& blue) {
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        renderer.render(*root, camera, target);
        const std::vector<float> rgba = target.read_color();
        orange = blue = 0;
        for (size_t p = 0; p < rgba.size(); p += 4) {
            if (rgba[p + 3] < 0.5f) continue;  // background
            orange += rgba[p] > 2 * rgba[p + 2];
            blue += rgba[p + 2] > rgba[p];
        }
    };
    size_t orange = 0, blue = 0;
    count(orange, blue);
    EXPECT_EQ(orange, 0u);
    EXPECT_GT(blue, 2000u);
    model->set_residency(without_the_finest_level(*model));
    count(orange, blue);
    EXPECT_GT(orange, 1000u);
}

// Children that arrive late fade in (nodes/README.md, "Stand-ins"): the first frame after a stood-in
// group arrives draws what the stand-ins drew, the next frames carry the change a step at a time, and
// once nothing fades the frame is the one every cube resident draws. Without the fade the arrival
// would show at once.
TEST_F(Render, ChildrenThatArriveLateFadeInWithoutAPop) {
    auto model = HlodModel::load(test::bunny_hlod());
    model->set_pixel_error(1.0);
    auto root = std::make_shared<Group>();
    root->add(model);
    Camera camera;
    look_from_aside(camera, *root);
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
    Renderer renderer;
    auto frame = [&](bool full_detail, FrameStats* stats = nullptr) {
        RenderSettings settings;
        settings.full_detail = full_detail;
        const FrameStats s = renderer.render(*root, camera, target, settings);
        if (stats) *stats = s;
        return target.read_color();
    };
    auto mean_difference = [](const std::vector<float>& a, const std::vector<float>& b) {
        double sum = 0;
        for (size_t i = 0; i < a.size(); ++i) sum += std::abs(a[i] - b[i]);
        return sum / double(a.size());
    };
    const std::vector<float> reference = frame(true);
    model->set_residency(without_the_finest_level(*model));
    std::vector<float> stood_in;
    for (int k = 0; k < 3; ++k) stood_in = frame(false);
    const double change = mean_difference(stood_in, reference);
    ASSERT_GT(test::differing(stood_in, reference, 1.0f / 255), 0.02) << "the finest level shows: something to fade in";
    model->set_residency(std::vector<uint8_t>(model->cubes().size(), 1));
    std::vector<float> previous = frame(false);
    EXPECT_LE(test::differing(stood_in, previous, 1.0f / 255), 0.001) << "the frame the children arrive draws what the stand-ins drew";
    FrameStats stats;
    double largest_step = 0;
    int frames = 1;
    for (; frames < 20 * HlodModel::kFadeFrames; ++frames) {
        const std::vector<float> next = frame(false, &stats);
        largest_step = std::max(largest_step, mean_difference(previous, next));
        previous = next;
        if (stats.frames_unconverged == 0) break;
    }
    EXPECT_EQ(stats.frames_unconverged, 0u);
    EXPECT_GE(frames, HlodModel::kFadeFrames);
    EXPECT_LT(largest_step, 1.5 / HlodModel::kFadeFrames * change) << "no frame carries much more than its share of the change";
    EXPECT_EQ(previous, reference) << "faded in, the frame is the one every cube resident draws";
}

// Lemma 2 on the GPU: a cube drawn just outside its switch distance and its children drawn just
// inside it give the same image; the morph is what makes it so.
TEST_F(Render, NoPopWhenACubeIsReplacedByItsChildren) {
    auto model = HlodModel::load(test::bunny_hlod());
    const double kappa0 = std::max(2.5, model->min_kappa0());
    model->set_kappa0(kappa0);
    const uint32_t chosen = test::busiest_cube(*model, 2);
    ASSERT_NE(chosen, kNoCube);
    auto root = std::make_shared<Group>();
    root->add(model);
    const test::PopFrames morphed = test::pop_frames(*root, *model, chosen, kappa0, true);
    ASSERT_TRUE(morphed.before_selected) << "just outside the switch distance the cube itself is drawn";
    ASSERT_FALSE(morphed.after_selected) << "just inside it its children are";
    EXPECT_LE(test::differing(morphed.before, morphed.after, 1.0f / 255), 0.001);
    // The control: without the morph the switch shows.
    const test::PopFrames plain = test::pop_frames(*root, *model, chosen, kappa0, false);
    EXPECT_GT(test::differing(plain.before, plain.after, 1.0f / 255), 0.001);
}

// The GPU draws exactly what the CPU twin computes: every drawn vertex's morphed position, bit for
// bit, in a view close to the surface (mixed levels, vertices mid-morph) under a rotated, scaled and
// translated Transform.
TEST_F(Render, TheShaderMorphsBitForBitLikeTheCpuTwin) {
    auto model = HlodModel::load(test::bunny_hlod());
    model->set_kappa0(std::max(2.0, model->min_kappa0()));
    model->set_capture_morph(true);
    auto root = std::make_shared<Group>();
    auto place = std::make_shared<Transform>();
    const glm::dmat4 world_from_node = glm::scale(
        glm::rotate(glm::translate(glm::dmat4(1.0), {1000.25, -3.5, 20.0}), glm::radians(33.0), glm::normalize(glm::dvec3(1, 2, 3))),
        glm::dvec3(1.7));
    place->set_matrix(world_from_node);
    place->add(model);
    root->add(place);
    Camera camera;
    camera.width = camera.height = 160;
    const Box bound = root->bound();
    // Just off the surface, at a vertex of the finest level, looking in at the middle.
    const HlodCube* finest = nullptr;
    for (const HlodCube& c : model->cubes())
        if (c.node.level == model->header().max_level && (!finest || c.data->vertex_count() > finest->data->vertex_count())) finest = &c;
    ASSERT_NE(finest, nullptr);
    const glm::dvec3 on_surface = world_from_node * model->lattice_to_node() * glm::dvec4(model->vertex_position(*finest, 0), 1.0);
    camera.look_at(on_surface + 0.3 * (on_surface - bound.center()), bound.center());
    gl::Framebuffer target({.width = 160, .height = 160});
    Renderer renderer;
    renderer.render(*root, camera, target);

    const HlodModel::LatticeAnchor anchor = model->anchor_for(world_from_node, camera.position);
    const Kappas kappa = model->kappas_for(camera);
    std::vector<glm::vec3> cpu;
    size_t cubes = 0, vertices = 0, mid_morph = 0, mismatches = 0;
    std::set<uint32_t> levels;
    for (uint32_t c = 0; c < model->cubes().size(); ++c) {
        const std::vector<glm::vec4>* gpu = model->captured_morph(c);
        if (!gpu) continue;
        model->morphed_positions(c, anchor, *kappa, cpu);
        ASSERT_EQ(gpu->size(), cpu.size());
        // Only vertices a triangle uses go through the shader.
        const auto& indices = model->cubes()[c].data->indices;
        for (const uint32_t v : std::set<uint32_t>(indices.begin(), indices.end())) {
            const glm::vec3 drawn((*gpu)[v]);
            mismatches += std::memcmp(&drawn, &cpu[v], sizeof drawn) != 0;
            const float lambda = (*gpu)[v].w;
            mid_morph += lambda > 0 && lambda < 1;
        }
        ++cubes;
        vertices += std::set<uint32_t>(indices.begin(), indices.end()).size();
        levels.insert(model->cubes()[c].node.level);
    }
    EXPECT_EQ(mismatches, 0u) << "of " << vertices << " vertices in " << cubes << " cubes";
    EXPECT_GE(levels.size(), 2u) << "the view should mix levels";
    EXPECT_GT(mid_morph, 100u) << "the view should catch vertices mid-morph";
}

// An orthographic view (elevations, orthophotos) draws one level everywhere: the coarsest whose error
// fits the pixel error, unmorphed.
TEST_F(Render, OrthographicViewsDrawOneLevelChosenByPixelSize) {
    auto model = HlodModel::load(test::bunny_hlod());
    auto root = std::make_shared<Group>();
    root->add(model);
    Camera camera;
    camera.projection = ProjectionKind::orthographic;
    camera.width = camera.height = 200;
    camera.look_at(model->bound().center() + glm::dvec3(0, 0, 1), model->bound().center());
    camera.frame(model->bound());
    gl::Framebuffer target({.width = 200, .height = 200, .level = true});
    Renderer renderer;
    model->set_pixel_error(1.0);
    const FrameStats fine = renderer.render(*root, camera, target);
    const int level = model->orthographic_level(camera);
    for (float l : target.read_level()) EXPECT_TRUE(l == -1.0f || l == float(level));
    model->set_pixel_error(50.0);
    const FrameStats coarse = renderer.render(*root, camera, target);
    EXPECT_LT(model->orthographic_level(camera), level);
    EXPECT_LT(coarse.triangles, fine.triangles);
}

}  // namespace
}  // namespace strata

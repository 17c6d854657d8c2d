// Scene scripts (scripting/scene_script.h): a scene of three HLOD models, a mesh, a plane, lights and user
// values, with a camera, bookmarks and a path, saved as Lua, run in a fresh runtime and read back bit for
// bit; saving that again writes the same text; the project folder can move; failures leave no file.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <typeinfo>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/scene/light.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "preprocess/mesh_io.h"
#include "scripting/runtime.h"
#include "scripting/scene_script.h"
#include "scripting/wrap_scene.h"
#include "tests/support/bunny_model.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

namespace fs = std::filesystem;

template <class T>
bool same_bits(const T& a, const T& b) {
    return std::memcmp(&a, &b, sizeof(T)) == 0;
}

std::string read_text(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

// Runs the script in a fresh runtime and returns the globals it set.
SceneState run_scene_script(const fs::path& script) {
    Runtime runtime;
    EXPECT_EQ(runtime.run_file(script, {}), 0);
    return read_scene_globals(runtime.state());
}

std::shared_ptr<Transform> placed(const std::string& name, const glm::dmat4& matrix, NodePtr child) {
    auto transform = std::make_shared<Transform>();
    transform->set_name(name);
    transform->set_matrix(matrix);
    transform->add(std::move(child));
    return transform;
}

// The test scene, its files in `folder` (models/bunny.hlod, meshes/ball.ply).
SceneState sample_scene(const fs::path& folder) {
    fs::create_directories(folder / "models");
    fs::create_directories(folder / "meshes");
    fs::copy_file(test::bunny_hlod(), folder / "models" / "bunny.hlod");
    write_ply(folder / "meshes" / "ball.ply", test::icosphere(1));

    auto root = std::make_shared<Group>();
    root->set_name("scene");
    root->set_user_value("site", std::string("Tomb \"A\"\\\nnorth wing"));
    root->set_user_value("year", 1922.0);
    root->set_user_value("surveyed", true);

    // The same scan three times: different settings, one hidden.
    std::shared_ptr<HlodModel> bunnies[3];
    for (int i = 0; i < 3; ++i) {
        bunnies[i] = HlodModel::load(folder / "models" / "bunny.hlod");
        bunnies[i]->set_name("bunny " + std::to_string(i + 1));
    }
    bunnies[0]->set_pixel_error(1.5);
    bunnies[0]->set_user_value("condition", std::string("good"));
    bunnies[1]->set_kappa0(3.5);
    bunnies[1]->set_morph(false);
    bunnies[1]->set_debug_view(HlodDebugView::levels);
    bunnies[1]->set_show_cube_boxes(true);
    bunnies[2]->set_pixel_error(0.75);
    bunnies[2]->set_debug_view(HlodDebugView::wireframe);
    bunnies[2]->set_visible(false);
    // A translation (written readably), a rotation with a scale, and a matrix built otherwise.
    const glm::dquat tilt = glm::angleAxis(glm::radians(37.0), glm::normalize(glm::dvec3(1, 2, 3)));
    root->add(placed("left", compose_transform({12, 0, -0.1}, glm::dquat(1, 0, 0, 0), 1), bunnies[0]));
    root->add(placed("tilted", compose_transform({-3, 0.25, 7}, tilt, 2.75), bunnies[1]));
    root->add(placed("turned", glm::rotate(glm::translate(glm::dmat4(1), glm::dvec3(0.1, 0.2, 0.3)), 0.3,
                                           glm::dvec3(0, 1, 0)) * glm::scale(glm::dmat4(1), glm::dvec3(1 / 3.0)),
                     bunnies[2]));

    auto ball = Geometry::load(folder / "meshes" / "ball.ply");
    ball->set_user_value("weight", 0.1);
    root->add(ball);
    auto floor = Geometry::plane({0, -0.5, 0}, {0, 2, 0.1}, 40, 25);
    floor->set_name("floor");
    floor->material.base_color = {0.4f, 0.35f, 0.3f, 1};
    root->add(floor);
    auto sun = std::make_shared<DirectionalLight>();
    sun->set_name("sun");
    sun->direction = {-1, -2, -0.5};
    sun->color = {1, 0.95f, 0.9f};
    sun->intensity = 1.2f;
    root->add(sun);
    auto ambient = std::make_shared<AmbientLight>();
    ambient->set_name("sky");
    ambient->color = {0.1f, 0.12f, 0.15f};
    root->add(ambient);

    auto camera = std::make_shared<Camera>();
    camera->look_at({3, 1.6, 4}, {0, 1, 0});
    camera->fov_y_degrees = 35;
    camera->width = 1920;
    camera->height = 1080;
    camera->near_clip = 0.05;
    camera->far_clip = std::numeric_limits<double>::infinity();

    Camera view;
    view.look_at({0, 2, 9}, {0, 0.5, 0});
    std::vector<Bookmark> bookmarks{{"entrance", view.position, view.orientation, 50},
                                    {"detail", {0.3, 0.2, 1.1}, glm::normalize(glm::dquat(0.9, 0.1, -0.3, 0.05)), 28.5}};

    std::vector<Keyframe> keys(3);
    keys[0].position = {0, 1, 5};
    keys[0].target = glm::dvec3(0, 0.5, 0);
    keys[0].duration = 4;
    keys[0].handles.out = glm::dvec3(2, 1.5, 5);
    keys[1].position = {5, 2, 0};
    keys[1].orientation = view.orientation;
    keys[1].fov_degrees = 40;
    keys[2].position = {0, 1, -5};
    keys[2].target = glm::dvec3(0, 0.5, 0);
    PathOptions options;
    options.positions = Interpolation::bezier;
    options.orientations = OrientationInterpolation::slerp;
    options.easing = Easing::ease_in_out;
    options.ease_seconds = 1.5;
    options.total_duration = 12;
    auto tour = std::make_shared<CameraPath>(CameraPath::from_keys(keys, options));

    return {root, camera, bookmarks, {{"tour", tour}}};
}

void expect_same_node(const Node& a, const Node& b) {
    SCOPED_TRACE("node '" + a.name() + "'");
    ASSERT_EQ(typeid(a), typeid(b));
    EXPECT_EQ(a.name(), b.name());
    EXPECT_EQ(a.visible(), b.visible());
    EXPECT_EQ(a.user_values(), b.user_values());
    if (const auto* t = dynamic_cast<const Transform*>(&a)) {
        EXPECT_TRUE(same_bits(t->matrix(), dynamic_cast<const Transform&>(b).matrix()));
    }
    if (const auto* m = dynamic_cast<const HlodModel*>(&a)) {
        const auto& n = dynamic_cast<const HlodModel&>(b);
        EXPECT_TRUE(fs::equivalent(m->path(), n.path()));
        EXPECT_EQ(m->pixel_error(), n.pixel_error());
        EXPECT_EQ(m->kappa0(), n.kappa0());
        EXPECT_EQ(m->morph(), n.morph());
        EXPECT_EQ(m->debug_view(), n.debug_view());
        EXPECT_EQ(m->show_cube_boxes(), n.show_cube_boxes());
    }
    if (const auto* g = dynamic_cast<const Geometry*>(&a)) {
        const auto& h = dynamic_cast<const Geometry&>(b);
        ASSERT_EQ(g->source().index(), h.source().index());
        if (const auto* plane = std::get_if<PlaneSource>(&g->source())) {
            const auto& other = std::get<PlaneSource>(h.source());
            EXPECT_TRUE(same_bits(plane->center, other.center) && same_bits(plane->up, other.up));
            EXPECT_EQ(plane->width, other.width);
            EXPECT_EQ(plane->depth, other.depth);
        } else {
            EXPECT_TRUE(fs::equivalent(std::get<fs::path>(g->source()), std::get<fs::path>(h.source())));
        }
        EXPECT_TRUE(same_bits(g->material.base_color, h.material.base_color));
        EXPECT_EQ(g->mesh().positions, h.mesh().positions);
    }
    if (const auto* light = dynamic_cast<const DirectionalLight*>(&a)) {
        const auto& other = dynamic_cast<const DirectionalLight&>(b);
        EXPECT_TRUE(same_bits(light->direction, other.direction) && same_bits(light->color, other.color));
        EXPECT_EQ(light->intensity, other.intensity);
    }
    if (const auto* ambient = dynamic_cast<const AmbientLight*>(&a)) {
        EXPECT_TRUE(same_bits(ambient->color, dynamic_cast<const AmbientLight&>(b).color));
    }
    if (const auto* group = dynamic_cast<const Group*>(&a)) {
        const auto& other = dynamic_cast<const Group&>(b);
        ASSERT_EQ(group->child_count(), other.child_count());
        for (size_t i = 0; i < group->child_count(); ++i) expect_same_node(*group->child(i), *other.child(i));
    }
}

void expect_same_state(const SceneState& a, const SceneState& b) {
    expect_same_node(*a.scene, *b.scene);
    ASSERT_TRUE(b.camera);
    const Camera &c = *a.camera, &d = *b.camera;
    EXPECT_TRUE(same_bits(c.position, d.position) && same_bits(c.orientation, d.orientation));
    EXPECT_EQ(c.projection, d.projection);
    EXPECT_EQ(c.fov_y_degrees, d.fov_y_degrees);
    EXPECT_EQ(c.ortho_height, d.ortho_height);
    EXPECT_EQ(c.near_clip, d.near_clip);
    EXPECT_EQ(c.far_clip, d.far_clip);
    EXPECT_EQ(c.width, d.width);
    EXPECT_EQ(c.height, d.height);
    ASSERT_EQ(a.bookmarks.size(), b.bookmarks.size());
    for (size_t i = 0; i < a.bookmarks.size(); ++i) {
        EXPECT_EQ(a.bookmarks[i].name, b.bookmarks[i].name);
        EXPECT_TRUE(same_bits(a.bookmarks[i].position, b.bookmarks[i].position));
        EXPECT_TRUE(same_bits(a.bookmarks[i].orientation, b.bookmarks[i].orientation));
        EXPECT_EQ(a.bookmarks[i].fov_degrees, b.bookmarks[i].fov_degrees);
    }
    ASSERT_EQ(a.paths.size(), b.paths.size());
    for (size_t i = 0; i < a.paths.size(); ++i) {
        EXPECT_EQ(a.paths[i].first, b.paths[i].first);
        EXPECT_EQ(a.paths[i].second->to_json(), b.paths[i].second->to_json());  // every key and option, exactly
    }
}

class SceneScript : public ::testing::Test {
protected:
    void SetUp() override {
        if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
        state_ = sample_scene(project_.path());
    }
    fs::path script() const { return project_ / "scene.lua"; }

    test::TempDir project_;
    SceneState state_;
};

TEST_F(SceneScript, ReloadsToTheSameStateAndSavesTheSameText) {
    save_scene_script(state_, script());
    const std::string text = read_text(script());
    EXPECT_NE(text.find("strata.transform{ name = \"left\", translate = {12, 0, -0.1} }"), std::string::npos) << text;
    EXPECT_NE(text.find("matrix = {"), std::string::npos);
    EXPECT_NE(text.find("far = math.huge"), std::string::npos);
    EXPECT_NE(text.find("here .. \"models/bunny.hlod\""), std::string::npos);

    const SceneState reloaded = run_scene_script(script());
    ASSERT_TRUE(reloaded.scene);
    expect_same_state(state_, reloaded);
    EXPECT_EQ(scene_to_lua(reloaded, script()), text);  // a fixed point
}

TEST_F(SceneScript, LoadsFromAMovedFolder) {
    save_scene_script(state_, script());
    test::TempDir elsewhere;
    const fs::path moved = elsewhere / "moved project";
    fs::copy(project_.path(), moved, fs::copy_options::recursive);
    fs::remove_all(project_.path() / "models");
    fs::remove_all(project_.path() / "meshes");

    const SceneState reloaded = run_scene_script(moved / "scene.lua");
    ASSERT_TRUE(reloaded.scene);
    const auto& left = dynamic_cast<const Group&>(*dynamic_cast<const Group&>(*reloaded.scene).child(0));
    const auto& bunny = dynamic_cast<const HlodModel&>(*left.child(0));
    EXPECT_TRUE(fs::equivalent(bunny.path(), moved / "models" / "bunny.hlod"));
}

TEST_F(SceneScript, UnwritableDestinationIsNamedAndLeavesNoFile) {
    const fs::path missing = project_ / "no such folder" / "scene.lua";
    try {
        save_scene_script(state_, missing);
        FAIL() << "saved into a missing folder";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(missing.parent_path()));
}

TEST_F(SceneScript, NodeThatCannotBeWrittenIsNamedAndNothingIsWritten) {
    class Marker : public Node {};
    save_scene_script(state_, script());
    const std::string before = read_text(script());
    auto marker = std::make_shared<Marker>();
    marker->set_name("pin");
    std::dynamic_pointer_cast<Group>(state_.scene)->add(marker);
    try {
        save_scene_script(state_, script());
        FAIL() << "wrote a node type the script cannot rebuild";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("'pin'"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("Marker"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(script().string()), std::string::npos) << e.what();
    }
    EXPECT_EQ(read_text(script()), before);
    for (const auto& entry : fs::directory_iterator(project_.path()))
        EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();

    const SceneState built = {Geometry::from_mesh(test::icosphere(1)), nullptr, {}, {}};
    EXPECT_THROW(scene_to_lua(built, script()), std::runtime_error);
}

TEST_F(SceneScript, SharedNodeStaysShared) {
    auto group = std::dynamic_pointer_cast<Group>(state_.scene);
    const NodePtr bunny = std::dynamic_pointer_cast<Group>(group->child(0))->child(0);
    group->add(placed("again", glm::translate(glm::dmat4(1), glm::dvec3(0, 0, 20)), bunny));
    save_scene_script(state_, script());

    const SceneState reloaded = run_scene_script(script());
    ASSERT_TRUE(reloaded.scene);
    expect_same_node(*state_.scene, *reloaded.scene);
    const auto& root = dynamic_cast<const Group&>(*reloaded.scene);
    const auto& first = dynamic_cast<const Group&>(*root.child(0));
    const auto& last = dynamic_cast<const Group&>(*root.children().back());
    EXPECT_EQ(first.child(0), last.child(0));
}

TEST(SceneScriptGlobals, MissingSceneIsAnError) {
    Runtime runtime;
    ASSERT_EQ(runtime.run_string("camera = strata.camera()", "test"), 0);
    EXPECT_THROW(read_scene_globals(runtime.state()), std::runtime_error);
    ASSERT_EQ(runtime.run_string("scene = strata.scene(); paths = { tour = 42 }", "test"), 0);
    try {
        read_scene_globals(runtime.state());
        FAIL() << "a path that is a number";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("tour"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace strata

// strata view: files (HLOD models and meshes) in a GLFW window with orbit and fly navigation, keys for
// the debug views and the morph, and the frame's figures in the title.
#include "engine/gl/gl.h"  // epoxy before GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include <glm/gtc/quaternion.hpp>

#include "editor/commands.h"
#include "editor/scene_files.h"
#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/io/image.h"
#include "engine/render/present.h"
#include "engine/render/renderer.h"
#include "engine/scene/camera.h"
#include "nodes/hlod_model.h"

namespace strata::cli {

namespace {

struct ViewOptions {
    std::vector<std::string> files;
    std::string size = "1280x720";
    SceneOptions scene;
    int frames = 0;          // > 0: quit after that many frames (scripts and tests)
    std::string screenshot;  // with --frames: the last frame as PNG
};

const char* const kHelpText =
    "mouse: left drag orbits (looks around in fly mode), right drag or wheel zooms, middle drag pans\n"
    "keys:  F fly/orbit, W A S D Q E move in fly mode (Shift: faster), R reset the view\n"
    "       1 shaded, 2 colour by level, 3 wireframe, B cube boxes, M morph on/off, [ ] pixel error, Esc quit\n";

// The viewer's camera control: orbit about a target, or fly.
class Navigator {
public:
    Navigator(Camera& camera, const Box& bounds) : camera_(camera), bounds_(bounds) { reset(); }

    void reset() {
        target_ = bounds_.center();
        camera_.look_at(target_ + glm::dvec3(0.4, 0.3, 1.0), target_);
        camera_.frame(bounds_);
        distance_ = glm::length(camera_.position - target_);
    }
    void toggle_fly() { fly_ = !fly_; }
    bool flying() const { return fly_; }

    void rotate(double dx, double dy) {
        const double speed = 0.005;
        const glm::dquat yaw = glm::angleAxis(-dx * speed, glm::dvec3(0, 1, 0));
        const glm::dquat pitch = glm::angleAxis(-dy * speed, camera_.orientation * glm::dvec3(1, 0, 0));
        camera_.orientation = glm::normalize(yaw * pitch * camera_.orientation);
        if (!fly_) camera_.position = target_ - camera_.forward() * distance_;
    }
    void zoom(double steps) {
        distance_ *= std::pow(0.9, steps);
        distance_ = std::max(distance_, 1e-6 * bounds_.radius());
        if (fly_) camera_.position += camera_.forward() * steps * 0.05 * bounds_.radius();
        else camera_.position = target_ - camera_.forward() * distance_;
    }
    void pan(double dx, double dy) {
        const double scale = (fly_ ? bounds_.radius() : distance_) * 0.002;
        const glm::dvec3 move = camera_.orientation * glm::dvec3(-dx * scale, dy * scale, 0);
        camera_.position += move;
        target_ += move;
    }
    // Fly mode: moves along the view axes by `direction` (camera frame) for `seconds`.
    void fly(const glm::dvec3& direction, double seconds) {
        const glm::dvec3 step = camera_.orientation * direction * (0.3 * bounds_.radius() * seconds);
        camera_.position += step;
        target_ += step;
    }

private:
    Camera& camera_;
    Box bounds_;
    glm::dvec3 target_;
    double distance_ = 1;
    bool fly_ = false;
};

struct ViewState {
    Navigator* navigator = nullptr;
    std::vector<HlodModel*> models;
    double last_x = 0, last_y = 0;
};

void for_models(ViewState& state, auto&& action) {
    for (HlodModel* model : state.models) action(*model);
}

void on_key(GLFWwindow* window, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    auto& state = *static_cast<ViewState*>(glfwGetWindowUserPointer(window));
    switch (key) {
    case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(window, GLFW_TRUE); break;
    case GLFW_KEY_F: state.navigator->toggle_fly(); break;
    case GLFW_KEY_R: state.navigator->reset(); break;
    case GLFW_KEY_1: for_models(state, [](HlodModel& m) { m.set_debug_view(HlodDebugView::none); }); break;
    case GLFW_KEY_2: for_models(state, [](HlodModel& m) { m.set_debug_view(HlodDebugView::levels); }); break;
    case GLFW_KEY_3: for_models(state, [](HlodModel& m) { m.set_debug_view(HlodDebugView::wireframe); }); break;
    case GLFW_KEY_B: for_models(state, [](HlodModel& m) { m.set_show_cube_boxes(!m.show_cube_boxes()); }); break;
    case GLFW_KEY_M: for_models(state, [](HlodModel& m) { m.set_morph(!m.morph()); }); break;
    case GLFW_KEY_LEFT_BRACKET: for_models(state, [](HlodModel& m) { m.set_pixel_error(m.pixel_error() / 1.5); }); break;
    case GLFW_KEY_RIGHT_BRACKET: for_models(state, [](HlodModel& m) { m.set_pixel_error(m.pixel_error() * 1.5); }); break;
    default: break;
    }
}

void on_cursor(GLFWwindow* window, double x, double y) {
    auto& state = *static_cast<ViewState*>(glfwGetWindowUserPointer(window));
    const double dx = x - state.last_x, dy = y - state.last_y;
    state.last_x = x, state.last_y = y;
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) state.navigator->rotate(dx, dy);
    else if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) state.navigator->zoom(-dy * 0.05);
    else if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS) state.navigator->pan(dx, dy);
}

void on_scroll(GLFWwindow* window, double, double dy) {
    static_cast<ViewState*>(glfwGetWindowUserPointer(window))->navigator->zoom(dy);
}

glm::dvec3 fly_direction(GLFWwindow* window) {
    auto down = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS ? 1.0 : 0.0; };
    glm::dvec3 d{down(GLFW_KEY_D) - down(GLFW_KEY_A), down(GLFW_KEY_E) - down(GLFW_KEY_Q), down(GLFW_KEY_S) - down(GLFW_KEY_W)};
    return d * (down(GLFW_KEY_LEFT_SHIFT) ? 4.0 : 1.0);
}

int run_view(const ViewOptions& o) {
    int width = 0, height = 0;
    try {
        std::tie(width, height) = parse_size(o.size);
    } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "strata view: %s\n", e.what());
        return kUsage;
    }
    auto context = gl::create_window_context("strata view", width, height);
    auto scene = load_scene_files(o.files, o.scene);
    Camera camera;
    Navigator navigator(camera, scene->bound());
    ViewState state{&navigator, {}, 0, 0};
    for (const NodePtr& child : scene->children())
        if (auto* model = dynamic_cast<HlodModel*>(child.get())) state.models.push_back(model);
    GLFWwindow* window = context->window();
    glfwSetWindowUserPointer(window, &state);
    glfwSetKeyCallback(window, on_key);
    glfwSetCursorPosCallback(window, on_cursor);
    glfwSetScrollCallback(window, on_scroll);
    std::fputs(kHelpText, stdout);

    Renderer renderer;
    std::unique_ptr<gl::Framebuffer> target;
    auto last = std::chrono::steady_clock::now();
    double fps = 0;
    for (int frame = 1; !context->should_close(); ++frame) {
        context->poll_events();
        const auto now = std::chrono::steady_clock::now();
        const double seconds = std::chrono::duration<double>(now - last).count();
        last = now;
        fps = fps == 0 ? 1 / std::max(seconds, 1e-6) : 0.9 * fps + 0.1 / std::max(seconds, 1e-6);
        if (navigator.flying()) navigator.fly(fly_direction(window), seconds);
        const glm::ivec2 size = context->framebuffer_size();
        if (size.x == 0 || size.y == 0) {  // minimized: sleep until something happens
            glfwWaitEvents();
            continue;
        }
        if (!target || target->width() != size.x || target->height() != size.y)
            target = std::make_unique<gl::Framebuffer>(gl::FramebufferFormat{.width = size.x, .height = size.y, .samples = 4});
        camera.width = size.x;
        camera.height = size.y;
        const FrameStats stats = renderer.render(*scene, camera, *target, {.background = {0.06f, 0.06f, 0.07f, 1.0f}});
        char title[256];
        std::snprintf(title, sizeof title, "strata view — %.0f fps, %.2f M triangles, %llu cubes%s", fps,
                      stats.triangles / 1e6, (unsigned long long)stats.cubes,
                      !state.models.empty() && !state.models[0]->morph() ? ", morph off" : "");
        glfwSetWindowTitle(window, title);
        if (o.frames > 0 && frame >= o.frames) {
            if (!o.screenshot.empty()) write_png(renderer.read_image(*target), o.screenshot);
            break;
        }
        present(*target, *context);
    }
    return kOk;
}

}  // namespace

Command add_view(CLI::App& app) {
    auto o = std::make_shared<ViewOptions>();
    CLI::App* sub = app.add_subcommand("view", "Explore HLOD models (.hlod) and meshes in a window.");
    sub->footer(kHelpText);
    sub->add_option("files", o->files, "The .hlod models and meshes (PLY, OBJ, OFF, STL) to show")->required();
    sub->add_option("--size", o->size, "Window size, WIDTHxHEIGHT")->capture_default_str();
    sub->add_option("--pixel-error", o->scene.pixel_error, "Screen-space error the HLOD models may show, in pixels")
        ->check(CLI::PositiveNumber)->capture_default_str();
    sub->add_option("--frames", o->frames, "Quit after this many frames (for scripts and tests)")->check(CLI::PositiveNumber);
    sub->add_option("--screenshot", o->screenshot, "With --frames: write the last frame to this PNG")->needs("--frames");
    return {sub, [o] { return run_view(*o); }};
}

}  // namespace strata::cli

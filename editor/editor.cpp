#include "editor/editor.h"

#include "engine/gl/gl.h"  // epoxy before GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>
#include <stdexcept>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include "editor/widgets.h"
#include "engine/gl/context.h"
#include "engine/render/present.h"
#include "engine/render/renderer.h"
#include "engine/scene/light.h"
#include "engine/scene/visitor.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "nodes/terrain.h"
#include "preprocess/byte_size.h"
#include "scripting/node_types.h"

namespace strata {

namespace {

Editor* the_editor = nullptr;  // ImGui's context is global: one editor at a time

double milliseconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// ---- input: the navigator gets the mouse and keys ImGui does not want ----------------------------

struct Mouse {
    double x = 0, y = 0;
} mouse;

void on_cursor(GLFWwindow* window, double x, double y) {
    const double dx = x - mouse.x, dy = y - mouse.y;
    mouse = {x, y};
    if (!the_editor || ImGui::GetIO().WantCaptureMouse) return;
    Navigator& navigator = the_editor->navigator();
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) navigator.rotate(dx, dy);
    else if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) navigator.zoom(-dy * 0.05);
    else if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS) navigator.pan(dx, dy);
}

// A left click in the view: pressed and released without a drag, the press not on a panel; where it
// was pressed, in framebuffer pixels. Read from ImGui's input state after NewFrame, not from GLFW's
// callbacks: ImGui knows the press landed on a panel even when the pointer moved there and clicked
// within one frame (common at a few frames a second), when WantCaptureMouse still tells of the last.
std::optional<ImVec2> view_click() {
    const ImGuiIO& io = ImGui::GetIO();
    const int left = ImGuiMouseButton_Left;
    if (!io.MouseReleased[left] || io.MouseDownOwned[left] || io.MouseDragMaxDistanceSqr[left] > 3 * 3) return {};
    // ImGui's positions are in screen coordinates; the framebuffer may have more pixels (HiDPI).
    const ImVec2 at = io.MouseClickedPos[left];
    return ImVec2(at.x * io.DisplayFramebufferScale.x, at.y * io.DisplayFramebufferScale.y);
}

// ImGui 1.86 reads keys as states once a frame: a key pressed and released within one frame (a quick
// tap at a few frames a second) would never be seen down, and Enter would not run the console's line.
// So a release that follows its press within a frame is held back until the next frame. Installed
// after ImGui's backend, in front of it; ImGui's callback calls the viewer's (on_key) in turn.
struct KeyTaps {
    GLFWkeyfun imgui = nullptr;
    std::vector<int> pressed;  // since the last frame
    struct Release {
        int key, scancode, mods;
    };
    std::vector<Release> held;
} key_taps;

void on_key_event(GLFWwindow* window, int key, int scancode, int action, int mods) {
    if (action == GLFW_PRESS) key_taps.pressed.push_back(key);
    if (action == GLFW_RELEASE && std::ranges::find(key_taps.pressed, key) != key_taps.pressed.end()) {
        key_taps.held.push_back({key, scancode, mods});
        return;
    }
    if (key_taps.imgui) key_taps.imgui(window, key, scancode, action, mods);
}

// Before a frame's events: the releases held back in the last frame.
void release_held_keys(GLFWwindow* window) {
    std::vector<KeyTaps::Release> held;
    held.swap(key_taps.held);
    key_taps.pressed.clear();
    if (key_taps.imgui)
        for (const KeyTaps::Release& r : held) key_taps.imgui(window, r.key, r.scancode, GLFW_RELEASE, r.mods);
}

void on_scroll(GLFWwindow*, double, double dy) {
    if (the_editor && !ImGui::GetIO().WantCaptureMouse) the_editor->navigator().zoom(dy);
}

// Every HLOD model at or below `node` (a NodeVisitor: it walks a scene of any depth on its own stack).
void for_each_model(Node& node, const std::function<void(HlodModel&)>& action) {
    struct Models : NodeVisitor {
        const std::function<void(HlodModel&)>& action;
        explicit Models(const std::function<void(HlodModel&)>& a) : action(a) {}
        void apply(Drawable& drawable) override {
            if (auto* model = dynamic_cast<HlodModel*>(&drawable)) action(*model);
        }
    } models(action);
    node.accept(models);
}

// The outliner shows this many levels of the tree: a deeper scene (a script can build any depth) would
// recurse as deep through ImGui, whose tree depth has limits of its own.
constexpr int kOutlinerDepth = 64;

// The viewer's keys: navigation, and debug views for every model (the inspector sets them one by one).
void on_key(GLFWwindow*, int key, int, int action, int) {
    if (!the_editor || action != GLFW_PRESS || ImGui::GetIO().WantCaptureKeyboard) return;
    Node& scene = the_editor->scene();
    auto view = [&](HlodDebugView v) { for_each_model(scene, [&](HlodModel& m) { m.set_debug_view(v); }); };
    switch (key) {
    case GLFW_KEY_F: the_editor->navigator().toggle_fly(); break;
    case GLFW_KEY_R: the_editor->navigator().reset(); break;
    case GLFW_KEY_1: view(HlodDebugView::none); break;
    case GLFW_KEY_2: view(HlodDebugView::levels); break;
    case GLFW_KEY_3: view(HlodDebugView::wireframe); break;
    case GLFW_KEY_4: view(HlodDebugView::residency); break;
    case GLFW_KEY_B: for_each_model(scene, [](HlodModel& m) { m.set_show_cube_boxes(!m.show_cube_boxes()); }); break;
    case GLFW_KEY_M: for_each_model(scene, [](HlodModel& m) { m.set_morph(!m.morph()); }); break;
    case GLFW_KEY_TAB: the_editor->show_panels(!the_editor->panels_shown()); break;
    default: break;
    }
}

glm::dvec3 fly_direction(GLFWwindow* window) {
    auto down = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS ? 1.0 : 0.0; };
    glm::dvec3 d{down(GLFW_KEY_D) - down(GLFW_KEY_A), down(GLFW_KEY_E) - down(GLFW_KEY_Q), down(GLFW_KEY_S) - down(GLFW_KEY_W)};
    return d * (down(GLFW_KEY_LEFT_SHIFT) ? 4.0 : 1.0);
}

bool same_pose(const Camera& camera, const Pose& pose) {
    return camera.position == pose.position && camera.orientation == pose.orientation;
}

// ---- lifetime ------------------------------------------------------------------------------------

// Raises a count for a scope, whatever way it ends.
struct Raised {
    int& count;
    explicit Raised(int& c) : count(++c) {}
    ~Raised() { --count; }
};

SceneState with_camera(SceneState state) {
    if (!state.camera) state.camera = std::make_shared<Camera>();
    return state;
}

}  // namespace

Editor::Editor(Runtime& runtime, SceneState state)
    : runtime_(runtime),
      state_(with_camera(std::move(state))),
      scene_(checked_scene(state_.scene)),
      window_(runtime.window_context()),
      navigator_(*state_.camera, scene_->bound()),
      path_(*state_.camera),
      console_(runtime) {
    if (the_editor) throw std::runtime_error("an editor is already open");
    GLFWwindow* window = window_.window();
    glfwShowWindow(window);
    glfwSetWindowShouldClose(window, GLFW_FALSE);
    glfwSetWindowTitle(window, "strata");
    // Ours first: ImGui's backend calls the callbacks installed before it, after its own.
    glfwSetCursorPosCallback(window, on_cursor);
    glfwSetScrollCallback(window, on_scroll);
    glfwSetKeyCallback(window, on_key);
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // the layout is the editor's, not a file left in the working folder
    ImGui::StyleColorsDark();
    ImGui_ImplGlfw_InitForOpenGL(window, true);
    key_taps = {};
    key_taps.imgui = glfwSetKeyCallback(window, on_key_event);
    ImGui_ImplOpenGL3_Init("#version 450");
    the_editor = this;
    if (same_pose(camera(), Pose{})) navigator_.reset();  // a camera never placed: frame the scene
    else navigator_.follow_camera();
    if (!state_.paths.empty()) {
        path_name_ = state_.paths.front().first;
        path_.set_path(*state_.paths.front().second);
    }
    last_frame_ = std::chrono::steady_clock::now();
}

Editor::~Editor() {
    window_.make_current();
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    GLFWwindow* window = window_.window();
    glfwSetCursorPosCallback(window, nullptr);
    glfwSetScrollCallback(window, nullptr);
    glfwSetKeyCallback(window, nullptr);
    key_taps = {};
    glfwHideWindow(window);
    the_editor = nullptr;
}

std::shared_ptr<Group> Editor::checked_scene(const NodePtr& scene) {
    auto group = std::dynamic_pointer_cast<Group>(scene);
    if (!group) throw std::invalid_argument("the scene must be a group (strata.scene())");
    return group;
}

void Editor::enter_console_line(const std::string& line) {
    const Raised running(console_lines_);
    console_.enter(line);
}

void Editor::close() {
    if (!open_) return;
    open_ = false;
    glfwHideWindow(window_.window());
}

// ---- one frame -----------------------------------------------------------------------------------

void Editor::handle_navigation(double seconds) {
    if (navigator_.flying() && !ImGui::GetIO().WantCaptureKeyboard) navigator_.fly(fly_direction(window_.window()), seconds);
    path_.advance();
}

bool Editor::frame() {
    if (!open_) return false;
    if (drawing_ > 0) throw std::logic_error("the editor is drawing a frame: frame() and screenshot() cannot run from its console");
    const Raised drawing(drawing_);
    window_.make_current();
    navigator_.set_bounds(scene_->bound());
    navigator_.follow_if_moved();  // by a script or the REPL since the last frame
    release_held_keys(window_.window());
    window_.poll_events();
    if (window_.should_close()) {
        close();
        return false;
    }
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_frame_).count();
    last_frame_ = now;
    fps_ = fps_ == 0 ? 1 / std::max(seconds, 1e-6) : 0.9 * fps_ + 0.1 / std::max(seconds, 1e-6);
    handle_navigation(seconds);

    const glm::ivec2 size = window_.framebuffer_size();
    if (size.x == 0 || size.y == 0) return true;  // minimized
    if (!target_ || target_->width() != size.x || target_->height() != size.y)
        target_ = std::make_unique<gl::Framebuffer>(gl::FramebufferFormat{.width = size.x, .height = size.y, .samples = 4});
    camera().width = size.x;
    camera().height = size.y;
    const auto scene_start = std::chrono::steady_clock::now();
    stats_ = runtime_.renderer().render(*scene_, camera(), *target_, {.background = {0.06f, 0.06f, 0.07f, 1.0f}});
    blit_to_window(*target_, window_);
    if (measure_) glFinish();
    timings_.scene_ms = milliseconds_since(scene_start);

    // Measuring: the scene's GL work finishes first, and the panels' before the clock stops, so the
    // figure is the panels' whole cost and nothing of the scene's (a driver may otherwise make the
    // panels' buffer uploads wait for the scene).
    if (measure_) glFinish();
    const auto ui_start = std::chrono::steady_clock::now();
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    double picking_ms = 0;  // timed apart (pick_ms), so out of the panels' figures
    if (const std::optional<ImVec2> at = view_click()) {
        click(at->x, at->y);
        picking_ms = timings_.pick_ms;
    } else if (geo_.active()) {
        const ImGuiIO& io = ImGui::GetIO();
        if (!io.WantCaptureMouse && !ImGui::IsAnyMouseDown() && (io.MouseDelta.x != 0 || io.MouseDelta.y != 0) && ImGui::IsMousePosValid() &&
            hover(io.MousePos.x * io.DisplayFramebufferScale.x, io.MousePos.y * io.DisplayFramebufferScale.y))
            picking_ms = timings_.pick_ms;
    }
    frame_geo_ = geo_view();  // read once, shown by the Camera panel and the stats line
    draw_panels();
    if (const std::optional<NodePtr> made = embeddings_.poll()) selected_ = *made;  // an Embed or Move done
    navigator_.follow_if_moved();  // by the path playing, or the panels (a bookmark, the timeline, the console)
    ImGui::Render();
    timings_.ui_build_ms = milliseconds_since(ui_start) - picking_ms;
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, size.x, size.y);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (measure_) glFinish();
    timings_.ui_ms = milliseconds_since(ui_start) - picking_ms;
    last_width_ = size.x;
    last_height_ = size.y;
    if (capture_) capture_back_buffer(size.x, size.y);  // before the swap leaves it undefined
    window_.swap_buffers();
    ++frames_;
    return true;
}

std::vector<uint8_t> Editor::screenshot(int& width, int& height) {
    capture_ = true;
    frame();
    capture_ = false;
    width = last_width_;
    height = last_height_;
    return std::move(captured_);
}

void Editor::capture_back_buffer(int width, int height) {
    captured_.resize(size_t(width) * size_t(height) * 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    glReadBuffer(GL_BACK);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, captured_.data());
    // OpenGL's rows run bottom to top.
    const auto row = std::ptrdiff_t(width) * 4;
    for (int y = 0; y < height / 2; ++y)
        std::swap_ranges(captured_.begin() + y * row, captured_.begin() + (y + 1) * row, captured_.begin() + (height - 1 - y) * row);
}

// ---- scene edits ---------------------------------------------------------------------------------

void Editor::remove(const NodePtr& node) {
    if (selected() == node) selected_.reset();
    const std::vector<Group*> parents = node->parents();  // a copy: remove() changes the list
    for (Group* parent : parents) parent->remove(node.get());
}

NodePtr Editor::add_file(const std::filesystem::path& file) {
    NodePtr node;
    if (file.extension() == ".hlod") node = HlodModel::open(file);
    else node = Geometry::load(file);
    node->set_name(file.stem().string());
    scene_->add(node);
    selected_ = node;
    return node;
}

void Editor::add_bookmark(const std::string& name) {
    auto same = [&](const Bookmark& b) { return b.name == name; };
    std::erase_if(state_.bookmarks, same);
    state_.bookmarks.push_back({name, camera().position, camera().orientation, camera().fov_y_degrees});
}

bool Editor::go_to_bookmark(const std::string& name) {
    for (const Bookmark& bookmark : state_.bookmarks) {
        if (bookmark.name != name) continue;
        camera().position = bookmark.position;
        camera().orientation = bookmark.orientation;
        camera().fov_y_degrees = bookmark.fov_degrees;
        return true;
    }
    return false;
}

NodePtr Editor::embed_site(const std::filesystem::path& site, SitePlacement placement) {
    const std::optional<TerrainPart> part = terrain_part(selected());
    if (!part) throw std::runtime_error("select a terrain (or click its ground) to embed a site in it");
    if (!placement.at && !placement.matrix) placement.at = default_site_place(*scene_, *part->terrain, cursor_point_);
    embeddings_.start_embed(*part->terrain, site, placement, true);
    return await_embedding();
}

NodePtr Editor::await_embedding() {
    // Frames go on while it is made (its progress in the Inspector), but not from the console, which
    // runs inside one, nor while the window is minimized: there it is waited for.
    try {
        while (!embeddings_.job_finished()) {
            const glm::ivec2 size = window_.framebuffer_size();
            if (drawing_ == 0 && open_ && size.x > 0 && size.y > 0)
                frame();
            else
                embeddings_.wait_job();
        }
    } catch (...) {
        embeddings_.cancel_job();  // a frame that failed leaves no job behind it
        throw;
    }
    NodePtr node = embeddings_.finish_job();
    selected_ = node;
    return node;
}

namespace {

// The embedding `node` is or lies in, with its terrain. Throws when there is none.
TerrainPart embedding_part(const NodePtr& node) {
    const std::optional<TerrainPart> part = terrain_part(node);
    if (!part || !part->child || part->child == part->terrain->ground()) throw std::runtime_error("select an embedding (or a node in one) to move it");
    return *part;
}

}  // namespace

SitePlacement Editor::embedding_placement() const {
    const TerrainPart part = embedding_part(selected());
    return part.terrain->placement(part.child.get());
}

NodePtr Editor::move_embedding(const SitePlacement& placement) {
    const TerrainPart part = embedding_part(selected());
    embeddings_.start_move(part.child, *part.terrain, placement, true);
    return await_embedding();
}

std::optional<PickHit> Editor::click(double x, double y) {
    const auto start = std::chrono::steady_clock::now();
    std::optional<PickHit> hit = pick(*scene_, camera(), x, y);
    timings_.pick_ms = milliseconds_since(start);
    if (hit) selected_ = find_node(NodePtr(scene_), hit->node);
    else selected_.reset();
    cursor_point_ = hit ? std::optional(hit->point) : std::nullopt;
    return hit;
}

// The surface under the pointer, for the geographic read-out: picked when the pointer has moved over
// the view, at most ten times a second (a pick of a large terrain takes milliseconds).
bool Editor::hover(double x, double y) {
    const auto now = std::chrono::steady_clock::now();
    if (now - last_hover_ < std::chrono::milliseconds(100)) return false;
    last_hover_ = now;
    const std::optional<PickHit> hit = pick(*scene_, camera(), x, y);
    timings_.pick_ms = milliseconds_since(now);
    cursor_point_ = hit ? std::optional(hit->point) : std::nullopt;
    return true;
}

std::optional<Editor::GeoView> Editor::geo_view() {
    geo_.update(*scene_, selected().get());
    if (!geo_.active()) return std::nullopt;
    return GeoView{geo_.model_name(), geo_.crs_label(), geo_.read(camera().position),
                   cursor_point_ ? geo_.read(*cursor_point_) : std::nullopt};
}

void Editor::sync_path() {
    auto entry = std::find_if(state_.paths.begin(), state_.paths.end(), [&](const auto& named) { return named.first == path_name_; });
    if (path_.keys().empty()) {
        if (entry != state_.paths.end()) state_.paths.erase(entry);
    } else if (!path_.path()) {
        // Keys that make no path cannot be written as one; dropping them would lose the user's work.
        throw std::runtime_error("the path '" + path_name_ + "' cannot be saved: " + path_.error());
    } else if (entry != state_.paths.end()) {
        entry->second = std::make_shared<CameraPath>(*path_.path());
    } else {
        state_.paths.insert(state_.paths.begin(), {path_name_, std::make_shared<CameraPath>(*path_.path())});
    }
}

const SceneState& Editor::state() {
    sync_path();
    return state_;
}

void Editor::save(const std::filesystem::path& file) {
    try {
        save_scene_script(state(), file);
    } catch (const std::runtime_error& e) {
        const std::string message = e.what();
        if (message.find(file.string()) != std::string::npos) throw;
        throw std::runtime_error("cannot save " + file.string() + ": " + message);
    }
}

// ---- panels --------------------------------------------------------------------------------------

void Editor::draw_panels() {
    const ImVec2 display = ImGui::GetIO().DisplaySize;
    const float side = 300.0f, console_height = 180.0f;
    auto place = [](ImVec2 position, ImVec2 size) {
        ImGui::SetNextWindowPos(position, ImGuiCond_FirstUseEver);
        ImGui::SetNextWindowSize(size, ImGuiCond_FirstUseEver);
    };
    const float column = display.y - console_height;
    if (!panels_shown_) return draw_overlays();
    place({0, 0}, {side, column * 0.5f});
    if (ImGui::Begin("Outliner")) draw_outliner();
    ImGui::End();
    place({0, column * 0.5f}, {side, column * 0.5f});
    if (ImGui::Begin("Inspector")) draw_inspector();
    ImGui::End();
    place({display.x - side, 0}, {side, column * 0.4f});
    if (ImGui::Begin("Camera")) draw_camera_panel();
    ImGui::End();
    place({display.x - side, column * 0.4f}, {side, column * 0.6f});
    if (ImGui::Begin("Path")) path_.draw_panel();
    ImGui::End();
    place({0, column}, {display.x, console_height});
    if (ImGui::Begin("Console")) console_.draw_panel();
    ImGui::End();
    draw_overlays();
}

void Editor::draw_overlays() {
    const ImVec2 display = ImGui::GetIO().DisplaySize;
    draw_stats_overlay();
    path_.draw_overlay(*ImGui::GetBackgroundDrawList(), display.x, display.y);
}

void Editor::draw_outliner_node(const NodePtr& node, int depth) {
    if (depth >= kOutlinerDepth) {
        ImGui::TextDisabled("(%d levels shown; deeper nodes are not)", kOutlinerDepth);
        return;
    }
    const auto* group = dynamic_cast<const Group*>(node.get());
    ImGuiTreeNodeFlags flags = ImGuiTreeNodeFlags_OpenOnArrow | ImGuiTreeNodeFlags_DefaultOpen | ImGuiTreeNodeFlags_SpanAvailWidth;
    if (!group || group->child_count() == 0) flags |= ImGuiTreeNodeFlags_Leaf;
    if (selected() == node) flags |= ImGuiTreeNodeFlags_Selected;
    ImGui::PushID(node.get());
    bool visible = node->visible();
    if (ImGui::Checkbox("##visible", &visible)) node->set_visible(visible);
    ImGui::SameLine();
    const bool open = ImGui::TreeNodeEx("node", flags, "%s  [%s]", node->name().empty() ? "(unnamed)" : node->name().c_str(),
                                        node_type_of(*node).name);
    if (ImGui::IsItemClicked() && !ImGui::IsItemToggledOpen()) selected_ = node;
    bool deleted = false;
    if (ImGui::BeginPopupContextItem()) {
        std::string name = node->name();
        if (ImGui::InputText("name", &name)) node->set_name(name);
        if (node != scene_ && ImGui::MenuItem("Delete")) deleted = true;
        ImGui::EndPopup();
    }
    if (open) {
        if (group) {
            const std::vector<NodePtr> children = group->children();  // a copy: a child may be deleted
            for (const NodePtr& child : children) draw_outliner_node(child, depth + 1);
        }
        ImGui::TreePop();
    }
    ImGui::PopID();
    if (deleted) remove(node);
}

void Editor::draw_outliner() {
    draw_outliner_node(scene_, 0);
    ImGui::Separator();
    if (file_field("add", ".hlod or mesh file", new_file_, "Add")) add_message_ = outcome([&] { add_file(new_file_); }, "");
    if (!add_message_.empty()) ImGui::TextColored(ImVec4(1.0f, 0.45f, 0.4f, 1.0f), "%s", add_message_.c_str());
    if (file_field("save", "scene script (.lua)", file_, "Save")) save_message_ = outcome([&] { save(file_); }, "saved " + file_);
    if (!save_message_.empty()) ImGui::TextWrapped("%s", save_message_.c_str());
}

void Editor::draw_inspector() {
    const NodePtr node = selected();
    if (!node) {
        ImGui::TextDisabled("Select a node in the outliner or click one in the view.");
        embeddings_.draw(*scene_, node, cursor_point_);  // an embedding being made shows its progress
        return;
    }
    std::string name = node->name();
    if (ImGui::InputText("name", &name)) node->set_name(name);
    const NodeType& type = node_type_of(*node);
    ImGui::Text("type: %s", type.name);
    ImGuiInspector fields;
    for (const NodeType* t : type_chain(type))
        if (t->inspect) t->inspect(*node, fields);
    if (const std::optional<NodePtr> next = embeddings_.draw(*scene_, node, cursor_point_)) selected_ = *next;
    ImGui::Separator();
    ImGui::TextDisabled("drawn this frame (whole scene)");
    ImGui::Text("%.3f M triangles, %llu cubes", stats_.triangles / 1e6, (unsigned long long)stats_.cubes);
    ImGui::Text("%.1f MB resident", stats_.bytes_resident / 1e6);
    if (timings_.pick_ms > 0) ImGui::Text("last pick %.2f ms", timings_.pick_ms);
}

void Editor::draw_camera_panel() {
    int mode = navigator_.flying() ? 1 : 0;
    if (ImGui::RadioButton("orbit", &mode, 0) && navigator_.flying()) navigator_.toggle_fly();
    ImGui::SameLine();
    if (ImGui::RadioButton("fly (WASD QE)", &mode, 1) && !navigator_.flying()) navigator_.toggle_fly();
    float fov = float(camera().fov_y_degrees);
    if (ImGui::SliderFloat("fov", &fov, 10.0f, 120.0f, "%.0f°")) camera().fov_y_degrees = fov;
    if (ImGui::Button("Reset view (R)")) navigator_.reset();
    ImGui::Separator();
    ImGui::TextDisabled("bookmarks");
    ImGui::SetNextItemWidth(-50);
    ImGui::InputTextWithHint("##bookmark", "name", &bookmark_name_);
    ImGui::SameLine();
    if (ImGui::Button("Add") && !bookmark_name_.empty()) add_bookmark(bookmark_name_);
    std::optional<std::string> removed;
    for (const Bookmark& bookmark : state_.bookmarks) {
        ImGui::PushID(bookmark.name.c_str());
        if (ImGui::Selectable(bookmark.name.c_str(), false, ImGuiSelectableFlags_AllowItemOverlap, ImVec2(ImGui::GetContentRegionAvail().x - 30, 0)))
            go_to_bookmark(bookmark.name);
        ImGui::SameLine();
        if (ImGui::SmallButton("x")) removed = bookmark.name;
        ImGui::PopID();
    }
    if (removed) std::erase_if(state_.bookmarks, [&](const Bookmark& b) { return b.name == *removed; });
    if (frame_geo_) {
        ImGui::Separator();
        ImGui::TextDisabled("on the Earth (%s, %s)", frame_geo_->model.c_str(), frame_geo_->crs.c_str());
        draw_geo_lines(false);
    }
}

// This frame's camera and cursor places, one line each (compact: both on one line, for the overlay).
void Editor::draw_geo_lines(bool compact) {
    if (!frame_geo_) return;
    const std::string camera_text = frame_geo_->camera ? GeoReadout::describe(*frame_geo_->camera) : "outside the CRS";
    const std::string cursor_text = frame_geo_->cursor ? GeoReadout::describe(*frame_geo_->cursor) : "-";
    if (compact) ImGui::Text("camera %s  |  cursor %s", camera_text.c_str(), cursor_text.c_str());
    else ImGui::TextWrapped("camera: %s\ncursor: %s", camera_text.c_str(), cursor_text.c_str());
}

void Editor::draw_stats_overlay() {
    const ImVec2 display = ImGui::GetIO().DisplaySize;
    ImGui::SetNextWindowPos(ImVec2(display.x * 0.5f, 8), ImGuiCond_Always, ImVec2(0.5f, 0));
    ImGui::SetNextWindowBgAlpha(0.5f);
    const ImGuiWindowFlags flags = ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoSavedSettings |
                                   ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoInputs;
    if (ImGui::Begin("stats", nullptr, flags)) {
        ImGui::Text("%.0f fps  %.1f ms  |  %.2f M triangles  %llu cubes  |  streamed %s + tables %s, %llu loading, %llu stand-ins, %s  |  ui %.2f ms",
                    fps_, 1000.0 / std::max(fps_, 1e-6), stats_.triangles / 1e6, (unsigned long long)stats_.cubes,
                    describe_bytes(stats_.memory_resident).c_str(), describe_bytes(stats_.memory_tables).c_str(),
                    (unsigned long long)stats_.loads_pending,
                    (unsigned long long)stats_.stand_ins,
                    stats_.frames_unconverged == 0 ? "converged" : ("converging for " + std::to_string(stats_.frames_unconverged) + " frames").c_str(),
                    timings_.ui_ms);
        draw_geo_lines(true);
    }
    ImGui::End();
}

}  // namespace strata

// The editor: a scene in a window with Dear ImGui panels — outliner, inspector, camera and bookmarks,
// path editor with a timeline, Lua console, stats overlay — over the live Lua runtime, so the console,
// a driving script or the REPL act on the very scene shown. One editor per process (ImGui's context
// is global); it draws a frame each time frame() is called, from its own loop or the REPL's.
#pragma once

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "editor/console.h"
#include "editor/embedding_panel.h"
#include "editor/geo_readout.h"
#include "editor/navigator.h"
#include "editor/path_editor.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/draw_context.h"
#include "engine/scene/camera.h"
#include "engine/scene/node.h"
#include "engine/scene/pick.h"
#include "scripting/runtime.h"
#include "scripting/scene_script.h"

namespace strata {

// The editor's own cost per frame, apart from drawing the scene: building and drawing the panels, and
// picking (when a click picked this frame). Exact only while measuring (Editor::set_measure): the GPU
// work is then waited for at each step.
struct EditorTimings {
    double ui_ms = 0;        // the panels: laid out on the CPU, then drawn
    double ui_build_ms = 0;  // of which laying them out (ImGui's CPU work)
    double pick_ms = 0;
    double scene_ms = 0;  // culling and drawing the scene, for comparison
};

class Editor {
public:
    // Opens the window (the runtime's window context) on `state` (a scene script's: the scene, which
    // must be a group, its camera — a new one when null —, bookmarks, and paths, the first of which the
    // path editor takes) and sets up ImGui. Throws gl::GlError when there is no display,
    // std::invalid_argument when the scene is not a group.
    Editor(Runtime& runtime, SceneState state);
    ~Editor();
    Editor(const Editor&) = delete;
    Editor& operator=(const Editor&) = delete;

    // Draws one frame (events, navigation, path playback, scene, panels). False once the window was
    // closed; the window is then hidden and frame() does nothing more. Throws std::logic_error when
    // called inside a frame (from the console: ImGui's frames do not nest).
    bool frame();
    bool open() const { return open_; }
    void close();
    // Drawing a frame or running a console line: Lua run from there may not replace the editor.
    bool busy() const { return drawing_ > 0 || console_lines_ > 0; }
    // A line run in the console as if typed (scripts, tests).
    void enter_console_line(const std::string& line);
    // The scene an editor can open: a group (strata.scene()). Throws std::invalid_argument otherwise.
    static std::shared_ptr<Group> checked_scene(const NodePtr& scene);

    // The state as edited, with the path editor's path in `paths` (none when it has no keys). Throws
    // std::runtime_error when its keys make no valid path (one key, two keys at one place…).
    const SceneState& state();
    Group& scene() { return *scene_; }
    const std::shared_ptr<Group>& scene_pointer() const { return scene_; }
    Camera& camera() { return *state_.camera; }
    const std::shared_ptr<Camera>& camera_pointer() const { return state_.camera; }
    Navigator& navigator() { return navigator_; }
    PathEditor& path() { return path_; }
    Console& console() { return console_; }
    const FrameStats& stats() const { return stats_; }
    const EditorTimings& timings() const { return timings_; }
    uint64_t frames() const { return frames_; }  // drawn since the editor opened
    // Waits for the GPU between the scene and the panels each frame, so timings() split them exactly
    // (benchmarks; it costs the overlap of CPU and GPU work).
    void set_measure(bool on) { measure_ = on; }
    // Hidden panels (Tab) leave the view clear for a presentation or a screenshot; the stats overlay and
    // the path stay.
    void show_panels(bool on) { panels_shown_ = on; }
    bool panels_shown() const { return panels_shown_; }

    NodePtr selected() const { return selected_.lock(); }
    void select(const NodePtr& node) { selected_ = node; }
    // Removes a node from every parent; clears the selection if it was the node.
    void remove(const NodePtr& node);
    // Loads an .hlod model or a mesh and adds it to the scene (selected). Throws naming the file.
    NodePtr add_file(const std::filesystem::path& file);
    // Embeds `site` in the terrain the selection belongs to (editor/embedding_panel.h), at `placement`,
    // whose `at`, when unset, is the cursor's point on the ground (else the ground's middle); selects and
    // returns the new node. Throws std::runtime_error when the selection is in no terrain, or naming the
    // files when the site cannot be embedded there.
    NodePtr embed_site(const std::filesystem::path& site, SitePlacement placement);
    // Moves the selected embedding (or the one the selected node lies in) to `placement`; selects and
    // returns its new node. Throws as Terrain::move_embedding does, or when none is selected.
    NodePtr move_embedding(const SitePlacement& placement);
    // Where the embedding move_embedding would move stands now (Terrain::placement).
    SitePlacement embedding_placement() const;

    // Selects the node drawn at pixel (x, y) of the window's framebuffer (none on the background) and
    // returns the hit; what a click in the view does. The hit is the cursor's point of the geographic
    // read-out until the pointer moves on.
    std::optional<PickHit> click(double x, double y);
    // The geographic read-out (a scene with a georeferenced model): the camera's place and the cursor's
    // (the surface under the pointer, or last clicked), as the Camera panel and the overlay show them.
    struct GeoView {
        std::string model, crs;
        std::optional<GeoReading> camera, cursor;
    };
    std::optional<GeoView> geo_view();

    // Saves the scene, camera, bookmarks and paths as a scene script (temp file + rename). Throws
    // std::runtime_error naming the file or the node that cannot be written.
    void save(const std::filesystem::path& file);
    void set_file(const std::filesystem::path& file) { file_ = file.string(); }

    const std::vector<Bookmark>& bookmarks() const { return state_.bookmarks; }
    void add_bookmark(const std::string& name);
    // False when there is no bookmark of that name.
    bool go_to_bookmark(const std::string& name);

    // Draws a frame and returns the window's pixels (scene and panels), rows top to bottom, 8-bit
    // sRGB RGBA.
    std::vector<uint8_t> screenshot(int& width, int& height);

private:
    // embed_site and move_embedding make their file on a worker thread (editor/embedding_job.h) and wait
    // for it here, drawing frames meanwhile unless called from inside one (the console); the new node.
    NodePtr await_embedding();
    void draw_panels();
    void draw_outliner();
    void draw_outliner_node(const NodePtr& node, int depth);
    void draw_inspector();
    void draw_camera_panel();
    void draw_overlays();  // over the view, panels shown or not: the stats and the path
    void draw_stats_overlay();
    void draw_geo_lines(bool compact);
    // Picks the surface under the pointer for the read-out, unless it did less than 100 ms ago; whether it picked.
    bool hover(double x, double y);
    void handle_navigation(double seconds);
    void capture_back_buffer(int width, int height);

    void sync_path();

    Runtime& runtime_;
    SceneState state_;
    std::shared_ptr<Group> scene_;
    std::string path_name_ = "path";  // the name the edited path has in state_.paths
    gl::Context& window_;
    Navigator navigator_;
    PathEditor path_;
    Console console_;
    std::unique_ptr<gl::Framebuffer> target_;
    std::weak_ptr<Node> selected_;
    GeoReadout geo_;
    EmbeddingPanel embeddings_;
    std::optional<glm::dvec3> cursor_point_;  // world frame: under the pointer, or clicked
    std::optional<GeoView> frame_geo_;        // the read-out this frame shows
    std::chrono::steady_clock::time_point last_hover_{};
    FrameStats stats_;
    EditorTimings timings_;
    bool capture_ = false;
    int drawing_ = 0, console_lines_ = 0;  // frames and console lines in progress (busy())
    bool measure_ = false;
    bool panels_shown_ = true;
    std::vector<uint8_t> captured_;
    int last_width_ = 0, last_height_ = 0;
    std::chrono::steady_clock::time_point last_frame_;
    double fps_ = 0;
    uint64_t frames_ = 0;
    bool open_ = true;
    std::string new_file_;      // the outliner's "add a file" field
    std::string add_message_;  // why the last Add failed
    std::string bookmark_name_;
    std::string file_ = "scene.lua";  // where "Save scene" writes
    std::string save_message_;
};

}  // namespace strata

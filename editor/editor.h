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
#include "editor/navigator.h"
#include "editor/path_editor.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/draw_context.h"
#include "engine/scene/camera.h"
#include "engine/scene/node.h"
#include "scripting/runtime.h"

namespace strata {

// A named camera pose the user can jump back to.
struct Bookmark {
    std::string name;
    Pose pose;
};

// What the editor edits: the scene, the camera looking at it, bookmarks and the path.
struct EditorDocument {
    std::shared_ptr<Group> scene;
    std::shared_ptr<Camera> camera;
    std::vector<Bookmark> bookmarks;
};

// The editor's own cost per frame, apart from drawing the scene: building and drawing the panels, and
// picking (when a click picked this frame). Exact only while measuring (Editor::set_measure): the GPU
// work is then waited for at each step.
struct EditorTimings {
    double ui_ms = 0;
    double pick_ms = 0;
    double scene_ms = 0;  // culling and drawing the scene, for comparison
};

class Editor {
public:
    // Opens the window (the runtime's window context) and sets up ImGui. Throws gl::GlError when there
    // is no display.
    Editor(Runtime& runtime, EditorDocument document);
    ~Editor();
    Editor(const Editor&) = delete;
    Editor& operator=(const Editor&) = delete;

    // Draws one frame (events, navigation, path playback, scene, panels). False once the window was
    // closed; the window is then hidden and frame() does nothing more.
    bool frame();
    bool open() const { return open_; }
    void close();

    EditorDocument& document() { return document_; }
    Camera& camera() { return *document_.camera; }
    Navigator& navigator() { return navigator_; }
    PathEditor& path() { return path_; }
    Console& console() { return console_; }
    const FrameStats& stats() const { return stats_; }
    const EditorTimings& timings() const { return timings_; }
    // Waits for the GPU between the scene and the panels each frame, so timings() split them exactly
    // (benchmarks; it costs the overlap of CPU and GPU work).
    void set_measure(bool on) { measure_ = on; }

    NodePtr selected() const { return selected_.lock(); }
    void select(const NodePtr& node) { selected_ = node; }
    // Removes a node from every parent; clears the selection if it was the node.
    void remove(const NodePtr& node);
    // Loads an .hlod model or a mesh and adds it to the scene (selected). Throws naming the file.
    NodePtr add_file(const std::filesystem::path& file);

    void add_bookmark(const std::string& name);
    // False when there is no bookmark of that name.
    bool go_to_bookmark(const std::string& name);

    // Draws a frame and returns the window's pixels (scene and panels), rows top to bottom, 8-bit
    // sRGB RGBA.
    std::vector<uint8_t> screenshot(int& width, int& height);

private:
    void draw_panels();
    void draw_outliner();
    void draw_outliner_node(const NodePtr& node);
    void draw_inspector();
    void draw_camera_panel();
    void draw_stats_overlay();
    void handle_navigation(double seconds);
    void capture_back_buffer(int width, int height);

    Runtime& runtime_;
    EditorDocument document_;
    gl::Context& window_;
    Navigator navigator_;
    PathEditor path_;
    Console console_;
    std::unique_ptr<gl::Framebuffer> target_;
    std::weak_ptr<Node> selected_;
    FrameStats stats_;
    EditorTimings timings_;
    bool capture_ = false;
    bool measure_ = false;
    std::vector<uint8_t> captured_;
    int last_width_ = 0, last_height_ = 0;
    std::chrono::steady_clock::time_point last_frame_;
    double fps_ = 0;
    bool open_ = true;
    std::string new_file_;      // the outliner's "add a file" field
    std::string add_error_;
    std::string bookmark_name_;
};

}  // namespace strata

// strata view: the editor on a scene script (SCENE.lua, which sets the global `scene`) or on files
// (HLOD models and meshes); optionally driven by a script (tests, demos) and closed after N frames.
#include "engine/gl/gl.h"  // epoxy before GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstdio>
#include <memory>

#include <lua.hpp>

#include "editor/commands.h"
#include "editor/scene_files.h"
#include "editor/wrap_editor.h"
#include "engine/gl/context.h"
#include "engine/io/image.h"

namespace strata::cli {

namespace {

struct ViewOptions {
    std::vector<std::string> files;
    std::string size = "1280x720";
    SceneOptions scene;
    MemoryOptions memory;
    std::string script;      // run once the editor is open, with the global `editor`
    int frames = 0;          // > 0: quit after that many frames (scripts and tests)
    std::string screenshot;  // with --frames: the window's last frame (panels and all) as PNG
};

const char* const kHelpText =
    "mouse: left drag orbits (looks around in fly mode), a left click selects, right drag or wheel zooms,\n"
    "       middle drag pans\n"
    "keys:  F fly/orbit, W A S D Q E move in fly mode (Shift: faster), R reset the view\n"
    "       1 shaded, 2 colour by level, 3 wireframe, 4 residency, B cube boxes, M morph on/off (every model)\n"
    "panels: outliner, inspector, camera and bookmarks, path (keys, timeline), Lua console; Tab hides them\n";

bool is_scene_script(const std::vector<std::string>& files) {
    return files.size() == 1 && std::filesystem::path(files[0]).extension() == ".lua";
}

SceneState load_state(Runtime& runtime, const ViewOptions& o) {
    if (!is_scene_script(o.files)) return {load_scene_files(o.files, o.scene), nullptr, {}, {}};
    if (runtime.run_file(o.files[0], {}) != 0) throw std::runtime_error("");  // the error is printed
    try {
        return read_scene_globals(runtime.state());
    } catch (const std::exception& e) {
        throw std::runtime_error(o.files[0] + ": " + e.what());
    }
}

int run_view(const ViewOptions& o) {
    if (!apply_memory_options(o.memory, "view")) return kUsage;
    int width = 0, height = 0;
    try {
        std::tie(width, height) = parse_size(o.size);
    } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "strata view: %s\n", e.what());
        return kUsage;
    }
    Runtime runtime;
    register_editor(runtime.state());
    std::shared_ptr<Editor> editor;
    try {
        SceneState state = load_state(runtime, o);
        runtime.window_context();  // no display: fail before anything else
        glfwSetWindowSize(runtime.window_context().window(), width, height);
        editor = open_editor(runtime, std::move(state));
        if (is_scene_script(o.files)) editor->set_file(o.files[0]);  // "Save" writes back to it
    } catch (const std::exception& e) {
        if (*e.what()) std::fprintf(stderr, "strata view: %s\n", e.what());
        return kFailed;
    }
    std::fputs(kHelpText, stdout);
    push_editor(runtime.state());
    lua_setglobal(runtime.state(), "editor");
    if (!o.script.empty() && runtime.run_file(o.script, {}) != 0) return kFailed;
    for (int frame = 1; runtime.has_live_windows(); ++frame) {
        runtime.pump_live_windows();
        if (o.frames > 0 && frame >= o.frames) break;
    }
    if (!o.screenshot.empty()) {
        // Asked for and not written is a failure, not a quiet success.
        if (!editor->open()) {
            std::fprintf(stderr, "strata view: %s: not written, the window was closed before the last frame\n", o.screenshot.c_str());
            return kFailed;
        }
        try {
            int w = 0, h = 0;
            const std::vector<uint8_t> pixels = editor->screenshot(w, h);
            write_png_rgba8(pixels, w, h, o.screenshot);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "strata view: %s\n", e.what());
            return kFailed;
        }
    }
    return kOk;
}

}  // namespace

Command add_view(CLI::App& app) {
    auto o = std::make_shared<ViewOptions>();
    CLI::App* sub = app.add_subcommand("view", "The editor: explore and arrange scans, author paths, a Lua console.");
    sub->footer(kHelpText);
    sub->add_option("files", o->files, "A scene script (.lua, sets the global `scene`), or .hlod models and meshes (PLY, OBJ, OFF, STL)")
        ->required();
    sub->add_option("--size", o->size, "Window size, WIDTHxHEIGHT")->capture_default_str();
    sub->add_option("--pixel-error", o->scene.pixel_error, "Pixels an HLOD cube's error bound may span at its nearest point (the finest level is exempt)")
        ->check(positive_number())->capture_default_str();
    sub->add_option("--script", o->script, "A Lua script run once the window is open, with the global `editor`");
    sub->add_option("--frames", o->frames, "Quit after this many frames (for scripts and tests)")->check(positive_number());
    sub->add_option("--screenshot", o->screenshot, "With --frames: write the window's last frame to this PNG")->needs("--frames");
    add_memory_options(*sub, o->memory);
    return {sub, [o] { return run_view(*o); }};
}

}  // namespace strata::cli

// Runs Lua scripts with the `strata` module: a Lua 5.4 state, the module registered for `require`
// (and as the global `strata`), the script's arguments in `arg`, its folder on package.path, errors
// reported with a traceback. Renders go to a headless context, or to a window when asked.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string_view>
#include <string>
#include <utility>
#include <vector>

#include "engine/render/renderer.h"

struct lua_State;

namespace strata {

namespace gl {
class Context;
}
class ImageWriter;

struct RuntimeOptions {
    bool window = false;  // show each rendered frame in a window while the script runs
};

class Runtime {
public:
    explicit Runtime(RuntimeOptions options = {});
    ~Runtime();
    Runtime(const Runtime&) = delete;
    Runtime& operator=(const Runtime&) = delete;

    // Runs `script` with `args` (arg[0] is the script's path, arg[1…] the arguments). On an error
    // prints the message with file:line and a traceback to stderr and returns 1; else 0.
    int run_file(const std::filesystem::path& script, const std::vector<std::string>& args);
    // Runs a chunk of Lua source (tests); the same error handling. `name` names it.
    int run_string(const std::string& source, const std::string& name);

    // Calls the function below its `arguments` on the stack with a traceback handler; true with
    // `results` values left (LUA_MULTRET: all), or false after printing the error.
    bool protected_call(int arguments, int results);

    // Where `print` and error messages go: stdout and stderr, unless a sink is set (the editor's
    // console sets one while it runs a line). `error` is true for error messages. Returns the sink it
    // replaces, to be put back.
    using OutputSink = std::function<void(std::string_view text, bool error)>;
    OutputSink set_output_sink(OutputSink sink) { return std::exchange(sink_, std::move(sink)); }
    void write_output(std::string_view text, bool error) const;

    // Windows that stay open beside the script or the REPL (the editor): each frame() draws one frame
    // and answers false once its window is closed, when it is dropped. pump() draws one frame of each.
    void add_live_window(std::function<bool()> frame) { live_windows_.push_back(std::move(frame)); }
    bool has_live_windows() const { return !live_windows_.empty(); }
    void pump_live_windows();

    lua_State* state() const { return L_; }
    const RuntimeOptions& options() const { return options_; }
    // The GL context and renderer, made on first use (a script that renders nothing needs no GL).
    gl::Context& context();
    // A context with a window (the editor's): the current one when it has a window, else a new window
    // context that replaces the headless one (its GPU caches are rebuilt on the next render).
    gl::Context& window_context();
    Renderer& renderer();
    // Frames written with { async = true } go through this writer thread, made on first use.
    ImageWriter& writer();

    // The runtime that owns `L`.
    static Runtime& of(lua_State* L);

    // The poses a camera path's next frames will have, set as a script steps through path:frames and
    // cleared when the loop ends: strata.render tells streamed models to prefetch for them.
    std::vector<RenderSettings::Pose>& upcoming_poses() { return upcoming_poses_; }

private:
    int call(int arguments);

    RuntimeOptions options_;
    lua_State* L_;
    std::unique_ptr<gl::Context> context_;
    std::unique_ptr<Renderer> renderer_;
    std::unique_ptr<ImageWriter> writer_;
    OutputSink sink_;
    std::vector<std::function<bool()>> live_windows_;
    std::vector<RenderSettings::Pose> upcoming_poses_;
};

// Registers the `strata` module's functions (wrap_*.cpp, one per area) into the table on top of the stack.
void register_scene(lua_State* L);
void register_camera(lua_State* L);
void register_render(lua_State* L);
void register_build(lua_State* L);
void register_video(lua_State* L);
void register_measure(lua_State* L);
void register_memory(lua_State* L);
void register_files(lua_State* L);
void register_path(lua_State* L);
void register_pick(lua_State* L);
void register_scene_script(lua_State* L);

}  // namespace strata

// strata run: a Lua script with the `strata` module, headless unless --window.
#include <memory>

#include "editor/commands.h"
#include "editor/wrap_editor.h"
#include "scripting/runtime.h"

namespace strata::cli {

namespace {

struct RunOptions {
    std::string script;
    MemoryOptions memory;
    bool window = false;
};

}  // namespace

Command add_run(CLI::App& app) {
    auto o = std::make_shared<RunOptions>();
    CLI::App* sub = app.add_subcommand("run", "Run a Lua script (the strata module: scenes, cameras, rendering).");
    sub->add_option("script", o->script, "The .lua file")->required();
    sub->add_flag("--window", o->window, "Show each rendered frame in a window while the script runs");
    add_memory_options(*sub, o->memory);
    sub->footer("Everything after SCRIPT goes to the script, options included: in its `arg` table and `...`.");
    sub->prefix_command();
    return {sub, [o, sub] {
                if (!apply_memory_options(o->memory, "run")) return kUsage;
                Runtime runtime({.window = o->window});
                register_editor(runtime.state());
                const int status = runtime.run_file(o->script, sub->remaining());
                // An editor the script opened (strata.view) stays until its window is closed.
                while (status == kOk && runtime.has_live_windows()) runtime.pump_live_windows();
                return status;
            }};
}

}  // namespace strata::cli

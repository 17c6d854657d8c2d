// strata shell: the terminal Lua REPL, optionally after running a scene script in the same state.
#include <cstdlib>
#include <memory>

#include "editor/commands.h"
#include "editor/wrap_editor.h"
#include "scripting/repl.h"

#include <lua.hpp>

namespace strata::cli {

namespace {

// $STRATA_HISTORY, else ~/.strata_history, else none.
std::filesystem::path history_file() {
    if (const char* file = std::getenv("STRATA_HISTORY")) return file;
    if (const char* home = std::getenv("HOME")) return std::filesystem::path(home) / ".strata_history";
    return {};
}

}  // namespace

Command add_shell(CLI::App& app) {
    auto scene = std::make_shared<std::string>();
    CLI::App* sub = app.add_subcommand("shell", "A Lua REPL with the strata module: line editing, history, tab completion.");
    sub->add_option("scene", *scene, "A .lua script to run first, in the same state (its globals stay)");
    sub->footer("Expressions print their values; statements run; an unfinished line continues on the next.\n"
                "History is kept in $STRATA_HISTORY or ~/.strata_history. Ctrl-D leaves.");
    return {sub, [scene] {
                Runtime runtime;
                register_editor(runtime.state());
                // At the prompt, view() opens the editor on the globals `scene` and `camera`.
                lua_getglobal(runtime.state(), "strata");
                lua_getfield(runtime.state(), -1, "view");
                lua_setglobal(runtime.state(), "view");
                lua_pop(runtime.state(), 1);
                if (!scene->empty() && runtime.run_file(*scene, {}) != 0) return kFailed;
                return run_repl(runtime, {history_file()});
            }};
}

}  // namespace strata::cli

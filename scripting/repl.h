// The terminal REPL behind `strata shell`: Lua against a live runtime, with line editing, persistent
// history and tab completion (Debian's libedit) on a terminal, plain lines otherwise; multi-line input;
// expressions printed readably (tables, nodes).
#pragma once

#include <filesystem>

#include "scripting/runtime.h"

namespace strata {

struct ReplOptions {
    std::filesystem::path history;  // empty: no persistent history
};

// Reads, evaluates and prints until end of input; returns 0 (errors are printed, not fatal).
int run_repl(Runtime& runtime, const ReplOptions& options);

}  // namespace strata

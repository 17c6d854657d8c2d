// The `strata` subcommands. Each registers its options on the CLI11 app and runs when chosen;
// run functions return the process exit status.
#pragma once

#include <CLI/CLI.hpp>

namespace strata::cli {

// Exit statuses, Unix style.
inline constexpr int kOk = 0;
inline constexpr int kFailed = 1;       // bad input, I/O failure, invariant violated
inline constexpr int kUsage = 2;        // wrong arguments
inline constexpr int kInterrupted = 130;

// A check for options that take a number above zero, worded for people (CLI11's PositiveNumber prints
// its range as 0 to 1.797...e308 written out in full).
inline CLI::Validator positive_number() {
    return CLI::Validator(
        [](std::string& input) -> std::string {
            double value = 0;
            if (!CLI::detail::lexical_cast(input, value) || !(value > 0)) return "must be a number above 0, not '" + input + "'";
            return {};
        },
        "POSITIVE");
}

// --memory SIZE and --gpu-memory SIZE for the commands that draw: the streaming budget (engine/stream)
// that every streamed model shares, and a cap on its GPU share alone, in the build's grammar.
// apply_memory_options sets them, or prints the error and says no.
struct MemoryOptions {
    std::string total, gpu;
};
void add_memory_options(CLI::App& command, MemoryOptions& options);
bool apply_memory_options(const MemoryOptions& options, const char* command);

struct Command {
    CLI::App* app;
    std::function<int()> run;
};

Command add_build(CLI::App& app);
Command add_embed(CLI::App& app);
Command add_info(CLI::App& app);
Command add_verify(CLI::App& app);
Command add_render(CLI::App& app);
Command add_view(CLI::App& app);
Command add_run(CLI::App& app);
Command add_shell(CLI::App& app);

}  // namespace strata::cli

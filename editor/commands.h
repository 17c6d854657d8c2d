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

// --memory SIZE for the commands that draw: the streaming budget (engine/stream) that every streamed
// model shares, in the build's grammar. apply_memory_option sets it, or prints the error and says no.
inline const char* const kMemoryOptionHelp =
    "Memory for models' geometry, CPU and GPU together: a hard cap shared by every model (e.g. 512M, 2G; at least 16M; "
    "default a quarter of physical memory)";
bool apply_memory_option(const std::string& memory, const char* command);

struct Command {
    CLI::App* app;
    std::function<int()> run;
};

Command add_build(CLI::App& app);
Command add_info(CLI::App& app);
Command add_verify(CLI::App& app);
Command add_render(CLI::App& app);
Command add_view(CLI::App& app);
Command add_run(CLI::App& app);
Command add_shell(CLI::App& app);

}  // namespace strata::cli

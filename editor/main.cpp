// strata: the command line. `strata --help` lists the commands; `strata COMMAND --help` each one.
#include "editor/commands.h"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <vector>

int main(int argc, char** argv) {
    using namespace strata::cli;
    CLI::App app{"Strata: hierarchical level-of-detail models of huge 3D scans."};
    app.require_subcommand(1);
    app.set_version_flag("--version", "strata 0.1.0");
    std::vector<Command> commands = {add_build(app), add_embed(app), add_info(app), add_verify(app), add_render(app), add_view(app), add_run(app), add_shell(app)};
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        // CLI11 reads an unknown command as a missing one.
        const auto named = [&](const Command& c) { return c.app->get_name() == argv[1]; };
        if (argc > 1 && argv[1][0] != '-' && std::none_of(commands.begin(), commands.end(), named))
            std::fprintf(stderr, "strata: unknown command '%s'\nRun 'strata --help' for usage.\n", argv[1]);
        else
            std::fprintf(stderr, "strata: %s\nRun 'strata --help' for usage.\n", e.what());
        return kUsage;
    }
    for (const Command& c : commands)
        if (c.app->parsed()) {
            try {
                return c.run();
            } catch (const std::exception& e) {
                std::fprintf(stderr, "strata %s: %s\n", c.app->get_name().c_str(), e.what());
                return kFailed;
            }
        }
    return kUsage;
}

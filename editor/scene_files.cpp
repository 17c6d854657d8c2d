#include "editor/scene_files.h"

#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "editor/commands.h"
#include "engine/stream/stream_cache.h"
#include "nodes/geometry.h"
#include "preprocess/byte_size.h"
#include "nodes/hlod_model.h"

namespace strata::cli {

namespace {

HlodDebugView parse_debug_view(const std::string& name) {
    if (const auto view = debug_view_named(name)) return *view;
    throw std::invalid_argument("unknown debug view '" + name + "' (" + kHlodDebugViewNames + ")");
}

}  // namespace

std::shared_ptr<Group> load_scene_files(const std::vector<std::string>& files, const SceneOptions& options) {
    auto scene = std::make_shared<Group>();
    scene->set_name("scene");
    const HlodDebugView debug_view = parse_debug_view(options.debug_view);
    for (const std::string& file : files) {
        if (std::filesystem::path(file).extension() == ".hlod") {
            auto model = HlodModel::open(file);
            model->set_pixel_error(options.pixel_error);
            model->set_morph(options.morph);
            model->set_debug_view(debug_view);
            model->set_show_cube_boxes(options.cube_boxes);
            scene->add(model);
        } else {
            scene->add(Geometry::load(file));
        }
    }
    return scene;
}

std::pair<int, int> parse_size(const std::string& size) {
    int width = 0, height = 0;
    char x = 0, rest = 0;
    if (std::sscanf(size.c_str(), "%d%c%d%c", &width, &x, &height, &rest) != 3 || (x != 'x' && x != 'X') ||
        width <= 0 || height <= 0 || width > 16384 || height > 16384)
        throw std::invalid_argument("--size takes WIDTHxHEIGHT (each 1 to 16384), not '" + size + "'");
    return {width, height};
}

void add_memory_options(CLI::App& command, MemoryOptions& options) {
    command.add_option("--memory", options.total,
                       "Memory for models' geometry, CPU and GPU together: a hard cap shared by every model (e.g. 512M, 2G; "
                       "at least 16M; default a quarter of physical memory)");
    command.add_option("--gpu-memory", options.gpu, "A cap on the GPU's share of --memory on its own (e.g. 1G; at least 16M; default none)");
}

bool apply_memory_options(const MemoryOptions& options, const char* command) {
    // A size of at least 16M in `bytes` (0 when not given), or false after saying what is wrong.
    auto parse = [&](const std::string& text, const char* option, uint64_t& bytes) {
        if (text.empty()) return true;
        try {
            bytes = parse_byte_size(text);
            if (bytes < (uint64_t(16) << 20)) throw std::invalid_argument("'" + text + "' is less than the least, 16M");
            return true;
        } catch (const std::invalid_argument& e) {
            std::fprintf(stderr, "strata %s: %s: %s\n", command, option, e.what());
            return false;
        }
    };
    uint64_t total = 0, gpu = 0;
    if (!parse(options.total, "--memory", total) || !parse(options.gpu, "--gpu-memory", gpu)) return false;
    if (total) StreamCache::shared()->set_budget(total);
    if (gpu) StreamCache::shared()->set_gpu_budget(gpu);
    return true;
}

}  // namespace strata::cli

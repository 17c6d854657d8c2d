// Turns the files named on a command line into a scene: .hlod files load as HLOD models, anything
// else goes through the mesh importer as Geometry. Each keeps its own coordinates.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "engine/scene/node.h"

namespace strata::cli {

struct SceneOptions {
    double pixel_error = 1.0;  // target screen-space error of the HLOD models, in pixels
    bool morph = true;
    std::string debug_view = "none";  // none | levels | wireframe | residency
    bool cube_boxes = false;
};

// Throws std::runtime_error naming the file that could not be loaded.
std::shared_ptr<Group> load_scene_files(const std::vector<std::string>& files, const SceneOptions& options);

// "WIDTHxHEIGHT" (each 1 to 16384); throws std::invalid_argument quoting `size` otherwise.
std::pair<int, int> parse_size(const std::string& size);

}  // namespace strata::cli

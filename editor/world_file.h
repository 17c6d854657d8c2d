// The world file and .prj of an orthographic render straight down on a georeferenced scene (issue 17
// §3), so that GIS tools place the picture: `strata render terrain.hlod --top -o map.png` also writes
// map.pgw and map.prj.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "engine/scene/camera.h"
#include "engine/scene/node.h"

namespace strata::cli {

struct WorldFiles {
    std::vector<std::filesystem::path> written;
    std::string not_written;  // why a view straight down got none (empty when it did, or is no map)
};

// When the camera is orthographic and looks straight down, and the scene's georeferenced models lie in
// one CRS's plane at one origin, writes the image's world file (the extension's first and last letters
// and 'w': map.pgw, map.erw) and IMAGE.prj (the CRS as ESRI WKT) beside it, each whole or not at all.
// Throws std::runtime_error naming a file it cannot write.
WorldFiles write_world_files(const std::filesystem::path& image, const Camera& camera, const Group& scene);

}  // namespace strata::cli

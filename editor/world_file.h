// Where a render straight down on a georeferenced scene lies (issue 17 §3), so that GIS tools place
// the picture: `strata render terrain.hlod --top -o map.png` also writes map.pgw and map.prj, and
// `-o map.tif` writes a GeoTIFF, its georeference in its tags.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "engine/io/image.h"
#include "engine/scene/camera.h"
#include "engine/scene/node.h"

namespace strata::cli {

// A map's placement: its CRS and the world file's six terms (x and y of a step along a row, of a step
// down a column, then the centre of the top-left pixel), in the world file's order A D B E C F.
struct MapPlacement {
    std::string crs;
    std::array<double, 6> world{};
};

// When the camera is orthographic and looks straight down, and the scene's georeferenced models lie in
// one CRS's plane at one origin, where its image lies; else nothing, with `why` saying why when the
// view was straight down (empty otherwise).
std::optional<MapPlacement> map_placement(const Camera& camera, const Group& scene, std::string& why);

// The image as an 8-bit sRGB RGBA GeoTIFF (deflate), with the placement's geotransform and CRS in its
// tags when it has one; written to a temporary file beside `path` and renamed. Throws
// std::runtime_error naming the file when GDAL cannot write it.
void write_geotiff(const Image& image, const std::filesystem::path& path, const std::optional<MapPlacement>& placement);

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

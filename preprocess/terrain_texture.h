// A terrain's imagery draped as per-cube textures (issue 17 §2; section TXTR, preprocess/cube_textures.h):
// an orthophoto (any raster GDAL reads, RGB or grey, in any CRS and resolution) is resampled onto
// each cube's footprint, for every cube of every level, so that a level's texels are twice as dense
// as its parent's: the finest level's as dense as the image's pixels (up to 1024 texels a cube).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "preprocess/cube_textures.h"
#include "preprocess/hlod_format.h"
#include "preprocess/progress.h"

namespace strata {

struct TextureSettings {
    std::filesystem::path image;
    std::vector<int> bands;  // the image's bands that give red, green and blue (1-based); empty: 1, 2, 3 (grey: 1)
    uint32_t size = 0;       // texels along a cube's texture; 0: from the image's resolution
};

struct TextureReport {
    std::string image;
    TextureLayout layout;
    uint64_t textures = 0;
    uint64_t stored_bytes = 0;   // compressed, in the file
    double image_metres = 0;     // the image's pixel size in the model's metres, at its centre
    double seconds = 0;
};

// The DEM's height in metres at a raster position (column, row; sample centres at whole numbers),
// bilinear; nothing off the raster or on nodata.
using GroundHeight = std::function<std::optional<double>(double column, double row)>;

// Checks the image before a build spends time on the ground: a raster GDAL reads, with a georeference
// and a CRS, 8- or 16-bit samples, the bands named; and the texture size asked for. Throws InputError
// naming the file and the problem.
void check_texture_image(const TextureSettings& settings);

// Writes the section TXTR for the cubes `writer` holds, of the terrain `header` describes (its
// georeference places the image), whose vertices lie within `margin`·s_l of their cells in x and y.
// `scratch`: where a large image without overviews gets them for the build (a VRT there and its .ovr,
// removed after). `ground`: the DEM's heights, which place a texel in the ecef frame (where a model
// (x, y) stands for different ground at different heights). Throws InputError naming the image when
// it cannot be read or does not overlap the terrain, Cancelled when progress.cancel is raised.
TextureReport build_terrain_textures(const TextureSettings& settings, const HlodHeader& header, float margin, HlodWriter& writer,
                                     const std::filesystem::path& scratch, const GroundHeight& ground, unsigned threads,
                                     const Progress& progress);

}  // namespace strata

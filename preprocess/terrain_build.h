// `strata build DEM.tif -o terrain.hlod` (issue 17): a terrain straight from an elevation raster, no
// intermediate mesh and no QEM. The levels are the grid pyramid of preprocess/terrain_pyramid.h, cut
// into the octree's cubes as DESIGN.md §2 asks of every model (so `strata verify` and the renderer treat
// it as any other), each cube with its error bound against the full raster (preprocess/terrain_bounds.h).
//
// The model's frame (preprocess/terrain_frame.h): x east, y north, z up, in metres; a projected CRS's
// own plane moved to the south-west sample, or for a raster in degrees a tangent plane at its centre.
// In a projected CRS with square pixels the cubes fall on whole samples: a level-L cube holds
// cube_cells × cube_cells cells, as does a cube of every coarser level, whose samples are twice as far
// apart.
#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "preprocess/hlod_builder.h"
#include "preprocess/progress.h"
#include "preprocess/terrain_frame.h"
#include "preprocess/terrain_texture.h"

namespace strata {

struct TerrainSettings {
    uint32_t cube_cells = 64;     // cells per cube side (even, 8‥256)
    std::optional<float> fill;    // nodata becomes this elevation (metres) instead of a hole
    std::string crs;              // the CRS of rasters that declare none (EPSG:N, WKT, PROJ string)
    // The unit of elevations when the raster does not say (m, ft, us-ft); empty: metres.
    std::string elevation_unit;
    // The model's frame for a raster in degrees (preprocess/terrain_frame.h): enu or ecef.
    TerrainFrameKind frame = TerrainFrameKind::enu;
    // A projected CRS in metres (EPSG:N, WKT, PROJ string) to reproject any raster into instead.
    std::string frame_crs;
    // Bytes the build may hold; 0: a quarter of physical memory. A raster larger than half of it is
    // built in tiles (each read with a margin), then the coarse levels from one of its levels; never
    // changes a byte of the output.
    uint64_t memory = 0;
    // How far a vertex's height may move from the raster's value at full detail (metres): heights are
    // stored on a lattice that fine, and each cube's error bound includes it. Default: 1/128 of the
    // sample spacing. 0: the finest lattice (2^-15 of a cube). The raster's exact values stay in HGHT.
    std::optional<double> height_tolerance;
    int threads = 0;              // threads compressing cubes; 0: every core
    // The tiles instead of what `memory` allows: level T and level-T cubes per tile side (tests and
    // benchmarks show the output does not depend on them).
    std::optional<std::array<uint32_t, 2>> tiles;
    // Imagery draped over the ground as per-cube textures (preprocess/terrain_texture.h).
    std::optional<TextureSettings> texture;
};

// Sets the frame a `--frame` value names: enu, ecef, or any other text as a projected CRS in metres to
// reproject into (TerrainFrame::check_crs: InputError naming it when it is not one).
void set_frame(TerrainSettings& settings, const std::string& frame);

// Builds `output` from the DEM `files` (one raster, or the tiles of one grid). The report's stage
// seconds: read_seconds the first pass over the raster, partition_seconds the tiles (levels L … T),
// simplify_seconds the coarse levels (T … 0), write_seconds the bounds and the file. Throws InputError naming the raster and the problem (not a DEM, no CRS, a geographic CRS, a unit it cannot convert, nodata
// everywhere, ground too steep for its cubes), Cancelled when progress.cancel is raised,
// std::runtime_error when the output cannot be written; in every case no output file is left behind.
BuildReport build_terrain(const std::vector<std::filesystem::path>& files, const std::filesystem::path& output,
                          const TerrainSettings& settings, const std::string& source_name, const Progress& progress = {});

// Whether `file` is read as an elevation raster rather than a mesh (by its extension: not PLY, OBJ, OFF, STL).
bool is_elevation_raster(const std::filesystem::path& file);

}  // namespace strata

// Embedding a mesh in a terrain (HYBRID.md §2): where the mesh lies on the terrain's raster (its
// footprint), the zone of grid cells it replaces, and the skirt that joins the ground to its boundary,
// in the terrain's model frame with the raster's own heights.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "preprocess/footprint.h"
#include "preprocess/hlod_format.h"
#include "preprocess/mesh.h"
#include "preprocess/skirt.h"

namespace strata {

class Georeference;
class TerrainHeights;

// What the embedding needs of a terrain .hlod: its header, where its samples lie, and their heights.
struct TerrainSite {
    std::shared_ptr<const HlodFile> file;
    std::shared_ptr<const Georeference> georeference;
    std::shared_ptr<const TerrainHeights> heights;

    // Throws std::runtime_error naming the file when it is not a terrain (no TERR or HGHT, no CRS).
    static TerrainSite open(const std::filesystem::path& path);
    const HlodHeader& header() const { return file->header(); }
    const TerrainGrid& grid() const { return *file->header().terrain; }
};

struct EmbeddingPlan {
    Footprint footprint;
    // m ≥ 1: the embedding is drawn where the grid over its zone is at level m or finer, not below.
    uint32_t zone_level = 0;
    // The footprint's covers at level m − 1: its PC and CC cells are the zone. Its border lies on
    // grid lines of level m − 1, which the grid's vertices at level m and finer only slide along as they
    // morph (their parents are the samples at the lower index on each axis), so the ring seam follows
    // them without folding.
    CellCovers zone;
    Skirt skirt;              // in raster index space
    // The skirt in the terrain's model frame: vertex v is skirt.vertices[v] (samples at the raster's
    // heights, ring vertices at the mesh's, crossings on the mesh's boundary edges), triangles
    // counter-clockwise seen from above.
    Mesh skirt_mesh;
    double height_difference = 0;  // ΔH: the largest |mesh height − ground height| over the mesh's vertices
    bool zone_capped = false;      // m had to be finer than ΔH asks (HYBRID.md §2): the mesh appears at m
    // A closed mesh (a statue on its plinth: no open boundary) stands on the ground: the grid is kept
    // whole under it and nothing is stitched; zone, skirt and footprint are empty.
    bool standing = false;
};

// Plans the embedding of `mesh` (positions in its own frame) placed by `mesh_to_terrain` into the
// terrain's model frame. A closed mesh stands (above). Throws InputError naming `what` for a mesh that cannot be embedded (its
// footprint: footprint.h; the skirt: skirt.h; a zone over nodata samples or beyond the raster).
EmbeddingPlan plan_embedding(const TerrainSite& terrain, const Mesh& mesh, const glm::dmat4& mesh_to_terrain, const std::string& what);
// The same with ΔH given: `mesh` need only hold the boundary right (a locked model's coarsest level,
// whose open boundary is the finest level's, embedding_file.h), ΔH measured over every vertex of the
// finest level apart (height_difference, a cube at a time).
EmbeddingPlan plan_embedding(const TerrainSite& terrain, const Mesh& mesh, const glm::dmat4& mesh_to_terrain, double height_difference,
                             const std::string& what);

// ΔH of `mesh`'s vertices placed by `mesh_to_terrain`: the largest |height − ground height| over those
// the raster has a height under (0 for none).
double height_difference(const TerrainSite& terrain, const Mesh& mesh, const glm::dmat4& mesh_to_terrain);

// Whether counter-clockwise in raster index space is clockwise seen from above: when the raster's rows
// run south (the usual north-up raster), the sign of its axes in the model turns triangles over.
bool raster_turns_over(const Georeference& geo);

// The coarsest level m whose zone may replace the grid: the embedding is dropped where the grid is drawn
// coarser than m, which stays within the terrain's own screen-space bound when ΔH ≤ 2·ε_q·s_(m−1)
// (HYBRID.md §2); no coarser than the level whose cells are about twice the footprint's extent
// (`extent_cells` finest cells), so that the zone stays a few cells around it; at least 1. `capped`
// says whether that limit decided.
uint32_t zone_level(const HlodHeader& terrain, double height_difference, double extent_cells, bool& capped);

}  // namespace strata

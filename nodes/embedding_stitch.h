// One embedding at run time (preprocess/HYBRID.md §2): a mesh (the site) embedded in a terrain, joined to
// the ground by its skirt. Per view it says whether the embedding is drawn (every terrain cube over its
// zone, or beside it, at level m or finer), which of a terrain cube's triangles the zone hides, and the
// seams: the ring seam between the grid's edge at whatever level each stretch of the zone's border is
// drawn at and the skirt's finest samples, and the zero-area boundary seam between the site's boundary
// and the skirt's. Each seam vertex is the very float its owner's shader computes (the CPU twin of the
// morph), so the seams weld to what the three models draw, bit for bit.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

#include "nodes/hlod_model.h"
#include "preprocess/footprint.h"
#include "preprocess/ring_seam.h"

namespace strata {

// Which model draws a seam vertex: the vertex is drawn through that model's anchor and transform.
enum class StitchOwner : uint8_t { terrain, skirt, site };
struct StitchVertex {
    StitchOwner owner = StitchOwner::terrain;
    glm::vec3 position{0.0f};  // from the owner's lattice anchor, as its shader computes it
};
using StitchTriangle = std::array<StitchVertex, 3>;
// A seam vertex as its owner holds it: vertex `vertex` of its cube `cube`, which the owner's morph places.
struct StitchRef {
    StitchOwner owner = StitchOwner::terrain;
    uint32_t cube = 0, vertex = 0;
    bool operator==(const StitchRef&) const = default;
};
using StitchRefTriangle = std::array<StitchRef, 3>;

// The models an embedding joins and what its preprocessing decided (preprocess/embedding.h).
struct EmbeddedModels {
    std::shared_ptr<const HlodModel> terrain;
    std::shared_ptr<const HlodModel> skirt;  // in the terrain's node frame
    std::shared_ptr<const HlodModel> site;
    glm::dmat4 site_to_terrain{1.0};  // the site's node frame to the terrain's
    uint32_t drawn_from = 0;          // m: the embedding is drawn where the grid over its zone is at level m or finer
    CellCovers zone;                  // the zone's cells (level m − 1's): their PC and CC cells are the zone
};

// What one view draws of a model: its selected cubes, and how they morph.
struct ModelView {
    std::span<const uint32_t> cubes;
    const HlodModel::MorphInputs* inputs = nullptr;
};

class EmbeddingStitch {
public:
    // Reads the skirt's and the site's boundaries from their roots (level 0 holds a locked boundary
    // whole) and matches them to the zone's border and to each other. Throws std::runtime_error naming
    // `what` when they do not match (a skirt built for another zone, a site moved since).
    EmbeddingStitch(EmbeddedModels models, std::string what);

    const EmbeddedModels& models() const { return models_; }
    size_t border_steps() const { return step_count_; }
    size_t boundary_vertices() const { return site_boundary_.size(); }

    // What a terrain cube contributes, computed once per cube (its data must be resident).
    struct TerrainCube {
        bool near_zone = false;  // one of its triangles reaches into the zone or the finest cells beside it
        bool hides = false;      // some of its triangles lie in the zone (kept is not the whole list)
        // Its triangles outside the zone, as runs of its index list: {first index, index count}. The
        // whole list for a cube coarser than m, which the zone never hides.
        std::vector<std::array<uint32_t, 2>> kept;
        std::vector<std::pair<uint32_t, uint32_t>> border_samples;  // {vertex, sample of the zone's border}
        std::vector<uint32_t> steps;  // the border steps whose neighbouring grid triangle it holds
    };
    const TerrainCube& terrain_cube(uint32_t cube) const;

    // Whether the embedding is drawn along with the terrain's `cubes` (a view's selection): none of them
    // near the zone is coarser than m. Where it is not, the grid covers the zone as it is and neither
    // the site, the skirt nor the seams are drawn. Where it is, `hiding` (if given) gets the cubes among
    // them whose triangles in the zone the ground must hide (one pass over the selection for both).
    bool drawn_with(std::span<const uint32_t> terrain_cubes, std::vector<uint32_t>* hiding = nullptr) const;

    // The seams for one view, appended to `out` as the owners' vertices: for each border step whose
    // neighbouring grid triangle is drawn, the ring seam at that triangle's level; for each boundary edge
    // of the site drawn, the boundary seam. Steps or edges whose owners' cubes the view does not draw
    // (culled) are left out. The GPU morphs these vertices as the owners' shaders do (terrain_draw.cpp).
    void seam_vertices(std::span<const uint32_t> terrain_cubes, std::span<const uint32_t> skirt_cubes, std::span<const uint32_t> site_cubes,
                       std::vector<StitchRefTriangle>& out) const;
    // The same seams with their positions, each the float its owner's shader computes: the CPU twin of
    // the GPU pass, for the crack checks and the benchmarks.
    void seams(const ModelView& terrain, const ModelView& skirt, const ModelView& site, std::vector<StitchTriangle>& out) const;

private:
    struct CubePoints {  // a skirt or site cube's vertices that seams use: {vertex, point}
        std::vector<std::pair<uint32_t, uint32_t>> points;
    };
    const CubePoints& skirt_cube(uint32_t cube) const;
    const CubePoints& site_cube(uint32_t cube) const;
    CubePoints find_points(const HlodModel& model, uint32_t cube, const std::unordered_map<uint64_t, uint32_t>& ids) const;
    void match_skirt(const std::string& what);
    void match_site(const std::string& what);
    void claim_steps();

    EmbeddedModels models_;
    int64_t columns_ = 0, rows_ = 0;
    uint32_t finest_ = 0;
    // Counter-clockwise in raster space is clockwise from above when rows run south (north-up rasters):
    // the ring seam's triangles turn over then, to face up as the grid's do.
    bool flip_ = false;
    std::vector<std::vector<BorderStep>> loops_;
    std::vector<size_t> loop_first_;  // a loop's first step's number
    size_t step_count_ = 0;
    std::unordered_map<uint64_t, uint32_t> border_sample_;  // (column, row) → sample number
    // The skirt's points: the border's samples (numbered as above: border sample s is skirt point s),
    // then its inner boundary's points (the site's boundary vertices and the crossings between them), by
    // their level-0 lattice steps.
    std::unordered_map<uint64_t, uint32_t> skirt_point_;
    std::vector<uint64_t> skirt_inner_;                       // the inner points' steps, in their numbers' order
    std::unordered_map<uint64_t, uint64_t> skirt_next_;       // the skirt's boundary: from → to, in its triangles' order
    std::unordered_map<uint64_t, glm::dvec3> skirt_position_; // its boundary points in the terrain's node frame
    // The site's boundary, in its order: per vertex its skirt point, and the crossings between its copy
    // and the next vertex's along the skirt's inner boundary, from its own side.
    struct BoundaryVertex {
        uint32_t skirt_point;
        std::vector<uint32_t> crossings;
    };
    std::vector<BoundaryVertex> site_boundary_;
    std::unordered_map<uint64_t, uint32_t> site_point_;  // the site's boundary vertices by level-0 lattice steps
    // (level, cell column, cell row, which triangle) → the steps that triangle borders.
    std::unordered_map<uint64_t, std::vector<uint32_t>> claims_;

    mutable std::mutex mutex_;
    mutable std::unordered_map<uint32_t, TerrainCube> terrain_cubes_;
    mutable std::unordered_map<uint32_t, CubePoints> skirt_cubes_, site_cubes_;
};

}  // namespace strata

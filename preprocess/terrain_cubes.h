// A terrain's levels cut into the octree's cubes and encoded (DESIGN.md §2): each triangle goes to the
// cube the grid pyramid gave it (preprocess/terrain_pyramid.h), grouped by the child it came from; a
// cube's vertices, with the parents its children need, are in row order (its grid payload's, FORMAT.md
// §5.1); each vertex names its parent's place in the parent cube.
#pragma once

#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "preprocess/build_cubes.h"
#include "preprocess/error_bound.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/terrain_bounds.h"
#include "preprocess/terrain_pyramid.h"

namespace strata::terrain {

// One cube of one level while the model is assembled: its vertices (the level's ids) in row order, the
// parents its children need among them.
struct Cube {
    build::CubeKey key = 0;
    std::vector<uint64_t> vertices;
    std::vector<uint32_t> triangles;
    std::array<uint32_t, 8> child_counts{};
};

// Sorts a cube's vertices into row-major order (by their level ids), as its grid payload lists them
// (FORMAT.md §5.1), renumbering its triangles.
void in_row_order(Cube& cube);

// A cube's payload content, and where its vertices stand in the level's grid.
struct CubeContent {
    CubeData data;
    GridPlacement grid;
};

// A place per vertex of a level, kUnnumbered except while one cube is being numbered.
inline constexpr uint32_t kUnnumbered = ~0u;

// The coarser level's vertex that is P(v) of the finer level's vertex v.
uint64_t parent_vertex(const TerrainLevel& finer, const TerrainLevel& coarse, uint64_t v);

// The level's cubes that `owned` accepts, in key order, with an (empty) cube for every parent of
// `children` that has no triangle of its own. `finer`: the level below (null at level L), whose cubes
// the triangles came from. `number`: kUnnumbered for each of the level's vertices, and left so.
std::vector<Cube> level_cubes(const TerrainLevel& level, const TerrainLevel* finer, const std::vector<Cube>& children,
                              std::vector<uint32_t>& number, const std::function<bool(build::CubeKey)>& owned);

// Encodes cubes into the writer, each vertex naming its parent in the parent cube (itself at level 0),
// and keeps each cube's F and D for the error bounds and its level's counts.
class CubeEncoder {
public:
    // The writer, errors and level counts may be shared by encoders on other threads: `output_lock`
    // guards them.
    // `height_shift`: every level's heights lie on its lattice's multiples of 2^height_shift.
    CubeEncoder(const build::Frame& f, std::string name, HlodWriter& writer, std::vector<build::CubeErrors>& errors,
                std::vector<LevelStats>& levels, std::mutex& output_lock, unsigned threads, uint32_t height_shift);

    // Sets the level whose cubes come next: its normals, and its cubes' F and D (null: 0).
    void start_level(const TerrainLevel& level, const CubeDistances* forward, const CubeDistances* coverage);
    // A cube's payload content: its vertices on the level's lattice, each naming its parent's place in
    // the parent cube (`parent_number`, over the coarse level) or itself at level 0 (null `coarse`).
    CubeContent cube_data(const Cube& cube, const TerrainLevel& level, const TerrainLevel* coarse, const std::vector<uint32_t>* parent_number);
    // Compresses the cubes' payloads on the encoder's threads and adds them to the writer in the
    // order given (so the output does not depend on the thread count).
    void write(const std::vector<const Cube*>& cubes, std::vector<CubeContent>& content, uint32_t level);
    // The σ0 the vertices need: their distance to their cube's cell (÷ s_l) and to their parent (÷ s_{l+1}).
    double sigma0_needed() const { return needed_; }
    // How far the vertices, and their parents, lie outside their cube's cell in x and y (÷ s_l): the
    // margin of the cubes' textures (preprocess/cube_textures.h), which a morphing vertex stays within.
    double texture_margin_needed() const { return overhang_xy_; }

private:
    const build::Frame& f_;
    const std::string name_;
    HlodWriter& writer_;
    std::vector<build::CubeErrors>& errors_;
    std::vector<LevelStats>& levels_;  // by level
    std::mutex& output_lock_;
    std::vector<int16_t> normals_;  // the level's, 2 per vertex
    const CubeDistances *forward_ = nullptr, *coverage_ = nullptr;
    unsigned threads_;
    uint32_t height_shift_;
    double needed_ = 0, overhang_xy_ = 0;
};

// Gives each parent the vertices its children need and it lacks, then encodes the children, parent by
// parent: a parent's vertex order is final once its children's are. `number`: as for level_cubes, over
// the coarse level.
void encode_children(std::vector<Cube>& parents, const std::vector<Cube>& children, const TerrainLevel& finer,
                     const TerrainLevel& coarse, std::vector<uint32_t>& number, CubeEncoder& encoder);

}  // namespace strata::terrain

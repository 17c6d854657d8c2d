// A textured model's imagery at any model (x, y), read from its cubes' textures (section TXTR, planar
// mapping, FORMAT.md §4.9): what an embedding takes from its terrain's textures, at embed time for its
// skirt's cubes (embedding_file.cpp) and at run time for its seams (nodes/terrain_draw.cpp), so that both
// show the ground's own imagery at the ground's own density.
#pragma once

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "preprocess/cube_textures.h"
#include "preprocess/hlod_format.h"

namespace strata {

// A grid of texels in model x and y: texel (c, r) centred at (x0 + c·step, y0 + r·step), row 0 first.
struct TexelGrid {
    double x0 = 0, y0 = 0, step = 1;
    uint32_t columns = 0, rows = 0;
};

class ImagerySampler {
public:
    // The model's cubes whose textures reach into the box [lo, hi] (model x, y), found in its node table
    // (`node(n)`, the n-th of `node_count`): only those are ever read.
    ImagerySampler(const HlodHeader& header, const CubeTextures& textures, uint64_t node_count,
                   const std::function<const HlodNode&(uint64_t)>& node, const double lo[2], const double hi[2]);

    // The model units between two texels of a level's textures: (1 + 2·margin)·s_l / size.
    double texel_spacing(uint32_t level) const;
    // The coarsest level whose texels are at least as dense as `spacing` (the finest when none is): the
    // ground's own density there, which a bilinear resampling then neither blurs nor aliases by more
    // than a factor of two, as a GPU's mip selection does.
    uint32_t level_for(double spacing) const;

    // The grid's texels as RGB8 (sRGB), each the bilinear blend, in linear light, of the level's mip-0
    // texels around it, in the texture of the level's cube whose cell holds it (its texels clamped at the
    // texture's edge, as a GPU's sampler clamps them); mid grey where the level has no cube. Textures are
    // decoded as needed and kept until a call no longer uses them: sampling neighbouring grids in turn
    // decodes each texture about once, and memory stays a call's textures.
    std::vector<uint8_t> sample(uint32_t level, const TexelGrid& grid);

private:
    struct Cube {
        uint64_t index;  // in the node table
        HlodNode node;
    };
    const std::vector<uint8_t>& decoded(const Cube& cube);

    HlodHeader header_;
    const CubeTextures& textures_;
    std::unordered_map<uint64_t, Cube> cubes_;  // by (level, i, j): one cube of each column of cubes
    std::unordered_map<uint64_t, std::vector<uint8_t>> kept_, previous_;  // decoded mip 0, by node index
};

}  // namespace strata

// Per-cube textures (section TXTR, FORMAT.md §4.9): every cube of a textured model carries a square
// image of the same size, so a cube's texel density doubles with each level, as its triangles' does.
// Stored as BC1 (DXT1) blocks, sRGB, with the whole mip chain down to 4 × 4, one zstd frame per cube:
// BC1 is what every desktop GPU samples as it is (4 bits a texel, a sixth of RGB8 in memory too, and no
// decode on the CPU but zstd's, above 1 GB/s), at a quality close to a JPEG of the same ground's
// (its 4 × 4 blocks of two end colours show on sharp colour edges, rare in aerial imagery).
//
// How a cube's vertices find their texels is the section's mapping. Mapping 1, planar: the texture
// covers the cube's cell in model x and y grown by `margin`·s_l on each side (x east to the right,
// y north upwards), so a terrain's texture coordinates come from its positions and cost no bytes.
// A mesh with UVs into an atlas (OBJ, glTF) would be a second mapping, its UVs in the payload.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "preprocess/hlod_format.h"

namespace strata {

inline constexpr char kTexturesTag[5] = "TXTR";

enum class TextureMapping : uint32_t { planar = 1 };

// The section's head: what every cube's texture is.
struct TextureLayout {
    uint32_t size = 0;   // texels along a side of mip 0: a power of two, 8‥4096
    float margin = 0;    // planar: the cell grown by margin·s_l on each side, 0 ≤ margin < 0.5
    TextureMapping mapping = TextureMapping::planar;

    // Whether `size` may be a texture's: a power of two, 8‥4096.
    static bool valid_size(uint32_t size);
    // Mip levels stored: size, size/2, … 4.
    uint32_t mip_count() const;
    uint32_t mip_size(uint32_t mip) const { return size >> mip; }
    // BC1 bytes of one mip level, and of the whole chain (what a cube's texture holds, decompressed).
    static uint64_t bc1_bytes(uint32_t size) { return uint64_t(size / 4) * (size / 4) * 8; }
    uint64_t chain_bytes() const;
};

// An 8-bit sRGB value in linear light (0‥1), and back (rounded, clamped): how textures are averaged
// and blended, as a GPU samples them.
float srgb_to_linear(uint8_t value);
uint8_t linear_to_srgb(float linear);
// srgb_to_linear of every byte.
const std::array<float, 256>& srgb_to_linear_table();

// The BC1 mip chain of a size × size RGB8 image (3 bytes a texel, row 0 first, as the mapping puts it):
// each coarser mip averages 2 × 2 texels of the finer in linear light (the bytes are sRGB), and every
// mip is cut into 4 × 4 blocks compressed by stb_dxt (high quality), in rows of blocks from row 0.
std::vector<uint8_t> encode_bc1_chain(std::span<const uint8_t> rgb, uint32_t size);
// Decodes one BC1 mip of `size` × `size` into RGB8 (what a GPU samples; for tests and for readers
// without BC1 support).
std::vector<uint8_t> decode_bc1(std::span<const uint8_t> blocks, uint32_t size);

// Writes the section: textures arrive in any order, keyed by their cube, each compressed into one zstd
// frame and spooled by the HlodWriter; finish() writes the head and an index in NODE's order.
class TextureSectionWriter {
public:
    TextureSectionWriter(HlodWriter& writer, TextureLayout layout);
    // The cube's BC1 chain (encode_bc1_chain); safe to call from several threads.
    void add(uint32_t level, uint32_t i, uint32_t j, uint32_t k, std::span<const uint8_t> chain);
    // Every cube the writer holds must have its texture. Throws std::logic_error otherwise.
    void finish();
    uint64_t bytes() const { return bytes_; }  // the compressed textures' bytes so far

private:
    struct Entry {
        uint64_t key, offset;
        uint32_t size, checksum;
    };
    HlodWriter& writer_;
    TextureLayout layout_;
    std::mutex mutex_;
    std::vector<Entry> entries_;
    uint64_t bytes_ = 0;
};

// Reads the textures of an opened model; safe to call from several threads.
class CubeTextures {
public:
    // Reads the head and the index (16 bytes a cube) and checks them. Throws std::runtime_error naming
    // the file when they are corrupt or of a codec or mapping this Strata does not know.
    CubeTextures(std::shared_ptr<const HlodFile> file, const HlodSection& section, uint64_t node_count);

    const TextureLayout& layout() const { return layout_; }
    // The BC1 chain of `node`, the node table's `index`-th cube (layout().chain_bytes() bytes), its
    // checksum checked. Throws std::runtime_error naming the file and the cube when the bytes are corrupt.
    std::vector<uint8_t> read(uint64_t index, const HlodNode& node) const;
    // The compressed bytes of every texture (strata verify reads each through read()).
    uint64_t stored_bytes() const { return stored_bytes_; }
    // What the index takes in memory.
    uint64_t index_bytes() const { return uint64_t(index_.capacity()) * sizeof(IndexEntry); }

private:
    struct IndexEntry {
        uint64_t offset;
        uint32_t size, checksum;
    };
    std::shared_ptr<const HlodFile> file_;
    HlodSection section_;
    TextureLayout layout_;
    std::vector<IndexEntry> index_;
    uint64_t stored_bytes_ = 0;
};

}  // namespace strata

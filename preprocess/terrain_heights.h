// A terrain's heights, kept as the raster had them (section HGHT, FORMAT.md §4.8): what
// `model:height_at` reads, since the position lattice (2^-15 of a cube) is too coarse for heights to the
// centimetre. Heights are integers q on a step (the raster's own step for integer rasters, so those
// round-trip exactly; 1 mm for floating-point ones): h = base + q·step. The grid is cut into blocks of
// 256 × 256 samples, each one zstd frame of the residuals of LOCO-I's median edge predictor (a
// sample from its left, upper and upper-left neighbours), zigzagged and split into byte planes, after
// the block's common factor (whole metres in a float raster) is divided out, with a bitmap of its
// nodata samples when it has some. An index of the blocks (16 bytes each) is read when
// the model opens; a block is read and decoded when a height in it is asked for.
#pragma once

#include <array>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "preprocess/hlod_format.h"

namespace strata {

inline constexpr char kHeightsTag[5] = "HGHT";
inline constexpr uint32_t kHeightBlock = 256;  // samples along a block's side

// Heights' lattice: h = base + q·step, metres.
struct HeightStep {
    double step = 0.001, base = 0;
};

// Encodes a raster's heights into `writer`'s HGHT section, band by band, as the build's first pass
// reads them.
class HeightSectionWriter {
public:
    // `name` (the raster) names the errors.
    HeightSectionWriter(HlodWriter& writer, uint64_t columns, uint64_t rows, HeightStep step, std::string name);
    // The next `rows` whole rows of heights in metres (NaN: nodata): kHeightBlock rows, or fewer for the
    // grid's last band. Blocks encode on `threads` threads. Throws InputError for a height the lattice
    // cannot hold (beyond ±2^30 steps: ±1 074 km at 1 mm).
    void add_band(std::span<const float> heights, uint64_t rows, unsigned threads);
    // Writes the section's head and index; every row must have been added.
    void finish();
    uint64_t bytes() const { return bytes_; }  // the blocks' bytes so far

private:
    HlodWriter& writer_;
    uint64_t columns_, rows_, rows_added_ = 0, bytes_ = 0;
    HeightStep step_;
    std::string name_;
    std::vector<uint8_t> index_;
};

// Reads the heights of an opened model; safe to call from several threads.
class TerrainHeights {
public:
    // Reads the HGHT section's head and index and checks them against the model's TERR. Throws
    // std::runtime_error naming the file when they are corrupt.
    TerrainHeights(std::shared_ptr<const HlodFile> file, const HlodSection& section);

    uint64_t columns() const { return columns_; }
    uint64_t rows() const { return rows_; }
    HeightStep step() const { return step_; }
    // The height of sample (column, row), or nothing on nodata. Throws std::runtime_error naming the file
    // and the block when its bytes are corrupt; std::out_of_range outside the grid.
    std::optional<double> sample(uint64_t column, uint64_t row) const;
    // Bilinear between the four samples around (column, row) (sample centres at whole numbers): the
    // sample's own height at a centre; nothing outside the grid or where a sample with a weight is nodata.
    std::optional<double> at(double column, double row) const;
    // Decodes every block (strata verify); throws as sample does.
    void check_all() const;

private:
    struct Block {
        std::vector<int32_t> q;
        std::vector<uint8_t> nodata;  // one byte per sample; empty when the block has none
    };
    std::shared_ptr<const Block> block(uint64_t index) const;

    std::shared_ptr<const HlodFile> file_;
    HlodSection section_;
    uint64_t columns_ = 0, rows_ = 0, blocks_across_ = 0;
    HeightStep step_;
    struct IndexEntry {
        uint64_t offset = 0;
        uint32_t size = 0, checksum = 0;
    };
    std::vector<IndexEntry> index_;
    // The blocks decoded last (a path over the ground asks for the same few again and again).
    static constexpr size_t kCachedBlocks = 16;
    mutable std::mutex mutex_;
    mutable std::list<std::pair<uint64_t, std::shared_ptr<const Block>>> cache_;
};

}  // namespace strata

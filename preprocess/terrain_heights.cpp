#include "preprocess/terrain_heights.h"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <stdexcept>

#include "preprocess/byte_packing.h"
#include "preprocess/mesh.h"
#include "preprocess/parallel.h"

namespace strata {
namespace {

constexpr uint32_t kHeightCodec = 1;
constexpr size_t kHeadBytes = 56, kIndexEntryBytes = 16;
// |q| below this: a residual against a prediction between two neighbours fits 32 bits, zigzagged too.
constexpr int64_t kMostSteps = int64_t(1) << 30;
constexpr int kZstdLevel = 3;

// LOCO-I's median edge detector from the left (a), upper (b) and upper-left (c) neighbours; along the
// block's first row the left one, down its first column the upper one.
int64_t predict(const int32_t* q, uint32_t width, uint32_t x, uint32_t y) {
    if (y == 0) return x ? q[x - 1] : 0;
    const int64_t b = q[(y - 1) * width + x];
    if (x == 0) return b;
    const int64_t a = q[y * width + x - 1], c = q[(y - 1) * width + x - 1];
    if (c >= std::max(a, b)) return std::min(a, b);
    if (c <= std::min(a, b)) return std::max(a, b);
    return a + b - c;
}

// A block decompressed: a flag byte, the common factor, the nodata bitmap when flagged, four byte planes.
constexpr size_t kBlockHead = 5;
size_t raw_block_bytes(size_t samples, bool holes) { return kBlockHead + (holes ? (samples + 7) / 8 : 0) + 4 * samples; }

// One block of `width` × `height` samples from the band (rows of `columns` heights), from column x0.
std::vector<uint8_t> encode_block(const float* band, uint64_t columns, uint64_t x0, uint32_t width, uint32_t height, HeightStep step,
                                  const std::string& name) {
    const size_t n = size_t(width) * height;
    std::vector<int32_t> q(n);
    std::vector<uint8_t> holes;
    for (uint32_t y = 0; y < height; ++y)
        for (uint32_t x = 0; x < width; ++x) {
            const size_t s = size_t(y) * width + x;
            const float h = band[y * columns + x0 + x];
            if (std::isnan(h)) {
                if (holes.empty()) holes.assign((n + 7) / 8, 0);
                holes[s / 8] |= uint8_t(1u << (s % 8));
                q[s] = int32_t(predict(q.data(), width, x, y));  // a zero residual; decoding makes the same
                continue;
            }
            const double steps = std::round((double(h) - step.base) / step.step);
            if (!(std::abs(steps) < double(kMostSteps)))
                throw InputError(name + ": a height of " + std::to_string(h) + " m, beyond what a terrain keeps (±" +
                                 std::to_string(double(kMostSteps) * step.step / 1000) + " km)");
            q[s] = int32_t(steps);
        }
    // Heights that are whole metres in a float raster, or whole decimetres, share a factor (1000 steps
    // of 1 mm, 100): dividing it out shrinks every residual alike.
    uint32_t factor = 0;
    for (size_t s = 0; s < n && factor != 1; ++s)
        if (holes.empty() || !(holes[s / 8] >> (s % 8) & 1)) factor = std::gcd(factor, uint32_t(std::abs(q[s])));
    factor = std::max(factor, 1u);
    for (int32_t& v : q) v /= int32_t(factor);  // nodata's predictions stay multiples: they derive from valid ones
    std::vector<uint8_t> raw(raw_block_bytes(n, !holes.empty()));
    raw[0] = holes.empty() ? 0 : 1;
    std::memcpy(&raw[1], &factor, sizeof factor);
    std::copy(holes.begin(), holes.end(), raw.begin() + kBlockHead);
    uint8_t* planes = raw.data() + kBlockHead + holes.size();
    for (uint32_t y = 0; y < height; ++y)
        for (uint32_t x = 0; x < width; ++x) {
            const size_t s = size_t(y) * width + x;
            const uint32_t z = zigzag(int32_t(q[s] - predict(q.data(), width, x, y)));
            for (size_t b = 0; b < 4; ++b) planes[b * n + s] = uint8_t(z >> (8 * b));
        }
    std::vector<uint8_t> frame(ZSTD_compressBound(raw.size()));
    const size_t size = ZSTD_compress(frame.data(), frame.size(), raw.data(), raw.size(), kZstdLevel);
    if (ZSTD_isError(size)) throw std::runtime_error(name + ": heights: " + ZSTD_getErrorName(size));
    frame.resize(size);
    return frame;
}

uint64_t blocks_along(uint64_t samples) { return (samples + kHeightBlock - 1) / kHeightBlock; }

}  // namespace

HeightSectionWriter::HeightSectionWriter(HlodWriter& writer, uint64_t columns, uint64_t rows, HeightStep step, std::string name)
    : writer_(writer), columns_(columns), rows_(rows), step_(step), name_(std::move(name)) {}

void HeightSectionWriter::add_band(std::span<const float> heights, uint64_t rows, unsigned threads) {
    if (rows == 0 || rows > kHeightBlock || (rows < kHeightBlock && rows_added_ + rows != rows_) || rows_added_ + rows > rows_ ||
        heights.size() != rows * columns_)
        throw std::invalid_argument("HeightSectionWriter: a band of " + std::to_string(rows) + " rows after " + std::to_string(rows_added_));
    std::vector<std::vector<uint8_t>> blocks(blocks_along(columns_));
    parallel_for(blocks.size(), threads, [&](size_t b, unsigned) {
        const uint64_t x0 = b * kHeightBlock;
        blocks[b] = encode_block(heights.data(), columns_, x0, uint32_t(std::min<uint64_t>(kHeightBlock, columns_ - x0)), uint32_t(rows), step_, name_);
    });
    const uint64_t blocks_total = blocks_along(columns_) * blocks_along(rows_);
    for (const std::vector<uint8_t>& block : blocks) {
        ByteWriter entry;
        entry.put(uint64_t(kHeadBytes + kIndexEntryBytes * blocks_total + bytes_));
        entry.put(uint32_t(block.size()));
        entry.put(crc32c(block.data(), block.size()));
        index_.insert(index_.end(), entry.bytes.begin(), entry.bytes.end());
        writer_.append_to_section(kHeightsTag, block);
        bytes_ += block.size();
    }
    rows_added_ += rows;
}

void HeightSectionWriter::finish() {
    if (rows_added_ != rows_) throw std::logic_error("HeightSectionWriter::finish before every row");
    ByteWriter head;
    head.put(kHeightCodec), head.put(kHeightBlock);
    head.put(columns_), head.put(rows_);
    head.put(step_.step), head.put(step_.base);
    head.put(uint64_t(index_.size() / kIndexEntryBytes));
    head.put(crc32c(index_.data(), index_.size())), head.put(uint32_t(0));
    head.put_bytes(index_.data(), index_.size());
    writer_.set_section_head(kHeightsTag, std::move(head.bytes));
}

TerrainHeights::TerrainHeights(std::shared_ptr<const HlodFile> file, const HlodSection& section) : file_(std::move(file)), section_(section) {
    const std::string what = file_->path().string() + ": section 'HGHT'";
    const std::optional<TerrainGrid>& grid = file_->header().terrain;
    if (!grid) throw std::runtime_error(what + " in a model without a terrain grid (section 'TERR')");
    const std::vector<uint8_t> head = file_->read_section_part(section, 0, kHeadBytes, "head");
    ByteReader r(head, what);
    const uint32_t codec = r.get<uint32_t>(), block = r.get<uint32_t>();
    columns_ = r.get<uint64_t>(), rows_ = r.get<uint64_t>();
    step_.step = r.get<double>(), step_.base = r.get<double>();
    const uint64_t count = r.get<uint64_t>();
    const uint32_t index_checksum = r.get<uint32_t>();
    if (codec != kHeightCodec) throw std::runtime_error(what + ": heights codec " + std::to_string(codec) + ", which this Strata does not know");
    if (block != kHeightBlock) throw std::runtime_error(what + ": blocks of " + std::to_string(block) + " samples");
    if (columns_ != grid->columns || rows_ != grid->rows)
        throw std::runtime_error(what + ": a grid of " + std::to_string(columns_) + " × " + std::to_string(rows_) + " heights for a raster of " +
                                 std::to_string(grid->columns) + " × " + std::to_string(grid->rows));
    if (!(step_.step > 0) || !std::isfinite(step_.step) || !std::isfinite(step_.base)) throw std::runtime_error(what + ": a height step that is not a positive number");
    blocks_across_ = blocks_along(columns_);
    if (count != blocks_across_ * blocks_along(rows_)) throw std::runtime_error(what + ": " + std::to_string(count) + " blocks for its grid");
    const std::vector<uint8_t> index = file_->read_section_part(section, kHeadBytes, kIndexEntryBytes * count, "index");
    if (crc32c(index.data(), index.size()) != index_checksum) throw std::runtime_error(what + ": index checksum mismatch (the file is corrupt)");
    ByteReader entries(index, what);
    index_.resize(count);
    for (IndexEntry& e : index_) e.offset = entries.get<uint64_t>(), e.size = entries.get<uint32_t>(), e.checksum = entries.get<uint32_t>();
}

std::shared_ptr<const TerrainHeights::Block> TerrainHeights::block(uint64_t index) const {
    {
        std::lock_guard lock(mutex_);
        for (auto it = cache_.begin(); it != cache_.end(); ++it)
            if (it->first == index) {
                cache_.splice(cache_.begin(), cache_, it);
                return it->second;
            }
    }
    const uint64_t bx = index % blocks_across_, by = index / blocks_across_;
    const uint32_t width = uint32_t(std::min<uint64_t>(kHeightBlock, columns_ - bx * kHeightBlock));
    const uint32_t height = uint32_t(std::min<uint64_t>(kHeightBlock, rows_ - by * kHeightBlock));
    const std::string what = "heights block " + std::to_string(bx) + " " + std::to_string(by);
    const IndexEntry& e = index_[index];
    const std::vector<uint8_t> frame = file_->read_section_part(section_, e.offset, e.size, what);
    auto corrupt = [&](const std::string& problem) {
        return std::runtime_error(file_->path().string() + ": " + what + ": " + problem + " (the file is corrupt)");
    };
    if (crc32c(frame.data(), frame.size()) != e.checksum) throw corrupt("checksum mismatch");
    const size_t n = size_t(width) * height;
    std::vector<uint8_t> raw(raw_block_bytes(n, true));
    const size_t size = ZSTD_decompress(raw.data(), raw.size(), frame.data(), frame.size());
    if (ZSTD_isError(size) || size == 0) throw corrupt("not a zstd frame of its size");
    const bool holes = raw[0] == 1;
    if (raw[0] > 1 || size != raw_block_bytes(n, holes)) throw corrupt("the wrong size for its samples");
    uint32_t factor;
    std::memcpy(&factor, &raw[1], sizeof factor);
    if (factor == 0 || factor >= uint32_t(kMostSteps)) throw corrupt("a common factor of " + std::to_string(factor));
    auto out = std::make_shared<Block>();
    out->q.resize(n);
    if (holes) {
        out->nodata.resize(n);
        for (size_t s = 0; s < n; ++s) out->nodata[s] = (raw[kBlockHead + s / 8] >> (s % 8)) & 1;
    }
    const uint8_t* planes = raw.data() + kBlockHead + (holes ? (n + 7) / 8 : 0);
    for (uint32_t y = 0; y < height; ++y)
        for (uint32_t x = 0; x < width; ++x) {
            const size_t s = size_t(y) * width + x;
            const uint32_t z = uint32_t(planes[s]) | uint32_t(planes[n + s]) << 8 | uint32_t(planes[2 * n + s]) << 16 | uint32_t(planes[3 * n + s]) << 24;
            const int64_t q = predict(out->q.data(), width, x, y) + unzigzag(z);
            if (q * factor <= -kMostSteps || q * factor >= kMostSteps) throw corrupt("a height beyond the lattice");
            out->q[s] = int32_t(q);
        }
    if (factor > 1)
        for (int32_t& v : out->q) v *= int32_t(factor);
    std::lock_guard lock(mutex_);
    cache_.emplace_front(index, out);
    if (cache_.size() > kCachedBlocks) cache_.pop_back();
    return out;
}

std::optional<double> TerrainHeights::sample(uint64_t column, uint64_t row) const {
    if (column >= columns_ || row >= rows_) throw std::out_of_range("TerrainHeights::sample outside the grid");
    const std::shared_ptr<const Block> b = block(row / kHeightBlock * blocks_across_ + column / kHeightBlock);
    const uint64_t width = std::min<uint64_t>(kHeightBlock, columns_ - column / kHeightBlock * kHeightBlock);
    const size_t s = size_t(row % kHeightBlock * width + column % kHeightBlock);
    if (!b->nodata.empty() && b->nodata[s]) return std::nullopt;
    return step_.base + double(b->q[s]) * step_.step;
}

std::optional<double> TerrainHeights::at(double column, double row) const {
    // A position computed from a grid edge's coordinates may land a rounding error outside it.
    constexpr double kEdge = 1e-6;
    const double last_column = double(columns_ - 1), last_row = double(rows_ - 1);
    if (!(column >= -kEdge && row >= -kEdge && column <= last_column + kEdge && row <= last_row + kEdge)) return std::nullopt;
    column = std::clamp(column, 0.0, last_column), row = std::clamp(row, 0.0, last_row);
    const uint64_t c0 = std::min(uint64_t(column), columns_ - 1), r0 = std::min(uint64_t(row), rows_ - 1);
    const double u = column - double(c0), v = row - double(r0);
    double sum = 0;
    for (int corner = 0; corner < 4; ++corner) {
        const double weight = (corner & 1 ? u : 1 - u) * (corner & 2 ? v : 1 - v);
        if (weight == 0) continue;
        const std::optional<double> h = sample(c0 + (corner & 1), r0 + (corner >> 1 & 1));
        if (!h) return std::nullopt;
        sum += weight * *h;
    }
    return sum;
}

void TerrainHeights::check_all() const {
    for (uint64_t b = 0; b < index_.size(); ++b) block(b);
}

}  // namespace strata

#include "preprocess/cube_textures.h"

#include <zstd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>  // stb_dxt.h uses memcpy without including it
#include <stdexcept>

#define STB_DXT_IMPLEMENTATION
#include <stb/stb_dxt.h>

#include "preprocess/byte_packing.h"

namespace strata {
namespace {

constexpr uint32_t kTextureCodec = 1;  // BC1, sRGB, the mip chain down to 4 × 4, one zstd frame a cube
constexpr size_t kHeadBytes = 32, kIndexEntryBytes = 16;
// BC1 blocks are near-random bytes to a general-purpose coder: a low level gains as much as a high one.
constexpr int kZstdLevel = 3;

uint64_t cube_key(uint32_t level, uint32_t i, uint32_t j, uint32_t k) {
    return uint64_t(level) << 60 | uint64_t(k) << 40 | uint64_t(j) << 20 | uint64_t(i);  // NODE's order: level, k, j, i
}

// The next mip: 2 × 2 texels averaged in linear light.
std::vector<uint8_t> half_size(std::span<const uint8_t> rgb, uint32_t size, const std::array<float, 256>& linear) {
    const uint32_t half = size / 2;
    std::vector<uint8_t> out(size_t(half) * half * 3);
    for (uint32_t y = 0; y < half; ++y)
        for (uint32_t x = 0; x < half; ++x)
            for (int c = 0; c < 3; ++c) {
                auto at = [&](uint32_t dx, uint32_t dy) { return linear[rgb[(size_t(2 * y + dy) * size + 2 * x + dx) * 3 + size_t(c)]]; };
                out[(size_t(y) * half + x) * 3 + size_t(c)] = linear_to_srgb((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1)) / 4);
            }
    return out;
}

void compress_mip(std::span<const uint8_t> rgb, uint32_t size, std::vector<uint8_t>& out) {
    std::array<uint8_t, 64> block{};
    std::array<uint8_t, 8> packed{};
    for (uint32_t by = 0; by < size / 4; ++by)
        for (uint32_t bx = 0; bx < size / 4; ++bx) {
            for (uint32_t t = 0; t < 16; ++t) {
                const uint8_t* texel = &rgb[(size_t(4 * by + t / 4) * size + 4 * bx + t % 4) * 3];
                block[4 * t] = texel[0], block[4 * t + 1] = texel[1], block[4 * t + 2] = texel[2], block[4 * t + 3] = 255;
            }
            stb_compress_dxt_block(packed.data(), block.data(), 0, STB_DXT_HIGHQUAL);
            out.insert(out.end(), packed.begin(), packed.end());
        }
}

std::array<uint8_t, 3> expand_565(uint16_t c) {
    const uint32_t r = c >> 11, g = (c >> 5) & 63, b = c & 31;
    return {uint8_t(r << 3 | r >> 2), uint8_t(g << 2 | g >> 4), uint8_t(b << 3 | b >> 2)};
}

}  // namespace

float srgb_to_linear(uint8_t value) {
    const float c = float(value) / 255.0f;
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

uint8_t linear_to_srgb(float c) {
    c = std::clamp(c, 0.0f, 1.0f);
    const float s = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
    return uint8_t(std::lround(s * 255.0f));
}

const std::array<float, 256>& srgb_to_linear_table() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int v = 0; v < 256; ++v) t[size_t(v)] = srgb_to_linear(uint8_t(v));
        return t;
    }();
    return table;
}

bool TextureLayout::valid_size(uint32_t size) { return std::has_single_bit(size) && size >= 8 && size <= 4096; }

uint32_t TextureLayout::mip_count() const { return size < 4 ? 0 : uint32_t(std::bit_width(size)) - 2; }

uint64_t TextureLayout::chain_bytes() const {
    uint64_t bytes = 0;
    for (uint32_t m = 0; m < mip_count(); ++m) bytes += bc1_bytes(mip_size(m));
    return bytes;
}

std::vector<uint8_t> encode_bc1_chain(std::span<const uint8_t> rgb, uint32_t size) {
    if (!std::has_single_bit(size) || size < 4 || rgb.size() != size_t(size) * size * 3)
        throw std::invalid_argument("encode_bc1_chain: " + std::to_string(rgb.size()) + " bytes for " + std::to_string(size) + "² texels");
    const std::array<float, 256>& linear = srgb_to_linear_table();
    std::vector<uint8_t> out;
    out.reserve(TextureLayout{.size = size}.chain_bytes());
    std::vector<uint8_t> mip(rgb.begin(), rgb.end());
    for (uint32_t s = size;; s /= 2) {
        compress_mip(mip, s, out);
        if (s == 4) break;
        mip = half_size(mip, s, linear);
    }
    return out;
}

std::vector<uint8_t> decode_bc1(std::span<const uint8_t> blocks, uint32_t size) {
    if (size % 4 || blocks.size() != TextureLayout::bc1_bytes(size)) throw std::invalid_argument("decode_bc1: the wrong number of bytes");
    std::vector<uint8_t> rgb(size_t(size) * size * 3);
    for (uint32_t by = 0; by < size / 4; ++by)
        for (uint32_t bx = 0; bx < size / 4; ++bx) {
            const uint8_t* b = &blocks[(size_t(by) * (size / 4) + bx) * 8];
            const uint16_t c0 = uint16_t(b[0] | b[1] << 8), c1 = uint16_t(b[2] | b[3] << 8);
            std::array<std::array<uint8_t, 3>, 4> palette{expand_565(c0), expand_565(c1)};
            for (int c = 0; c < 3; ++c) {
                const int p = palette[0][size_t(c)], q = palette[1][size_t(c)];
                if (c0 > c1) {
                    palette[2][size_t(c)] = uint8_t((2 * p + q + 1) / 3);
                    palette[3][size_t(c)] = uint8_t((p + 2 * q + 1) / 3);
                } else {
                    palette[2][size_t(c)] = uint8_t((p + q + 1) / 2);
                    palette[3][size_t(c)] = 0;  // transparent black: opaque images never use it
                }
            }
            const uint32_t bits = uint32_t(b[4]) | uint32_t(b[5]) << 8 | uint32_t(b[6]) << 16 | uint32_t(b[7]) << 24;
            for (uint32_t t = 0; t < 16; ++t) {
                const auto& colour = palette[(bits >> (2 * t)) & 3];
                std::copy(colour.begin(), colour.end(), &rgb[(size_t(4 * by + t / 4) * size + 4 * bx + t % 4) * 3]);
            }
        }
    return rgb;
}

TextureSectionWriter::TextureSectionWriter(HlodWriter& writer, TextureLayout layout) : writer_(writer), layout_(layout) {
    if (!TextureLayout::valid_size(layout.size) || !(layout.margin >= 0 && layout.margin < 0.5f))
        throw std::invalid_argument("TextureSectionWriter: textures of " + std::to_string(layout.size) + " texels, margin " + std::to_string(layout.margin));
}

void TextureSectionWriter::add(uint32_t level, uint32_t i, uint32_t j, uint32_t k, std::span<const uint8_t> chain) {
    if (chain.size() != layout_.chain_bytes()) throw std::invalid_argument("TextureSectionWriter::add: a chain of the wrong size");
    std::vector<uint8_t> frame(ZSTD_compressBound(chain.size()));
    const size_t size = ZSTD_compress(frame.data(), frame.size(), chain.data(), chain.size(), kZstdLevel);
    if (ZSTD_isError(size)) throw std::runtime_error(std::string("textures: ") + ZSTD_getErrorName(size));
    frame.resize(size);
    const uint32_t checksum = crc32c(frame.data(), frame.size());
    std::lock_guard lock(mutex_);
    entries_.push_back({cube_key(level, i, j, k), bytes_, uint32_t(size), checksum});
    writer_.append_to_section(kTexturesTag, frame);
    bytes_ += size;
}

void TextureSectionWriter::finish() {
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
    const std::vector<HlodNode> nodes = writer_.nodes_in_file_order();
    if (nodes.size() != entries_.size()) throw std::logic_error("TextureSectionWriter::finish: not every cube has a texture");
    ByteWriter head;
    head.put(kTextureCodec), head.put(uint32_t(layout_.mapping)), head.put(layout_.size), head.put(layout_.margin);
    ByteWriter index;
    const uint64_t first = kHeadBytes + kIndexEntryBytes * nodes.size();
    for (const HlodNode& node : nodes) {
        const auto it = std::lower_bound(entries_.begin(), entries_.end(), cube_key(node.level, node.i, node.j, node.k),
                                         [](const Entry& e, uint64_t key) { return e.key < key; });
        if (it == entries_.end() || it->key != cube_key(node.level, node.i, node.j, node.k))
            throw std::logic_error("TextureSectionWriter::finish: a cube without a texture");
        index.put(first + it->offset), index.put(it->size), index.put(it->checksum);
    }
    head.put(uint64_t(nodes.size()));
    head.put(crc32c(index.bytes.data(), index.bytes.size())), head.put(uint32_t(0));
    head.put_bytes(index.bytes.data(), index.bytes.size());
    writer_.set_section_head(kTexturesTag, std::move(head.bytes));
}

CubeTextures::CubeTextures(std::shared_ptr<const HlodFile> file, const HlodSection& section, uint64_t node_count)
    : file_(std::move(file)), section_(section) {
    const std::string what = file_->path().string() + ": section 'TXTR'";
    const std::vector<uint8_t> head = file_->read_section_part(section, 0, kHeadBytes, "head");
    ByteReader r(head, what);
    const uint32_t codec = r.get<uint32_t>(), mapping = r.get<uint32_t>();
    layout_.size = r.get<uint32_t>();
    layout_.margin = r.get<float>();
    const uint64_t count = r.get<uint64_t>();
    const uint32_t index_checksum = r.get<uint32_t>();
    if (codec != kTextureCodec) throw std::runtime_error(what + ": texture codec " + std::to_string(codec) + ", which this Strata does not know");
    if (mapping != uint32_t(TextureMapping::planar))
        throw std::runtime_error(what + ": texture mapping " + std::to_string(mapping) + ", which this Strata does not know");
    if (!TextureLayout::valid_size(layout_.size))
        throw std::runtime_error(what + ": textures of " + std::to_string(layout_.size) + " texels (a power of two, 8 to 4096)");
    if (!(layout_.margin >= 0 && layout_.margin < 0.5f)) throw std::runtime_error(what + ": a margin of " + std::to_string(layout_.margin) + " (0 to 0.5)");
    if (count != node_count)
        throw std::runtime_error(what + ": " + std::to_string(count) + " textures for " + std::to_string(node_count) + " cubes");
    const std::vector<uint8_t> index = file_->read_section_part(section, kHeadBytes, kIndexEntryBytes * count, "index");
    if (crc32c(index.data(), index.size()) != index_checksum) throw std::runtime_error(what + ": index checksum mismatch (the file is corrupt)");
    ByteReader entries(index, what);
    index_.resize(count);
    for (IndexEntry& e : index_) {
        e.offset = entries.get<uint64_t>(), e.size = entries.get<uint32_t>(), e.checksum = entries.get<uint32_t>();
        if (e.size == 0 || e.offset > section.size || e.size > section.size - e.offset)
            throw std::runtime_error(what + ": a texture outside the section (the file is corrupt)");
        stored_bytes_ += e.size;
    }
}

std::vector<uint8_t> CubeTextures::read(uint64_t index, const HlodNode& node) const {
    const IndexEntry& e = index_.at(index);
    const std::string what = "the texture of " + describe_cube(node);
    const std::vector<uint8_t> frame = file_->read_section_part(section_, e.offset, e.size, what);
    auto corrupt = [&](const std::string& problem) {
        return std::runtime_error(file_->path().string() + ": " + what + ": " + problem + " (the file is corrupt)");
    };
    if (crc32c(frame.data(), frame.size()) != e.checksum) throw corrupt("checksum mismatch");
    const uint64_t bytes = layout_.chain_bytes();
    if (ZSTD_getFrameContentSize(frame.data(), frame.size()) != bytes) throw corrupt("not a zstd frame of its size");
    std::vector<uint8_t> chain(bytes);
    const size_t size = ZSTD_decompress(chain.data(), chain.size(), frame.data(), frame.size());
    if (ZSTD_isError(size) || size != bytes) throw corrupt("not a zstd frame of its size");
    return chain;
}

}  // namespace strata

// The .hlod format (preprocess/FORMAT.md): CRC-32C, octahedral normals, lattice coordinates that decode
// bit-identically from neighbouring cells, cube payloads (round trip and every kind of bad payload), and
// whole files through HlodWriter / HlodFile (round trip and layout, no leftovers, opening without payload
// reads, every kind of bad header, section table and section named in the error, version 1 refused).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <iterator>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <meshoptimizer.h>
#include <zstd.h>

#include "preprocess/hlod_format.h"
#include "tests/support/hlod_bytes.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

using ::testing::HasSubstr;

// ---- helpers ----------------------------------------------------------------------------------------

void write_bytes(const std::filesystem::path& p, const std::vector<uint8_t>& bytes) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

using namespace test;  // get, put and the container's offsets (tests/support/hlod_bytes.h)

std::vector<std::string> directory_entries(const std::filesystem::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

// A small cube with every field filled: V vertices whose parents are vertex v mod Q of the parent cube,
// T triangles spread over the child groups, colours and UVs when the flags ask for them.
CubeData make_cube(uint32_t vertices, uint32_t parents, uint32_t triangles, uint32_t flags) {
    CubeData c;
    std::mt19937 rng(vertices * 131 + triangles);
    std::uniform_int_distribution<int> coord(12000, 53000);
    auto fill = [&](VertexArrays& a, uint32_t n) {
        for (uint32_t v = 0; v < n; ++v) {
            for (int k = 0; k < 3; ++k) a.positions.push_back(uint16_t(coord(rng)));
            float t = 0.37f * float(v);
            auto normal = encode_normal(std::cos(t), std::sin(t), 0.5f - float(v % 3) * 0.4f);
            a.normals.insert(a.normals.end(), normal.begin(), normal.end());
            if (flags & kHasColors) a.colors.insert(a.colors.end(), {uint8_t(v * 7), uint8_t(255 - v), 128, 255});
            if (flags & kHasUvs) a.uvs.insert(a.uvs.end(), {0.125f * float(v), 1.0f - 0.0625f * float(v)});
        }
    };
    fill(c.vertices, vertices);
    for (uint32_t v = 0; v < vertices; ++v) c.parent_vertex.push_back(parents ? v % parents : 0);
    for (uint32_t t = 0; t < triangles; ++t)
        c.indices.insert(c.indices.end(), {t % vertices, (t + 1) % vertices, (t + 2) % vertices});
    // Groups 0, 2 and 5 get the triangles, in that order (some groups empty, as for a missing child).
    c.child_triangle_counts = {triangles / 2, 0, triangles / 4, 0, 0, triangles - triangles / 2 - triangles / 4, 0, 0};
    return c;
}

HlodNode node_for(const CubeData& c, uint32_t level = 1, uint32_t i = 0, uint32_t j = 1, uint32_t k = 1) {
    HlodNode n;
    n.level = level, n.i = i, n.j = j, n.k = k;
    n.vertex_count = c.vertex_count();
    n.triangle_count = c.triangle_count();
    return n;
}

// Triangles equal in order and winding; the index codec may rotate a triangle's corners (FORMAT.md §5).
void expect_same_triangles(const std::vector<uint32_t>& got, const std::vector<uint32_t>& want) {
    ASSERT_EQ(got.size(), want.size());
    for (size_t t = 0; t < want.size(); t += 3) {
        std::array<uint32_t, 3> g{got[t], got[t + 1], got[t + 2]}, w{want[t], want[t + 1], want[t + 2]};
        bool same = false;
        for (int r = 0; r < 3 && !same; ++r) {
            same = g == w;
            g = {g[1], g[2], g[0]};
        }
        EXPECT_TRUE(same) << "triangle " << t / 3 << ": " << got[t] << " " << got[t + 1] << " " << got[t + 2]
                          << " vs " << want[t] << " " << want[t + 1] << " " << want[t + 2];
    }
}

void expect_same_arrays(const VertexArrays& got, const VertexArrays& want, uint32_t flags) {
    EXPECT_EQ(got.positions, want.positions);
    EXPECT_EQ(got.normals, want.normals);
    if (flags & kHasColors) EXPECT_EQ(got.colors, want.colors);
    else EXPECT_TRUE(got.colors.empty());
    if (flags & kHasUvs) EXPECT_EQ(got.uvs, want.uvs);
    else EXPECT_TRUE(got.uvs.empty());
}

void expect_same_cube(const CubeData& got, const CubeData& want, uint32_t flags) {
    expect_same_arrays(got.vertices, want.vertices, flags);
    EXPECT_EQ(got.parent_vertex, want.parent_vertex);
    EXPECT_EQ(got.child_triangle_counts, want.child_triangle_counts);
    expect_same_triangles(got.indices, want.indices);
}

// Payload header offsets and streams (FORMAT.md §5).
constexpr size_t kVertexCountAt = 0, kTriangleCountAt = 4, kChildCountsAt = 8, kStreamSizesAt = 40, kStreamsAt = 96;
constexpr int kStreams = 7, kIndexStream = 0, kPositionStream = 1, kNormalStream = 2, kParentStream = 3, kColorStream = 4,
              kUvStream = 5, kBitStream = 6;
uint32_t stream_size(const std::vector<uint8_t>& payload, int s) { return get<uint32_t>(payload, kStreamSizesAt + 8 * s); }
uint32_t stored_size(const std::vector<uint8_t>& payload, int s) { return get<uint32_t>(payload, kStreamSizesAt + 8 * s + 4); }

std::vector<uint8_t> zstd_frame(const std::vector<uint8_t>& bytes) {
    std::vector<uint8_t> frame(ZSTD_compressBound(bytes.size()));
    frame.resize(ZSTD_compress(frame.data(), frame.size(), bytes.data(), bytes.size(), 3));
    return frame;
}

// The streams of a payload, unpacked as FORMAT.md §5 says (independently of decode_cube).
std::vector<std::vector<uint8_t>> unpacked_streams(const std::vector<uint8_t>& payload) {
    std::vector<std::vector<uint8_t>> streams(kStreams);
    size_t at = kStreamsAt;
    for (int s = 0; s < kStreams; ++s) {
        const uint32_t size = stream_size(payload, s), stored = stored_size(payload, s);
        streams[s].resize(size);
        if (stored == size) {
            std::copy(payload.begin() + at, payload.begin() + at + size, streams[s].begin());
        } else {
            EXPECT_EQ(ZSTD_decompress(streams[s].data(), size, &payload[at], stored), size) << "stream " << s;
        }
        at += stored;
    }
    EXPECT_EQ(at, payload.size());
    return streams;
}

// The payload's header (counts) with these streams, each stored as it is or, where `zstd` says, as a
// zstd frame where that is smaller (or as the frame given in `frames`).
std::vector<uint8_t> with_streams(const std::vector<uint8_t>& payload, const std::vector<std::vector<uint8_t>>& streams,
                                  bool zstd, const std::vector<std::vector<uint8_t>>& frames = {}) {
    std::vector<uint8_t> out(payload.begin(), payload.begin() + kStreamsAt);
    for (int s = 0; s < kStreams; ++s) {
        std::vector<uint8_t> stored = streams[s];
        if (!frames.empty() && !frames[s].empty()) stored = frames[s];
        else if (zstd && !stored.empty() && zstd_frame(stored).size() < stored.size()) stored = zstd_frame(stored);
        put<uint32_t>(out, kStreamSizesAt + 8 * s, uint32_t(streams[s].size()));
        put<uint32_t>(out, kStreamSizesAt + 8 * s + 4, uint32_t(stored.size()));
        out.insert(out.end(), stored.begin(), stored.end());
    }
    return out;
}

// The same payload with every stream stored as it is: for editing a stream in place.
std::vector<uint8_t> stored_payload(const std::vector<uint8_t>& payload) {
    return with_streams(payload, unpacked_streams(payload), false);
}

// A regular grid of side² vertices at spacing 1000, heights h(x, y), its two triangles per square, the
// parents of a grid half as fine, and normals that are the area-weighted ones of its own triangles (as
// the builder computes them inside a cube).
template <class Height>
CubeData grid_cube(uint32_t side, Height h) {
    CubeData c;
    for (uint32_t y = 0; y < side; ++y)
        for (uint32_t x = 0; x < side; ++x) {
            c.vertices.positions.insert(c.vertices.positions.end(),
                                        {uint16_t(20000 + 1000 * x), uint16_t(20000 + 1000 * y), uint16_t(32768 + h(x, y))});
            c.parent_vertex.push_back((y / 2) * (side / 2) + x / 2);
        }
    for (uint32_t y = 0; y + 1 < side; ++y)
        for (uint32_t x = 0; x + 1 < side; ++x) {
            const uint32_t a = y * side + x;
            c.indices.insert(c.indices.end(), {a, a + 1, a + side + 1, a, a + side + 1, a + side});
        }
    c.child_triangle_counts[0] = c.triangle_count();
    std::vector<std::array<float, 3>> sums(side * side, {0, 0, 0});
    for (size_t t = 0; t < c.indices.size(); t += 3) {
        float p[3][3];
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) p[k][a] = float(c.vertices.positions[3 * c.indices[t + k] + a]);
        const float e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
        const float e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
        const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) sums[c.indices[t + k]][a] += n[a];
    }
    for (const auto& s : sums) {
        const auto n = encode_normal(s[0], s[1], s[2]);
        c.vertices.normals.insert(c.vertices.normals.end(), n.begin(), n.end());
    }
    return c;
}

// ---- CRC-32C ----------------------------------------------------------------------------------------

uint32_t crc32c_bitwise(const uint8_t* p, size_t n) {
    uint32_t crc = ~0u;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (crc & 1 ? 0x82F63B78u : 0u);
    }
    return ~crc;
}

TEST(Crc32c, CheckValueAndEmpty) {
    const char* check = "123456789";
    EXPECT_EQ(crc32c(check, 9), 0xE3069283u);
    EXPECT_EQ(crc32c(nullptr, 0), 0u);
    EXPECT_EQ(crc32c(check, 0), 0u);
}

TEST(Crc32c, MatchesTheBitwiseDefinitionAtEveryLengthAndAlignment) {
    std::vector<uint8_t> data(300);
    std::mt19937 rng(3);
    for (uint8_t& b : data) b = uint8_t(rng());
    for (size_t offset = 0; offset < 8; ++offset)
        for (size_t n = 0; n + offset <= data.size(); n += 1 + n / 8)
            ASSERT_EQ(crc32c(data.data() + offset, n), crc32c_bitwise(data.data() + offset, n))
                << "offset " << offset << " length " << n;
    // One flipped bit changes it.
    uint32_t before = crc32c(data.data(), data.size());
    data[150] ^= 0x10;
    EXPECT_NE(crc32c(data.data(), data.size()), before);
}

TEST(Crc32c, CombineEqualsTheCrcOfTheConcatenation) {
    std::vector<uint8_t> data(9000);
    std::mt19937 rng(5);
    for (uint8_t& b : data) b = uint8_t(rng());
    std::fill(data.begin() + 5000, data.begin() + 9000, 0);  // zero runs, as the padding between levels
    for (size_t split : {size_t(0), size_t(1), size_t(7), size_t(4096), size_t(5000), size_t(8999), size_t(9000)}) {
        const uint32_t a = crc32c(data.data(), split), b = crc32c(data.data() + split, data.size() - split);
        EXPECT_EQ(crc32c_combine(a, b, data.size() - split), crc32c(data.data(), data.size())) << "split at " << split;
    }
}

// ---- normals ----------------------------------------------------------------------------------------

double angle_degrees(std::array<float, 3> a, std::array<double, 3> b) {
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return std::acos(std::clamp(d, -1.0, 1.0)) * 180.0 / std::numbers::pi;
}

TEST(NormalEncoding, RoundTripWithinATenthOfADegree) {
    std::vector<std::array<double, 3>> directions = {
        {0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0},  // poles and axes
        {1, 1, 1}, {-1, 1, -1}, {1, -1, -1}, {-1, -1, -1}, {1, 1, -1},        // octant centres
        {1, 1, 0}, {1, -1, 0}, {-1, 0, -1}, {0, 1, -1}, {0, -1, 1},            // octahedron edges
        {1e-4, 0, -1}, {-1e-4, 1e-4, -1}, {1e-4, 0, 1}, {1, 0, -1e-4},        // near the folds
    };
    const int fibonacci = 4000;  // spread over the whole sphere, half of it in z < 0
    for (int i = 0; i < fibonacci; ++i) {
        double z = 1 - (2 * i + 1.0) / fibonacci, r = std::sqrt(1 - z * z), phi = i * std::numbers::pi * (3 - std::sqrt(5.0));
        directions.push_back({r * std::cos(phi), r * std::sin(phi), z});
    }
    double worst = 0;
    for (auto d : directions) {
        double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        for (double& x : d) x /= len;
        auto code = encode_normal(float(d[0]), float(d[1]), float(d[2]));
        for (int16_t c : code) {
            EXPECT_GE(c, -2047);
            EXPECT_LE(c, 2047);
        }
        auto back = decode_normal(code[0], code[1]);
        EXPECT_NEAR(back[0] * back[0] + back[1] * back[1] + back[2] * back[2], 1.0f, 1e-5f);
        double angle = angle_degrees(back, d);
        worst = std::max(worst, angle);
        EXPECT_LT(angle, 0.1) << d[0] << " " << d[1] << " " << d[2];
        // Length does not matter.
        auto scaled = decode_normal(encode_normal(float(7 * d[0]), float(7 * d[1]), float(7 * d[2]))[0],
                                    encode_normal(float(7 * d[0]), float(7 * d[1]), float(7 * d[2]))[1]);
        EXPECT_LT(angle_degrees(scaled, d), 0.1);
    }
    EXPECT_LT(worst, 0.06);  // FORMAT.md §7: about 0.04°
    // Exact at the poles and axes.
    EXPECT_EQ(decode_normal(encode_normal(0, 0, -1)[0], encode_normal(0, 0, -1)[1]), (std::array<float, 3>{0, 0, -1}));
    EXPECT_EQ(decode_normal(encode_normal(0, 0, 1)[0], encode_normal(0, 0, 1)[1]), (std::array<float, 3>{0, 0, 1}));
    EXPECT_EQ(decode_normal(encode_normal(-1, 0, 0)[0], encode_normal(-1, 0, 0)[1]), (std::array<float, 3>{-1, 0, 0}));
}

TEST(NormalEncoding, ZeroVectorStoresAsUp) {
    EXPECT_EQ(encode_normal(0, 0, 0), (std::array<int16_t, 2>{0, 0}));
    EXPECT_EQ(decode_normal(0, 0), (std::array<float, 3>{0, 0, 1}));
}

// ---- lattice coordinates ----------------------------------------------------------------------------

TEST(LatticeCoordinate, NeighbouringCellsDecodeBitIdentically) {
    HlodHeader h;
    h.origin[0] = -3.25, h.origin[1] = 1.0 / 3.0, h.origin[2] = 1234.5678;
    h.root_size = 7.3;
    int checked = 0;
    for (uint32_t level : {1u, 3u, 8u, 15u})
        for (int axis = 0; axis < 3; ++axis) {
            const uint32_t cells = 1u << level;
            for (uint32_t cell : {1u, cells / 2, cells - 1}) {
                if (cell == 0) continue;
                // stored ≥ 2^15 in `cell` is the same lattice point as stored − 2^15 in cell + 1; stored < 2^15
                // in `cell` is stored + 2^15 in cell − 1.
                for (uint16_t stored : {uint16_t(32768), uint16_t(40000), uint16_t(49152), uint16_t(65535)}) {
                    float here = decode_coordinate(h, axis, level, cell, stored);
                    float next = decode_coordinate(h, axis, level, cell + 1, uint16_t(stored - 32768));
                    EXPECT_EQ(std::bit_cast<uint32_t>(here), std::bit_cast<uint32_t>(next))
                        << "level " << level << " cell " << cell << " stored " << stored;
                    ++checked;
                }
                for (uint16_t stored : {uint16_t(0), uint16_t(16384), uint16_t(20000), uint16_t(32767)}) {
                    float here = decode_coordinate(h, axis, level, cell, stored);
                    float previous = decode_coordinate(h, axis, level, cell - 1, uint16_t(stored + 32768));
                    EXPECT_EQ(std::bit_cast<uint32_t>(here), std::bit_cast<uint32_t>(previous))
                        << "level " << level << " cell " << cell << " stored " << stored;
                    ++checked;
                }
            }
        }
    EXPECT_GT(checked, 100);
}

TEST(LatticeCoordinate, DecodesToOriginPlusLatticeSteps) {
    HlodHeader h;
    h.origin[0] = -3.25, h.origin[1] = 0.5, h.origin[2] = 10;
    h.root_size = 8;
    // 2^14 is the cell's lower corner, 2^14 + 2^15 its upper one.
    for (uint32_t level : {0u, 2u, 5u}) {
        const double s = h.cube_size(level);
        for (uint32_t cell : {0u, (1u << level) - 1}) {
            EXPECT_FLOAT_EQ(decode_coordinate(h, 0, level, cell, 16384), float(-3.25 + cell * s));
            EXPECT_FLOAT_EQ(decode_coordinate(h, 1, level, cell, 16384 + 32768), float(0.5 + (cell + 1) * s));
            EXPECT_FLOAT_EQ(decode_coordinate(h, 2, level, cell, 16384 + 16384), float(10 + (cell + 0.5) * s));
            EXPECT_NEAR(decode_coordinate(h, 2, level, cell, 0), 10 + (cell - 0.5) * s, 1e-5);  // half a cell below
        }
        EXPECT_FLOAT_EQ(h.lattice_step(level), float(s / 32768));
    }
}

// ---- cube payloads ----------------------------------------------------------------------------------

TEST(CubePayload, RoundTripWithEveryFlagCombination) {
    for (uint32_t flags : {0u, uint32_t(kHasColors), uint32_t(kHasUvs), uint32_t(kHasColors | kHasUvs)}) {
        CubeData cube = make_cube(40, 11, 57, flags);
        std::vector<uint8_t> payload = encode_cube(cube, flags);
        CubeData back = decode_cube(payload, node_for(cube), flags);
        SCOPED_TRACE("flags " + std::to_string(flags));
        expect_same_cube(back, cube, flags);

        // The layout of FORMAT.md §5: counts, child counts, each stream's size and stored size, the streams.
        ASSERT_GE(payload.size(), kStreamsAt);
        EXPECT_EQ(get<uint32_t>(payload, kVertexCountAt), 40u);
        EXPECT_EQ(get<uint32_t>(payload, kTriangleCountAt), 57u);
        EXPECT_EQ(get<uint32_t>(payload, kChildCountsAt + 4 * 5), cube.child_triangle_counts[5]);
        EXPECT_EQ(stream_size(payload, kPositionStream), 3 * 40u);
        EXPECT_EQ(stream_size(payload, kNormalStream), 40u);
        EXPECT_EQ(stream_size(payload, kParentStream), 40u);
        EXPECT_GT(stream_size(payload, kIndexStream), 0u);
        EXPECT_GT(stream_size(payload, kBitStream), 0u);
        EXPECT_EQ(stream_size(payload, kColorStream) > 0, bool(flags & kHasColors));
        EXPECT_EQ(stream_size(payload, kUvStream) > 0, bool(flags & kHasUvs));
        const auto streams = unpacked_streams(payload);
        EXPECT_EQ(streams[kIndexStream][0], 0xE0) << "index codec version 0";
        if (flags & kHasColors) {
            EXPECT_EQ(streams[kColorStream][0], 0xA0) << "vertex codec version 0";
        }

        // Stored or zstd, every stream decodes to the same cube.
        expect_same_cube(decode_cube(with_streams(payload, streams, false), node_for(cube), flags), cube, flags);
        const std::vector<uint8_t> packed = with_streams(payload, streams, true);
        EXPECT_LT(stored_size(packed, kPositionStream), stream_size(packed, kPositionStream)) << "zstd-packed";
        expect_same_cube(decode_cube(packed, node_for(cube), flags), cube, flags);
    }
}

// A regular flat grid: every vertex that a triangle across an edge predicts (all but the first row and
// the first of each other row) is exactly its parallelogram, residual class 0.
TEST(CubePayload, PositionsThatTheTrianglesPredictCostNothing) {
    constexpr uint32_t side = 20;
    const CubeData flat = grid_cube(side, [](uint32_t, uint32_t) { return 0.0; });
    const std::vector<uint8_t> payload = encode_cube(flat, 0);
    expect_same_cube(decode_cube(payload, node_for(flat), 0), flat, 0);
    const std::vector<uint8_t> classes = unpacked_streams(payload)[kPositionStream];
    const size_t nonzero = size_t(std::count_if(classes.begin(), classes.end(), [](uint8_t c) { return c != 0; }));
    EXPECT_LE(nonzero, 3 * (2 * side)) << "of " << classes.size();
    // The same vertices in a random order cost far more.
    CubeData shuffled = flat;
    std::mt19937 rng(3);
    for (size_t v = 0; v < flat.vertex_count(); ++v) {
        const size_t w = rng() % flat.vertex_count();
        for (int a = 0; a < 3; ++a) std::swap(shuffled.vertices.positions[3 * v + a], shuffled.vertices.positions[3 * w + a]);
    }
    EXPECT_LT(4 * payload.size(), encode_cube(shuffled, 0).size());
}

// Normals that the triangles predict cost far less than the same patch with unrelated normals.
TEST(CubePayload, NormalsThatTheTrianglesPredictCostLittle) {
    const CubeData smooth = grid_cube(24, [](uint32_t x, uint32_t y) { return 4000 * std::sin(0.2 * x) * std::cos(0.15 * y); });
    CubeData unrelated = smooth;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> component(-1, 1);
    for (size_t v = 0; v < smooth.vertex_count(); ++v) {
        const auto n = encode_normal(component(rng), component(rng), component(rng));
        std::copy(n.begin(), n.end(), unrelated.vertices.normals.begin() + 2 * v);
    }
    const std::vector<uint8_t> predicted = encode_cube(smooth, 0), random = encode_cube(unrelated, 0);
    expect_same_cube(decode_cube(predicted, node_for(smooth), 0), smooth, 0);
    expect_same_cube(decode_cube(random, node_for(unrelated), 0), unrelated, 0);
    // Positions are the same in both, so the difference is the normals' classes and low bits.
    const size_t predicted_bytes = predicted.size() - stored_size(predicted, kPositionStream);
    const size_t random_bytes = random.size() - stored_size(random, kPositionStream);
    EXPECT_LT(2 * predicted_bytes, random_bytes) << predicted_bytes << " vs " << random_bytes;
    EXPECT_LT(stored_size(predicted, kNormalStream), stream_size(predicted, kNormalStream)) << "zstd-packed";
}

// Parents of a grid half as fine: most repeat a neighbour's or are the next new one.
TEST(CubePayload, ParentsThatRepeatANeighboursCostLittle) {
    const CubeData grid = grid_cube(24, [](uint32_t, uint32_t) { return 0.0; });
    const std::vector<uint8_t> payload = encode_cube(grid, 0);
    const std::vector<uint8_t> symbols = unpacked_streams(payload)[kParentStream];
    // Symbols 0‥3 need no low bits (FORMAT.md §9).
    const size_t explicit_parents = size_t(std::count_if(symbols.begin(), symbols.end(), [](uint8_t s) { return s >= 4; }));
    EXPECT_LT(explicit_parents * 4, symbols.size());
}

TEST(CubePayload, RoundTripWithoutTriangles) {
    for (uint32_t flags : {0u, uint32_t(kHasColors | kHasUvs)}) {
        // Extra vertices only (FORMAT.md §9): vertices with their parents, no triangles.
        CubeData extras = make_cube(3, 2, 0, flags);
        std::vector<uint8_t> payload = encode_cube(extras, flags);
        EXPECT_EQ(stream_size(payload, kIndexStream), 0u);  // empty index stream
        CubeData back = decode_cube(payload, node_for(extras), flags);
        expect_same_cube(back, extras, flags);
        EXPECT_EQ(back.triangle_count(), 0u);

        // Nothing at all: just the header, every stream empty.
        CubeData empty;
        payload = encode_cube(empty, flags);
        EXPECT_EQ(payload.size(), kStreamsAt);
        for (int s = 0; s < kStreams; ++s) EXPECT_EQ(stream_size(payload, s) + stored_size(payload, s), 0u);
        back = decode_cube(payload, node_for(empty), flags);
        EXPECT_EQ(back.vertex_count(), 0u);
        EXPECT_TRUE(back.parent_vertex.empty());
        EXPECT_TRUE(back.indices.empty());
    }
}

// ---- grid payloads (codec 3, FORMAT.md §5.1) --------------------------------------------------------

struct GridCube {
    CubeData cube;
    GridPlacement grid;
};

// A terrain cube as the builder makes one: the samples of a width × height window at column 10, row 20
// of its level, less those `hole` names; each cell's triangle t where its corners are samples, in child
// group octant(c, r, t) (−1: not this cube's); heights h(c, r) on multiples of 2^shift; parents the
// coarser grid's (c/2, r/2), numbered row-major; normals as the builder computes them (the lattice sums
// over the level's triangles: here those of the cube, and a few vertices off by some steps, as on a
// cube's border).
template <class Hole, class Octant, class Height>
GridCube terrain_cube(uint32_t width, uint32_t height, uint32_t shift, bool rows_run_north, Hole hole, Octant octant, Height h) {
    GridCube g;
    g.grid.height_shift = shift, g.grid.rows_run_north = rows_run_north;
    CubeData& c = g.cube;
    std::vector<uint32_t> at(size_t(width) * height, ~0u);
    for (uint32_t r = 0; r < height; ++r)
        for (uint32_t col = 0; col < width; ++col) {
            if (hole(col, r)) continue;
            at[size_t(r) * width + col] = c.vertex_count();
            const uint32_t z = (uint32_t(32768 + h(col, r)) >> shift) << shift;
            c.vertices.positions.insert(c.vertices.positions.end(), {uint16_t(16384 + 512 * col), uint16_t(16384 + 512 * (rows_run_north ? r : height - 1 - r)), uint16_t(z)});
            c.parent_vertex.push_back((r / 2) * ((width + 1) / 2) + col / 2);
            g.grid.samples.push_back({10 + col, 20 + r});
        }
    for (int o = 0; o < 8; ++o)
        for (uint32_t r = 0; r + 1 < height; ++r)
            for (uint32_t col = 0; col + 1 < width; ++col)
                for (int t = 0; t < 2; ++t) {
                    if (octant(col, r, t) != o) continue;
                    const uint32_t min = at[size_t(r) * width + col], max = at[size_t(r + 1) * width + col + 1];
                    const uint32_t side = t == 0 ? at[size_t(r + 1) * width + col] : at[size_t(r) * width + col + 1];
                    if (min == ~0u || max == ~0u || side == ~0u) continue;
                    const bool turn = (t == 0) != rows_run_north;
                    c.indices.insert(c.indices.end(), {min, turn ? side : max, turn ? max : side});
                    c.child_triangle_counts[size_t(o)]++;
                }
    std::vector<std::array<uint64_t, 3>> sums(c.vertex_count(), {0, 0, 0});
    for (size_t t = 0; t < c.indices.size(); t += 3) {
        int64_t p[3][3];
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) p[k][a] = c.vertices.positions[3 * c.indices[t + size_t(k)] + size_t(a)];
        const int64_t e[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]}, f[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
        const int64_t n[3] = {e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]};
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) sums[c.indices[t + size_t(k)]][size_t(a)] += uint64_t(n[a]);
    }
    for (uint32_t v = 0; v < c.vertex_count(); ++v) {
        std::array<int16_t, 2> n = lattice_normal(sums[v]);
        if (v % 7 == 3) n[0] = int16_t(std::clamp(n[0] + 5, -2047, 2047));
        c.vertices.normals.insert(c.vertices.normals.end(), n.begin(), n.end());
    }
    return g;
}

// Rolling ground, a hole with an isolated sample inside it (a vertex no triangle uses, as an extra
// vertex of §9 is), the four quadrants in four child groups and two heights' halves in two more.
GridCube rolling_cube(uint32_t side, uint32_t shift, bool rows_run_north) {
    auto hole = [](uint32_t c, uint32_t r) { return c >= 3 && c <= 5 && r >= 2 && r <= 4 && !(c == 4 && r == 3); };
    auto octant = [side](uint32_t c, uint32_t r, int t) { return int(c >= side / 2) + 2 * int(r >= side / 2) + 4 * ((c + r + uint32_t(t)) % 5 == 0); };
    auto height = [](uint32_t c, uint32_t r) { return int(900 * std::sin(0.3 * c) * std::cos(0.23 * r) + 37 * ((c * 7 + r * 3) % 5)); };
    return terrain_cube(side, side, shift, rows_run_north, hole, octant, height);
}

HlodNode grid_node(const CubeData& c) { return node_for(c); }

TEST(GridPayload, RoundTripsAsTheBuilderMadeIt) {
    auto none = [](uint32_t, uint32_t) { return false; };
    auto flat = [](uint32_t, uint32_t) { return 0; };
    auto first = [](uint32_t, uint32_t, int) { return 0; };
    std::vector<GridCube> cases;
    for (const uint32_t shift : {0u, 3u, 14u})
        for (const bool north : {false, true}) cases.push_back(rolling_cube(17, shift, north));
    cases.push_back(terrain_cube(1, 1, 0, false, none, first, flat));   // one vertex
    cases.push_back(terrain_cube(9, 1, 2, false, none, first, flat));   // a row: no cells
    cases.push_back(terrain_cube(2, 2, 0, true, none, [](uint32_t, uint32_t, int t) { return t == 1 ? 7 : -1; }, flat));
    for (const GridCube& g : cases) {
        SCOPED_TRACE(::testing::Message() << g.grid.samples.size() << " vertices, shift " << g.grid.height_shift);
        const std::vector<uint8_t> payload = encode_grid_cube(g.cube, g.grid);
        const CubeData back = decode_cube(payload, grid_node(g.cube), 0, kGridPayloadCodec);
        EXPECT_EQ(back.vertices.positions, g.cube.vertices.positions);
        EXPECT_EQ(back.vertices.normals, g.cube.vertices.normals);
        EXPECT_EQ(back.parent_vertex, g.cube.parent_vertex);
        EXPECT_EQ(back.child_triangle_counts, g.cube.child_triangle_counts);
        EXPECT_EQ(back.indices, g.cube.indices) << "the same triangles in the same order, corners unrotated";
        // Read as a mesh payload, the grid stream is no index stream.
        EXPECT_THROW(decode_cube(payload, grid_node(g.cube), 0, kCubePayloadCodec), std::runtime_error);
    }
}

// The grid costs a few bytes where the index codec spends about a byte a triangle, and a coarser height
// lattice saves about a bit a vertex per step of shift.
TEST(GridPayload, CostsFarLessThanTheMeshPayloadOfTheSameCube) {
    const GridCube g = rolling_cube(65, 0, false);
    const std::vector<uint8_t> grid = encode_grid_cube(g.cube, g.grid), mesh = encode_cube(g.cube, 0);
    EXPECT_LT(8 * stored_size(grid, kIndexStream), stored_size(mesh, kIndexStream));
    EXPECT_LT(2 * grid.size(), mesh.size()) << grid.size() << " against " << mesh.size();
    const GridCube coarse = rolling_cube(65, 4, false);
    EXPECT_LT(encode_grid_cube(coarse.cube, coarse.grid).size() + 3 * g.cube.vertex_count() / 8, grid.size());
}

// On a plane every height is predicted exactly, along the first row and column too (the line through
// the last two), but for the first vertex and the second of the row and of the column.
TEST(GridPayload, APlaneCostsNoHeightResidualsButAtItsCorner) {
    auto none = [](uint32_t, uint32_t) { return false; };
    auto first = [](uint32_t, uint32_t, int) { return 0; };
    const GridCube plane = terrain_cube(17, 13, 0, false, none, first, [](uint32_t c, uint32_t r) { return int(100 + 40 * c + 25 * r); });
    const std::vector<uint8_t> payload = encode_grid_cube(plane.cube, plane.grid);
    const std::vector<uint8_t> classes = unpacked_streams(payload)[kPositionStream];
    const uint32_t n = plane.cube.vertex_count();
    ASSERT_EQ(classes.size(), 3 * size_t(n));
    const long heights = std::count_if(classes.begin() + 2 * n, classes.end(), [](uint8_t c) { return c != 0; });
    EXPECT_EQ(heights, 3) << "nonzero height residuals (planar stream 1: the z classes last)";
    const long across = std::count_if(classes.begin() + 1, classes.begin() + 2 * n, [](uint8_t c) { return c != 0; });
    EXPECT_LE(across, 3) << "x and y follow the grid";
}

TEST(GridPayload, ABuildersMistakeIsALogicError) {
    GridCube g = rolling_cube(9, 2, false);
    GridCube swapped = g;
    std::swap(swapped.cube.indices[0], swapped.cube.indices[3]);  // corners of two triangles mixed
    EXPECT_THROW(encode_grid_cube(swapped.cube, swapped.grid), std::logic_error);
    GridCube reordered = g;
    std::rotate(reordered.cube.indices.begin(), reordered.cube.indices.begin() + 3, reordered.cube.indices.begin() + 6);
    EXPECT_THROW(encode_grid_cube(reordered.cube, reordered.grid), std::logic_error);
    GridCube off_lattice = g;
    off_lattice.cube.vertices.positions[2] += 1;
    EXPECT_THROW(encode_grid_cube(off_lattice.cube, off_lattice.grid), std::logic_error);
    GridCube out_of_order = g;
    std::swap(out_of_order.grid.samples[0], out_of_order.grid.samples[1]);
    EXPECT_THROW(encode_grid_cube(out_of_order.cube, out_of_order.grid), std::logic_error);
}

class BadGridPayload : public ::testing::Test {
protected:
    void SetUp() override {
        g = rolling_cube(12, 2, false);
        node = grid_node(g.cube);
        payload = encode_grid_cube(g.cube, g.grid);
        streams = unpacked_streams(payload);
        ASSERT_NO_THROW(decode_cube(payload, node, 0, kGridPayloadCodec));
    }
    void expect_rejected(const std::vector<uint8_t>& bytes, const std::string& what) {
        try {
            decode_cube(bytes, node, 0, kGridPayloadCodec);
            ADD_FAILURE() << "accepted; expected \"" << what << "\"";
        } catch (const std::runtime_error& e) {
            EXPECT_THAT(e.what(), HasSubstr(describe_cube(node)));
            EXPECT_THAT(e.what(), HasSubstr(what));
        }
    }
    // The payload with its grid stream's header fields replaced, or its runs.
    std::vector<uint8_t> with_grid(std::vector<uint8_t> grid) const {
        auto edited = streams;
        edited[kIndexStream] = std::move(grid);
        return with_streams(payload, edited, false);
    }
    std::vector<uint8_t> grid_with(size_t at, std::vector<uint8_t> bytes) const {
        std::vector<uint8_t> grid = streams[kIndexStream];
        std::copy(bytes.begin(), bytes.end(), grid.begin() + long(at));
        return grid;
    }
    GridCube g;
    HlodNode node;
    std::vector<uint8_t> payload;
    std::vector<std::vector<uint8_t>> streams;
};

TEST_F(BadGridPayload, HeaderFieldsOutOfRange) {
    expect_rejected(with_grid(grid_with(0, {0, 0})), "a grid of 0 × 12 samples");
    expect_rejected(with_grid(grid_with(2, {0x01, 0x10})), "a grid of 12 × 4097 samples");
    expect_rejected(with_grid(grid_with(4, {15})), "height shift 15 past 14");
    expect_rejected(with_grid(grid_with(5, {2})), "unknown grid flags");
}

TEST_F(BadGridPayload, RunsThatDoNotCoverTheGrid) {
    // One sample run of all 144 samples absent, then the cells: no vertex where the counts say 137.
    std::vector<uint8_t> absent(streams[kIndexStream].begin(), streams[kIndexStream].begin() + 6);
    absent.insert(absent.end(), {0x90, 0x01, 0x00, 0x79});
    expect_rejected(with_grid(absent), "grid has fewer vertices than its count");
    // Every sample present: more vertices than the count.
    std::vector<uint8_t> all(streams[kIndexStream].begin(), streams[kIndexStream].begin() + 6);
    all.insert(all.end(), {0x00, 0x90, 0x01, 0x00, 0x79});
    expect_rejected(with_grid(all), "more vertices than its count");
    std::vector<uint8_t> longer = streams[kIndexStream];
    longer.insert(longer.end(), {0x11, 0x01});
    expect_rejected(with_grid(longer), "grid stream longer than its grid");
    std::vector<uint8_t> shorter(streams[kIndexStream].begin(), streams[kIndexStream].end() - 2);
    expect_rejected(with_grid(shorter), "ends early");
}

TEST_F(BadGridPayload, CellsThatNameNoGroupOrLackACorner) {
    std::vector<uint8_t> cells(streams[kIndexStream]);
    // The last cell run's value: a group past 8.
    std::vector<uint8_t> bad = cells;
    bad[bad.size() - 2] = 0x9A;
    expect_rejected(with_grid(bad), "names no child group");
    // All 121 cells with both triangles, in group 0: the hole's cells lack corners.
    std::vector<uint8_t> full(cells.begin(), cells.begin() + 6);
    const std::vector<uint8_t> samples(cells.begin() + 6, cells.end());
    size_t sample_runs = 0;  // the sample runs' bytes: varints summing to 144
    for (uint64_t covered = 0; covered < 144;) {
        uint64_t value = 0;
        for (int s = 0;; s += 7) {
            const uint8_t b = samples[sample_runs++];
            value |= uint64_t(b & 0x7F) << s;
            if (!(b & 0x80)) break;
        }
        covered += value;
    }
    full.insert(full.end(), samples.begin(), samples.begin() + long(sample_runs));
    std::vector<uint8_t> zero_run = full;
    full.insert(full.end(), {0x11, 121});
    expect_rejected(with_grid(full), "lacks a corner");
    zero_run.insert(zero_run.end(), {0x11, 0});
    expect_rejected(with_grid(zero_run), "a cell run of length 0");
}

TEST_F(BadGridPayload, CountsABuilderCouldNotWrite) {
    // More triangles than two a vertex, caught before anything is allocated for them.
    std::vector<uint8_t> bytes = payload;
    const uint32_t triangles = 2 * node.vertex_count + 1;
    put<uint32_t>(bytes, kTriangleCountAt, triangles);
    put<uint32_t>(bytes, kChildCountsAt, triangles);
    for (int o = 1; o < 8; ++o) put<uint32_t>(bytes, kChildCountsAt + 4 * size_t(o), 0);
    HlodNode more = node;
    more.triangle_count = triangles;
    try {
        decode_cube(bytes, more, 0, kGridPayloadCodec);
        ADD_FAILURE() << "accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr("counts larger than the payload could hold"));
    }
    // Groups whose counts disagree with the grid's cells.
    bytes = payload;
    put<uint32_t>(bytes, kChildCountsAt, g.cube.child_triangle_counts[0] + 1);
    put<uint32_t>(bytes, kChildCountsAt + 4, g.cube.child_triangle_counts[1] - 1);
    expect_rejected(bytes, "child group 1 has more triangles than its count");
}

// Any byte of a grid payload changed, or its end cut off: refused or decoded, never a crash (the fuzz
// target goes further).
TEST_F(BadGridPayload, AnyDamageIsRefusedOrDecoded) {
    for (size_t keep = 0; keep < payload.size(); keep += 7)
        EXPECT_THROW(decode_cube(std::vector<uint8_t>(payload.begin(), payload.begin() + long(keep)), node, 0, kGridPayloadCodec),
                     std::runtime_error);
    const std::vector<uint8_t> stored = stored_payload(payload);
    for (size_t at = 0; at < stored.size(); ++at)
        for (const uint8_t flip : {uint8_t(1), uint8_t(0x80), uint8_t(0xFF)}) {
            std::vector<uint8_t> bytes = stored;
            bytes[at] ^= flip;
            try {
                decode_cube(bytes, node, 0, kGridPayloadCodec);
            } catch (const std::runtime_error&) {
            }
        }
}

class BadPayload : public ::testing::Test {
protected:
    void SetUp() override {
        cube = make_cube(24, 7, 30, flags);
        node = node_for(cube);
        payload = encode_cube(cube, flags);
        streams = unpacked_streams(payload);
        ASSERT_NO_THROW(decode_cube(payload, node, flags));
    }
    // Decoding throws std::runtime_error naming the cube and containing `what`.
    void expect_rejected(const std::vector<uint8_t>& bytes, const HlodNode& n, const std::string& what) {
        try {
            decode_cube(bytes, n, flags);
            ADD_FAILURE() << "accepted; expected \"" << what << "\"";
        } catch (const std::runtime_error& e) {
            EXPECT_THAT(e.what(), HasSubstr(describe_cube(n)));
            EXPECT_THAT(e.what(), HasSubstr(what));
        }
    }
    // The payload with stream s replaced (stored as it is).
    std::vector<uint8_t> with_stream(int s, const std::vector<uint8_t>& bytes) const {
        auto edited = streams;
        edited[s] = bytes;
        return with_streams(payload, edited, false);
    }
    const uint32_t flags = kHasColors | kHasUvs;
    CubeData cube;
    HlodNode node;
    std::vector<uint8_t> payload;
    std::vector<std::vector<uint8_t>> streams;
};

TEST_F(BadPayload, Truncated) {
    for (size_t keep : {size_t(0), size_t(10), kStreamSizesAt + 8, kStreamsAt, payload.size() / 2, payload.size() - 1}) {
        std::vector<uint8_t> cut(payload.begin(), payload.begin() + keep);
        EXPECT_THROW(decode_cube(cut, node, flags), std::runtime_error) << "kept " << keep << " bytes";
    }
    expect_rejected(std::vector<uint8_t>(payload.begin(), payload.begin() + kStreamsAt - 4), node, "ends early");
    expect_rejected(std::vector<uint8_t>(payload.begin(), payload.end() - 1), node, "ends early");
}

TEST_F(BadPayload, CountsDisagreeWithTheNode) {
    HlodNode more_vertices = node;
    more_vertices.vertex_count++;
    expect_rejected(payload, more_vertices, "counts disagree");
    HlodNode fewer_triangles = node;
    fewer_triangles.triangle_count--;
    expect_rejected(payload, fewer_triangles, "counts disagree");
    // The payload's own count edited instead: node and payload disagree just the same.
    std::vector<uint8_t> edited = payload;
    put<uint32_t>(edited, kTriangleCountAt, 31);
    expect_rejected(edited, node, "counts disagree");
}

TEST_F(BadPayload, ChildCountsDoNotAddUp) {
    std::vector<uint8_t> edited = payload;
    put<uint32_t>(edited, kChildCountsAt + 4 * 3, 1);  // group 3 was empty
    expect_rejected(edited, node, "do not add up");
    edited = payload;
    put<uint32_t>(edited, kChildCountsAt, get<uint32_t>(payload, kChildCountsAt) - 1);
    expect_rejected(edited, node, "do not add up");
}

TEST_F(BadPayload, StreamSizesThatDoNotMatchTheStreams) {
    // Positions, normals and parents hold exactly 3, 1 and 1 bytes per vertex; colours and UVs are present
    // exactly when the flags say so.
    auto longer = streams[kPositionStream];
    longer.push_back(0);
    expect_rejected(with_stream(kPositionStream, longer), node, "stream sizes disagree with the counts");
    expect_rejected(with_stream(kParentStream, {}), node, "stream sizes disagree with the counts");
    expect_rejected(with_stream(kUvStream, {}), node, "stream sizes disagree with the counts");
    // Stored bytes: after the last stream nothing may follow, and none may be stored in more bytes than it holds.
    std::vector<uint8_t> edited = payload;
    edited.push_back(0);
    expect_rejected(edited, node, "payload longer than its streams");
    edited = stored_payload(payload);
    put<uint32_t>(edited, kStreamSizesAt + 8 * kBitStream, stream_size(edited, kBitStream) - 1);
    expect_rejected(edited, node, "stored in more bytes than it holds");
    // zstd: the frame must hold exactly the stream's size.
    auto frames = std::vector<std::vector<uint8_t>>(kStreams);
    frames[kBitStream] = zstd_frame(std::vector<uint8_t>(streams[kBitStream].size() - 1, 0));
    expect_rejected(with_streams(payload, streams, false, frames), node, "zstd frame does not hold the stream's size");
}

TEST_F(BadPayload, CorruptZstdFrame) {
    auto frames = std::vector<std::vector<uint8_t>>(kStreams);
    frames[kPositionStream] = zstd_frame(streams[kPositionStream]);
    frames[kPositionStream].resize(frames[kPositionStream].size() - 3);  // its end cut off (the header still declares the size)
    expect_rejected(with_streams(payload, streams, false, frames), node, "zstd frame does not decode");
    frames[kPositionStream] = zstd_frame(streams[kPositionStream]);
    frames[kPositionStream][0] ^= 0xFF;  // no zstd magic
    expect_rejected(with_streams(payload, streams, false, frames), node, "zstd frame does not hold the stream's size");
}

TEST_F(BadPayload, StreamsFarLargerThanTheirFrame) {
    // A zstd frame of 64 KiB of zeros is a few dozen bytes: a reader refuses what would take more than 64
    // times its stored bytes, before allocating for it.
    auto edited = streams;
    edited[kBitStream] = std::vector<uint8_t>(65536, 0);
    auto frames = std::vector<std::vector<uint8_t>>(kStreams);
    frames[kBitStream] = zstd_frame(edited[kBitStream]);
    expect_rejected(with_streams(payload, edited, false, frames), node, "counts larger than the payload could hold");
}

TEST_F(BadPayload, StreamThatDoesNotDecode) {
    // The meshoptimizer streams overwritten with bytes no codec version starts with.
    for (int s : {kIndexStream, kColorStream, kUvStream}) {
        auto bytes = streams[s];
        bytes[0] = 0x00;
        expect_rejected(with_stream(s, bytes), node, s == kIndexStream ? "index stream does not decode" : "vertex stream does not decode");
    }
}

TEST_F(BadPayload, ResidualsPastTheirClasses) {
    auto classes = streams[kPositionStream];
    classes[4] = 17;
    expect_rejected(with_stream(kPositionStream, classes), node, "position residual class 17 past 16");
    auto symbols = streams[kParentStream];
    symbols[2] = 37;
    expect_rejected(with_stream(kParentStream, symbols), node, "parent symbol 37 past 36");
    // The first vertex of the walk has no corner before it whose parent it could repeat.
    symbols = streams[kParentStream];
    symbols[0] = 1;
    expect_rejected(with_stream(kParentStream, symbols), node, "names a corner not yet decoded");
}

TEST_F(BadPayload, BitStreamOfTheWrongLength) {
    auto bits = streams[kBitStream];
    bits.pop_back();
    expect_rejected(with_stream(kBitStream, bits), node, "bit stream ends early");
    bits = streams[kBitStream];
    bits.push_back(0);
    expect_rejected(with_stream(kBitStream, bits), node, "bit stream longer than its residuals");
}

TEST_F(BadPayload, NormalOutOfRange) {
    // A residual that puts the normal past ±2047 (FORMAT.md §7): the writer codes any int16 it is given.
    CubeData bad = cube;
    bad.vertices.normals[2 * 3] = 3000;
    expect_rejected(encode_cube(bad, flags), node, "normal of vertex 3 out of range");
}

TEST_F(BadPayload, ParentPastTheParentCubeIsRefusedWhenResolved) {
    // A payload that is well formed byte for byte but names vertex 7 of a 7-vertex parent cube.
    CubeData bad = cube;
    bad.parent_vertex[5] = 7;
    CubeData back = decode_cube(encode_cube(bad, flags), node, flags);
    const CubeData parent = make_cube(7, 7, 0, flags);
    try {
        resolve_parents(back, parent.vertices, describe_cube(node));
        ADD_FAILURE() << "resolved a parent past the parent cube";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr(describe_cube(node) + ": vertex 5's parent 7 lies past the parent cube's 7 vertices"));
    }
}

TEST(ResolveParents, CopiesEachDistinctParentOnceInFirstUseOrder) {
    const uint32_t flags = kHasColors | kHasUvs;
    const CubeData parent = make_cube(9, 9, 0, flags);
    CubeData child = make_cube(6, 9, 0, flags);
    child.parent_vertex = {4, 2, 4, 8, 2, 0};
    resolve_parents(child, parent.vertices, "child");
    EXPECT_EQ(child.parent_of, (std::vector<uint32_t>{0, 1, 0, 2, 1, 3}));
    ASSERT_EQ(child.parents.size(), 4u);
    const uint32_t from[4] = {4, 2, 8, 0};
    for (uint32_t p = 0; p < 4; ++p) {
        for (int a = 0; a < 3; ++a) EXPECT_EQ(child.parents.positions[3 * p + a], parent.vertices.positions[3 * from[p] + a]);
        for (int a = 0; a < 2; ++a) EXPECT_EQ(child.parents.normals[2 * p + a], parent.vertices.normals[2 * from[p] + a]);
        for (int a = 0; a < 4; ++a) EXPECT_EQ(child.parents.colors[4 * p + a], parent.vertices.colors[4 * from[p] + a]);
        for (int a = 0; a < 2; ++a) EXPECT_EQ(child.parents.uvs[2 * p + a], parent.vertices.uvs[2 * from[p] + a]);
    }
}

TEST_F(BadPayload, IndexPastTheVertices) {
    // The writer never codes such an index (it checks the triangles it codes), so the stream is made here.
    std::vector<uint32_t> bad = cube.indices;
    bad[3 * 12 + 1] = 24;
    std::vector<uint8_t> stream(meshopt_encodeIndexBufferBound(bad.size(), 25));
    stream.resize(meshopt_encodeIndexBuffer(stream.data(), stream.size(), bad.data(), bad.size()));
    expect_rejected(with_stream(kIndexStream, stream), node, "index 24 past its 24 vertices");
}

// ---- files ------------------------------------------------------------------------------------------

// A two-level model's worth of cubes: the root and two level-1 children, georeferenced.
struct SmallModel {
    HlodHeader header;
    std::vector<HlodNode> nodes;
    std::vector<CubeData> cubes;

    SmallModel() {
        header.flags = kHasColors;
        header.origin[0] = -1.5, header.origin[1] = 2.25, header.origin[2] = 1e-3;
        header.root_size = 3.75;
        header.max_level = 1;
        header.block_size = 8;
        header.sigma0 = 0.3f;
        header.error_q = 0.0123f;
        header.ratio = 0.3f;
        header.error_limit = 0.02f;
        header.input_vertices = 12345;
        header.input_triangles = 67890;
        header.source = "scan.ply";
        header.texture = "scan texture.png";
        header.geo_origin[0] = 500000.25, header.geo_origin[1] = 5400000.5, header.geo_origin[2] = 312.75;
        header.crs = "EPSG:32633";
        cubes = {make_cube(10, 10, 8, header.flags), make_cube(12, 4, 9, header.flags), make_cube(5, 2, 0, header.flags)};
        nodes = {node_for(cubes[0], 0, 0, 0, 0), node_for(cubes[1], 1, 1, 0, 1), node_for(cubes[2], 1, 0, 1, 0)};
        nodes[1].error = 0.01f, nodes[2].error = 0.02f;
    }
    // Writes the model, finest level first as the builder does; returns the writer's node table.
    std::vector<HlodNode> write(const std::filesystem::path& path) const {
        HlodWriter writer(path);
        for (size_t c = cubes.size(); c-- > 0;) writer.add_cube(nodes[c], encode_cube(cubes[c], header.flags));
        writer.finish(header);
        return writer.nodes();
    }
};

void expect_same_nodes(const std::vector<HlodNode>& got, const std::vector<HlodNode>& want) {
    ASSERT_EQ(got.size(), want.size());
    for (size_t i = 0; i < want.size(); ++i) {
        SCOPED_TRACE("node " + std::to_string(i));
        EXPECT_EQ(got[i].level, want[i].level);
        EXPECT_EQ(got[i].i, want[i].i);
        EXPECT_EQ(got[i].j, want[i].j);
        EXPECT_EQ(got[i].k, want[i].k);
        EXPECT_EQ(got[i].error, want[i].error);
        EXPECT_EQ(got[i].vertex_count, want[i].vertex_count);
        EXPECT_EQ(got[i].triangle_count, want[i].triangle_count);
        EXPECT_EQ(got[i].offset, want[i].offset);
        EXPECT_EQ(got[i].size, want[i].size);
        EXPECT_EQ(got[i].checksum, want[i].checksum);
    }
}

// FORMAT.md §4.1: MODL field offsets.
constexpr size_t kCodecAt = 0, kMaxLevelAt = 40, kSigma0At = 48, kNodeCountAt = 80, kSourceAt = 88;

// The byte offset of the section table entry tagged `tag` (0 if there is none).
size_t entry_of(const std::vector<uint8_t>& bytes, const char* tag) {
    for (size_t e = 0; e < get<uint32_t>(bytes, kSectionCountAt); ++e)
        if (std::memcmp(&bytes[kTableAt + kEntryBytes * e], tag, 4) == 0) return kTableAt + kEntryBytes * e;
    return 0;
}
uint64_t section_offset(const std::vector<uint8_t>& bytes, const char* tag) { return get<uint64_t>(bytes, entry_of(bytes, tag) + kEntryOffsetAt); }
uint64_t section_size(const std::vector<uint8_t>& bytes, const char* tag) { return get<uint64_t>(bytes, entry_of(bytes, tag) + kEntrySizeAt); }

TEST(HlodFileRoundTrip, HeaderNodesAndCubesComeBack) {
    test::TempDir dir;
    SmallModel model;
    std::vector<HlodNode> written = model.write(dir / "model.hlod");
    EXPECT_EQ(directory_entries(dir.path()), std::vector<std::string>{"model.hlod"});  // no temporary left

    // File order: the root, then level 1 in (k, j, i) order, whatever order the cubes were added in.
    const std::vector<size_t> file_order = {0, 2, 1};
    const std::vector<uint8_t> bytes = test::file_bytes(dir / "model.hlod");
    const uint64_t payloads = section_offset(bytes, "PAYL");
    EXPECT_EQ(payloads % 4096, 0u);
    ASSERT_EQ(written.size(), 3u);
    for (size_t w = 0; w < written.size(); ++w) {
        const size_t c = file_order[w];
        std::vector<uint8_t> payload = encode_cube(model.cubes[c], model.header.flags);
        EXPECT_EQ(written[w].level, model.nodes[c].level);
        EXPECT_EQ(written[w].k, model.nodes[c].k);
        EXPECT_EQ(written[w].size, payload.size());
        EXPECT_EQ(written[w].checksum, crc32c(payload.data(), payload.size()));
        EXPECT_TRUE(std::equal(payload.begin(), payload.end(), bytes.begin() + long(written[w].offset)));
    }
    // Each level starts on a 4 KiB boundary; within a level the payloads are packed.
    EXPECT_EQ(written[0].offset, payloads);
    EXPECT_EQ(written[1].offset, (payloads + written[0].size + 4095) / 4096 * 4096);
    EXPECT_EQ(written[2].offset, written[1].offset + written[1].size);
    EXPECT_EQ(section_size(bytes, "PAYL"), written[2].offset + written[2].size - payloads);

    HlodFile file(dir / "model.hlod");
    const HlodHeader& h = file.header();
    const HlodHeader& want = model.header;
    EXPECT_EQ(h.version, kHlodVersion);
    EXPECT_EQ(h.payload_codec, kCubePayloadCodec);
    EXPECT_EQ(h.flags, want.flags);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(h.origin[a], want.origin[a]);
    EXPECT_EQ(h.root_size, want.root_size);
    EXPECT_EQ(h.max_level, want.max_level);
    EXPECT_EQ(h.block_size, want.block_size);
    EXPECT_EQ(h.sigma0, want.sigma0);
    EXPECT_EQ(h.error_q, want.error_q);
    EXPECT_EQ(h.ratio, want.ratio);
    EXPECT_EQ(h.error_limit, want.error_limit);
    EXPECT_EQ(h.input_vertices, want.input_vertices);
    EXPECT_EQ(h.input_triangles, want.input_triangles);
    EXPECT_EQ(h.node_count, 3u);
    EXPECT_EQ(h.source, want.source);
    EXPECT_EQ(h.texture, want.texture);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(h.geo_origin[a], want.geo_origin[a]);
    EXPECT_EQ(h.crs, want.crs);
    EXPECT_EQ(file.file_size(), bytes.size());
    EXPECT_EQ(get<uint64_t>(bytes, kFileSizeAt), bytes.size());
    EXPECT_EQ(file.path(), dir / "model.hlod");
    std::vector<std::string> tags;
    for (const HlodSection& s : file.sections()) tags.push_back(s.name());
    EXPECT_EQ(tags, (std::vector<std::string>{"MODL", "NODE", "GEOR", "PAYL"}));
    expect_same_nodes(file.nodes(), written);
    for (size_t w = 0; w < written.size(); ++w) {
        SCOPED_TRACE("cube " + std::to_string(w));
        expect_same_cube(file.read_cube(file.nodes()[w]), model.cubes[file_order[w]], want.flags);
    }
    EXPECT_NO_THROW(file.check_section(*file.find_section("PAYL")));  // its CRC covers the padding too
}

TEST(HlodFileRoundTrip, NoGeoreferenceSectionWithoutACrs) {
    test::TempDir dir;
    SmallModel model;
    model.header.crs.clear();
    model.write(dir / "model.hlod");
    HlodFile file(dir / "model.hlod");
    EXPECT_EQ(file.find_section("GEOR"), nullptr);
    EXPECT_EQ(file.sections().size(), 3u);
    EXPECT_TRUE(file.header().crs.empty());
    EXPECT_EQ(file.header().geo_origin[0], 0.0);
}

// Opening reads the header, the table, MODL and NODE, never a payload byte: a file whose payloads are
// all overwritten opens and lists its cubes, and only reading a cube fails, naming it.
TEST(HlodFileRoundTrip, OpeningReadsNoPayloadByte) {
    test::TempDir dir;
    SmallModel().write(dir / "model.hlod");
    std::vector<uint8_t> bytes = test::file_bytes(dir / "model.hlod");
    const uint64_t payloads = section_offset(bytes, "PAYL");
    std::fill(bytes.begin() + long(payloads), bytes.end(), 0xAA);
    write_bytes(dir / "model.hlod", bytes);
    HlodFile file(dir / "model.hlod");
    ASSERT_EQ(file.nodes().size(), 3u);
    EXPECT_EQ(file.nodes()[0].level, 0u);
    try {
        file.read_cube(file.nodes()[1]);
        ADD_FAILURE() << "read an overwritten payload";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr((dir / "model.hlod").string() + ": " + describe_cube(file.nodes()[1]) + " checksum mismatch"));
    }
    EXPECT_THROW(file.check_section(*file.find_section("PAYL")), std::runtime_error);
}

TEST(HlodFileRoundTrip, FinishReplacesAnExistingFile) {
    test::TempDir dir;
    write_bytes(dir / "model.hlod", std::vector<uint8_t>(1000, 0x55));
    SmallModel model;
    model.write(dir / "model.hlod");
    EXPECT_EQ(directory_entries(dir.path()), std::vector<std::string>{"model.hlod"});
    HlodFile file(dir / "model.hlod");
    EXPECT_EQ(file.header().node_count, 3u);
}

TEST(HlodWriterCleanup, UnfinishedWriterLeavesNothing) {
    test::TempDir dir;
    const auto path = dir / "model.hlod";
    const auto spool = dir / ("model.hlod.tmp-" + std::to_string(::getpid()) + ".payloads");
    {
        HlodWriter writer(path);
        CubeData cube = make_cube(6, 3, 4, 0);
        writer.add_cube(node_for(cube, 0, 0, 0, 0), encode_cube(cube, 0));
        EXPECT_TRUE(std::filesystem::exists(spool));  // payloads go to "<path>.tmp-<pid>.payloads"…
        EXPECT_FALSE(std::filesystem::exists(path));   // …never straight to the output
    }
    EXPECT_TRUE(directory_entries(dir.path()).empty());

    // An earlier output survives a writer that never finishes.
    write_bytes(path, {1, 2, 3});
    { HlodWriter writer(path); }
    EXPECT_EQ(directory_entries(dir.path()), std::vector<std::string>{"model.hlod"});
    EXPECT_EQ(test::file_bytes(path), (std::vector<uint8_t>{1, 2, 3}));
}

TEST(HlodWriterCleanup, UnwritableDirectoryThrowsNamingThePath) {
    test::TempDir dir;
    const auto path = dir / "missing" / "model.hlod";
    try {
        HlodWriter writer(path);
        ADD_FAILURE() << "opened a file in a missing directory";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr(path.string()));
    }
}

TEST(HlodWriterCleanup, FailedFinishThrowsNamingThePathAndLeavesNothing) {
    test::TempDir dir;
    const auto path = dir / "model.hlod";
    std::filesystem::create_directory(path);  // the rename over it fails
    {
        HlodWriter writer(path);
        CubeData cube = make_cube(6, 3, 4, 0);
        writer.add_cube(node_for(cube, 0, 0, 0, 0), encode_cube(cube, 0));
        SmallModel model;
        try {
            writer.finish(model.header);
            ADD_FAILURE() << "renamed over a directory";
        } catch (const std::runtime_error& e) {
            EXPECT_THAT(e.what(), HasSubstr(path.string()));
        }
    }
    EXPECT_EQ(directory_entries(dir.path()), std::vector<std::string>{"model.hlod"});
    EXPECT_TRUE(std::filesystem::is_directory(path));
}

class BadFile : public ::testing::Test {
protected:
    void SetUp() override {
        SmallModel().write(dir / "good.hlod");
        good = test::file_bytes(dir / "good.hlod");
        ASSERT_GT(good.size(), 4096u);
    }
    // Opening `bytes` as a file throws std::runtime_error naming the file and containing `what`.
    void expect_rejected(const std::vector<uint8_t>& bytes, const std::string& what) {
        const auto path = dir / "bad.hlod";
        write_bytes(path, bytes);
        try {
            HlodFile file(path);
            ADD_FAILURE() << "opened; expected \"" << what << "\"";
        } catch (const std::runtime_error& e) {
            EXPECT_THAT(e.what(), HasSubstr(path.string()));
            EXPECT_THAT(e.what(), HasSubstr(what));
        }
    }
    // Re-seals the header checksum (bytes 0‥27, then the section table) after an edit of either.
    static void reseal_header(std::vector<uint8_t>& bytes) {
        std::vector<uint8_t> covered(bytes.begin(), bytes.begin() + kHeaderCrcAt);
        covered.insert(covered.end(), bytes.begin() + kTableAt,
                       bytes.begin() + long(kTableAt + kEntryBytes * get<uint32_t>(bytes, kSectionCountAt)));
        put<uint32_t>(bytes, kHeaderCrcAt, crc32c(covered.data(), covered.size()));
    }
    // Re-seals a section's checksum, then the header's.
    static void reseal_section(std::vector<uint8_t>& bytes, const char* tag) {
        const size_t entry = entry_of(bytes, tag);
        put<uint32_t>(bytes, entry + 24, crc32c(bytes.data() + get<uint64_t>(bytes, entry + 8), get<uint64_t>(bytes, entry + 16)));
        reseal_header(bytes);
    }
    static size_t node_entry(const std::vector<uint8_t>& bytes, size_t index) { return section_offset(bytes, "NODE") + kNodeBytes * index; }
    // Re-seals every payload's checksum, then NODE's and the header's, after an edit of either.
    static void reseal_nodes(std::vector<uint8_t>& bytes) {
        for (size_t n = 0; n < section_size(bytes, "NODE") / kNodeBytes; ++n) {
            const size_t entry = node_entry(bytes, n);
            const uint64_t offset = get<uint64_t>(bytes, entry + kNodeOffsetAt), size = get<uint64_t>(bytes, entry + kNodeSizeAt);
            put<uint32_t>(bytes, entry + kNodeChecksumAt, crc32c(bytes.data() + offset, size));
        }
        reseal_section(bytes, "NODE");
    }
    // An edit of MODL's bytes at `at`, resealed.
    template <class T>
    std::vector<uint8_t> with_model_field(size_t at, T value) const {
        std::vector<uint8_t> bytes = good;
        put<T>(bytes, section_offset(bytes, "MODL") + at, value);
        reseal_section(bytes, "MODL");
        return bytes;
    }
    // The GEOR entry retagged (and flagged) as a section this reader does not know.
    std::vector<uint8_t> with_georeference_as(const char* tag, uint32_t flags) const {
        std::vector<uint8_t> bytes = good;
        const size_t entry = entry_of(bytes, "GEOR");
        std::memcpy(&bytes[entry], tag, 4);
        put<uint32_t>(bytes, entry + 4, flags);
        reseal_header(bytes);
        return bytes;
    }
    // Opening `bytes` succeeds, but reading cube `index` throws naming the file and containing `what`.
    void expect_cube_rejected(const std::vector<uint8_t>& bytes, size_t index, const std::string& what) {
        const auto path = dir / "bad.hlod";
        write_bytes(path, bytes);
        HlodFile file(path);
        try {
            file.read_cube(file.nodes().at(index));
            ADD_FAILURE() << "read cube " << index << "; expected \"" << what << "\"";
        } catch (const std::runtime_error& e) {
            EXPECT_THAT(e.what(), HasSubstr(path.string()));
            EXPECT_THAT(e.what(), HasSubstr(what));
        }
    }

    test::TempDir dir;
    std::vector<uint8_t> good;
};

TEST_F(BadFile, TheResealedGoodOneOpens) {
    std::vector<uint8_t> copy = good;
    reseal_nodes(copy);
    reseal_section(copy, "MODL");
    reseal_section(copy, "GEOR");
    EXPECT_EQ(copy, good);  // the helpers find the checksums where the writer put them
    write_bytes(dir / "copy.hlod", copy);
    EXPECT_NO_THROW(HlodFile(dir / "copy.hlod"));
}

// FORMAT.md §4.7: a terrain's grid, at the offsets the format gives, and refused when it cannot be one.
TEST_F(BadFile, TerrainGridComesBackFromItsOffsetsAndABadOneIsRefused) {
    SmallModel model;
    model.header.terrain = TerrainGrid{.columns = 1201, .rows = 2401, .spacing = {30, 25}, .nodata_samples = 77, .cube_cells = 64, .rows_run_north = true, .frame = 0, .raster_geographic = false, .raster_crs = {},
                                       .first_sample = {452015, 5169987.5}, .semi_major = 6378137, .inverse_flattening = 298.257223563};
    model.write(dir / "terrain.hlod");
    const std::vector<uint8_t> bytes = test::file_bytes(dir / "terrain.hlod");
    const uint64_t at = section_offset(bytes, "TERR");
    ASSERT_NE(entry_of(bytes, "TERR"), 0u);
    EXPECT_EQ(section_size(bytes, "TERR"), 88u);
    EXPECT_EQ(get<uint32_t>(bytes, entry_of(bytes, "TERR") + 4), 0u) << "optional in the CRS's own plane";
    EXPECT_EQ(get<uint64_t>(bytes, at + 0), 1201u);
    EXPECT_EQ(get<uint64_t>(bytes, at + 8), 2401u);
    EXPECT_EQ(get<double>(bytes, at + 16), 30.0);
    EXPECT_EQ(get<double>(bytes, at + 24), 25.0);
    EXPECT_EQ(get<uint64_t>(bytes, at + 32), 77u);
    EXPECT_EQ(get<uint32_t>(bytes, at + 40), 64u);
    EXPECT_EQ(get<uint32_t>(bytes, at + 44), 1u);
    EXPECT_EQ(get<uint32_t>(bytes, at + 48), 0u);
    EXPECT_EQ(get<double>(bytes, at + 56), 452015.0);
    EXPECT_EQ(get<double>(bytes, at + 64), 5169987.5);
    EXPECT_EQ(get<double>(bytes, at + 72), 6378137.0);
    EXPECT_EQ(get<double>(bytes, at + 80), 298.257223563);
    const HlodFile file(dir / "terrain.hlod");
    ASSERT_TRUE(file.header().terrain);
    EXPECT_EQ(file.header().terrain->rows, 2401u);
    EXPECT_EQ(file.header().terrain->spacing[1], 25.0);
    EXPECT_TRUE(file.header().terrain->rows_run_north);
    EXPECT_EQ(file.header().terrain->first_sample[1], 5169987.5);
    EXPECT_EQ(file.header().terrain->inverse_flattening, 298.257223563);
    EXPECT_FALSE(HlodFile(dir / "good.hlod").header().terrain);

    auto with = [&](size_t offset, auto value) {
        std::vector<uint8_t> copy = bytes;
        put(copy, at + offset, value);
        reseal_section(copy, "TERR");
        return copy;
    };
    expect_rejected(with(16, -30.0), "sample spacing");
    expect_rejected(with(8, uint64_t(1)), "a grid of 1201 × 1 samples");
    expect_rejected(with(32, uint64_t(1201) * 2401 + 1), "more nodata samples than samples");
    expect_rejected(with(40, uint32_t(7)), "cubes of 7 cells");
    expect_rejected(with(44, uint32_t(4)), "unknown flags");
    expect_rejected(with(48, uint32_t(4)), "frame 4, which this Strata does not know");
    expect_rejected(with(56, std::numeric_limits<double>::quiet_NaN()), "the first sample's position is not finite");
    expect_rejected(with(72, -1.0), "an ellipsoid of semi-major axis -1");
    // A section of the development build that kept 56 bytes: refused with how to rebuild.
    std::vector<uint8_t> short_section = bytes;
    put<uint64_t>(short_section, entry_of(short_section, "TERR") + kEntrySizeAt, 56);
    reseal_section(short_section, "TERR");
    expect_rejected(short_section, "rebuild the model from its raster");

    // In a tangent plane, GEOR's origin is a longitude and latitude: a reader must know TERR to place it.
    model.header.terrain->frame = 1;
    model.write(dir / "enu.hlod");
    {  // an enu frame needs its ellipsoid
        std::vector<uint8_t> flat = test::file_bytes(dir / "enu.hlod");
        put(flat, section_offset(flat, "TERR") + 72, 0.0);
        reseal_section(flat, "TERR");
        expect_rejected(flat, "an ellipsoid of semi-major axis 0");
    }
    const std::vector<uint8_t> enu = test::file_bytes(dir / "enu.hlod");
    EXPECT_EQ(get<uint32_t>(enu, entry_of(enu, "TERR") + 4), 1u) << "required";
    EXPECT_EQ(HlodFile(dir / "enu.hlod").header().terrain->frame, 1u);
}

TEST_F(BadFile, Missing) {
    try {
        HlodFile file(dir / "nothing.hlod");
        ADD_FAILURE() << "opened a missing file";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr((dir / "nothing.hlod").string()));
    }
}

TEST_F(BadFile, Truncated) {
    expect_rejected({}, "too short");
    expect_rejected(std::vector<uint8_t>(good.begin(), good.begin() + 31), "too short");
    expect_rejected(std::vector<uint8_t>(good.begin(), good.begin() + 40), "truncated inside its section table");
    expect_rejected(std::vector<uint8_t>(good.begin(), good.end() - 1),
                    "truncated: " + std::to_string(good.size() - 1) + " of its " + std::to_string(good.size()) + " bytes");
    expect_rejected(std::vector<uint8_t>(good.begin(), good.begin() + long(section_offset(good, "PAYL"))), "truncated");
    std::vector<uint8_t> longer = good;
    longer.push_back(0);
    expect_rejected(longer, "1 bytes past the end its header declares");
}

size_t open_descriptors() {
    return size_t(std::distance(std::filesystem::directory_iterator("/proc/self/fd"), {}));
}

TEST_F(BadFile, RejectedFilesAreClosed) {
    std::vector<uint8_t> bytes = good;
    put<uint64_t>(bytes, entry_of(bytes, "NODE") + 16, 1);  // rejected after the table is read
    reseal_header(bytes);
    write_bytes(dir / "bad.hlod", bytes);
    const size_t before = open_descriptors();
    for (int i = 0; i < 20; ++i) EXPECT_THROW(HlodFile(dir / "bad.hlod"), std::runtime_error);
    EXPECT_EQ(open_descriptors(), before);  // the constructor threw after opening: no descriptor is left
}

TEST_F(BadFile, BadMagic) {
    std::vector<uint8_t> bytes = good;
    bytes[0] = 'X';
    expect_rejected(bytes, "bad magic");
    expect_rejected(std::vector<uint8_t>(200, 0), "bad magic");
}

TEST_F(BadFile, VersionOneIsRefusedWithHowToRebuild) {
    const std::filesystem::path fixture = std::filesystem::path(STRATA_SOURCE_DIR) / "tests/data/octahedron_v1.hlod";
    const std::vector<uint8_t> old = test::file_bytes(fixture);
    ASSERT_GT(old.size(), 128u) << fixture;
    ASSERT_EQ(get<uint32_t>(old, 8), 1u);
    const std::string path = (dir / "bad.hlod").string();
    expect_rejected(old, path + ": a version 1 model (from an older Strata); rebuild it from its scan: strata build SCAN -o " + path);
}

TEST_F(BadFile, NewerVersion) {
    std::vector<uint8_t> bytes = good;
    put<uint32_t>(bytes, 8, 3);
    reseal_header(bytes);
    expect_rejected(bytes, ".hlod version 3, but this Strata reads version 2; it was written by a newer version");
}

TEST_F(BadFile, HeaderChecksumMismatch) {
    std::vector<uint8_t> bytes = good;
    bytes[kFileSizeAt] ^= 1;  // in the header, without resealing
    expect_rejected(bytes, "header checksum mismatch");
    bytes = good;
    bytes[kTableAt + 9] ^= 1;  // in the section table
    expect_rejected(bytes, "header checksum mismatch");
    bytes = good;
    bytes[kHeaderCrcAt] ^= 1;  // the CRC itself
    expect_rejected(bytes, "header checksum mismatch");
}

TEST_F(BadFile, SectionCountOutOfRange) {
    std::vector<uint8_t> bytes = good;
    put<uint32_t>(bytes, kSectionCountAt, 0);
    reseal_header(bytes);
    expect_rejected(bytes, "0 sections");
    put<uint32_t>(bytes, kSectionCountAt, 4'000'000'000u);  // checked before the table is read or its CRC
    expect_rejected(bytes, "4000000000 sections");
}

TEST_F(BadFile, SectionOutOfTheFile) {
    std::vector<uint8_t> bytes = good;
    put<uint64_t>(bytes, entry_of(bytes, "NODE") + 16, good.size());  // NODE's size
    reseal_header(bytes);
    expect_rejected(bytes, "section 'NODE' reaches past the end of the file");
    bytes = good;
    put<uint64_t>(bytes, entry_of(bytes, "PAYL") + 8, ~uint64_t(0) - 8);  // an offset that overflows with the size
    reseal_header(bytes);
    expect_rejected(bytes, "section 'PAYL' reaches past the end of the file");
    bytes = good;
    put<uint64_t>(bytes, entry_of(bytes, "MODL") + 8, 40);  // inside the table
    reseal_header(bytes);
    expect_rejected(bytes, "section 'MODL' overlaps the header");
}

TEST_F(BadFile, SectionsOverlap) {
    std::vector<uint8_t> bytes = good;
    put<uint64_t>(bytes, entry_of(bytes, "NODE") + 8, section_offset(good, "MODL") + 8);
    reseal_header(bytes);
    expect_rejected(bytes, "sections 'MODL' and 'NODE' overlap");
}

TEST_F(BadFile, DuplicateTag) {
    expect_rejected(with_georeference_as("NODE", 1), "section 'NODE' appears twice");
}

TEST_F(BadFile, SectionChecksumMismatch) {
    std::vector<uint8_t> bytes = good;
    bytes[section_offset(good, "MODL") + kSourceAt + 4] ^= 0x20;  // a letter of the source name
    expect_rejected(bytes, "section 'MODL' checksum mismatch");
    bytes = good;
    bytes[node_entry(good, 1) + kNodeLevelAt + 2] ^= 1;
    expect_rejected(bytes, "section 'NODE' checksum mismatch");
    bytes = good;
    bytes[section_offset(good, "GEOR") + 30] ^= 1;  // a letter of the CRS
    expect_rejected(bytes, "section 'GEOR' checksum mismatch");
}

TEST_F(BadFile, UnknownRequiredSectionIsRefusedByName) {
    expect_rejected(with_georeference_as("ABCD", 1),
                    "needs section 'ABCD', which this Strata does not know; it was written by a newer version");
    expect_rejected(with_georeference_as("MATL", 3), "needs section 'MATL'");  // other flag bits do not matter
    std::vector<uint8_t> bytes = with_georeference_as("AB\x01\x02", 1);
    expect_rejected(bytes, "section table entry 2 has a tag that is not ASCII");
}

TEST_F(BadFile, UnknownOptionalSectionsAreSkipped) {
    for (const char* tag : {"ABCD", "MATL", "ZZZZ"}) {
        SCOPED_TRACE(tag);
        std::vector<uint8_t> bytes = with_georeference_as(tag, 0);
        put<uint32_t>(bytes, entry_of(bytes, tag) + 24, 0xBADC0DE);  // skipped unread: its CRC does not matter
        reseal_header(bytes);
        write_bytes(dir / "newer.hlod", bytes);
        HlodFile file(dir / "newer.hlod");
        EXPECT_TRUE(file.header().crs.empty());  // the georeference is gone with its tag
        EXPECT_EQ(file.nodes().size(), 3u);
        EXPECT_NO_THROW(file.read_cube(file.nodes()[2]));
    }
}

TEST_F(BadFile, RequiredSectionMissing) {
    std::vector<uint8_t> bytes = good;
    std::memcpy(&bytes[entry_of(bytes, "NODE")], "NODX", 4);
    put<uint32_t>(bytes, entry_of(bytes, "NODX") + 4, 0);
    reseal_header(bytes);
    expect_rejected(bytes, "has no section 'NODE'");
}

TEST_F(BadFile, UnknownPayloadCodec) {
    expect_rejected(with_model_field<uint32_t>(kCodecAt, 4),
                    "payload codec 4, which this Strata does not know; it was written by a newer version");
    // Codec 3 (a terrain's grid payloads) has no colours or UVs: a model with them cannot be one.
    expect_rejected(with_model_field<uint32_t>(kCodecAt, 3), "a terrain's grid payloads carry no colours or UVs");
    // Codec 1, the payload before codec 2 (2026-12), is no longer read: the message says how to rebuild.
    expect_rejected(with_model_field<uint32_t>(kCodecAt, 1),
                    "payload codec 1 (from an older Strata), which this Strata no longer reads; rebuild it from its "
                    "scan: strata build SCAN -o ");
}

TEST_F(BadFile, ModelValuesOutOfRange) {
    expect_rejected(with_model_field<float>(kSigma0At, 0.5f), "out of range");  // σ0 must stay below one half
    expect_rejected(with_model_field<uint32_t>(kMaxLevelAt, 16), "out of range");  // max_level at most 15
}

// Counts are checked against the bytes that could hold them before anything is allocated for them.
TEST_F(BadFile, NodeCountOfTenBillion) {
    expect_rejected(with_model_field<uint64_t>(kNodeCountAt, 9'999'999'999),
                    "section 'NODE' holds 144 bytes, not 48 for each of the model's 9999999999 cubes");
}

TEST_F(BadFile, NameLongerThanTheSection) {
    expect_rejected(with_model_field<uint32_t>(kSourceAt, 4'000'000'000u), "name of 4000000000 bytes");
    expect_rejected(with_model_field<uint32_t>(kSourceAt, 4000), "section 'MODL' ends early");
}

TEST_F(BadFile, NodeLevelPastAnyShift) {
    std::vector<uint8_t> bytes = good;
    put<uint32_t>(bytes, node_entry(bytes, 2) + kNodeLevelAt, 64);  // would shift a 64-bit one out of range
    reseal_nodes(bytes);
    expect_rejected(bytes, "cube (level 64, 1 0 1) outside the octree");
}

TEST_F(BadFile, PayloadOutsideItsSection) {
    std::vector<uint8_t> bytes = good;
    put<uint64_t>(bytes, node_entry(bytes, 0) + kNodeOffsetAt, section_offset(good, "GEOR"));
    reseal_section(bytes, "NODE");
    expect_rejected(bytes, "cube (level 0, 0 0 0) payload out of range");
}

TEST_F(BadFile, ValidPayloadDeclaringFourBillionVertices) {
    // Node entry and payload agree and every checksum is valid: only the bytes cannot hold the vertices.
    std::vector<uint8_t> bytes = good;
    const size_t entry = node_entry(bytes, 0);
    put<uint32_t>(bytes, entry + kNodeVerticesAt, 4'000'000'000u);
    put<uint32_t>(bytes, get<uint64_t>(bytes, entry + kNodeOffsetAt), 4'000'000'000u);
    reseal_nodes(bytes);
    expect_cube_rejected(bytes, 0, "stream sizes disagree with the counts");
}

TEST_F(BadFile, PayloadChecksumMismatchNamesTheCube) {
    std::vector<uint8_t> bytes = good;
    bytes[section_offset(good, "PAYL") + 80] ^= 0xFF;  // inside the first (root) payload's streams
    write_bytes(dir / "bad.hlod", bytes);
    HlodFile file(dir / "bad.hlod");  // header, table, MODL and NODE are fine
    try {
        file.read_cube(file.nodes()[0]);
        ADD_FAILURE() << "read a corrupt payload";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr((dir / "bad.hlod").string()));
        EXPECT_THAT(e.what(), HasSubstr("cube (level 0, 0 0 0) checksum mismatch"));
    }
    EXPECT_NO_THROW(file.read_cube(file.nodes()[1]));
    // The payload section's own CRC, which opening does not read, catches it too.
    try {
        file.check_section(*file.find_section("PAYL"));
        ADD_FAILURE() << "the payload section's CRC missed a flipped byte";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr("section 'PAYL' checksum mismatch"));
    }
}

}  // namespace
}  // namespace strata

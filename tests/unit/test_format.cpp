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

std::vector<uint8_t> read_bytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

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
constexpr size_t kVertexCountAt = 0, kTriangleCountAt = 4, kChildCountsAt = 8, kSizesAt = 40, kPackingAt = 64,
                 kStreamsAt = 68;
constexpr int kStreams = 6, kNormalStream = 1, kColorStream = 2, kUvStream = 3, kParentStream = 4, kIndexStream = 5;
constexpr uint32_t kStored = 0, kZstd = 1;

// The streams of a payload, unpacked as FORMAT.md §5 says (independently of decode_cube).
std::vector<uint8_t> unpacked_streams(const std::vector<uint8_t>& payload) {
    uint64_t total = 0;
    for (int s = 0; s < kStreams; ++s) total += get<uint32_t>(payload, kSizesAt + 4 * s);
    std::vector<uint8_t> body(payload.begin() + kStreamsAt, payload.end());
    if (get<uint32_t>(payload, kPackingAt) == kStored) return body;
    std::vector<uint8_t> streams(total);
    EXPECT_EQ(ZSTD_decompress(streams.data(), streams.size(), body.data(), body.size()), total);
    return streams;
}

// A payload with its streams stored as they are, not as a zstd frame: for editing a stream in place.
std::vector<uint8_t> stored_payload(const std::vector<uint8_t>& payload) {
    std::vector<uint8_t> out(payload.begin(), payload.begin() + kStreamsAt);
    put<uint32_t>(out, kPackingAt, kStored);
    const std::vector<uint8_t> streams = unpacked_streams(payload);
    out.insert(out.end(), streams.begin(), streams.end());
    return out;
}

// The same payload with its streams as the zstd frame `frame`.
std::vector<uint8_t> with_frame(const std::vector<uint8_t>& payload, const std::vector<uint8_t>& frame) {
    std::vector<uint8_t> out(payload.begin(), payload.begin() + kStreamsAt);
    put<uint32_t>(out, kPackingAt, kZstd);
    out.insert(out.end(), frame.begin(), frame.end());
    return out;
}

std::vector<uint8_t> zstd_frame(const std::vector<uint8_t>& bytes) {
    std::vector<uint8_t> frame(ZSTD_compressBound(bytes.size()));
    frame.resize(ZSTD_compress(frame.data(), frame.size(), bytes.data(), bytes.size(), 3));
    return frame;
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

        // The layout of FORMAT.md §5: counts, child counts, sizes, packing, then the streams.
        ASSERT_GE(payload.size(), kStreamsAt);
        EXPECT_EQ(get<uint32_t>(payload, kVertexCountAt), 40u);
        EXPECT_EQ(get<uint32_t>(payload, kTriangleCountAt), 57u);
        EXPECT_EQ(get<uint32_t>(payload, kChildCountsAt + 4 * 5), cube.child_triangle_counts[5]);
        size_t total = 0;
        uint32_t sizes[kStreams];
        for (int s = 0; s < kStreams; ++s) total += sizes[s] = get<uint32_t>(payload, kSizesAt + 4 * s);
        const std::vector<uint8_t> streams = unpacked_streams(payload);
        EXPECT_EQ(streams.size(), total);
        for (int s : {0, kNormalStream, kParentStream, kIndexStream}) EXPECT_GT(sizes[s], 0u) << "stream " << s;
        EXPECT_EQ(sizes[kColorStream] > 0, bool(flags & kHasColors));
        EXPECT_EQ(sizes[kUvStream] > 0, bool(flags & kHasUvs));
        EXPECT_EQ(streams[0], 0xA0) << "vertex codec version 0";
        EXPECT_EQ(streams[total - sizes[kIndexStream]], 0xE0) << "index codec version 0";

        // Either packing decodes to the same cube.
        expect_same_cube(decode_cube(stored_payload(payload), node_for(cube), flags), cube, flags);
        expect_same_cube(decode_cube(with_frame(payload, zstd_frame(streams)), node_for(cube), flags), cube, flags);
    }
}

// A smooth patch whose normals are the area-weighted ones of its own triangles (as the builder computes
// them inside a cube): the triangles predict them, so the normal stream is far smaller than for the
// same patch with unrelated normals, and a cube of many such vertices is packed with zstd.
TEST(CubePayload, NormalsThatTheTrianglesPredictCostLittle) {
    constexpr uint32_t side = 24;
    CubeData smooth;
    for (uint32_t y = 0; y < side; ++y)
        for (uint32_t x = 0; x < side; ++x) {
            const double h = 4000 * std::sin(0.2 * x) * std::cos(0.15 * y);
            smooth.vertices.positions.insert(smooth.vertices.positions.end(),
                                             {uint16_t(20000 + 1000 * x), uint16_t(20000 + 1000 * y), uint16_t(32768 + h)});
            smooth.parent_vertex.push_back((y / 2) * (side / 2) + x / 2);
        }
    for (uint32_t y = 0; y + 1 < side; ++y)
        for (uint32_t x = 0; x + 1 < side; ++x) {
            const uint32_t a = y * side + x;
            smooth.indices.insert(smooth.indices.end(), {a, a + 1, a + side + 1, a, a + side + 1, a + side});
        }
    smooth.child_triangle_counts[0] = smooth.triangle_count();
    std::vector<std::array<float, 3>> sums(side * side, {0, 0, 0});
    for (size_t t = 0; t < smooth.indices.size(); t += 3) {
        float p[3][3];
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) p[k][a] = float(smooth.vertices.positions[3 * smooth.indices[t + k] + a]);
        const float e1[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
        const float e2[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
        const float n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) sums[smooth.indices[t + k]][a] += n[a];
    }
    for (const auto& s : sums) {
        const auto n = encode_normal(s[0], s[1], s[2]);
        smooth.vertices.normals.insert(smooth.vertices.normals.end(), n.begin(), n.end());
    }
    CubeData unrelated = smooth;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> component(-1, 1);
    for (size_t v = 0; v < sums.size(); ++v) {
        const auto n = encode_normal(component(rng), component(rng), component(rng));
        std::copy(n.begin(), n.end(), unrelated.vertices.normals.begin() + 2 * v);
    }
    const std::vector<uint8_t> predicted = encode_cube(smooth, 0), random = encode_cube(unrelated, 0);
    expect_same_cube(decode_cube(predicted, node_for(smooth), 0), smooth, 0);
    expect_same_cube(decode_cube(random, node_for(unrelated), 0), unrelated, 0);
    const uint32_t predicted_bytes = get<uint32_t>(predicted, kSizesAt + 4 * kNormalStream);
    const uint32_t random_bytes = get<uint32_t>(random, kSizesAt + 4 * kNormalStream);
    EXPECT_LT(predicted_bytes * 4, random_bytes) << predicted_bytes << " vs " << random_bytes;
    EXPECT_EQ(get<uint32_t>(predicted, kPackingAt), kZstd);
}

TEST(CubePayload, RoundTripWithoutTriangles) {
    for (uint32_t flags : {0u, uint32_t(kHasColors | kHasUvs)}) {
        // Extra vertices only (FORMAT.md §9): vertices with their parents, no triangles.
        CubeData extras = make_cube(3, 2, 0, flags);
        std::vector<uint8_t> payload = encode_cube(extras, flags);
        EXPECT_EQ(get<uint32_t>(payload, kSizesAt + 4 * kIndexStream), 0u);  // empty index stream
        CubeData back = decode_cube(payload, node_for(extras), flags);
        expect_same_cube(back, extras, flags);
        EXPECT_EQ(back.triangle_count(), 0u);

        // Nothing at all: just the header, streams stored (all empty).
        CubeData empty;
        payload = encode_cube(empty, flags);
        EXPECT_EQ(payload.size(), kStreamsAt);
        EXPECT_EQ(get<uint32_t>(payload, kPackingAt), kStored);
        back = decode_cube(payload, node_for(empty), flags);
        EXPECT_EQ(back.vertex_count(), 0u);
        EXPECT_TRUE(back.parent_vertex.empty());
        EXPECT_TRUE(back.indices.empty());
    }
}

class BadPayload : public ::testing::Test {
protected:
    void SetUp() override {
        cube = make_cube(24, 7, 30, flags);
        node = node_for(cube);
        payload = encode_cube(cube, flags);
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
    const uint32_t flags = kHasColors | kHasUvs;
    CubeData cube;
    HlodNode node;
    std::vector<uint8_t> payload;
};

TEST_F(BadPayload, Truncated) {
    for (size_t keep : {size_t(0), size_t(10), kSizesAt + 8, kStreamsAt, payload.size() / 2, payload.size() - 1}) {
        std::vector<uint8_t> cut(payload.begin(), payload.begin() + keep);
        EXPECT_THROW(decode_cube(cut, node, flags), std::runtime_error) << "kept " << keep << " bytes";
    }
    expect_rejected(std::vector<uint8_t>(payload.begin(), payload.begin() + kPackingAt), node, "ends early");
    const std::vector<uint8_t> stored = stored_payload(payload);
    expect_rejected(std::vector<uint8_t>(stored.begin(), stored.end() - 1), node, "ends early");
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
    // Stored: the sizes must add up to exactly the bytes after the header.
    const std::vector<uint8_t> stored = stored_payload(payload);
    ASSERT_NO_THROW(decode_cube(stored, node, flags));
    std::vector<uint8_t> edited = stored;
    put<uint32_t>(edited, kSizesAt, get<uint32_t>(stored, kSizesAt) + 1);  // stream 0 one byte longer
    expect_rejected(edited, node, "ends early");
    edited = stored;
    put<uint32_t>(edited, kSizesAt + 4 * kIndexStream, get<uint32_t>(stored, kSizesAt + 4 * kIndexStream) - 1);
    expect_rejected(edited, node, "payload longer than its streams");
    edited = stored;  // sizes add up, but the boundary between two streams moved
    put<uint32_t>(edited, kSizesAt, get<uint32_t>(stored, kSizesAt) + 2);
    put<uint32_t>(edited, kSizesAt + 4 * kNormalStream, get<uint32_t>(stored, kSizesAt + 4 * kNormalStream) - 2);
    EXPECT_THROW(decode_cube(edited, node, flags), std::runtime_error);
    // zstd: the frame must hold exactly the streams' size.
    edited = with_frame(payload, zstd_frame(unpacked_streams(payload)));
    put<uint32_t>(edited, kSizesAt + 4 * kIndexStream, get<uint32_t>(edited, kSizesAt + 4 * kIndexStream) + 100);
    expect_rejected(edited, node, "zstd frame does not hold the streams' size");
}

TEST_F(BadPayload, UnknownPacking) {
    std::vector<uint8_t> edited = payload;
    put<uint32_t>(edited, kPackingAt, 2);
    expect_rejected(edited, node, "unknown stream packing 2");
}

TEST_F(BadPayload, CorruptZstdFrame) {
    std::vector<uint8_t> frame = zstd_frame(unpacked_streams(payload));
    frame.resize(frame.size() - 3);  // the frame's end cut off (its header still declares the size)
    expect_rejected(with_frame(payload, frame), node, "zstd frame does not decode");
    frame = zstd_frame(unpacked_streams(payload));
    frame[0] ^= 0xFF;  // no zstd magic
    expect_rejected(with_frame(payload, frame), node, "zstd frame does not hold the streams' size");
}

TEST_F(BadPayload, StreamsFarLargerThanTheirFrame) {
    // A zstd frame of 64 KiB of zeros is a few dozen bytes: a reader refuses what would take more
    // than 64 times the payload, before allocating for it.
    std::vector<uint8_t> edited = payload;
    put<uint32_t>(edited, kSizesAt + 4 * kParentStream, 65536);
    uint64_t total = 0;
    for (int s = 0; s < kStreams; ++s) total += get<uint32_t>(edited, kSizesAt + 4 * s);
    expect_rejected(with_frame(edited, zstd_frame(std::vector<uint8_t>(total, 0))), node,
                    "counts larger than the payload could hold");
}

TEST_F(BadPayload, StreamThatDoesNotDecode) {
    // Each vertex stream in turn, and the index stream, overwritten with bytes no codec version starts with.
    for (int stream = 0; stream < kStreams; ++stream) {
        std::vector<uint8_t> edited = stored_payload(payload);
        size_t at = kStreamsAt;
        for (int s = 0; s < stream; ++s) at += get<uint32_t>(edited, kSizesAt + 4 * s);
        edited[at] = 0x00;
        expect_rejected(edited, node, stream == kIndexStream ? "index stream does not decode" : "vertex stream does not decode");
    }
}

TEST_F(BadPayload, NormalOutOfRange) {
    // A normal residual that puts the stored value past ±2047 (FORMAT.md §7).
    CubeData bad = cube;
    bad.vertices.normals[2 * 3] = 2047;
    std::vector<uint8_t> edited = stored_payload(encode_cube(bad, flags));
    // The residual stream, re-encoded with vertex 3's first residual raised by 4000.
    size_t at = kStreamsAt + get<uint32_t>(edited, kSizesAt);
    const uint32_t size = get<uint32_t>(edited, kSizesAt + 4 * kNormalStream);
    std::vector<int16_t> residuals(2 * cube.vertex_count());
    ASSERT_EQ(meshopt_decodeVertexBuffer(residuals.data(), cube.vertex_count(), 4, &edited[at], size), 0);
    residuals[2 * 3] = int16_t(residuals[2 * 3] + 4000);
    std::vector<uint8_t> stream(meshopt_encodeVertexBufferBound(cube.vertex_count(), 4));
    stream.resize(meshopt_encodeVertexBuffer(stream.data(), stream.size(), residuals.data(), cube.vertex_count(), 4));
    edited.erase(edited.begin() + at, edited.begin() + at + size);
    edited.insert(edited.begin() + at, stream.begin(), stream.end());
    put<uint32_t>(edited, kSizesAt + 4 * kNormalStream, uint32_t(stream.size()));
    expect_rejected(edited, node, "normal of vertex 3 out of range");
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
    CubeData bad = cube;
    bad.indices[3 * 12 + 1] = 24;
    expect_rejected(encode_cube(bad, flags), node, "index 24 past its 24 vertices");
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
    const std::vector<uint8_t> bytes = read_bytes(dir / "model.hlod");
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
    std::vector<uint8_t> bytes = read_bytes(dir / "model.hlod");
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
    EXPECT_EQ(read_bytes(path), (std::vector<uint8_t>{1, 2, 3}));
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
        good = read_bytes(dir / "good.hlod");
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
    const std::vector<uint8_t> old = read_bytes(fixture);
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
    for (const char* tag : {"ABCD", "MATL", "TERR"}) {
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
    expect_rejected(with_model_field<uint32_t>(kCodecAt, 2),
                    "payload codec 2, which this Strata does not know; it was written by a newer version");
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
    expect_cube_rejected(bytes, 0, "counts larger than the payload could hold");
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

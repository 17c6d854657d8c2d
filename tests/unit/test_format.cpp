// The .hlod format (preprocess/FORMAT.md): CRC-32C, octahedral normals, lattice coordinates that decode
// bit-identically from neighbouring cells, cube payloads (round trip and every kind of bad payload), and
// whole files through HlodWriter / HlodFile (round trip, no leftovers, bad files named in the error).
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

#include "preprocess/hlod_format.h"
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

template <class T>
T get(const std::vector<uint8_t>& bytes, size_t at) {
    T value;
    std::memcpy(&value, bytes.data() + at, sizeof(T));
    return value;
}

template <class T>
void put(std::vector<uint8_t>& bytes, size_t at, T value) {
    std::memcpy(bytes.data() + at, &value, sizeof(T));
}

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

// Payload header offsets (FORMAT.md §5).
constexpr size_t kVertexCountAt = 0, kTriangleCountAt = 4, kChildCountsAt = 8, kSizesAt = 40, kStreamsAt = 60;
constexpr int kStreams = 5, kIndexStream = 4;

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

        // The layout of FORMAT.md §5: counts, child counts, sizes, then exactly the streams.
        ASSERT_GE(payload.size(), kStreamsAt);
        EXPECT_EQ(get<uint32_t>(payload, kVertexCountAt), 40u);
        EXPECT_EQ(get<uint32_t>(payload, kTriangleCountAt), 57u);
        EXPECT_EQ(get<uint32_t>(payload, kChildCountsAt + 4 * 5), cube.child_triangle_counts[5]);
        size_t total = kStreamsAt;
        uint32_t sizes[kStreams];
        for (int s = 0; s < kStreams; ++s) total += sizes[s] = get<uint32_t>(payload, kSizesAt + 4 * s);
        EXPECT_EQ(total, payload.size());
        for (int s : {0, 3, kIndexStream}) EXPECT_GT(sizes[s], 0u) << "stream " << s;
        EXPECT_EQ(sizes[1] > 0, bool(flags & kHasColors));
        EXPECT_EQ(sizes[2] > 0, bool(flags & kHasUvs));
        EXPECT_EQ(payload[kStreamsAt], 0xA0) << "vertex codec version 0";
    }
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

        // Nothing at all: just the header.
        CubeData empty;
        payload = encode_cube(empty, flags);
        EXPECT_EQ(payload.size(), kStreamsAt);
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
    std::vector<uint8_t> cut(payload.begin(), payload.end() - 1);
    expect_rejected(cut, node, "ends early");
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
    std::vector<uint8_t> edited = payload;
    put<uint32_t>(edited, kSizesAt, get<uint32_t>(payload, kSizesAt) + 1);  // stream 0 one byte longer
    EXPECT_THROW(decode_cube(edited, node, flags), std::runtime_error);
    edited = payload;
    put<uint32_t>(edited, kSizesAt + 4 * kIndexStream, get<uint32_t>(payload, kSizesAt + 4 * kIndexStream) + 100);  // past the end
    expect_rejected(edited, node, "");
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

// A two-level model's worth of cubes: the root and two level-1 children.
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
        cubes = {make_cube(10, 10, 8, header.flags), make_cube(12, 4, 9, header.flags), make_cube(5, 2, 0, header.flags)};
        nodes = {node_for(cubes[0], 0, 0, 0, 0), node_for(cubes[1], 1, 1, 0, 1), node_for(cubes[2], 1, 0, 1, 0)};
        nodes[1].error = 0.01f, nodes[2].error = 0.02f;
    }
    // Writes the model; returns the writer's node table.
    std::vector<HlodNode> write(const std::filesystem::path& path) const {
        HlodWriter writer(path);
        for (size_t c = 0; c < cubes.size(); ++c) writer.add_cube(nodes[c], encode_cube(cubes[c], header.flags));
        std::vector<HlodNode> written = writer.nodes();
        writer.finish(header);
        return written;
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

TEST(HlodFileRoundTrip, HeaderNodesAndCubesComeBack) {
    test::TempDir dir;
    SmallModel model;
    std::vector<HlodNode> written = model.write(dir / "model.hlod");
    EXPECT_EQ(directory_entries(dir.path()), std::vector<std::string>{"model.hlod"});  // no temporary left

    // The writer filled in where each payload went.
    uint64_t offset = 128;
    for (size_t c = 0; c < written.size(); ++c) {
        std::vector<uint8_t> payload = encode_cube(model.cubes[c], model.header.flags);
        EXPECT_EQ(written[c].offset, offset);
        EXPECT_EQ(written[c].size, payload.size());
        EXPECT_EQ(written[c].checksum, crc32c(payload.data(), payload.size()));
        offset += payload.size();
    }

    HlodFile file(dir / "model.hlod");
    const HlodHeader& h = file.header();
    const HlodHeader& want = model.header;
    EXPECT_EQ(h.version, kHlodVersion);
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
    EXPECT_EQ(h.node_table_offset, offset);  // 128 + every payload
    EXPECT_EQ(h.source, want.source);
    EXPECT_EQ(h.texture, want.texture);
    // The node table region ends the file: 12 + S + T + 48·N bytes.
    EXPECT_EQ(file.file_size(), offset + 12 + want.source.size() + want.texture.size() + 48 * 3);
    EXPECT_EQ(file.path(), dir / "model.hlod");
    expect_same_nodes(file.nodes(), written);
    for (size_t c = 0; c < model.cubes.size(); ++c) {
        SCOPED_TRACE("cube " + std::to_string(c));
        expect_same_cube(file.read_cube(file.nodes()[c]), model.cubes[c], want.flags);
        EXPECT_EQ(file.read_payload(file.nodes()[c]), encode_cube(model.cubes[c], want.flags));
    }
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
    const auto temporary = dir / ("model.hlod.tmp-" + std::to_string(::getpid()));
    {
        HlodWriter writer(path);
        CubeData cube = make_cube(6, 3, 4, 0);
        writer.add_cube(node_for(cube, 0, 0, 0, 0), encode_cube(cube, 0));
        EXPECT_TRUE(std::filesystem::exists(temporary));  // the work goes to "<path>.tmp-<pid>"…
        EXPECT_FALSE(std::filesystem::exists(path));       // …never straight to the output
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

class BadFile : public ::testing::Test {
protected:
    void SetUp() override {
        SmallModel().write(dir / "good.hlod");
        good = read_bytes(dir / "good.hlod");
        ASSERT_GT(good.size(), 128u);
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
    // Re-seals the header checksum after an edit, so that only the edit is wrong.
    static void reseal_header(std::vector<uint8_t>& bytes) { put<uint32_t>(bytes, 104, crc32c(bytes.data(), 104)); }
    // Where node entry `index` starts (FORMAT.md §4: after the two names).
    static size_t node_entry(const std::vector<uint8_t>& bytes, size_t index) {
        const size_t table = get<uint64_t>(bytes, 96);
        const size_t texture = table + 4 + get<uint32_t>(bytes, table);
        return texture + 4 + get<uint32_t>(bytes, texture) + 48 * index;
    }
    // Re-seals every payload's checksum, then the node table's, after an edit of either.
    static void reseal_table(std::vector<uint8_t>& bytes) {
        const size_t nodes = get<uint64_t>(bytes, 88);
        for (size_t n = 0; n < nodes; ++n) {
            const size_t entry = node_entry(bytes, n);
            const uint64_t offset = get<uint64_t>(bytes, entry + 32), size = get<uint64_t>(bytes, entry + 40);
            put<uint32_t>(bytes, entry + 28, crc32c(bytes.data() + offset, size));
        }
        const size_t table = get<uint64_t>(bytes, 96), end = node_entry(bytes, nodes);
        put<uint32_t>(bytes, end, crc32c(bytes.data() + table, end - table));
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

TEST_F(BadFile, TheGoodOneOpens) {
    std::vector<uint8_t> copy = good;
    reseal_header(copy);
    EXPECT_EQ(copy, good);  // the header CRC sits at byte 104 and covers bytes 0‥103
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
    expect_rejected(std::vector<uint8_t>(good.begin(), good.begin() + 127), "too short");
    const uint64_t table = get<uint64_t>(good, 96);
    expect_rejected(std::vector<uint8_t>(good.begin(), good.begin() + long(table)), "node table out of range");
    expect_rejected(std::vector<uint8_t>(good.begin(), good.begin() + long(table) + 20), "node table out of range");
    // Only the node table's CRC is missing.
    std::vector<uint8_t> cut(good.begin(), good.end() - 1);
    write_bytes(dir / "cut.hlod", cut);
    try {
        HlodFile file(dir / "cut.hlod");
        ADD_FAILURE() << "opened a file one byte short";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr((dir / "cut.hlod").string()));
    }
}

size_t open_descriptors() {
    return size_t(std::distance(std::filesystem::directory_iterator("/proc/self/fd"), {}));
}

TEST_F(BadFile, RejectedFilesAreClosed) {
    std::vector<uint8_t> bytes = good;
    bytes[0] = 'X';
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

TEST_F(BadFile, WrongVersion) {
    std::vector<uint8_t> bytes = good;
    put<uint32_t>(bytes, 8, 2);
    reseal_header(bytes);
    expect_rejected(bytes, "version 2");
}

TEST_F(BadFile, HeaderChecksumMismatch) {
    std::vector<uint8_t> bytes = good;
    put<float>(bytes, 64, 0.5f);  // ratio, without resealing
    expect_rejected(bytes, "header checksum mismatch");
    bytes = good;
    bytes[104] ^= 1;  // the CRC itself
    expect_rejected(bytes, "header checksum mismatch");
}

TEST_F(BadFile, NodeTableChecksumMismatch) {
    std::vector<uint8_t> bytes = good;
    const uint64_t table = get<uint64_t>(good, 96);
    bytes[table + 4] ^= 0x20;  // a letter of the source name
    expect_rejected(bytes, "node table checksum mismatch");
}

TEST_F(BadFile, HeaderValuesOutOfRange) {
    std::vector<uint8_t> bytes = good;
    put<float>(bytes, 56, 0.5f);  // σ0 must stay below one half
    reseal_header(bytes);
    expect_rejected(bytes, "out of range");
    bytes = good;
    put<uint32_t>(bytes, 48, 16);  // max_level at most 15
    reseal_header(bytes);
    expect_rejected(bytes, "out of range");
}

TEST_F(BadFile, TheResealedGoodOneOpens) {
    std::vector<uint8_t> copy = good;
    reseal_table(copy);
    EXPECT_EQ(copy, good);  // the helpers below find the checksums where the writer put them
}

// Counts are checked against the bytes that could hold them before anything is allocated for them.
TEST_F(BadFile, NodeCountOfTenBillion) {
    std::vector<uint8_t> bytes = good;
    put<uint64_t>(bytes, 88, 9'999'999'999);
    reseal_header(bytes);
    expect_rejected(bytes, "node table out of range");
}

TEST_F(BadFile, NameLongerThanTheTable) {
    std::vector<uint8_t> bytes = good;
    put<uint32_t>(bytes, get<uint64_t>(good, 96), 4'000'000'000u);  // the source name's length
    expect_rejected(bytes, "name of 4000000000 bytes");
}

TEST_F(BadFile, NodeLevelPastAnyShift) {
    std::vector<uint8_t> bytes = good;
    put<uint32_t>(bytes, node_entry(bytes, 1), 64);  // would shift a 64-bit one out of range
    reseal_table(bytes);
    expect_rejected(bytes, "cube (level 64, 1 0 1) outside the octree");
}

TEST_F(BadFile, ValidPayloadDeclaringFourBillionVertices) {
    // Node entry and payload agree and every checksum is valid: only the bytes cannot hold the vertices.
    std::vector<uint8_t> bytes = good;
    const size_t entry = node_entry(bytes, 0);
    put<uint32_t>(bytes, entry + 20, 4'000'000'000u);
    put<uint32_t>(bytes, get<uint64_t>(bytes, entry + 32), 4'000'000'000u);
    reseal_table(bytes);
    expect_cube_rejected(bytes, 0, "counts larger than the payload could hold");
}

TEST_F(BadFile, PayloadChecksumMismatchNamesTheCube) {
    std::vector<uint8_t> bytes = good;
    bytes[128 + 80] ^= 0xFF;  // inside the first (root) payload's streams
    write_bytes(dir / "bad.hlod", bytes);
    HlodFile file(dir / "bad.hlod");  // the header and node table are fine
    try {
        file.read_cube(file.nodes()[0]);
        ADD_FAILURE() << "read a corrupt payload";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr((dir / "bad.hlod").string()));
        EXPECT_THAT(e.what(), HasSubstr("cube (level 0, 0 0 0) checksum mismatch"));
    }
    EXPECT_NO_THROW(file.read_cube(file.nodes()[1]));
}

}  // namespace
}  // namespace strata

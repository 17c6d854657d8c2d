// Mesh import/export: every format from small hand-written files, PLY round trips, weld, and every kind
// of bad input failing with an InputError that names the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "preprocess/build_inputs.h"
#include "preprocess/byte_size.h"
#include "preprocess/mesh_io.h"

namespace strata {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

// ---- helpers --------------------------------------------------------------------------------------

// Bytes of a binary file, in either byte order.
class Bytes {
public:
    explicit Bytes(bool big_endian = false) : big_endian_(big_endian) {}
    Bytes& text(std::string_view s) {
        data.append(s);
        return *this;
    }
    template <class T>
    Bytes& put(T value) {
        char bytes[sizeof(T)];
        std::memcpy(bytes, &value, sizeof(T));
        if (big_endian_) std::reverse(bytes, bytes + sizeof(T));
        data.append(bytes, sizeof(T));
        return *this;
    }
    std::string data;

private:
    bool big_endian_;
};

// Unit cube, corners 0..7 = (x, y, z) bits; faces as quads wound counter-clockwise seen from outside.
const std::vector<std::array<float, 3>> kCubeCorners = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                                         {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
const std::vector<std::array<uint32_t, 4>> kCubeQuads = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                         {2, 3, 7, 6}, {0, 4, 7, 3}, {1, 2, 6, 5}};

std::string cube_vertex_lines(const char* prefix = "") {
    std::string out;
    for (const auto& c : kCubeCorners)
        out += prefix + std::to_string(int(c[0])) + " " + std::to_string(int(c[1])) + " " +
               std::to_string(int(c[2])) + "\n";
    return out;
}

// The cube as a mesh with every attribute, one vertex per corner (already welded).
Mesh attributed_cube() {
    Mesh mesh;
    for (size_t i = 0; i < kCubeCorners.size(); ++i) {
        const auto& c = kCubeCorners[i];
        mesh.positions.insert(mesh.positions.end(), c.begin(), c.end());
        const float s = 1.0f / std::sqrt(3.0f);
        for (float x : c) mesh.normals.push_back(x > 0 ? s : -s);
        mesh.colors.insert(mesh.colors.end(),
                           {uint8_t(30 * i), uint8_t(255 - 30 * i), uint8_t(7 * i), uint8_t(200 + i)});
        mesh.uvs.insert(mesh.uvs.end(), {0.125f * float(i), 1.0f - 0.1f * float(i)});
    }
    for (const auto& q : kCubeQuads) mesh.indices.insert(mesh.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
    return mesh;
}

// Every undirected edge used by exactly two triangles.
bool is_closed(const Mesh& mesh) {
    std::map<std::pair<uint32_t, uint32_t>, int> uses;
    for (size_t t = 0; t < mesh.indices.size(); t += 3)
        for (int k = 0; k < 3; ++k) {
            uint32_t a = mesh.indices[t + k], b = mesh.indices[t + (k + 1) % 3];
            ++uses[{std::min(a, b), std::max(a, b)}];
        }
    return !uses.empty() && std::all_of(uses.begin(), uses.end(), [](const auto& e) { return e.second == 2; });
}

void expect_same_mesh(const Mesh& a, const Mesh& b) {
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.normals, b.normals);
    EXPECT_EQ(a.colors, b.colors);
    EXPECT_EQ(a.uvs, b.uvs);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_EQ(a.texture, b.texture);
}

std::array<float, 3> position(const Mesh& mesh, uint32_t v) {
    return {mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]};
}

constexpr PlyEncoding kEncodings[] = {PlyEncoding::binary_little_endian, PlyEncoding::binary_big_endian,
                                      PlyEncoding::ascii};

class MeshIo : public ::testing::Test {
protected:
    void SetUp() override {
        static int counter = 0;
        dir_ = std::filesystem::temp_directory_path() /
               ("strata_mesh_io_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override {
        std::error_code ignored;
        std::filesystem::remove_all(dir_, ignored);
    }

    std::filesystem::path write(const std::string& name, std::string_view content) const {
        std::filesystem::path path = dir_ / name;
        std::ofstream(path, std::ios::binary).write(content.data(), std::streamsize(content.size()));
        return path;
    }

    // read_mesh must fail with an InputError starting "<path>: " and containing `detail`.
    static void expect_error(const std::filesystem::path& path, const std::string& detail) {
        try {
            read_mesh(path);
            ADD_FAILURE() << "no InputError for " << path;
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), StartsWith(path.string() + ": "));
            EXPECT_THAT(e.what(), HasSubstr(detail));
        }
    }

    std::filesystem::path dir_;
};

std::string ply_header(const std::string& format, const std::string& body) {
    return "ply\nformat " + format + " 1.0\n" + body + "end_header\n";
}

// ---- PLY ------------------------------------------------------------------------------------------

TEST_F(MeshIo, PlyRoundTripsInEveryEncoding) {
    Mesh cube = attributed_cube();
    cube.texture = "cube.png";
    cube.positions[0] = 1e-30f;  // values whose text form must be exact to read back equal
    cube.positions[1] = 3.4028234e38f;
    cube.uvs[1] = 0.1f;
    for (PlyEncoding encoding : kEncodings) {
        SCOPED_TRACE(int(encoding));
        const auto path = dir_ / "cube.ply";
        write_ply(path, cube, encoding);
        expect_same_mesh(read_mesh(path), cube);
    }
}

TEST_F(MeshIo, PlyRoundTripsWithoutAttributes) {
    Mesh cube = attributed_cube();
    cube.normals.clear();
    cube.colors.clear();
    cube.uvs.clear();
    for (PlyEncoding encoding : kEncodings) {
        write_ply(dir_ / "plain.ply", cube, encoding);
        Mesh back = read_mesh(dir_ / "plain.ply");
        expect_same_mesh(back, cube);
        EXPECT_FALSE(back.has_normals() || back.has_colors() || back.has_uvs());
    }
}

TEST_F(MeshIo, WritePlyReplacesTheFileAndLeavesNoTemporaries) {
    const auto path = dir_ / "out.ply";
    write("out.ply", "old content");
    write_ply(path, attributed_cube());
    EXPECT_EQ(read_mesh(path).triangle_count(), 12u);
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir_), {}), 1);
}

TEST_F(MeshIo, WritePlyFailureNamesTheFileAndLeavesNothing) {
    const auto missing_dir = dir_ / "no" / "such" / "out.ply";
    try {
        write_ply(missing_dir, attributed_cube());
        ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr(missing_dir.string()));
    }
    // The target is a directory: the rename fails, and the temporary file is removed.
    std::filesystem::create_directory(dir_ / "taken.ply");
    EXPECT_THROW(write_ply(dir_ / "taken.ply", attributed_cube()), std::runtime_error);
    Mesh broken = attributed_cube();
    broken.indices.push_back(99), broken.indices.push_back(0), broken.indices.push_back(1);
    try {
        write_ply(dir_ / "broken.ply", broken);
        ADD_FAILURE() << "no error";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr("broken.ply"));
    }
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir_), {}), 1);  // only taken.ply
}

TEST_F(MeshIo, AsciiPlyWithQuadsCommentsAndUnknownElements) {
    const std::string header = ply_header("ascii",
                                          "comment made by hand\n"
                                          "obj_info a cube\n"
                                          "element vertex 8\n"
                                          "property float x\nproperty float y\nproperty float z\n"
                                          "property float confidence\n"
                                          "element material 1\nproperty list uchar float ambient\n"
                                          "element face 6\n"
                                          "property uchar flags\n"
                                          "property list uchar int vertex_indices\n"
                                          "element edge 2\nproperty int vertex1\nproperty int vertex2\n");
    std::string body;
    for (const auto& c : kCubeCorners)
        body += std::to_string(c[0]) + " " + std::to_string(c[1]) + " " + std::to_string(c[2]) + " 0.5\n";
    body += "3 0.1 0.2 0.3\n";
    for (const auto& q : kCubeQuads)
        body += "7 4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
                std::to_string(q[3]) + "\n";
    body += "0 1\n1 2\n";
    Mesh mesh = read_mesh(write("cube.ply", header + body));
    EXPECT_EQ(mesh.vertex_count(), 8u);
    EXPECT_EQ(mesh.triangle_count(), 12u);
    EXPECT_TRUE(is_closed(mesh));
    EXPECT_FALSE(mesh.has_normals() || mesh.has_colors() || mesh.has_uvs());
}

// Binary PLY with unusual types: double positions, float colours, s/t uvs, a uint count and ushort
// indices, a polygon, a list on the vertex element and an unknown element with lists.
std::string unusual_binary_ply(bool big_endian) {
    Bytes b(big_endian);
    b.text(ply_header(big_endian ? "binary_big_endian" : "binary_little_endian",
                      "element vertex 5\n"
                      "property double x\nproperty double y\nproperty double z\n"
                      "property list uchar int neighbours\n"
                      "property float red\nproperty float green\nproperty float blue\n"
                      "property float s\nproperty float t\n"
                      "element tristrips 1\nproperty list int int vertex_indices\n"
                      "element face 2\n"
                      "property list uint ushort vertex_index\n"
                      "property list uchar float texcoord\n"));
    const double xyz[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}};
    for (int v = 0; v < 5; ++v) {
        b.put(xyz[v][0]).put(xyz[v][1]).put(xyz[v][2]);
        b.put(uint8_t(2)).put(int32_t(v)).put(int32_t(v + 1));
        b.put(1.0f).put(0.5f).put(0.0f).put(float(v) / 4).put(0.25f);
    }
    b.put(int32_t(4)).put(int32_t(0)).put(int32_t(1)).put(int32_t(2)).put(int32_t(-1));
    b.put(uint32_t(4)).put(uint16_t(0)).put(uint16_t(3)).put(uint16_t(2)).put(uint16_t(1));
    b.put(uint8_t(0));
    b.put(uint32_t(3)).put(uint16_t(0)).put(uint16_t(1)).put(uint16_t(4));
    b.put(uint8_t(2)).put(0.0f).put(1.0f);
    return b.data;
}

TEST_F(MeshIo, BinaryPlyWithUnusualTypesInBothByteOrders) {
    for (bool big_endian : {false, true}) {
        SCOPED_TRACE(big_endian);
        Mesh mesh = read_mesh(write("odd.ply", unusual_binary_ply(big_endian)));
        ASSERT_EQ(mesh.vertex_count(), 5u);
        EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 3, 2, 0, 2, 1, 0, 1, 4}));
        EXPECT_EQ(position(mesh, 4), (std::array<float, 3>{0.5f, 0.5f, 1.0f}));
        ASSERT_TRUE(mesh.has_colors());
        EXPECT_EQ(std::vector<uint8_t>(mesh.colors.begin(), mesh.colors.begin() + 4),
                  (std::vector<uint8_t>{255, 128, 0, 255}));
        ASSERT_TRUE(mesh.has_uvs());
        EXPECT_FLOAT_EQ(mesh.uvs[2 * 4], 1.0f);
        EXPECT_FLOAT_EQ(mesh.uvs[2 * 4 + 1], 0.25f);
    }
}

// The plain layout (float xyz, uchar 3 + int indices) takes a fast path; polygons and extra vertex
// properties in between must still come out right.
TEST_F(MeshIo, BinaryPlyFastPathMixesTrianglesAndPolygons) {
    Bytes b;
    b.text(ply_header("binary_little_endian",
                      "element vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
                      "property float nx\nproperty float ny\nproperty float nz\n"
                      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                      "element face 11\nproperty list uchar int vertex_indices\n"));
    for (size_t v = 0; v < kCubeCorners.size(); ++v) {
        for (float x : kCubeCorners[v]) b.put(x);
        b.put(0.0f).put(0.0f).put(1.0f);
        b.put(uint8_t(v)).put(uint8_t(2 * v)).put(uint8_t(3 * v));
    }
    for (size_t f = 0; f < kCubeQuads.size(); ++f) {
        const auto& q = kCubeQuads[f];
        if (f == 2) {  // one quad as a quad
            b.put(uint8_t(4)).put(q[0]).put(q[1]).put(q[2]).put(q[3]);
            continue;
        }
        b.put(uint8_t(3)).put(q[0]).put(q[1]).put(q[2]);
        b.put(uint8_t(3)).put(q[0]).put(q[2]).put(q[3]);
    }
    Mesh mesh = read_mesh(write("fast.ply", b.data));
    EXPECT_EQ(mesh.vertex_count(), 8u);
    EXPECT_EQ(mesh.triangle_count(), 12u);
    EXPECT_TRUE(is_closed(mesh));
    ASSERT_TRUE(mesh.has_normals());
    EXPECT_EQ(mesh.normals[3 * 5 + 2], 1.0f);
    EXPECT_EQ(mesh.colors[4 * 5 + 2], 15);
    EXPECT_EQ(mesh.colors[4 * 5 + 3], 255);  // no alpha property: opaque
}

TEST_F(MeshIo, PlyTextureFileCommentBecomesTheTexture) {
    Mesh cube = attributed_cube();
    cube.texture = "skin.jpg";
    write_ply(dir_ / "t.ply", cube, PlyEncoding::ascii);
    EXPECT_EQ(read_mesh(dir_ / "t.ply").texture, "skin.jpg");
}

// ---- OBJ ------------------------------------------------------------------------------------------

TEST_F(MeshIo, ObjCubeWithQuadsIsClosed) {
    std::string obj = "# cube\nmtllib missing.mtl\no cube\n" + cube_vertex_lines("v ");
    for (const auto& q : kCubeQuads)
        obj += "f " + std::to_string(q[0] + 1) + " " + std::to_string(q[1] + 1) + " " + std::to_string(q[2] + 1) + " " +
               std::to_string(q[3] + 1) + "\n";
    Mesh mesh = read_mesh(write("cube.obj", obj));
    EXPECT_EQ(mesh.vertex_count(), 8u);
    EXPECT_EQ(mesh.triangle_count(), 12u);
    EXPECT_TRUE(is_closed(mesh));
    EXPECT_TRUE(mesh.texture.empty());  // a missing .mtl is not an error
}

TEST_F(MeshIo, ObjCornerFormsNegativeIndicesAndSeams) {
    const std::string obj =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
        "vt 0 0\nvt 1 0\nvt 0 1\nvt 0.5 0.5\n"
        "vn 0 0 -1\nvn 0 0 1\n"
        "f 1/1/1 3/3/1 2/2/1\n"     // v/vt/vn
        "f -4/4 -3/2 -1/3\n"        // v/vt, relative: vertices 1 2 4; vertex 1 gets a second uv: a seam
        "f 2//2 3//2 4//2\n";       // v//vn
    Mesh mesh = read_mesh(write("forms.obj", obj));
    EXPECT_EQ(mesh.triangle_count(), 3u);
    ASSERT_TRUE(mesh.has_uvs());
    ASSERT_TRUE(mesh.has_normals());
    // Distinct (v, vt, vn) triples: 1/1/1 3/3/1 2/2/1 1/4 2/2 4/3 2//2 3//2 4//2 = 9 vertices.
    EXPECT_EQ(mesh.vertex_count(), 9u);
    size_t at_origin = 0;
    for (uint32_t v = 0; v < mesh.vertex_count(); ++v) at_origin += position(mesh, v) == std::array<float, 3>{0, 0, 0};
    EXPECT_EQ(at_origin, 2u);  // the seam keeps two vertices at one position
    EXPECT_EQ(mesh.indices[3], mesh.indices[0] + 3);  // second face starts with a new vertex for v1/vt4
}

TEST_F(MeshIo, ObjSameVertexWithTwoUvsIsTwoVertices) {
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0\n"
                            "f 1/1 2/2 3/3\nf 2/5 4/4 3/3\n";
    Mesh mesh = read_mesh(write("seam.obj", obj));
    EXPECT_EQ(mesh.vertex_count(), 5u);  // v2 appears with vt2 and vt5
    EXPECT_EQ(mesh.triangle_count(), 2u);
}

TEST_F(MeshIo, ObjVertexColorsAndMaterialTexture) {
    write("cube.mtl", "newmtl plain\nKd 1 1 1\nnewmtl skin\nmap_Kd -s 1 1 1 -clamp on textures/skin tone.png\n");
    const std::string obj = "mtllib cube.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nusemtl skin\nf 1 2 3\n";
    Mesh mesh = read_mesh(write("colored.obj", obj));
    EXPECT_EQ(mesh.texture, "textures/skin tone.png");
    ASSERT_TRUE(mesh.has_colors());
    EXPECT_EQ(mesh.colors, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255}));
}

TEST_F(MeshIo, ObjPolygonIsFanned) {
    Mesh mesh = read_mesh(write("pent.obj", "v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5\n"));
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 0, 3, 4}));
}

// ---- OFF ------------------------------------------------------------------------------------------

TEST_F(MeshIo, OffCubeWithCommentsBlankLinesAndFaceColours) {
    std::string off = "OFF\n# a cube\n\n8 6 12\n" + cube_vertex_lines();
    for (const auto& q : kCubeQuads)
        off += "4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
               std::to_string(q[3]) + "  255 0 0\n";
    Mesh mesh = read_mesh(write("cube.off", off));
    EXPECT_EQ(mesh.vertex_count(), 8u);
    EXPECT_EQ(mesh.triangle_count(), 12u);
    EXPECT_TRUE(is_closed(mesh));
}

TEST_F(MeshIo, OffCountsOnTheHeaderLineAndColouredVertices) {
    const std::string off = "COFF 4 1 0\n0 0 0 1 0 0 1\n1 0 0 0 1 0 1\n0 1 0 0 0 1 1\n5 5 5 1 1 1 1\n3 0 1 2\n";
    Mesh mesh = read_mesh(write("tri.off", off));
    EXPECT_EQ(mesh.vertex_count(), 3u);  // the unused fourth vertex is dropped
    ASSERT_TRUE(mesh.has_colors());
    EXPECT_EQ(mesh.colors[0], 255);
    EXPECT_EQ(mesh.colors[5], 255);
}

// Found by fuzzing (tests/fuzz/regressions/off): a NaN or out-of-range channel in 0..255 colours was cast
// to a byte, which is undefined. NaN reads as 0, values beyond the range are clamped.
TEST_F(MeshIo, NanAndOutOfRangeColourChannelsAreClamped) {
    const std::string off = "COFF 3 1 0\n0 0 0 nan 300 2\n1 0 0 -7 1e30 255\n0 1 0 0 0 0\n3 0 1 2\n";
    Mesh mesh = read_mesh(write("nan.off", off));
    ASSERT_TRUE(mesh.has_colors());
    EXPECT_EQ(std::vector<uint8_t>(mesh.colors.begin(), mesh.colors.begin() + 8),
              (std::vector<uint8_t>{0, 255, 2, 255, 0, 255, 255, 255}));
    const std::string obj = "v 0 0 0 nan 300 2\nv 1 0 0 -7 1e30 255\nv 0 1 0 0 0 0\nf 1 2 3\n";
    Mesh from_obj = read_mesh(write("nan.obj", obj));
    ASSERT_TRUE(from_obj.has_colors());
    EXPECT_EQ(std::vector<uint8_t>(from_obj.colors.begin(), from_obj.colors.begin() + 8),
              (std::vector<uint8_t>{0, 255, 2, 255, 0, 255, 255, 255}));
}

TEST_F(MeshIo, NoffReadsNormals) {
    const std::string off = "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n";
    Mesh mesh = read_mesh(write("n.off", off));
    ASSERT_TRUE(mesh.has_normals());
    EXPECT_EQ(mesh.normals, (std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1}));
}

// ---- STL ------------------------------------------------------------------------------------------

std::vector<std::array<float, 9>> cube_triangle_soup() {
    std::vector<std::array<float, 9>> soup;
    for (const auto& q : kCubeQuads)
        for (const auto& tri : {std::array<uint32_t, 3>{q[0], q[1], q[2]}, std::array<uint32_t, 3>{q[0], q[2], q[3]}}) {
            std::array<float, 9> t{};
            for (int k = 0; k < 3; ++k)
                for (int a = 0; a < 3; ++a) t[size_t(3 * k + a)] = kCubeCorners[tri[size_t(k)]][size_t(a)];
            soup.push_back(t);
        }
    return soup;
}

std::string binary_stl(const std::string& header80) {
    Bytes b;
    b.text(header80).text(std::string(80 - header80.size(), ' '));
    const auto soup = cube_triangle_soup();
    b.put(uint32_t(soup.size()));
    for (const auto& t : soup) {
        b.put(0.0f).put(0.0f).put(0.0f);
        for (float x : t) b.put(x);
        b.put(uint16_t(0));
    }
    return b.data;
}

TEST_F(MeshIo, AsciiStlIsWeldedIntoAClosedCube) {
    std::string stl = "solid cube made by hand\n";
    for (const auto& t : cube_triangle_soup()) {
        stl += "  facet normal 0 0 0\n    outer loop\n";
        for (int k = 0; k < 3; ++k)
            stl += "      vertex " + std::to_string(t[size_t(3 * k)]) + " " + std::to_string(t[size_t(3 * k + 1)]) +
                   " " + std::to_string(t[size_t(3 * k + 2)]) + "\n";
        stl += "    endloop\n  endfacet\n";
    }
    stl += "endsolid cube made by hand\n";
    Mesh mesh = read_mesh(write("cube.stl", stl));
    EXPECT_EQ(mesh.vertex_count(), 8u);  // 36 corners merged
    EXPECT_EQ(mesh.triangle_count(), 12u);
    EXPECT_TRUE(is_closed(mesh));
}

TEST_F(MeshIo, BinaryStlEvenWhenItsHeaderSaysSolid) {
    for (const std::string header : {"binary cube", "solid cube"}) {
        Mesh mesh = read_mesh(write("cube.stl", binary_stl(header)));
        EXPECT_EQ(mesh.vertex_count(), 8u);
        EXPECT_EQ(mesh.triangle_count(), 12u);
        EXPECT_TRUE(is_closed(mesh));
    }
}

// ---- format detection -----------------------------------------------------------------------------

TEST_F(MeshIo, ContentDecidesTheFormatAndTheExtensionIsTheFallback) {
    write_ply(dir_ / "really_a_ply.obj", attributed_cube());
    EXPECT_EQ(read_mesh(dir_ / "really_a_ply.obj").triangle_count(), 12u);
    // First keyword not one content sniffing knows, so the .obj extension decides.
    const auto path = write("fallback.obj", "usemap none\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    EXPECT_EQ(read_mesh(path).triangle_count(), 1u);
}

// ---- weld -----------------------------------------------------------------------------------------

TEST(MeshIoWeld, MergesEqualVerticesInFirstOccurrenceOrder) {
    Mesh mesh;
    mesh.positions = {5, 5, 5,  0, 0, 0,  1, 0, 0,  0.0f, -0.0f, 0,  0, 1, 0,  1, 0, 0};
    mesh.indices = {1, 2, 4, 3, 4, 5};  // vertex 0 unused; 3 is vertex 1 with -0.0; 5 repeats 2
    weld(mesh);
    EXPECT_EQ(mesh.positions, (std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}));
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 1}));
}

TEST(MeshIoWeld, KeepsSeamsApartButDropsDegenerateTriangles) {
    Mesh mesh;
    mesh.positions = {0, 0, 0,  1, 0, 0,  0, 1, 0,  0, 0, 0,  1, 1, 0};
    mesh.uvs = {0, 0,  1, 0,  0, 1,  0.5f, 0.5f,  1, 1};  // vertex 3: vertex 0's position, another uv
    mesh.indices = {0, 1, 2,  1, 4, 2,  0, 3, 1,  1, 1, 4};
    weld(mesh);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2}));  // both degenerate ones gone
    EXPECT_EQ(mesh.vertex_count(), 4u);  // the seam copy was only used by a degenerate triangle
    EXPECT_EQ(mesh.uvs, (std::vector<float>{0, 0, 1, 0, 0, 1, 1, 1}));

    Mesh seam;
    seam.positions = {0, 0, 0,  1, 0, 0,  0, 1, 0,  0, 0, 0};
    seam.colors = {0, 0, 0, 255,  1, 1, 1, 255,  2, 2, 2, 255,  9, 9, 9, 255};
    seam.indices = {0, 1, 2,  3, 2, 1};
    weld(seam);
    EXPECT_EQ(seam.vertex_count(), 4u);  // same position, different colour: kept apart
    EXPECT_EQ(seam.triangle_count(), 2u);
}

TEST(MeshIoWeld, RejectsInconsistentMeshes) {
    Mesh mesh;
    mesh.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    mesh.indices = {0, 1, 3};
    EXPECT_THROW(weld(mesh), std::invalid_argument);
    mesh.indices = {0, 1, 2};
    mesh.normals = {0, 0, 1};
    EXPECT_THROW(weld(mesh), std::invalid_argument);
}

// ---- progress -------------------------------------------------------------------------------------

TEST_F(MeshIo, ReportsLoadThenReadProgressInBytesAndHonoursCancel) {
    write_ply(dir_ / "cube.ply", attributed_cube());
    const double size = double(std::filesystem::file_size(dir_ / "cube.ply"));
    std::vector<std::pair<std::string, std::pair<double, double>>> calls;
    Progress progress;
    progress.report = [&](std::string_view stage, double done, double total, std::string_view unit) {
        EXPECT_EQ(unit, "B");
        calls.emplace_back(std::string(stage), std::make_pair(done, total));
    };
    read_mesh(dir_ / "cube.ply", progress);
    ASSERT_GE(calls.size(), 3u);
    EXPECT_EQ(calls.front(), std::make_pair(std::string("load"), std::make_pair(size, size)));  // one chunk
    for (size_t i = 1; i < calls.size(); ++i) EXPECT_EQ(calls[i].first, "read");
    EXPECT_EQ(calls.back().second, std::make_pair(size, size));

    std::atomic<bool> cancel{true};
    progress.cancel = &cancel;
    EXPECT_THROW(read_mesh(dir_ / "cube.ply", progress), Cancelled);
}

// A binary PLY of several load chunks (4 MB): many vertices, one triangle.
std::string large_binary_ply(size_t vertices) {
    Bytes b;
    b.text(ply_header("binary_little_endian", "element vertex " + std::to_string(vertices) +
                                                  "\nproperty float x\nproperty float y\nproperty float z\n"
                                                  "element face 1\nproperty list uchar int vertex_indices\n"));
    for (size_t v = 0; v < vertices; ++v) b.put(float(v)).put(float(v % 7)).put(0.0f);
    b.put(uint8_t(3)).put(0).put(1).put(2);
    return b.data;
}

// A file cut or grown while it is being read is an error naming the file, never a SIGBUS. The load
// progress report after the first chunk is the moment in between: no timing is involved.
TEST_F(MeshIo, FileChangedWhileBeingReadIsAnInputError) {
    const auto path = write("big.ply", large_binary_ply(500'000));  // 6 MB
    const auto size = std::filesystem::file_size(path);
    EXPECT_EQ(read_mesh(path).triangle_count(), 1u);  // intact, it reads
    for (const auto new_size : {size / 2, size + 1}) {
        SCOPED_TRACE(new_size);
        std::filesystem::resize_file(path, size);
        bool changed = false;
        Progress progress;
        progress.report = [&](std::string_view stage, double, double, std::string_view) {
            if (stage != "load" || changed) return;
            changed = true;
            std::filesystem::resize_file(path, new_size);
        };
        try {
            read_mesh(path, progress);
            ADD_FAILURE() << "no InputError";
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), StartsWith(path.string() + ": the file changed while it was being read: "));
            EXPECT_THAT(e.what(), HasSubstr(new_size < size ? "it ends after 4194304 of its" : "bytes now, not"));
        }
        EXPECT_TRUE(changed);
    }
    // Cut before it is read, the header promises more than is there.
    std::filesystem::resize_file(path, size / 2);
    expect_error(path, "expected 500000 vertices, file ends after");
}

// ---- files from other programs ---------------------------------------------------------------------
// Each quirk below is one that a widely used reader's bug tracker or test suite documents; the samples
// in tests/data/meshes reproduce them (its README names the source of each).

const std::filesystem::path kSamples = std::filesystem::path(STRATA_SOURCE_DIR) / "tests" / "data" / "meshes";

// The samples are all one tetrahedron: four corners, four triangles, closed.
void expect_tetrahedron(const Mesh& mesh) {
    EXPECT_EQ(mesh.vertex_count(), 4u);
    EXPECT_EQ(mesh.triangle_count(), 4u);
    EXPECT_TRUE(is_closed(mesh));
}

// The binary PLY samples' first value, whose first byte is 0x0A (LF): eating one byte too many or too
// few after end_header shifts it and everything after it.
const float kLfFirstByte = std::bit_cast<float>(uint32_t(0x3F80000A));

Mesh read_with_warnings(const std::filesystem::path& path, std::vector<std::string>& warnings) {
    return read_mesh(path, {}, warnings);
}

TEST_F(MeshIo, PlyFreeTextHeaderLineIsSkippedWithOneWarning) {  // Blender 2.47's exporter
    const auto path = kSamples / "blender247_free_text_header.ply";
    std::vector<std::string> warnings;
    expect_tetrahedron(read_with_warnings(path, warnings));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_THAT(warnings[0], StartsWith(path.string() + ": PLY header line 3: skipped 'Created by Blender3D"));

    // Several such lines: still one warning, which counts the others.
    const std::string header = "ply\nformat ascii 1.0\nmade by hand\nelement vertex 3\nproperty float x\n"
                               "property float y\nproperty float z\nelement face 1\nnot a keyword either\n"
                               "property list uchar int vertex_indices\nend_header\n";
    warnings.clear();
    read_with_warnings(write("two.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), warnings);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_THAT(warnings[0], HasSubstr("line 3: skipped 'made by hand'"));
    EXPECT_THAT(warnings[0], HasSubstr("(and 1 more such lines)"));
    warnings.clear();
    write_ply(dir_ / "clean.ply", attributed_cube());
    read_with_warnings(dir_ / "clean.ply", warnings);
    EXPECT_TRUE(warnings.empty());
}

TEST_F(MeshIo, BinaryPlyAfterHeadersEndingInCrAloneCrLfOrLf) {
    // Rhino 6 ends header lines in CR alone (MeshLab #463, Open3D #5091, draco #613); PCL on Windows in
    // CRLF (OpenCTM #6, assimp #3929, three.js #15099). The data starts with a 0x0A byte in both.
    for (const char* sample : {"rhino6_cr_header.ply", "pcl_crlf_header.ply"}) {
        SCOPED_TRACE(sample);
        Mesh mesh = read_mesh(kSamples / sample);
        expect_tetrahedron(mesh);
        EXPECT_EQ(position(mesh, 0), (std::array<float, 3>{kLfFirstByte, 0, 0}));
    }
    // LF, data starting with 0x0A: the one LF after end_header is the header's (assimp #3929).
    Bytes b;
    b.text(ply_header("binary_little_endian",
                      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\n"));
    b.put(kLfFirstByte).put(0.0f).put(0.0f).put(1.0f).put(0.0f).put(0.0f).put(0.0f).put(1.0f).put(0.0f);
    b.put(uint8_t(3)).put(0).put(1).put(2);
    EXPECT_EQ(position(read_mesh(write("lf.ply", b.data)), 0), (std::array<float, 3>{kLfFirstByte, 0, 0}));
}

TEST_F(MeshIo, PlyHeaderSpacingCommentsAndTypeAliases) {
    // An empty comment (assimp #819), a comment between an element and its properties (assimp #4866),
    // tabs, runs of spaces and trailing blanks (splat-transform #256), the sized type names and list
    // count types other than uchar (the PLY types both ways, as rply and tinyply read them), properties
    // in any order, colours as floats, and a blank CR line before the data (happly #45).
    const std::string header = "ply\nformat\tascii  1.0 \ncomment\nelement  vertex\t3\ncomment points\n"
                               "property float32 z\nproperty\tfloat64 y\nproperty float32   x \n"
                               "property float32 red\nproperty float32 green\nproperty float32 blue\n"
                               "property int16 flags\n"
                               "element face 1\nproperty list uint32 int32 vertex_indices\nproperty uint8 tag\n"
                               "element edge 1\nproperty list int16 uint vertex_index\n"
                               "end_header\n\r\n";
    const std::string body = "0 0 0  1 0 0 -1\n0 0 1  0 1 0 2\n0 1 0  0 0 1 3\n3 0 1 2 9\n2 0 1\n";
    std::vector<std::string> warnings;
    Mesh mesh = read_with_warnings(write("spaced.ply", header + body), warnings);
    EXPECT_TRUE(warnings.empty());
    ASSERT_EQ(mesh.vertex_count(), 3u);
    EXPECT_EQ(position(mesh, 1), (std::array<float, 3>{1, 0, 0}));  // x is the third property
    EXPECT_EQ(position(mesh, 2), (std::array<float, 3>{0, 1, 0}));
    EXPECT_EQ(mesh.colors, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255}));
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST_F(MeshIo, PlyWithoutThePlyLineIsRefused) {
    expect_error(write("fake.ply", "format ascii 1.0\nelement vertex 0\nend_header\n"), "not a PLY file");
}

TEST_F(MeshIo, ObjLineContinuationsEmptyFieldsAndWindowsText) {
    // Rhino wraps long lines with a backslash (trimesh #1103, helix-toolkit #152); Wings3D writes
    // "1//" for a corner without uv or normal (wings #391; "1/1/" in trimesh #808); Windows tools write
    // a byte order mark (tinyobjloader #394, assimp #6253) and CRLF, and some no final line ending
    // (assimp #2297, tinyobjloader-c #12).
    for (const char* sample : {"rhino_continued_lines.obj", "wings3d_empty_fields.obj", "bom_crlf_no_final_newline.obj"}) {
        SCOPED_TRACE(sample);
        Mesh mesh = read_mesh(kSamples / sample);
        expect_tetrahedron(mesh);
        EXPECT_FALSE(mesh.has_normals() || mesh.has_uvs());
    }
    Mesh uv = read_mesh(write("uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1/ 2/2/ 3/3/\n"));
    EXPECT_TRUE(uv.has_uvs());
    EXPECT_FALSE(uv.has_normals());
}

TEST_F(MeshIo, ObjTabsCrAloneNamesWithSpacesAndIgnoredStatements) {
    // A tab after the keyword (MeshLab #267), CR-alone line endings (classic Mac OS), names with spaces,
    // smoothing groups, lines, points and parameter-space vertices, a comment at a line's end.
    const std::string obj = "o my object\rg left side\rs off\rusemtl red paint\rvp 0.5\r"
                            "v\t0 0 0\rv 1\t0 0\rv 0 1 0 # apex\rv 0 0 1\r"
                            "l 1 2\rp 3\rf 1 3 2\rf 1 2 4\rf\t1 4 3\rf 2 3 4\r";
    expect_tetrahedron(read_mesh(write("mac.obj", obj)));
}

TEST_F(MeshIo, OffWithTheVertexCountGluedToTheKeyword) {  // ModelNet: trimesh #753, PyMesh #162
    expect_tetrahedron(read_mesh(kSamples / "modelnet_glued_counts.off"));
    expect_error(write("4d.off", "4OFF\n3 1 0\n0 0 0 0\n1 0 0 0\n0 1 0 0\n3 0 1 2\n"), "4D OFF is not supported");
    expect_error(write("other.off", "OFFSET 3 1 0\n"), "bad vertex count 'SET'");
}

TEST_F(MeshIo, BinaryStlThatSaysSolidOrHasAWrongCount) {
    // SolidWorks starts binary headers with "solid" (stl_reader #3, meshio #530).
    std::vector<std::string> warnings;
    expect_tetrahedron(read_with_warnings(kSamples / "solidworks_binary_solid.stl", warnings));
    EXPECT_TRUE(warnings.empty());
    // ZanderCAD leaves the triangle count 0 (MeshLab #1281): the size, a whole number of triangles, wins.
    const auto zero = kSamples / "zandercad_zero_count.stl";
    expect_tetrahedron(read_with_warnings(zero, warnings));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_EQ(warnings[0], zero.string() + ": the header says 0 triangles, but the file's size is exactly 4: read 4");
    // A count too large and a size that is not whole triangles is a cut file.
    std::ifstream in(zero, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    bytes[80] = 9;
    expect_error(write("cut.stl", bytes.substr(0, bytes.size() - 7)), "expected 9 triangles, file ends after 3");
}

TEST_F(MeshIo, AsciiStlInCapitalsWithNanNormalsAndTwoWordEnds) {
    // All capitals (numpy-stl #154, Slic3r #2971), "END LOOP" (MeshLab #194), NaN normals in several
    // spellings (OpenSCAD #1225, helix-toolkit #1150), an endsolid name that differs, CRLF.
    expect_tetrahedron(read_mesh(kSamples / "uppercase_nan_normals.stl"));
}

TEST_F(MeshIo, AsciiStlWithALongNameNoNameOrSeveralSolids) {
    const std::string facets = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                               "endloop\nendfacet\n";
    // A name longer than any sniffing window (MeshLab #734), "solid" alone (fstl #33), "end solid"
    // (numpy-stl #206), two solids in one file.
    EXPECT_EQ(read_mesh(write("long.stl", "solid " + std::string(3000, '/') + "\n" + facets + "endsolid x\n"))
                  .triangle_count(), 1u);
    EXPECT_EQ(read_mesh(write("bare.stl", "solid\n" + facets + "end solid\n")).triangle_count(), 1u);
    const std::string second = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 0 0 1\n"
                               "endloop\nendfacet\n";
    EXPECT_EQ(read_mesh(write("two.stl", "solid a\n" + facets + "endsolid a\nsolid b\n" + second + "endsolid b\n"))
                  .triangle_count(), 2u);
}

// ---- bad input ------------------------------------------------------------------------------------

TEST_F(MeshIo, UnopenableFilesAreInputErrors) {
    expect_error(dir_ / "missing.ply", "cannot open");
    expect_error(write("empty.ply", ""), "empty");
    expect_error(dir_, "directory");
    if (::geteuid() != 0) {  // root reads anything
        const auto locked = write("locked.ply", "ply\n");
        std::filesystem::permissions(locked, std::filesystem::perms::none);
        expect_error(locked, "cannot open");
    }
    expect_error(write("noise.dat", "hello world\n"), "unknown mesh format");
    expect_error(write("noise.obj", std::string("\x01\x02\x03 binary junk\n", 17)), "not an OBJ file");
}

TEST_F(MeshIo, TruncatedBinaryPlyFails) {
    Mesh cube = attributed_cube();
    write_ply(dir_ / "full.ply", cube);
    std::ifstream in(dir_ / "full.ply", std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    const size_t header = bytes.find("end_header\n") + 11;
    const size_t vertex_bytes = 8 * (12 + 12 + 4 + 8);
    expect_error(write("cut_vertices.ply", bytes.substr(0, header + 3 * (12 + 12 + 4 + 8) + 5)),
                 "expected 8 vertices, file ends after 3");
    expect_error(write("cut_faces.ply", bytes.substr(0, header + vertex_bytes + 13 * 5 + 2)), "faces");
}

TEST_F(MeshIo, LyingBinaryPlyCountFailsFastWithoutAllocating) {
    Bytes b;
    b.text(ply_header("binary_little_endian",
                      "element vertex 2147483648\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\n"));
    for (int i = 0; i < 80; ++i) b.put(float(i));
    expect_error(write("liar.ply", b.data), "expected 2147483648 vertices, file ends after 26");

    Bytes faces;
    faces.text(ply_header("binary_little_endian",
                          "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                          "element face 4000000000\nproperty list uchar int vertex_indices\n"));
    for (int i = 0; i < 9; ++i) faces.put(float(i));
    faces.put(uint8_t(3)).put(0).put(1).put(2);
    expect_error(write("liar_faces.ply", faces.data), "expected 4000000000 faces");
}

// A header count of ten billion is an error naming the file before anything is allocated, in every
// reader: never an out-of-memory kill.
TEST_F(MeshIo, CountsBeyondWhatTheFileCanHoldFailBeforeAllocating) {
    const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
    const std::string face = "property list uchar int vertex_indices\n";
    const std::string triangle = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    expect_error(write("vertices.ply", ply_header("ascii", "element vertex 9999999999\n" + xyz) + triangle),
                 "too many vertices (9999999999)");
    expect_error(write("faces.ply", ply_header("ascii", "element vertex 3\n" + xyz + "element face 9999999999\n" + face) +
                                        triangle),
                 "expected 9999999999 faces, but only 9 bytes are left, room for at most 2");
    expect_error(write("ascii_vertices.ply", ply_header("ascii", "element vertex 99999999\n" + xyz) + triangle),
                 "expected 99999999 vertices, but only 26 bytes are left, room for at most 4");
    expect_error(write("edges.ply", ply_header("ascii", "element vertex 3\n" + xyz + "element face 1\n" + face +
                                                        "element edge 9999999999\nproperty int a\nproperty int b\n") +
                                        triangle + "0 1\n"),
                 "expected 9999999999 'edge' elements, but only 5 bytes are left");
    Bytes binary;
    binary.text(ply_header("binary_little_endian", "element vertex 3\n" + xyz + "element face 9999999999\n" + face));
    for (int i = 0; i < 9; ++i) binary.put(0.0f);
    binary.put(uint8_t(3)).put(0).put(1).put(2);
    expect_error(write("binary_faces.ply", binary.data), "expected 9999999999 faces, but only 13 bytes are left");

    const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
    expect_error(write("vertices.off", "OFF\n9999999999 1 0\n" + vertices), "too many vertices (9999999999)");
    expect_error(write("faces.off", "OFF\n3 9999999999 0\n" + vertices + "3 0 1 2\n"),
                 "expected 9999999999 faces, but only 8 bytes are left, room for at most 2");
    expect_error(write("colours.off", "COFF 1000000 1 0\n" + vertices), "expected 1000000 vertices, but only 18");

    expect_error(write("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9999999999\n"),
                 "indexes vertex 9999999999 of 3");

    std::string stl = binary_stl("binary");
    const uint32_t most = UINT32_MAX;
    std::memcpy(stl.data() + 80, &most, 4);
    expect_error(write("count.stl", stl + "x"), "expected 4294967295 triangles, file ends after 12");
}

TEST_F(MeshIo, MalformedPlyHeadersAndAsciiBodies) {
    const std::string xyz = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
    const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
    expect_error(write("no_end.ply", "ply\nformat ascii 1.0\n" + xyz), "end_header");
    expect_error(write("negative.ply", ply_header("ascii", "element vertex -3\n")), "negative count");
    expect_error(write("bad_type.ply", ply_header("ascii", "element vertex 1\nproperty real x\n")),
                 "unknown property type");
    expect_error(write("no_xyz.ply", ply_header("ascii", "element vertex 1\nproperty float x\n") + "1\n"), "x, y or z");
    expect_error(write("short.ply", ply_header("ascii", "element vertex 5\nproperty float x\nproperty float y\n"
                                                        "property float z\n" + face) + vertices),
                 "expected 5 vertices, but only 18 bytes are left, room for at most 3");
    expect_error(write("cut.ply", ply_header("ascii", "element vertex 4\nproperty float x\nproperty float y\n"
                                                      "property float z\n" + face) + "0.000 0.000 0.000\n1.000 0.000 0.000\n"),
                 "expected 4 vertices, file ends after 2");
    expect_error(write("word.ply", ply_header("ascii", xyz + face) + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"),
                 "found 'zero'");
    expect_error(write("index.ply", ply_header("ascii", xyz + face) + vertices + "3 0 1 7\n"),
                 "face 0 indexes vertex 7 of 3");
    expect_error(write("two.ply", ply_header("ascii", xyz + face) + vertices + "2 0 1\n"), "face 0 has 2 corners");
    expect_error(write("nan.ply", ply_header("ascii", xyz + face) + "0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"),
                 "vertex 1 has a NaN or infinite coordinate");
    expect_error(write("extra.ply", ply_header("ascii", xyz + face) + vertices + "3 0 1 2\n3 0 2 1\n"),
                 "after the last element");
}

TEST_F(MeshIo, BadBinaryPlyIndicesAndCoordinates) {
    const std::string header = ply_header("binary_little_endian",
                                          "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                          "element face 2\nproperty list uchar int vertex_indices\n");
    auto file = [&](float nan_or_not, int32_t index, uint8_t corners) {
        Bytes b;
        b.text(header);
        for (float x : {0.0f, 0.0f, 0.0f, 1.0f, nan_or_not, 0.0f, 0.0f, 1.0f, 0.0f}) b.put(x);
        b.put(uint8_t(3)).put(0).put(1).put(2);
        b.put(corners);
        for (uint8_t k = 0; k < corners; ++k) b.put(k == 1 ? index : int32_t(k));
        b.text(std::string(8, '\0'));  // room for a triangle, so the size check up front passes
        return b.data;
    };
    expect_error(write("index.ply", file(0, 3, 3)), "face 1 indexes vertex 3 of 3");
    expect_error(write("negative.ply", file(0, -1, 3)), "face 1 indexes vertex -1 of 3");
    expect_error(write("corners.ply", file(0, 1, 1)), "face 1 has 1 corners");
    expect_error(write("inf.ply", file(std::numeric_limits<float>::infinity(), 1, 3)), "vertex 1 has a NaN");
}

TEST_F(MeshIo, MalformedObj) {
    const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    expect_error(write("index.obj", tri + "f 1 2 3\nf 1 2 4\n"), "face 2 indexes vertex 4 of 3");
    expect_error(write("zero.obj", tri + "f 0 1 2\n"), "indexes vertex 0");
    expect_error(write("relative.obj", tri + "f -1 -2 -4\n"), "indexes vertex -4 of 3");
    expect_error(write("uv.obj", tri + "vt 0 0\nf 1/1 2/2 3/1\n"), "indexes texture coordinate 2 of 1");
    expect_error(write("word.obj", "v 0 zero 0\n"), "found 'zero'");
    expect_error(write("short.obj", "v 0 0\n"), "v needs 3 numbers");
    expect_error(write("nan.obj", tri + "v 0 inf 0\nf 1 2 3\n"), "vertex 4 has a NaN or infinite coordinate");
    expect_error(write("two.obj", tri + "f 1 2\n"), "face 1 has 2 corners");
}

TEST_F(MeshIo, MalformedOff) {
    const std::string vertices = "0 0 0\n1 0 0\n0 1 0\n";
    expect_error(write("negative.off", "OFF\n-3 1 0\n" + vertices + "3 0 1 2\n"), "negative vertex count");
    expect_error(write("short.off", "OFF\n4 1 0\n" + vertices), "expected 4 vertices, but only 18 bytes are left");
    expect_error(write("cut.off", "OFF\n4 1 0\n0.000 0.000 0.000\n1.000 0.000 0.000\n"),
                 "expected 4 vertices, file ends after 2");
    expect_error(write("faces.off", "OFF\n3 2 0\n" + vertices + "3 0 1 2\n"), "expected 2 faces, file ends after 1");
    expect_error(write("room.off", "OFF\n3 3 0\n" + vertices + "3 0 1 2\n"), "expected 3 faces, but only 8 bytes");
    expect_error(write("index.off", "OFF\n3 1 0\n" + vertices + "3 0 1 5\n"), "face 0 indexes vertex 5 of 3");
    expect_error(write("word.off", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n"), "found 'x'");
    expect_error(write("count.off", "OFF\nmany 1 0\n"), "bad vertex count");
    expect_error(write("nan.off", "OFF\n3 1 0\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"), "vertex 1 has a NaN");
    expect_error(write("two.off", "OFF\n3 1 0\n" + vertices + "2 0 1\n"), "face 0 has 2 corners");
}

TEST_F(MeshIo, MalformedStl) {
    std::string stl = binary_stl("binary");
    expect_error(write("cut.stl", stl.substr(0, stl.size() - 60)), "expected 12 triangles, file ends after 10");
    expect_error(write("tiny.stl", "abc"), "too small");
    expect_error(write("word.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 zero 0\n"), "found 'zero'");
    expect_error(write("nan.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\n"
                                  "vertex 0 1 0\nendloop\nendfacet\nendsolid x\n"),
                 "triangle 0 has a NaN");
    expect_error(write("two.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n"
                                  "endfacet\nendsolid x\n"),
                 "facet has 2 vertices");
}


// ---- survey coordinates ---------------------------------------------------------------------------

// UTM-like coordinates with millimetre detail, which a float holding the whole coordinate rounds to
// 3 cm (eastings) and 25 cm (northings).
const std::vector<std::array<double, 3>> kSurveyPoints = {
    {512345.678, 5412345.123, 300.001}, {512346.679, 5412345.124, 300.002}, {512345.677, 5412346.125, 300.003}};

std::array<double, 3> true_position(const Mesh& mesh, uint32_t v) {
    return {mesh.origin[0] + double(mesh.positions[3 * v]), mesh.origin[1] + double(mesh.positions[3 * v + 1]),
            mesh.origin[2] + double(mesh.positions[3 * v + 2])};
}

void expect_survey_points(const Mesh& mesh) {
    ASSERT_EQ(mesh.vertex_count(), kSurveyPoints.size());
    EXPECT_EQ(mesh.origin, (std::array<double, 3>{512000, 5411840, 0})) << "the first vertex truncated to 1024s";
    for (uint32_t v = 0; v < 3; ++v)
        for (int a = 0; a < 3; ++a)
            EXPECT_NEAR(true_position(mesh, v)[a], kSurveyPoints[v][a], 1e-4) << "vertex " << v << " axis " << a;
}

std::string survey_text_vertices(const char* prefix) {
    std::string out;
    char line[128];
    for (const auto& p : kSurveyPoints) {
        std::snprintf(line, sizeof line, "%s%.3f %.3f %.3f\n", prefix, p[0], p[1], p[2]);
        out += line;
    }
    return out;
}

TEST_F(MeshIo, BinaryPlyDoublesKeepSurveyPrecision) {
    for (bool big : {false, true}) {
        Bytes b(big);
        b.text(ply_header(big ? "binary_big_endian" : "binary_little_endian",
                          "element vertex 3\nproperty double x\nproperty double y\nproperty double z\n"
                          "element face 1\nproperty list uchar int vertex_indices\n"));
        for (const auto& p : kSurveyPoints) b.put(p[0]).put(p[1]).put(p[2]);
        b.put(uint8_t(3)).put(int32_t(0)).put(int32_t(1)).put(int32_t(2));
        expect_survey_points(read_mesh(write(big ? "big.ply" : "little.ply", b.data)));
    }
}

TEST_F(MeshIo, TextFormatsKeepSurveyPrecision) {
    expect_survey_points(read_mesh(write("survey.ply", ply_header("ascii", "element vertex 3\nproperty double x\n"
                                                                            "property double y\nproperty double z\n"
                                                                            "element face 1\nproperty list uchar int vertex_indices\n") +
                                                             survey_text_vertices("") + "3 0 1 2\n")));
    // Declared float, but written with more digits than a float holds: still read in double.
    expect_survey_points(read_mesh(write("float.ply", ply_header("ascii", "element vertex 3\nproperty float x\n"
                                                                           "property float y\nproperty float z\n"
                                                                           "element face 1\nproperty list uchar int vertex_indices\n") +
                                                            survey_text_vertices("") + "3 0 1 2\n")));
    expect_survey_points(read_mesh(write("survey.obj", survey_text_vertices("v ") + "f 1 2 3\n")));
    expect_survey_points(read_mesh(write("survey.off", "OFF\n3 1 0\n" + survey_text_vertices("") + "3 0 1 2\n")));
    expect_survey_points(read_mesh(write("survey.stl", "solid s\nfacet normal 0 0 1\nouter loop\n" +
                                                           survey_text_vertices("vertex ") + "endloop\nendfacet\nendsolid s\n")));
}

TEST_F(MeshIo, DataNearZeroKeepsOriginZero) {
    const Mesh mesh = read_mesh(write("near.off", "OFF\n3 1 0\n1023.5 -1023.25 0.1\n2000 0 0\n0 5000 0\n3 0 1 2\n"));
    EXPECT_EQ(mesh.origin, (std::array<double, 3>{}));
    EXPECT_EQ(position(mesh, 0), (std::array<float, 3>{1023.5f, -1023.25f, 0.1f}));
    EXPECT_EQ(position(mesh, 2), (std::array<float, 3>{0, 5000, 0}));
}

TEST_F(MeshIo, WritePlyWritesTruePositionsInDouble) {
    Mesh mesh = read_mesh(write("survey.off", "OFF\n3 1 0\n" + survey_text_vertices("") + "3 0 1 2\n"));
    for (PlyEncoding encoding : kEncodings) {
        write_ply(dir_ / "out.ply", mesh, encoding);
        expect_survey_points(read_mesh(dir_ / "out.ply"));
    }
}

// ---- tiles ----------------------------------------------------------------------------------------

// The unit cube in two OBJ tiles: its quads go to one tile or the other by their centre's x (the four
// whose centre is at x = 0.5 by their first corner), so the tiles share six corners along their border.
// `low_corner_suffix` follows every corner of the low tile's faces ("//1": a normal).
std::pair<std::string, std::string> cube_halves_as_obj(const std::string& preamble, const std::string& low_corner_suffix = "") {
    std::string low = preamble, high = preamble;
    for (const auto& q : kCubeQuads) {
        float x = 0;
        for (uint32_t c : q) x += kCubeCorners[c][0] / 4;
        const bool is_low = x < 0.5f || (x == 0.5f && q[0] == 0);
        std::string& out = is_low ? low : high;
        out += "f";
        for (uint32_t c : q) out += " " + std::to_string(c + 1) + (is_low ? low_corner_suffix : "");
        out += "\n";
    }
    return {low, high};
}

TEST_F(MeshIo, TilesWeldAlongSharedBorders) {
    const auto [low, high] = cube_halves_as_obj(cube_vertex_lines("v "));
    std::vector<std::string> warnings;
    const Mesh mesh = read_tiles({write("low.obj", low), write("high.obj", high)}, {}, warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(mesh.vertex_count(), 8u);
    EXPECT_EQ(mesh.triangle_count(), 12u);
    EXPECT_TRUE(is_closed(mesh));
}

TEST_F(MeshIo, TilesShareTheFirstTilesOrigin) {
    // Survey tiles whose first vertices lie in different 1024 m squares still weld exactly.
    const std::string a = "OFF\n3 1 0\n512345.678 5412345.123 300.001\n513100.5 5412345.123 300\n512345.678 5413000.25 300\n3 0 1 2\n";
    const std::string b = "OFF\n3 1 0\n513100.5 5412345.123 300\n513100.5 5413000.25 300\n512345.678 5413000.25 300\n3 0 1 2\n";
    std::vector<std::string> warnings;
    const Mesh mesh = read_tiles({write("a.off", a), write("b.off", b)}, {}, warnings);
    EXPECT_EQ(mesh.vertex_count(), 4u) << "the shared edge was not welded";
    EXPECT_EQ(mesh.origin, (std::array<double, 3>{512000, 5411840, 0}));
    EXPECT_NEAR(true_position(mesh, 3)[1], 5413000.25, 1e-4);
}

TEST_F(MeshIo, TilesDropAnAttributeNotAllHave) {
    const auto [low, high] = cube_halves_as_obj(cube_vertex_lines("v ") + "vn 0 0 1\n", "//1");
    std::vector<std::string> warnings;
    const std::filesystem::path a = write("a.obj", low), b = write("b.obj", high);
    const Mesh mesh = read_tiles({a, b}, {}, warnings);
    EXPECT_FALSE(mesh.has_normals());
    EXPECT_EQ(mesh.vertex_count(), 8u) << "the corners' copies with and without normals did not weld";
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_THAT(warnings[0], StartsWith(b.string() + ": no normals, which the other 1 of the 2 files have"));
}

TEST_F(MeshIo, TilesNamingDifferentTexturesAreRefused) {
    const std::filesystem::path a = write("a.ply", ply_header("ascii", "comment TextureFile one.png\nelement vertex 3\n"
                                                                        "property float x\nproperty float y\nproperty float z\n"
                                                                        "element face 1\nproperty list uchar int vertex_indices\n") +
                                                       "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    const std::filesystem::path b = write("b.ply", ply_header("ascii", "comment TextureFile two.png\nelement vertex 3\n"
                                                                        "property float x\nproperty float y\nproperty float z\n"
                                                                        "element face 1\nproperty list uchar int vertex_indices\n") +
                                                       "1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n");
    std::vector<std::string> warnings;
    try {
        read_tiles({a, b}, {}, warnings);
        ADD_FAILURE() << "different textures accepted";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), StartsWith(b.string() + ": names texture 'two.png', but " + a.string() + " names texture 'one.png'"));
    }
}

TEST_F(MeshIo, TileErrorsNameTheTile) {
    const std::filesystem::path good = write("good.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    const std::filesystem::path bad = write("bad.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    std::vector<std::string> warnings;
    for (const auto& [paths, named] : std::vector<std::pair<std::vector<std::filesystem::path>, std::filesystem::path>>{
             {{good, bad}, bad}, {{good, dir_ / "missing.off"}, dir_ / "missing.off"}}) {
        try {
            read_tiles(paths, {}, warnings);
            ADD_FAILURE() << "no error for " << named;
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), StartsWith(named.string() + ": "));
        }
    }
}

// ---- what a build takes in ------------------------------------------------------------------------

TEST_F(MeshIo, InputListsExpandRelativeToTheirFolder) {
    std::filesystem::create_directories(dir_ / "site");
    write("site/list.txt", "# tiles of the site\n\n  a.ply  \r\nsub/b.ply\n/abs/c.ply\n#last\n");
    const std::vector<std::filesystem::path> files =
        expand_inputs({"first.off", "@" + (dir_ / "site/list.txt").string(), "last.off"});
    const std::vector<std::filesystem::path> expected = {"first.off", dir_ / "site/a.ply", dir_ / "site/sub/b.ply",
                                                         "/abs/c.ply", "last.off"};
    EXPECT_EQ(files, expected);
    EXPECT_EQ(source_name({"@" + (dir_ / "site/list.txt").string()}, 3), "list.txt");
    EXPECT_EQ(source_name({"one.ply"}, 1), "one.ply");
    EXPECT_EQ(source_name({"a.ply", "b.ply"}, 2), "2 files");
}

TEST_F(MeshIo, InputListErrorsNameTheList) {
    const std::filesystem::path empty = write("empty.txt", "# nothing\n\n");
    for (const auto& [list, detail] : std::vector<std::pair<std::filesystem::path, std::string>>{
             {empty, "names no input files"}, {dir_ / "missing.txt", "cannot read the list of inputs"}}) {
        try {
            expand_inputs({"@" + list.string()});
            ADD_FAILURE() << "no error for " << list;
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), StartsWith(list.string() + ": "));
            EXPECT_THAT(e.what(), HasSubstr(detail));
        }
    }
}

TEST_F(MeshIo, TrianglesAreEstimatedFromHeaders) {
    EXPECT_EQ(estimate_triangles(write("a.ply", ply_header("binary_little_endian",
                                                           "element vertex 1000\nproperty float x\nproperty float y\n"
                                                           "property float z\nelement face 1234567\n"
                                                           "property list uchar int vertex_indices\n"))).triangles,
              1234567u);
    EXPECT_EQ(estimate_triangles(write("a.off", "OFF\n# counts\n8 6 0\n")).triangles, 6u);
    Bytes stl;
    stl.text(std::string(80, ' ')).put(uint32_t(2)).text(std::string(100, '\0'));
    const TriangleEstimate binary = estimate_triangles(write("a.stl", stl.data));
    EXPECT_EQ(binary.triangles, 2u);
    EXPECT_TRUE(binary.from_header);
    const TriangleEstimate obj = estimate_triangles(write("a.obj", std::string(3200, '#')));
    EXPECT_FALSE(obj.from_header);
    EXPECT_EQ(obj.triangles, 100u);
    try {
        estimate_triangles(dir_ / "missing.ply");
        ADD_FAILURE() << "a missing file estimated";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), StartsWith((dir_ / "missing.ply").string() + ": cannot open"));
    }
}

TEST(ByteSize, ParsesBinarySuffixesInEitherCase) {
    EXPECT_EQ(parse_byte_size("4096"), 4096u);
    EXPECT_EQ(parse_byte_size("2G"), uint64_t(2) << 30);
    EXPECT_EQ(parse_byte_size("2g"), uint64_t(2) << 30);
    EXPECT_EQ(parse_byte_size("512M"), uint64_t(512) << 20);
    EXPECT_EQ(parse_byte_size("1.5G"), uint64_t(3) << 29);
    EXPECT_EQ(parse_byte_size("8k"), 8192u);
    EXPECT_EQ(parse_byte_size("1T"), uint64_t(1) << 40);
    for (const char* bad : {"", "G", "-1G", "+2G", "2GB", "1e9", "inf", "0", "0.1", "2 G", "1.2.3M", "9000000T", "nan"}) {
        try {
            parse_byte_size(bad);
            ADD_FAILURE() << "accepted '" << bad << "'";
        } catch (const std::invalid_argument& e) {
            EXPECT_THAT(e.what(), StartsWith("'" + std::string(bad) + "'"));
        }
    }
    EXPECT_EQ(describe_bytes(uint64_t(3) << 30), "3.0 GiB");
    EXPECT_EQ(describe_bytes(800), "800 B");
    EXPECT_GT(default_memory_limit(), 0u);
}

TEST(ByteSize, TemporaryDiskPreflightNamesTheFolder) {
    const std::filesystem::path folder = std::filesystem::temp_directory_path();
    MemoryEstimate estimate{.triangles = 1000, .temp_bytes = 60'000};
    EXPECT_NO_THROW(check_temp_disk(estimate, folder));
    estimate.temp_bytes = uint64_t(1) << 62;  // more than any disk has free
    try {
        check_temp_disk(estimate, folder);
        ADD_FAILURE() << "4 EiB of temporary disk fit";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), StartsWith(folder.string() + ": the build needs about 4.0 EiB of temporary disk here, and only "));
        EXPECT_THAT(e.what(), HasSubstr("choose another folder with --temp"));
    }
    // A resumed build's work folder already holds part of what it needs.
    const std::filesystem::space_info space = std::filesystem::space(folder);
    estimate.temp_bytes = space.available + (uint64_t(1) << 40);  // margins no other writer moves
    EXPECT_THROW(check_temp_disk(estimate, folder), InputError);
    EXPECT_NO_THROW(check_temp_disk(estimate, folder, uint64_t(2) << 40));
}

TEST(ByteSize, MemoryPreflightRefusesWhatDoesNotFit) {
    const MemoryEstimate estimate{.triangles = 75'000'000, .in_memory_triangles = 75'000'000, .bytes = uint64_t(3) << 30};
    EXPECT_NO_THROW(check_memory(estimate, uint64_t(4) << 30, "--memory 4G"));
    try {
        check_memory(estimate, uint64_t(2) << 30, "--memory 2G");
        ADD_FAILURE() << "3 GiB fit under 2";
    } catch (const InputError& e) {
        EXPECT_THAT(e.what(), HasSubstr("needs about 3.0 GiB in memory for 75000000 triangles read whole into memory, "
                                        "more than --memory 2G"));
        EXPECT_THAT(e.what(), HasSubstr("binary PLY streams from disk"));
    }
}

}  // namespace
}  // namespace strata

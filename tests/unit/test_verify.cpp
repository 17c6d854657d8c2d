// `strata verify` (hlod_verify.h) against models tampered with properly: cubes are decoded, edited, and
// re-encoded into a new file by HlodWriter, so every checksum still matches and only the invariant under
// test is broken. Also: cancelling a build and bad build settings leave no file behind.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <regex>
#include <string>
#include <vector>

#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_format.h"
#include "preprocess/hlod_verify.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

using ::testing::HasSubstr;

// A whole .hlod decoded: header, node table and every cube, in file order.
struct Model {
    HlodHeader header;
    std::vector<HlodNode> nodes;
    std::vector<CubeData> cubes;

    explicit Model(const std::filesystem::path& path) {
        HlodFile file(path);
        header = file.header();
        nodes = file.nodes();
        for (const HlodNode& n : nodes) cubes.push_back(file.read_cube(n));
    }

    // Re-encodes every cube and writes a new file; HlodWriter recomputes offsets, sizes and checksums.
    void write(const std::filesystem::path& path) const {
        HlodWriter writer(path);
        for (size_t c = 0; c < cubes.size(); ++c) {
            HlodNode n = nodes[c];
            n.vertex_count = cubes[c].vertex_count();
            n.triangle_count = cubes[c].triangle_count();
            writer.add_cube(n, encode_cube(cubes[c], header.flags));
        }
        writer.finish(header);
    }

    size_t find(uint32_t level, uint32_t i, uint32_t j, uint32_t k) const {
        for (size_t c = 0; c < nodes.size(); ++c)
            if (nodes[c].level == level && nodes[c].i == i && nodes[c].j == j && nodes[c].k == k) return c;
        return nodes.size();
    }
    // The first cube of `level` with at least `triangles` triangles.
    size_t cube_at(uint32_t level, uint32_t triangles = 1) const {
        for (size_t c = 0; c < nodes.size(); ++c)
            if (nodes[c].level == level && cubes[c].triangle_count() >= triangles) return c;
        return nodes.size();
    }
    void erase(size_t c) {
        nodes.erase(nodes.begin() + long(c));
        cubes.erase(cubes.begin() + long(c));
    }

    // The cube c's parent cube.
    size_t parent_of(size_t c) const {
        const HlodNode& n = nodes[c];
        return find(n.level - 1, n.i / 2, n.j / 2, n.k / 2);
    }
    // Decoded position of vertex v of cube c.
    std::array<float, 3> vertex(size_t c, uint32_t v) const {
        const HlodNode& n = nodes[c];
        const uint32_t cell[3] = {n.i, n.j, n.k};
        std::array<float, 3> x;
        for (int a = 0; a < 3; ++a) x[a] = decode_coordinate(header, a, n.level, cell[a], cubes[c].vertices.positions[3 * v + a]);
        return x;
    }
};

double linf(std::array<float, 3> a, std::array<float, 3> b) {
    double d = 0;
    for (int k = 0; k < 3; ++k) d = std::max(d, std::fabs(double(a[k]) - double(b[k])));
    return d;
}

std::vector<std::string> directory_entries(const std::filesystem::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir)) names.push_back(e.path().filename().string());
    return names;
}

// Small models built once: a closed sphere and an open grid with colours and UVs, both 3 levels, and
// the grid again with its boundary locked.
class Verify : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = new test::TempDir;
        BuildSettings s;
        s.levels = 2;
        build_hlod(test::icosphere(4), *dir_ / "sphere.hlod", s, "sphere");
        build_hlod(test::colored_grid(48), *dir_ / "grid.hlod", s, "grid");
        s.lock_boundary = true;
        build_hlod(test::colored_grid(48), *dir_ / "locked.hlod", s, "grid");
        sphere_ = new Model(*dir_ / "sphere.hlod");
        grid_ = new Model(*dir_ / "grid.hlod");
        locked_grid_ = new Model(*dir_ / "locked.hlod");
    }
    static void TearDownTestSuite() {
        delete sphere_;
        delete grid_;
        delete locked_grid_;
        delete dir_;
        sphere_ = grid_ = locked_grid_ = nullptr;
        dir_ = nullptr;
    }

    // Writes `model` as a new file and verifies it: "" if it passes, else the VerifyError's message,
    // which must name the file.
    std::string verify(const Model& model) {
        const auto path = dir.path() / ("tampered-" + std::to_string(files_++) + ".hlod");
        model.write(path);
        HlodFile file(path);  // the header, node table and checksums are all fine
        try {
            last_report = verify_hlod(file);
            return "";
        } catch (const VerifyError& e) {
            std::string message = e.what();
            EXPECT_THAT(message, HasSubstr(path.string()));
            return message;
        }
    }

    static test::TempDir* dir_;
    static Model* sphere_;
    static Model* grid_;
    static Model* locked_grid_;
    test::TempDir dir;
    VerifyReport last_report;
    int files_ = 0;
};

test::TempDir* Verify::dir_ = nullptr;
Model* Verify::sphere_ = nullptr;
Model* Verify::grid_ = nullptr;
Model* Verify::locked_grid_ = nullptr;

TEST_F(Verify, UntamperedRewriteVerifies) {
    Model sphere = *sphere_;
    ASSERT_EQ(sphere.header.max_level, 2u);
    EXPECT_EQ(verify(sphere), "");
    EXPECT_TRUE(last_report.watertight);
    EXPECT_EQ(last_report.cubes, sphere.nodes.size());
    Model grid = *grid_;
    ASSERT_EQ(grid.header.flags, uint32_t(kHasColors | kHasUvs | kErrorsAreBounds));
    EXPECT_EQ(verify(grid), "");
    EXPECT_FALSE(last_report.watertight);
    // The original files too, of course.
    EXPECT_NO_THROW(verify_hlod(HlodFile(*dir_ / "sphere.hlod")));
}

// A locked boundary (MODL flag bit 3): every level's open edges, decoded, are level L's.
TEST_F(Verify, ALockedBoundaryThatMovedOrIsNotLocked) {
    Model locked = *locked_grid_;
    ASSERT_TRUE(locked.header.flags & kLockedBoundary);
    EXPECT_EQ(verify(locked), "");
    EXPECT_TRUE(last_report.boundary_locked);

    // A boundary vertex of level 1 (on the grid's side x = 0) one lattice step along the side, in one cube.
    const size_t c = locked.cube_at(1);
    uint32_t v = 0;
    while (v < locked.cubes[c].vertex_count() && locked.vertex(c, v)[0] != 0.0f) ++v;
    ASSERT_LT(v, locked.cubes[c].vertex_count());
    locked.cubes[c].vertices.positions[3 * v + 1] += 1;
    EXPECT_THAT(verify(locked), HasSubstr("level 1's open boundary is not the full-resolution level's"));

    // A model whose boundary was simplified, saying it is locked.
    Model free = *grid_;
    free.header.flags |= kLockedBoundary;
    EXPECT_THAT(verify(free), HasSubstr("level 0's open boundary is not the full-resolution level's"));
}

TEST_F(Verify, VertexFarOutsideItsCell) {
    Model m = *sphere_;
    ASSERT_LT(m.header.sigma0, 0.45f);
    const size_t c = m.cube_at(2);
    ASSERT_LT(c, m.nodes.size());
    m.cubes[c].vertices.positions[3 * 4 + 0] = 65535;  // x half a cell past the cell's upper side
    std::string message = verify(m);
    EXPECT_THAT(message, HasSubstr(describe_cube(m.nodes[c]) + ": vertex 4 lies"));
    EXPECT_THAT(message, HasSubstr("from its cell"));

    // The same at level 1, below the cell (children then no longer find it: the bound is checked first).
    m = *sphere_;
    const size_t p = m.cube_at(1);
    m.cubes[p].vertices.positions[3 * 0 + 1] = 0;
    message = verify(m);
    EXPECT_THAT(message, HasSubstr(describe_cube(m.nodes[p]) + ": vertex 0 lies"));
    EXPECT_THAT(message, HasSubstr("from its cell"));
}

TEST_F(Verify, ParentPastTheParentCubesVertices) {
    Model m = *sphere_;
    const size_t c = m.cube_at(2);
    const uint32_t parent_vertices = m.cubes[m.parent_of(c)].vertex_count();
    m.cubes[c].parent_vertex[3] = parent_vertices;
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(m.nodes[c]) + ": vertex 3's parent " + std::to_string(parent_vertices) +
                                     " lies past the parent cube's " + std::to_string(parent_vertices) + " vertices"));
}

TEST_F(Verify, ChildTriangleRemoved) {
    Model m = *sphere_;
    const size_t c = m.cube_at(2);
    CubeData& cube = m.cubes[c];
    const CubeData& parent_cube = m.cubes[m.parent_of(c)];
    // A triangle whose image under P is a real triangle (removing a degenerate one changes nothing).
    auto parent_position = [&](uint32_t v) {
        const uint16_t* p = &parent_cube.vertices.positions[3 * size_t(cube.parent_vertex[v])];
        return std::array<uint16_t, 3>{p[0], p[1], p[2]};
    };
    size_t victim = cube.triangle_count();
    for (size_t t = 0; t < cube.triangle_count() && victim == cube.triangle_count(); ++t) {
        auto a = parent_position(cube.indices[3 * t]), b = parent_position(cube.indices[3 * t + 1]),
             d = parent_position(cube.indices[3 * t + 2]);
        if (a != b && b != d && a != d) victim = t;
    }
    ASSERT_LT(victim, cube.triangle_count());
    cube.indices.erase(cube.indices.begin() + long(3 * victim), cube.indices.begin() + long(3 * victim + 3));
    cube.child_triangle_counts[0]--;  // level L: every triangle counts in group 0
    std::string message = verify(m);
    // "…: its N triangles mapped by P differ from the N + 1 of its part of cube (level 1, …)"
    std::smatch match;
    ASSERT_TRUE(std::regex_search(message, match, std::regex(R"(: its (\d+) triangles mapped by P differ from the (\d+) of its part of cube \(level 1, )")))
        << message;
    EXPECT_THAT(message, HasSubstr(describe_cube(m.nodes[c]) + ": its "));
    EXPECT_EQ(std::stoi(match[1]) + 1, std::stoi(match[2]));

    // The other way: a triangle of the parent's part removed. Level-1 cubes are checked against the
    // root first, so it is caught there or by the children, whichever comes first: either way it fails.
    m = *sphere_;
    const size_t p = m.cube_at(1, 4);
    ASSERT_LT(p, m.nodes.size());
    CubeData& parent = m.cubes[p];
    size_t group = 0;
    while (parent.child_triangle_counts[group] == 0) ++group;
    size_t first = 0;
    for (size_t o = 0; o < group; ++o) first += parent.child_triangle_counts[o];
    parent.indices.erase(parent.indices.begin() + long(3 * first), parent.indices.begin() + long(3 * first + 3));
    parent.child_triangle_counts[group]--;
    EXPECT_THAT(verify(m), HasSubstr("triangles mapped by P differ"));
}

TEST_F(Verify, ParentFartherThanSigma0) {
    Model m = *sphere_;
    const double bound = m.header.sigma0 * m.header.cube_size(3);  // σ0·s_{l+1} for l = 2
    // Point some vertex at another vertex of the parent cube that lies well beyond the bound: a real
    // vertex of the parent cube, just too far away.
    for (size_t c = 0; c < m.nodes.size(); ++c) {
        if (m.nodes[c].level != 2) continue;
        CubeData& cube = m.cubes[c];
        const size_t parent = m.parent_of(c);
        for (uint32_t v = 0; v < cube.vertex_count(); ++v)
            for (uint32_t e = 0; e < m.cubes[parent].vertex_count(); ++e)
                if (linf(m.vertex(c, v), m.vertex(parent, e)) > 2 * bound) {
                    EXPECT_LE(linf(m.vertex(c, v), m.vertex(parent, cube.parent_vertex[v])), bound + 1e-4);  // before
                    cube.parent_vertex[v] = e;
                    std::string message = verify(m);
                    EXPECT_THAT(message, HasSubstr(describe_cube(m.nodes[c]) + ": vertex " + std::to_string(v) + " lies"));
                    EXPECT_THAT(message, HasSubstr("from its parent, more than σ0·s_{l+1}"));
                    return;
                }
    }
    FAIL() << "no parent vertex lies farther than 2·σ0·s_{l+1} from a vertex";
}

TEST_F(Verify, MissingCubes) {
    // No root.
    Model m = *sphere_;
    m.erase(m.find(0, 0, 0, 0));
    EXPECT_THAT(verify(m), HasSubstr("level 0 has no cubes"));

    // A level-1 cube gone while its children remain (an open model, so that the hole it leaves in level
    // 1 is not reported first as a boundary edge).
    m = *grid_;
    size_t dropped = m.nodes.size();
    for (size_t c = 0; c < m.nodes.size() && dropped == m.nodes.size(); ++c) {
        const HlodNode& n = m.nodes[c];
        if (n.level != 1) continue;
        for (const HlodNode& child : m.nodes)
            if (child.level == 2 && child.i / 2 == n.i && child.j / 2 == n.j && child.k / 2 == n.k) dropped = c;
    }
    ASSERT_LT(dropped, m.nodes.size());
    const HlodNode gone = m.nodes[dropped];
    m.erase(dropped);
    // Its group in the root goes too, so that the root no longer asks for it: only the children remain
    // as witnesses (otherwise the root's dangling group is reported first).
    CubeData& root = m.cubes[m.find(0, 0, 0, 0)];
    const uint32_t gone_octant = (gone.i & 1) | (gone.j & 1) << 1 | (gone.k & 1) << 2;
    size_t first = 0;
    for (uint32_t o = 0; o < gone_octant; ++o) first += root.child_triangle_counts[o];
    root.indices.erase(root.indices.begin() + long(3 * first),
                       root.indices.begin() + long(3 * (first + root.child_triangle_counts[gone_octant])));
    root.child_triangle_counts[gone_octant] = 0;
    // The verifier checks the node table in file order: the first orphan is named.
    const HlodNode* orphan = nullptr;
    for (const HlodNode& n : m.nodes)
        if (!orphan && n.level == 2 && n.i / 2 == gone.i && n.j / 2 == gone.j && n.k / 2 == gone.k) orphan = &n;
    ASSERT_NE(orphan, nullptr);
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(*orphan) + " has no parent cube"));

    // A leaf gone while its parent still holds triangles from it (FORMAT.md §8: a non-empty group has
    // its child cube).
    m = *sphere_;
    const size_t leaf = m.cube_at(2, 1);
    const HlodNode lost = m.nodes[leaf];
    m.erase(leaf);
    const HlodNode& parent = m.nodes[m.find(1, lost.i / 2, lost.j / 2, lost.k / 2)];
    const uint32_t octant = (lost.i & 1) | (lost.j & 1) << 1 | (lost.k & 1) << 2;
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(parent) + " has triangles from child octant " + std::to_string(octant)));

    // A whole level gone.
    m = *sphere_;
    for (size_t c = m.nodes.size(); c-- > 0;)
        if (m.nodes[c].level == 1) m.erase(c);
    EXPECT_THAT(verify(m), HasSubstr("level 1 has no cubes"));

    // And the same cube twice.
    m = *sphere_;
    m.nodes.push_back(m.nodes[m.cube_at(2)]);
    m.cubes.push_back(m.cubes[m.cube_at(2)]);
    EXPECT_THAT(verify(m), HasSubstr("appears twice"));
}

TEST_F(Verify, ErrorsInTheNodeTable) {
    // A bound is never below what the lattice's rounding alone can move a vertex.
    Model m = *sphere_;
    ASSERT_TRUE(m.header.flags & kErrorsAreBounds);
    const size_t c = m.cube_at(2);
    m.nodes[c].error = 0;
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(m.nodes[c]) + " has error 0, below its lattice's rounding"));

    // A model from before the bound (its error an estimate) keeps the old rule: exact at level L.
    m = *sphere_;
    m.header.flags &= ~uint32_t(kErrorsAreBounds);
    m.nodes[c].error = 1e-9f;
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(m.nodes[c]) + " at full resolution has nonzero error"));

    // Above the header's ε_q.
    m = *sphere_;
    ASSERT_GT(m.header.error_q, 0.0f);
    const size_t p = m.cube_at(1);
    m.nodes[p].error = 2 * m.header.error_q * float(m.header.cube_size(1));
    EXPECT_THAT(verify(m), HasSubstr("above the header's ε_q"));

    // Errors are cumulative against level L: a parent is never more exact than its children.
    m = *sphere_;
    const size_t root = m.find(0, 0, 0, 0);
    ASSERT_GT(m.nodes[p].error, 0.0f);
    m.nodes[root].error = m.nodes[p].error / 2;
    EXPECT_THAT(verify(m), HasSubstr("cube (level 0, 0 0 0) has error "));
    EXPECT_THAT(verify(m), HasSubstr(", less than its child"));

    // Not a number, or negative.
    m = *sphere_;
    m.nodes[p].error = -1;
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(m.nodes[p]) + " has error -1"));
    m.nodes[p].error = NAN;
    EXPECT_THAT(verify(m), HasSubstr(describe_cube(m.nodes[p]) + " has error"));
}

// A byte of the zero padding before level 1's payloads: no cube reads it, opening does not check PAYL's
// CRC, but verify does.
TEST_F(Verify, FlippedPaddingByteBetweenLevels) {
    std::vector<uint8_t> bytes;
    {
        std::ifstream in(*dir_ / "sphere.hlod", std::ios::binary);
        bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    const HlodNode& root = sphere_->nodes[sphere_->find(0, 0, 0, 0)];
    const uint64_t padding = root.offset + root.size;
    ASSERT_NE(padding % 4096, 0u);
    ASSERT_EQ(bytes.at(padding), 0);
    bytes[padding] = 0x5a;
    const auto path = dir.path() / "padding.hlod";
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    HlodFile file(path);
    for (const HlodNode& n : file.nodes()) EXPECT_NO_THROW(file.read_cube(n));
    try {
        verify_hlod(file);
        ADD_FAILURE() << "verified a file with a flipped padding byte";
    } catch (const std::runtime_error& e) {
        EXPECT_THAT(e.what(), HasSubstr(path.string() + ": section 'PAYL' checksum mismatch"));
    }
}

TEST_F(Verify, RootVertexNotItsOwnParent) {
    Model m = *sphere_;
    const size_t root = m.find(0, 0, 0, 0);
    ASSERT_LT(root, m.nodes.size());
    CubeData& cube = m.cubes[root];
    std::swap(cube.parent_vertex[0], cube.parent_vertex[1]);
    EXPECT_THAT(verify(m), HasSubstr("cube (level 0, 0 0 0): vertex 0 is not its own parent at level 0"));
}

// ---- build_hlod: cancellation and bad input -----------------------------------------------------------

TEST(BuildCancel, CancelledBeforeItStartsLeavesNothing) {
    test::TempDir dir;
    std::atomic<bool> cancel{true};
    Progress progress;
    progress.cancel = &cancel;
    BuildSettings s;
    s.levels = 2;
    EXPECT_THROW(build_hlod(test::icosphere(3), dir / "out.hlod", s, "sphere", progress), Cancelled);
    EXPECT_TRUE(directory_entries(dir.path()).empty()) << "left " << directory_entries(dir.path()).front();
}

TEST(BuildCancel, CancelledMidwayLeavesNothing) {
    test::TempDir dir;
    std::atomic<bool> cancel{false};
    int reports = 0;
    Progress progress;
    progress.cancel = &cancel;
    progress.report = [&](std::string_view stage, double, double, std::string_view) {
        ++reports;
        if (stage == "simplify level 1") cancel = true;  // level 2's payloads are already written
    };
    BuildSettings s;
    s.levels = 2;
    EXPECT_THROW(build_hlod(test::icosphere(4), dir / "out.hlod", s, "sphere", progress), Cancelled);
    EXPECT_TRUE(cancel.load());
    EXPECT_GT(reports, 0);
    EXPECT_TRUE(directory_entries(dir.path()).empty()) << "left " << directory_entries(dir.path()).front();
}

class BuildRejects : public ::testing::Test {
protected:
    // build_hlod throws InputError containing `what`, and leaves the directory empty.
    void expect_rejected(Mesh mesh, const BuildSettings& s, const std::string& what) {
        try {
            build_hlod(std::move(mesh), dir / "out.hlod", s, "input.ply");
            ADD_FAILURE() << "built; expected \"" << what << "\"";
        } catch (const InputError& e) {
            EXPECT_THAT(e.what(), HasSubstr(what));
        }
        EXPECT_TRUE(directory_entries(dir.path()).empty());
    }
    static BuildSettings with(void (*edit)(BuildSettings&)) {
        BuildSettings s;
        s.levels = 2;
        edit(s);
        return s;
    }
    test::TempDir dir;
};

TEST_F(BuildRejects, SettingsOutOfRange) {
    Mesh mesh = test::icosphere(1);
    expect_rejected(mesh, with([](BuildSettings& s) { s.block = 6; }), "--block");
    expect_rejected(mesh, with([](BuildSettings& s) { s.block = 0; }), "--block");
    expect_rejected(mesh, with([](BuildSettings& s) { s.ratio = 0; }), "--ratio");
    expect_rejected(mesh, with([](BuildSettings& s) { s.ratio = 1; }), "--ratio");
    expect_rejected(mesh, with([](BuildSettings& s) { s.ratio = NAN; }), "--ratio");
    expect_rejected(mesh, with([](BuildSettings& s) { s.sigma0 = 0.05f; }), "--sigma0");
    expect_rejected(mesh, with([](BuildSettings& s) { s.sigma0 = 0.5f; }), "--sigma0");
    expect_rejected(mesh, with([](BuildSettings& s) { s.levels = 16; }), "--levels");
    expect_rejected(mesh, with([](BuildSettings& s) { s.levels = -2; }), "--levels");
    expect_rejected(mesh, with([](BuildSettings& s) { s.error = 0; }), "--error");
    // The limits themselves are fine.
    BuildSettings edge = with([](BuildSettings& s) { s.sigma0 = 0.45f, s.ratio = 0.9f, s.block = 8; });
    EXPECT_NO_THROW(build_hlod(test::icosphere(3), dir / "edge.hlod", edge, "input.ply"));
    EXPECT_NO_THROW(verify_hlod(HlodFile(dir / "edge.hlod")));
}

TEST_F(BuildRejects, EmptyMesh) {
    expect_rejected(Mesh{}, with([](BuildSettings&) {}), "input.ply: the mesh has no triangles");
    Mesh points_only;
    points_only.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    expect_rejected(points_only, with([](BuildSettings&) {}), "no triangles");
}

TEST_F(BuildRejects, EveryVertexAtOnePoint) {
    Mesh mesh;
    mesh.positions = {1, 2, 3, 1, 2, 3, 1, 2, 3, 1, 2, 3};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    expect_rejected(mesh, with([](BuildSettings&) {}), "input.ply: every vertex lies at one point");
    Mesh automatic = mesh;
    expect_rejected(automatic, BuildSettings{}, "every vertex lies at one point");
}

}  // namespace
}  // namespace strata

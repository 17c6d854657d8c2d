// The files a build's jobs hand each other (job_files.h), and the triangle spill (run_spill.h): what
// goes in comes back exactly, grouped as the next stage asks for it, and damage is an error naming the file.
#include "preprocess/hlod_format.h"
#include "preprocess/job_files.h"
#include "preprocess/run_spill.h"
#include "tests/support/test_meshes.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <thread>

namespace strata::build {
namespace {

CubeRecord record(CubeKey key, uint32_t vertices, uint32_t triangles, bool attributes) {
    CubeRecord c;
    c.key = key;
    c.error = 0.25f * float(key % 7);
    for (uint32_t v = 0; v < vertices; ++v) {
        c.positions.insert(c.positions.end(), {float(v), float(key), -0.5f * float(v)});
        if (attributes) {
            c.colors.insert(c.colors.end(), {uint8_t(v), uint8_t(key), 7, 255});
            c.uvs.insert(c.uvs.end(), {0.5f * float(v), 1.0f});
            c.normals.insert(c.normals.end(), {0, 0, float(v % 2 ? 1 : -1)});
            c.boundary.push_back(uint8_t(v % 3 == 0));
        }
    }
    for (uint32_t t = 0; t < triangles; ++t) c.triangles.insert(c.triangles.end(), {t % vertices, (t + 1) % vertices, (t + 2) % vertices});
    c.child_counts = {triangles / 2, 0, 0, triangles - triangles / 2, 0, 0, 0, 0};
    return c;
}

void expect_same(const CubeRecord& a, const CubeRecord& b) {
    EXPECT_EQ(a.key, b.key);
    EXPECT_EQ(a.error, b.error);
    EXPECT_EQ(a.positions, b.positions);
    EXPECT_EQ(a.colors, b.colors);
    EXPECT_EQ(a.uvs, b.uvs);
    EXPECT_EQ(a.normals, b.normals);
    EXPECT_EQ(a.boundary, b.boundary);
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_EQ(a.child_counts, b.child_counts);
}

Frame test_frame() {
    Frame f{};
    f.root_size = 1, f.max_level = 6, f.block = 4, f.sigma0 = 0.25f;
    return f;
}

BorderEntry listing(float x, CubeKey block, CubeKey cube) {
    BorderEntry e{};
    const float position[3] = {x, 2 * x, -x};
    e.position = position_bits(position);
    e.block = block, e.cube = cube;
    e.normal_sum = {x, 0.5f, -1};
    return e;
}

void expect_throws_naming(const std::function<void()>& act, const std::string& path, const std::string& what) {
    try {
        act();
        ADD_FAILURE() << "no error for " << what;
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
}

void flip_byte(const std::filesystem::path& path, uint64_t at) {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekg(std::streamoff(at));
    const char c = char(file.get() ^ 0x20);
    file.seekp(std::streamoff(at));
    file.put(c);
}

OpenEdge edge(float x) {
    const float a[3] = {x, 0, 1}, b[3] = {x, 1, 0};
    return OpenEdge{position_bits(a), position_bits(b)};
}

// A job's cubes come back by block (the blocks a consumer asks for, in key order), whatever order they
// went in; the listings and the odd edges come back whole.
TEST(CubeFile, CubesComeBackGroupedByBlockInKeyOrder) {
    test::TempDir dir;
    const Frame f = test_frame();
    std::vector<CubeRecord> cubes;
    for (CubeKey c = 0; c < 60; ++c) {
        const CubeKey key = make_key(c * 7 % 13, c % 5, c * 3 % 11);
        bool seen = false;
        for (const CubeRecord& r : cubes) seen |= r.key == key;
        if (!seen) cubes.push_back(record(key, 3 + uint32_t(c % 9), uint32_t(c % 6), c % 2 == 0));
    }
    std::vector<BorderEntry> border;
    for (int e = 0; e < 40; ++e) border.push_back(listing(0.01f * float(e), CubeKey(e % 3), CubeKey(e)));
    const auto path = dir / "0000.cubes";
    const std::vector<OpenEdge> odd = {edge(0.25f), edge(0.5f), edge(2)};
    const uint64_t bytes = write_cube_file(path, cubes, 6, border, odd, f);
    EXPECT_EQ(bytes, std::filesystem::file_size(path));

    const CubeFile file(path);
    EXPECT_EQ(file.level(), 6u);
    std::map<CubeKey, std::vector<CubeRecord>> by_block;
    for (const CubeRecord& c : cubes) by_block[f.block_of(c.key)].push_back(c);
    ASSERT_GT(by_block.size(), 3u) << "the test needs cubes in several blocks";
    for (auto& [block, want] : by_block) {
        std::sort(want.begin(), want.end(), [](const CubeRecord& a, const CubeRecord& b) { return a.key < b.key; });
        const std::vector<CubeRecord> got = file.cubes_of(block);
        ASSERT_EQ(got.size(), want.size()) << "block " << block;
        uint64_t triangles = 0;
        for (size_t i = 0; i < got.size(); ++i) expect_same(got[i], want[i]), triangles += want[i].triangle_count();
        EXPECT_EQ(file.triangles_of(block), triangles);
    }
    EXPECT_TRUE(file.cubes_of(make_key(100, 100, 100)).empty());
    const std::vector<BorderEntry> listed = file.listings();
    ASSERT_EQ(listed.size(), border.size());
    EXPECT_EQ(std::memcmp(listed.data(), border.data(), border.size() * sizeof(BorderEntry)), 0);
    EXPECT_EQ(file.odd_edges(), odd);
}

TEST(CubeFile, AnEmptyJobWritesAFileThatReadsEmpty) {
    test::TempDir dir;
    write_cube_file(dir / "empty.cubes", {}, 3, {}, {}, test_frame());
    const CubeFile file(dir / "empty.cubes");
    EXPECT_TRUE(file.cubes_of(0).empty());
    EXPECT_TRUE(file.listings().empty());
    EXPECT_TRUE(file.odd_edges().empty());
}

TEST(CubeFile, DamageIsAnErrorNamingTheFile) {
    test::TempDir dir;
    const Frame f = test_frame();
    const auto path = dir / "job.cubes";
    const std::vector<CubeRecord> cubes = {record(make_key(1, 1, 1), 9, 5, true)};
    write_cube_file(path, cubes, 6, {listing(0.5f, 0, 1)}, {edge(1)}, f);
    const uint64_t cube_at = 16 + 44 + 2 * 28 + 4 + 10;  // past the index of one block: inside the cube's section
    flip_byte(path, cube_at);
    {
        const CubeFile file(path);  // the index is whole
        expect_throws_naming([&] { file.cubes_of(f.block_of(cubes[0].key)); }, path.string(), "checksum mismatch");
        EXPECT_EQ(file.listings().size(), 1u) << "the listings' section is whole";
        EXPECT_EQ(file.odd_edges().size(), 1u) << "the odd edges' section is whole";
    }
    flip_byte(path, cube_at);
    flip_byte(path, 20);  // inside the index
    expect_throws_naming([&] { CubeFile{path}; }, path.string(), "checksum mismatch");
    std::filesystem::resize_file(path, 10);
    expect_throws_naming([&] { CubeFile{path}; }, path.string(), "ends early");
    expect_throws_naming([&] { CubeFile{dir / "missing.cubes"}; }, (dir / "missing.cubes").string(), "cannot open");
}

TEST(PayloadFile, PayloadsComeBackAsWrittenAndDamageIsNamed) {
    test::TempDir dir;
    std::vector<EncodedCube> cubes;
    for (uint32_t c = 0; c < 5; ++c) {
        EncodedCube e;
        e.node.level = 4, e.node.i = c, e.node.j = 2 * c, e.node.k = 3, e.node.error = 0.125f * float(c);
        e.node.vertex_count = 10 + c, e.node.triangle_count = 7 * c;
        for (uint32_t b = 0; b < 100 * c; ++b) e.payload.push_back(uint8_t(b * 31 + c));
        cubes.push_back(e);
    }
    const auto path = dir / "job.payloads";
    const uint64_t bytes = write_payload_file(path, cubes);
    EXPECT_EQ(bytes, std::filesystem::file_size(path));
    const std::vector<EncodedCube> got = read_payload_file(path);
    ASSERT_EQ(got.size(), cubes.size());
    for (size_t c = 0; c < got.size(); ++c) {
        EXPECT_EQ(got[c].payload, cubes[c].payload);
        EXPECT_EQ(std::tie(got[c].node.level, got[c].node.i, got[c].node.j, got[c].node.k, got[c].node.vertex_count,
                           got[c].node.triangle_count),
                  std::tie(cubes[c].node.level, cubes[c].node.i, cubes[c].node.j, cubes[c].node.k,
                           cubes[c].node.vertex_count, cubes[c].node.triangle_count));
        EXPECT_EQ(got[c].node.error, cubes[c].node.error);
    }
    flip_byte(path, 200);
    expect_throws_naming([&] { read_payload_file(path); }, path.string(), "checksum mismatch");
    expect_throws_naming([&] { write_payload_file(dir / "missing" / "x.payloads", cubes); },
                         (dir / "missing" / "x.payloads").string(), "cannot write");
}

// Runs of bytes come back whole and in order whatever the budget made wait in memory; a released run
// gives its bytes back to the disk.
TEST(RunSpill, RunsReadBackInOrderWhateverTheBudget) {
    test::TempDir dir;
    auto fill = [&](RunSpill& spill) {
        std::vector<std::thread> writers;
        for (int w = 0; w < 3; ++w)  // each key has one writer, as the builder's blocks do
            writers.emplace_back([&, w] {
                for (uint32_t i = 0; i < 40000; ++i) {
                    const CubeKey key = CubeKey(w) * 7 + i % 5;
                    const uint32_t value[2] = {i, uint32_t(key)};
                    spill.append(key, value, sizeof value);
                }
            });
        for (std::thread& t : writers) t.join();
        spill.finish();
    };
    DiskUsage small_disk, large_disk;
    RunSpill small(dir / "small.runs", small_disk, 1), large(dir / "large.runs", large_disk, uint64_t(1) << 30);
    fill(small), fill(large);
    ASSERT_EQ(small.keys(), large.keys());
    EXPECT_EQ(small.keys().size(), 15u);
    EXPECT_LE(small.memory_bytes(), (uint64_t(1) << 20) + 8) << "waited past its budget";
    EXPECT_GT(large.memory_bytes(), uint64_t(900000));
    for (CubeKey key : small.keys()) {
        const std::vector<uint8_t> a = small.read(key), b = large.read(key);
        ASSERT_EQ(a, b) << "key " << key;
        ASSERT_EQ(a.size(), 8u * 8000);
        uint32_t first[2];
        std::memcpy(first, a.data() + 8, 8);
        EXPECT_EQ(first[0], 5u + key % 7) << "the second record of the run is its writer's second for the key";
    }
    EXPECT_TRUE(small.read(1000).empty());
    EXPECT_EQ(small_disk.peak(), 15u * 8 * 8000);
    for (CubeKey key : small.keys()) small.release(key);
    small.append(99, "x", 1);  // the usage falls back: a new peak would need all the bytes again
    small.finish();
    EXPECT_EQ(small_disk.peak(), 15u * 8 * 8000);
}

// A kept spill outlives its object, and its saved index opens it again, in another process as here.
TEST(RunSpill, AKeptSpillReopensFromItsIndex) {
    test::TempDir dir;
    const auto path = dir / "triangles.spill";
    DiskUsage disk;
    ByteWriter index;
    std::map<CubeKey, std::vector<uint8_t>> runs;
    {
        RunSpill spill(path, disk, 1, ScratchFile::Lifetime::kept);
        for (uint32_t i = 0; i < 300000; ++i) {
            const CubeKey key = i % 7 * 1000;
            spill.append(key, &i, 4);
        }
        spill.finish();
        for (CubeKey key : spill.keys()) runs[key] = spill.read(key);
        spill.save_index(index);
    }
    ASSERT_TRUE(std::filesystem::exists(path)) << "a kept spill stays";
    ByteReader reader{index.bytes, "index"};
    DiskUsage later;
    const RunSpill reopened(path, later, reader);
    ASSERT_EQ(reopened.keys().size(), runs.size());
    for (const auto& [key, bytes] : runs) EXPECT_EQ(reopened.read(key), bytes) << "key " << key;
    ByteReader cut{std::span<const uint8_t>(index.bytes).first(index.bytes.size() - 3), "index"};
    EXPECT_THROW(RunSpill(path, later, cut), std::runtime_error);
}

}  // namespace
}  // namespace strata::build

// CubeStore: the builder's level files. Records come back exactly as they went in, from any thread.
#include "preprocess/cube_store.h"
#include "preprocess/run_spill.h"
#include "tests/support/test_meshes.h"

#include <gtest/gtest.h>

#include <cstring>
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
    EXPECT_EQ(a.triangles, b.triangles);
    EXPECT_EQ(a.child_counts, b.child_counts);
}

TEST(CubeStore, RecordsComeBackByKeyFromConcurrentWriters) {
    test::TempDir dir;
    const auto path = dir / "level-3.cubes";
    DiskUsage disk;
    {
        CubeStore store(path, disk);
        std::vector<std::thread> writers;
        for (int w = 0; w < 4; ++w)
            writers.emplace_back([&, w] {
                for (CubeKey k = CubeKey(w); k < 200; k += 4) store.put(record(k * 977, 5 + uint32_t(k % 11), uint32_t(k % 13), k % 3 == 0));
            });
        for (std::thread& t : writers) t.join();
        const std::vector<CubeKey>& keys = store.keys();
        ASSERT_EQ(keys.size(), 200u);
        EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
        uint64_t triangles = 0;
        for (CubeKey k = 0; k < 200; ++k) {
            const CubeRecord want = record(k * 977, 5 + uint32_t(k % 11), uint32_t(k % 13), k % 3 == 0);
            expect_same(store.get(k * 977), want);
            triangles += want.triangle_count();
        }
        EXPECT_EQ(store.triangles(), triangles);
        EXPECT_THROW(store.get(1), std::logic_error);
        EXPECT_TRUE(std::filesystem::exists(path));
        EXPECT_EQ(disk.peak(), std::filesystem::file_size(path)) << "the store counts what it writes";
    }
    EXPECT_FALSE(std::filesystem::exists(path)) << "the store removes its file";
}

TEST(CubeStore, AFolderThatCannotHoldItIsNamed) {
    test::TempDir dir;
    try {
        DiskUsage disk;
        CubeStore store(dir / "missing" / "level-0.cubes", disk);
        ADD_FAILURE() << "created a store in a missing folder";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find((dir / "missing").string() + ": cannot create the build's temporary file level-0.cubes"),
                  std::string::npos)
            << e.what();
    }
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

}  // namespace
}  // namespace strata::build

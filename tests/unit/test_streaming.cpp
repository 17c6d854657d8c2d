// Streamed HLOD models (DESIGN.md §7, HlodModel::open, engine/stream): the real bunny model opened by
// its node table, its cubes loaded on the cache's threads. A fly-in never draws a cube that is not
// resident and never cracks (the CPU twin's crack check on every frame, stand-ins and capped band
// ends included), under a budget that forces evictions; a full-detail frame equals the model loaded
// whole, from a cold cache, a warm one and a budget just holding the frame; a budget below that is
// an error that says so.
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <random>
#include <set>

#include <fcntl.h>
#include <unistd.h>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "engine/scene/cull_visitor.h"
#include "nodes/hlod_model.h"
#include "tests/support/bunny_model.h"
#include "tests/support/crack_check.h"

namespace strata {
namespace {

// A camera at `eye` looking at the model's centre, with fixed clip planes (a streamed model's bound is
// its cells', looser than the decoded vertices' of a model loaded whole).
// The middle of the model's root cube, in its node frame: the same for a model loaded whole or streamed.
glm::dvec3 centre_of(const HlodModel& model) { return model.origin() + 0.5 * glm::dvec3(model.header().root_size); }

void aim(Camera& camera, const HlodModel& model, const glm::dvec3& eye) {
    camera.width = 320, camera.height = 240, camera.fov_y_degrees = 50;
    camera.near_clip = 1e-3 * model.header().root_size, camera.far_clip = 20 * model.header().root_size;
    camera.look_at(eye, centre_of(model));
}

// What one frame culls: the model's draw item (its cubes and the κ they morph with).
struct Culled {
    std::vector<uint32_t> cubes;
    Kappas kappa;
    glm::dvec3 eye;  // lattice frame
    uint64_t stand_ins = 0;
    uint64_t fading = 0;
};
// Interactive, without frustum culling (the whole selection, for the crack check); or full detail,
// culled as the renderer culls.
Culled cull_frame(Node& root, const HlodModel& model, const Camera& camera, bool full_detail = false) {
    RenderList list;
    CullVisitor cull(camera, camera.view_matrix(), camera.projection_matrix(camera.near_clip, camera.far_clip), list);
    cull.set_frustum_culling(full_detail);
    cull.set_full_detail(full_detail);
    root.accept(cull);
    Culled out{{}, model.kappas_for(camera), camera.position - model.origin(), cull.stats().stand_ins, cull.stats().fading};
    for (const DrawItem& item : list.opaque) {
        out.cubes.assign(list.item_data.begin() + item.first, list.item_data.begin() + item.first + item.count);
        out.kappa = std::static_pointer_cast<const HlodModel::DrawState>(item.state)->morph;
    }
    return out;
}

class Streaming : public ::testing::Test {
protected:
    void SetUp() override {
        if (test::bunny_hlod().empty()) GTEST_SKIP() << "data/bunny.off missing: run scripts/setup.sh";
    }
};

// What a model's cubes take once decoded, CPU and GPU together: what the budgets below are made from.
uint64_t decoded_bytes(const HlodModel& whole) {
    uint64_t bytes = 0;
    for (const HlodCube& cube : whole.cubes()) bytes += HlodModel::cube_bytes(*cube.data);
    return bytes;
}

// The fly-in, its loads either let in a few a frame (`load_rate` 0: each frame waits for one load to
// finish) or throttled to `load_rate` bytes a second while frames run on without waiting.
void fly_in_never_cracks(double load_rate) {
    const auto whole = HlodModel::load(test::bunny_hlod());
    const uint64_t model_bytes = decoded_bytes(*whole);
    auto shared_cache = std::make_shared<StreamCache>(model_bytes / 4, 2);  // a quarter of the model: the fly-in must evict
    StreamCache& cache = *shared_cache;
    cache.set_load_rate(load_rate);
    auto model = HlodModel::open(test::bunny_hlod(), shared_cache);
    model->set_kappa0(2.5);
    whole->set_kappa0(2.5);
    auto root = std::make_shared<Group>();
    root->add(model);
    const double size = model->header().root_size;
    const glm::dvec3 centre = centre_of(*model);
    int frames_with_stand_ins = 0, frames_drawn = 0;
    // From far away to just off the surface, circling, one step a frame; then the last view held.
    const int steps = 80;
    glm::dvec3 eye;
    if (load_rate > 0) {  // frames that do not wait start once the root is there: else they all draw nothing
        Camera first;
        aim(first, *model, centre + 3.0 * size * glm::dvec3(0, 0.3, 1));
        cull_frame(*root, *model, first);
        cache.wait_for_requests();
    }
    for (int frame = 0; frame < steps + 40; ++frame) {
        const double t = std::min(frame, steps) / double(steps);
        const double angle = 4.0 * t, distance = size * (3.0 * (1 - t) + 0.55 * t);
        eye = centre + distance * glm::dvec3(std::sin(angle), 0.3, std::cos(angle));
        Camera camera;
        aim(camera, *model, eye);
        const Culled culled = cull_frame(*root, *model, camera);
        frames_with_stand_ins += culled.stand_ins > 0;
        if (culled.stand_ins > 0) {
            EXPECT_TRUE(cache.has_requests()) << "a stand-in asks for its children";
        }
        if (!culled.cubes.empty()) {
            ++frames_drawn;
            for (const uint32_t c : culled.cubes) ASSERT_TRUE(model->resident(c)) << describe_cube(model->cubes()[c].node);
            ASSERT_EQ(test::odd_edges(test::drawn_triangles(*model, culled.cubes, culled.eye, *culled.kappa)), 0u)
                << "a crack in frame " << frame;
        }
        cache.update();
        const StreamCache::Stats s = cache.stats();
        ASSERT_LE(s.resident_bytes + s.reserved_bytes, s.budget);
        if (load_rate == 0) cache.wait_for_a_load();  // frames outrun loads here: let each see some arrive, not all
    }
    if (load_rate == 0) {  // throttled, a fast machine may outrun or trail the loads: only cracks count
        EXPECT_GT(frames_drawn, steps);
        EXPECT_GT(frames_with_stand_ins, 3) << "frames drew stand-ins while their children loaded";
        EXPECT_GT(cache.stats().evicted, 0u);
    }
    cache.set_load_rate(0);
    // Held still with room for it, the view converges on what the model loaded whole draws: a level or
    // more a frame, each level's arrival faded in over HlodModel::kFadeFrames frames.
    cache.set_budget(2 * model_bytes);
    Camera camera;
    aim(camera, *model, eye);
    std::vector<uint32_t> drawn;
    bool converged = false;
    for (int frame = 0; frame < 20 * HlodModel::kFadeFrames && !converged; ++frame) {
        const Culled culled = cull_frame(*root, *model, camera);
        drawn = culled.cubes;
        converged = !cache.has_requests() && culled.fading == 0 && culled.stand_ins == 0;
        cache.wait_for_requests();
    }
    EXPECT_TRUE(converged);
    std::vector<uint32_t> expected;
    whole->select({eye - whole->origin(), whole->kappas_for(camera)}, expected);
    EXPECT_EQ(drawn, expected);
}

TEST_F(Streaming, AFlyInDrawsOnlyResidentCubesAndNeverCracks) { fly_in_never_cracks(0); }

// What a full-detail frame culls, as the renderer does it: cull with the frustum, wait for what the
// cull asked for, again until it asks for nothing.
Culled full_detail_cull(Node& root, const HlodModel& model, const Camera& camera, StreamCache* cache) {
    for (;;) {
        Culled out = cull_frame(root, model, camera, true);
        if (!cache || !cache->has_requests()) return out;
        cache->wait_for_requests();
    }
}

// A full-detail frame draws what the model loaded whole draws, whatever the cache holds from before
// (issue 16 §2). Each history opens the model cold and runs a few interactive frames from random
// views close by, whose loads stop part way; then a full-detail view from close by looking past
// the model's centre, so that cubes beside and behind the eye lie outside its frustum, some of them
// resident without all their children. Such a cube stands in, and caps the drawn cubes beside it
// (coarser cubes, or band ends of 0), unless the frame loads its children too: the drawn triangles
// (the CPU twin's morphed positions, bit for bit) then differ from the model loaded whole.
TEST_F(Streaming, FullDetailCullsEqualTheWholeModelsAfterAnyHistory) {
    const auto whole = HlodModel::load(test::bunny_hlod());
    whole->set_pixel_error(1.0);
    auto whole_root = std::make_shared<Group>();
    whole_root->add(whole);
    const uint64_t model_bytes = decoded_bytes(*whole);
    const double size = whole->header().root_size;
    const glm::dvec3 centre = centre_of(*whole);
    std::mt19937 random(16);
    std::uniform_real_distribution<double> unit(-1.0, 1.0), near(0.55, 1.0);
    std::uniform_int_distribution<int> frames(1, 6);
    auto random_direction = [&] {
        glm::dvec3 d;
        do d = {unit(random), unit(random), unit(random)};
        while (glm::length(d) > 1 || glm::length(d) < 0.1);
        return glm::normalize(d);
    };
    auto random_view = [&](Camera& camera) {
        aim(camera, *whole, centre + near(random) * size * random_direction());
        camera.look_at(camera.position, centre + 0.5 * size * random_direction());
    };
    int differing = 0, views_with_cubes = 0;
    for (int history = 0; history < 40; ++history) {
        auto cache = std::make_shared<StreamCache>(2 * model_bytes, 2);
        auto model = HlodModel::open(test::bunny_hlod(), cache);
        cache->set_budget(model_bytes + cache->stats().held_bytes);  // the model's cubes beside its tables
        model->set_pixel_error(1.0);
        auto root = std::make_shared<Group>();
        root->add(model);
        for (int frame = frames(random); frame > 0; --frame) {
            Camera camera;
            random_view(camera);
            cull_frame(*root, *model, camera);
            cache->update();
            cache->wait_for_a_load();
        }
        Camera camera;
        random_view(camera);
        const Culled streamed = full_detail_cull(*root, *model, camera, cache.get());
        const Culled expected = full_detail_cull(*whole_root, *whole, camera, nullptr);
        EXPECT_EQ(streamed.stand_ins, 0u);
        views_with_cubes += !expected.cubes.empty();
        const bool same = streamed.cubes == expected.cubes &&
                          test::drawn_triangles(*model, streamed.cubes, streamed.eye, *streamed.kappa) ==
                              test::drawn_triangles(*whole, expected.cubes, expected.eye, *expected.kappa);
        differing += !same;
        EXPECT_TRUE(same) << "history " << history << ": " << streamed.cubes.size() << " cubes drawn, " << expected.cubes.size()
                          << " by the model loaded whole";
    }
    EXPECT_EQ(differing, 0);
    EXPECT_GT(views_with_cubes, 20) << "too few views saw the model to tell";
}

// Loads throttled to a disk's speed and to a tenth of it (the bunny's cubes are a few tens of kB):
// frames do not wait, and whatever they catch of the loads, none cracks.
TEST_F(Streaming, AFlyInWithLoadsAtDiskSpeedOrATenthOfItNeverCracks) {
    fly_in_never_cracks(100e6);
    fly_in_never_cracks(10e6);
}

// A copy of the bunny model to break, opened for streaming through a cache of its own whose budget
// pins the coarse levels only.
struct BreakableCopy {
    test::TempDir dir;
    std::filesystem::path path = dir / "bunny.hlod";
    std::shared_ptr<StreamCache> cache = std::make_shared<StreamCache>(uint64_t(16) << 20, 2);
    std::shared_ptr<HlodModel> model;
    std::shared_ptr<Group> root = std::make_shared<Group>();
    BreakableCopy() {
        std::filesystem::copy_file(test::bunny_hlod(), path);
        model = HlodModel::open(path, cache);
        model->set_kappa0(2.5);
        root->add(model);
    }
    // The finest cube with the most triangles.
    uint32_t largest_finest_cube() const {
        uint32_t largest = 0;
        for (uint32_t c = 0; c < model->cubes().size(); ++c) {
            const HlodNode& n = model->cubes()[c].node, &best = model->cubes()[largest].node;
            if (n.level > best.level || (n.level == best.level && n.triangle_count > best.triangle_count)) largest = c;
        }
        return largest;
    }
};

// Faults (issue 16 §4): a cube whose payload turns corrupt after the model was opened fails to load,
// named by file and cube; its parent stands in for it (and its siblings) on every frame, with no crack
// and no crash; a capture that needs it fails with that message; a truncated file fails alike.
TEST_F(Streaming, ACubeThatCannotBeReadLeavesItsParentStandingInAndACaptureNamesIt) {
    const BreakableCopy breakable;
    const std::filesystem::path& copy = breakable.path;
    const std::shared_ptr<StreamCache>& cache = breakable.cache;
    const std::shared_ptr<HlodModel>& model = breakable.model;
    const std::shared_ptr<Group>& root = breakable.root;
    const uint32_t broken = breakable.largest_finest_cube();  // seen from just off its cell
    {  // one byte of its payload flipped: its checksum no longer matches
        std::fstream file(copy, std::ios::in | std::ios::out | std::ios::binary);
        const auto at = std::streamoff(model->cubes()[broken].node.offset + model->cubes()[broken].node.size / 2);
        file.seekg(at);
        const char byte = char(file.get());
        file.seekp(at);
        file.put(char(byte ^ 0x5a));
    }
    const Box cell = model->cell(model->cubes()[broken].node);
    const glm::dvec3 eye = cell.center() + model->origin() + glm::dvec3(0, 0, 0.02 * model->header().root_size);
    Camera camera;
    aim(camera, *model, eye);
    bool failed = false;
    for (int frame = 0; frame < 60 && !failed; ++frame) {
        const Culled culled = cull_frame(*root, *model, camera);
        for (const uint32_t c : culled.cubes) ASSERT_TRUE(model->resident(c));
        ASSERT_EQ(test::odd_edges(test::drawn_triangles(*model, culled.cubes, culled.eye, *culled.kappa)), 0u) << "frame " << frame;
        cache->update();
        cache->wait_for_a_load();
        failed = cache->failure(0, broken).has_value();
    }
    ASSERT_TRUE(failed) << "the broken cube was never asked for";
    const std::string message = *cache->failure(0, broken);
    EXPECT_NE(message.find(copy.string()), std::string::npos) << message;
    EXPECT_NE(message.find(describe_cube(model->cubes()[broken].node)), std::string::npos) << message;
    // The parent stands in from now on: drawn, watertight, and a capture names the failure.
    const Culled culled = cull_frame(*root, *model, camera);
    EXPECT_NE(std::find(culled.cubes.begin(), culled.cubes.end(), model->parent(broken)), culled.cubes.end());
    EXPECT_EQ(test::odd_edges(test::drawn_triangles(*model, culled.cubes, culled.eye, *culled.kappa)), 0u);
    try {
        cache->wait_for_requests();
        FAIL() << "a capture waited for a cube that cannot be read";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), message);
    }
    // The file cut before its payloads: every cube not yet read fails the same way, naming the file.
    uint64_t payloads = UINT64_MAX;
    for (const HlodCube& cube : model->cubes()) payloads = std::min(payloads, cube.node.offset);
    std::filesystem::resize_file(copy, payloads);
    uint32_t unread = kNoCube;
    for (uint32_t c = 0; c < model->cubes().size() && unread == kNoCube; ++c)
        if (!cache->resident(0, c) && !cache->failure(0, c) && model->parent(c) != kNoCube && cache->resident(0, model->parent(c))) unread = c;
    ASSERT_NE(unread, kNoCube);
    cache->request(0, unread, 1.0);
    try {
        cache->wait_for_requests();
        FAIL() << "a cube was read past the end of the file";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(copy.string()), std::string::npos) << e.what();
    }
}

// The descriptor a model reads `path` through (HlodFile keeps it open), found in /proc/self/fd; -1 if none.
int descriptor_of(const std::filesystem::path& path) {
    const std::filesystem::path target = std::filesystem::canonical(path);
    for (const auto& entry : std::filesystem::directory_iterator("/proc/self/fd")) {
        std::error_code error;
        if (std::filesystem::read_symlink(entry.path(), error) == target) return std::stoi(entry.path().filename().string());
    }
    return -1;
}

// Faults (issue 16 §4): a read error. The model's descriptor is swapped, under it, for /proc/self/mem,
// whose low offsets (the payloads' offsets are a few MB at most) are unmapped addresses: every pread
// there fails with EIO in the kernel, as a failing disk's would. The cube is reported by file and
// cube with the system's reason, its parent stands in watertight, and a capture fails with that message.
TEST_F(Streaming, AReadErrorIsReportedByFileAndCubeWhileItsParentStandsIn) {
    const BreakableCopy breakable;
    const std::filesystem::path& copy = breakable.path;
    const std::shared_ptr<StreamCache>& cache = breakable.cache;
    const std::shared_ptr<HlodModel>& model = breakable.model;
    const std::shared_ptr<Group>& root = breakable.root;
    // The coarse levels first, read as usual: a far view until nothing is missing or loading.
    Camera camera;
    aim(camera, *model, centre_of(*model) + 3 * model->header().root_size * glm::dvec3(0, 0.3, 1));
    for (int frame = 0; frame < 200; ++frame) {
        const Culled culled = cull_frame(*root, *model, camera);
        if (culled.stand_ins == 0 && !cache->has_requests() && cache->stats().in_flight == 0) break;
        cache->update();
        cache->wait_for_a_load();
    }
    const uint32_t target = breakable.largest_finest_cube();  // where the view goes
    ASSERT_FALSE(cache->resident(0, target));
    const int fd = descriptor_of(copy);
    ASSERT_GE(fd, 0) << "the model does not hold " << copy << " open";
    const int mem = ::open("/proc/self/mem", O_RDONLY | O_CLOEXEC);
    ASSERT_GE(mem, 0);
    char byte;
    errno = 0;
    if (::pread(mem, &byte, 1, off_t(model->cubes()[target].node.offset)) != -1 || errno != EIO) {
        ::close(mem);
        GTEST_SKIP() << "the payload's offset is mapped in this process: no read error to be had from /proc/self/mem";
    }
    ASSERT_GE(::dup2(mem, fd), 0);
    ::close(mem);
    // Near the target every cube not yet read fails: the first the view asks for is the one it lacks.
    const Box cell = model->cell(model->cubes()[target].node);
    aim(camera, *model, cell.center() + model->origin() + glm::dvec3(0, 0, 0.02 * model->header().root_size));
    uint32_t broken = kNoCube;
    for (int frame = 0; frame < 60 && broken == kNoCube; ++frame) {
        const Culled culled = cull_frame(*root, *model, camera);
        for (const uint32_t c : culled.cubes) ASSERT_TRUE(model->resident(c));
        ASSERT_EQ(test::odd_edges(test::drawn_triangles(*model, culled.cubes, culled.eye, *culled.kappa)), 0u) << "frame " << frame;
        cache->update();
        cache->wait_for_a_load();
        for (uint32_t c = 0; c < model->cubes().size() && broken == kNoCube; ++c)
            if (cache->failure(0, c)) broken = c;
    }
    ASSERT_NE(broken, kNoCube) << "no read was tried";
    const std::string message = *cache->failure(0, broken);
    EXPECT_NE(message.find(copy.string()), std::string::npos) << message;
    EXPECT_NE(message.find(describe_cube(model->cubes()[broken].node)), std::string::npos) << message;
    EXPECT_NE(message.find(std::strerror(EIO)), std::string::npos) << message;
    // Its parent stands in, watertight, on every frame from now on.
    for (int frame = 0; frame < 10; ++frame) {
        const Culled culled = cull_frame(*root, *model, camera);
        EXPECT_NE(std::find(culled.cubes.begin(), culled.cubes.end(), model->parent(broken)), culled.cubes.end()) << "frame " << frame;
        for (const uint32_t c : culled.cubes) ASSERT_TRUE(model->resident(c));
        ASSERT_EQ(test::odd_edges(test::drawn_triangles(*model, culled.cubes, culled.eye, *culled.kappa)), 0u) << "frame " << frame;
        cache->update();
    }
    cull_frame(*root, *model, camera);
    try {
        cache->wait_for_requests();
        FAIL() << "a capture waited for a cube that cannot be read";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find(std::strerror(EIO)), std::string::npos) << e.what();
    }
}

class StreamingRender : public Streaming {
protected:
    static void SetUpTestSuite() { context_ = gl::create_headless_context(); }
    static void TearDownTestSuite() { context_.reset(); }
    static inline std::unique_ptr<gl::Context> context_;
};

// The frame of `model` from just off the bunny: its colour, and what the cache then held. Full detail
// unless `interactive`, which draws what is resident; `stats` receives the frame's statistics.
std::vector<float> full_detail_frame(const std::shared_ptr<HlodModel>& model, uint64_t* resident = nullptr,
                                     bool interactive = false, FrameStats* stats = nullptr) {
    model->set_pixel_error(1.0);
    auto root = std::make_shared<Group>();
    root->add(model);
    const double size = model->header().root_size;
    Camera camera;
    aim(camera, *model, centre_of(*model) + size * glm::dvec3(0.2, 0.15, 0.45));
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
    Renderer renderer;
    RenderSettings settings;
    settings.full_detail = !interactive;
    const FrameStats frame = renderer.render(*root, camera, target, settings);
    if (stats) *stats = frame;
    if (resident) *resident = StreamCache::shared()->stats().resident_bytes;
    return target.read_color();
}

TEST_F(StreamingRender, FullDetailFramesEqualTheWholeModelsFromAnyCacheThatHoldsThem) {
    StreamCache& cache = *StreamCache::shared();
    const uint64_t budget = cache.budget();
    const std::vector<float> reference = full_detail_frame(HlodModel::load(test::bunny_hlod()));
    uint64_t working_set = 0, tables = 0;
    std::weak_ptr<const void> cubes_of_the_model;
    {
        const auto model = HlodModel::open(test::bunny_hlod());
        cubes_of_the_model = model->cube_owner();
        tables = cache.stats().held_bytes;
        EXPECT_GT(tables, model->cubes().size() * 300) << "the model's per-cube tables count in the budget";
        // An interactive first frame from a cold cache draws stand-ins, or nothing, while cubes load.
        FrameStats first;
        full_detail_frame(model, nullptr, true, &first);
        EXPECT_GT(first.loads_pending, 0u);
        FrameStats full;
        const uint64_t loaded_before = cache.stats().loaded;
        EXPECT_EQ(full_detail_frame(model, &working_set, false, &full), reference) << "from a cold cache";
        EXPECT_GT(full.loaded, 0u);
        EXPECT_EQ(full.loaded, cache.stats().loaded - loaded_before) << "the cubes it loaded waiting count in its statistics";
        EXPECT_EQ(full.stand_ins, 0u);
        EXPECT_EQ(full.loads_pending, 0u);
        EXPECT_EQ(full.memory_resident, working_set);
        EXPECT_EQ(full.memory_tables, tables);
        EXPECT_EQ(full_detail_frame(model), reference) << "from a warm cache";
        EXPECT_LT(working_set, budget);
    }
    EXPECT_EQ(cache.stats().resident_bytes, 0u) << "a model's cubes go with it";
    EXPECT_EQ(cache.stats().held_bytes, 0u) << "and its tables";
    while (cache.stats().in_flight > 0) {  // loads still running hold the file's tree until they end
        cache.wait_for_a_load();
        cache.update();
    }
    EXPECT_TRUE(cubes_of_the_model.expired()) << "the counts went down, but the file's tree and cubes are still held";
    // Just the frame's cubes (and the coarse levels it pins) beside the model's tables, and room for
    // the largest cube's bound: a load reserves its bound until its actual size is known.
    uint64_t largest_bound = 0;
    {
        const auto model = HlodModel::open(test::bunny_hlod());
        for (const HlodCube& cube : model->cubes()) largest_bound = std::max(largest_bound, HlodModel::cube_bytes_bound(model->header(), cube.node, model->texture_bytes()));
    }
    cache.set_budget(working_set + tables + largest_bound);
    EXPECT_EQ(full_detail_frame(HlodModel::open(test::bunny_hlod())), reference) << "within a budget that just holds it";
    cache.set_budget(working_set / 3 + tables);
    try {
        full_detail_frame(HlodModel::open(test::bunny_hlod()));
        FAIL() << "a frame three times the budget was drawn";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("budget"), std::string::npos) << e.what();
    }
    cache.set_budget(budget);
}

// Faults (issue 16 §4): a file deleted while open, or replaced by another (renamed over it, as tools
// that save atomically do), goes on being read as the file the model opened: its full-detail frames
// are the model's, from a cold cache.
TEST_F(StreamingRender, AFileDeletedOrReplacedWhileOpenIsStillReadAsOpened) {
    const std::vector<float> reference = full_detail_frame(HlodModel::load(test::bunny_hlod()));
    test::TempDir dir;
    const std::filesystem::path path = dir / "bunny.hlod", other = dir / "other.hlod";
    std::filesystem::copy_file(test::bunny_hlod(), path);
    {
        const auto model = HlodModel::open(path);
        std::filesystem::remove(path);
        EXPECT_EQ(full_detail_frame(model), reference) << "deleted";
    }
    std::filesystem::copy_file(test::bunny_hlod(), path);
    std::filesystem::copy_file(std::filesystem::path(STRATA_SOURCE_DIR) / "tests/data/octahedron_v1.hlod", other);
    const auto model = HlodModel::open(path);
    std::filesystem::rename(other, path);
    EXPECT_EQ(full_detail_frame(model), reference) << "replaced";
}

// Models from the same file (issue 16 §1): opened twice, by its path and by a hard link, two
// instances side by side load each cube once, count it once in the budget and hold one block of it on
// the GPU; their full-detail frame equals two models loaded whole, and either draws on alone once the
// other is gone. A copy of the file (another inode) shares nothing.
TEST_F(StreamingRender, ModelsOpenedOnTheSameFileShareTheirCubesInMemoryAndOnTheGpu) {
    test::TempDir dir;
    const std::filesystem::path path = dir / "bunny.hlod", link = dir / "link.hlod", copy = dir / "copy.hlod";
    std::filesystem::copy_file(test::bunny_hlod(), path);
    std::filesystem::create_hard_link(path, link);
    std::filesystem::copy_file(test::bunny_hlod(), copy);
    const auto whole = HlodModel::load(test::bunny_hlod());
    const double size = whole->header().root_size;
    // Two instances, the second beside the first; the camera sees both.
    auto scene_of = [&](const std::shared_ptr<HlodModel>& a, const std::shared_ptr<HlodModel>& b) {
        auto root = std::make_shared<Group>();
        for (const auto& [model, x] : {std::pair{a, 0.0}, std::pair{b, 0.6 * size}}) {
            if (!model) continue;
            model->set_pixel_error(1.0);
            auto place = std::make_shared<Transform>();
            place->set_matrix(glm::translate(glm::dmat4(1.0), glm::dvec3(x, 0, 0)));
            place->add(model);
            root->add(place);
        }
        return root;
    };
    Camera camera;
    aim(camera, *whole, centre_of(*whole) + glm::dvec3(0.3 * size, 0.2 * size, 1.4 * size));
    camera.look_at(camera.position, centre_of(*whole) + glm::dvec3(0.3 * size, 0, 0));
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
    RenderSettings full;
    full.full_detail = true;
    auto frame = [&](const std::shared_ptr<Group>& root, Renderer& renderer, FrameStats* stats = nullptr) {
        const FrameStats s = renderer.render(*root, camera, target, full);
        if (stats) *stats = s;
        return target.read_color();
    };
    Renderer reference_renderer;
    const std::vector<float> reference = frame(scene_of(whole, HlodModel::load(test::bunny_hlod())), reference_renderer);
    const std::shared_ptr<StreamCache>& cache = StreamCache::shared();  // the one a full-detail frame waits on
    const uint64_t budget = cache->budget();
    cache->set_budget(2 * decoded_bytes(*whole));  // both views fit; 5 % of it pins the coarse levels only
    // One model alone: what one copy of the view's cubes holds, in the cache and on the GPU.
    uint64_t one_resident = 0, one_gpu = 0;
    {
        const auto a = HlodModel::open(path, cache);
        FrameStats stats;
        Renderer renderer;
        frame(scene_of(a, a), renderer, &stats);  // the same node twice: one model's cubes by construction
        one_resident = cache->stats().resident_bytes;
        one_gpu = stats.bytes_resident;
    }
    ASSERT_GT(one_resident, 0u);
    auto a = HlodModel::open(path, cache), b = HlodModel::open(link, cache);
    FrameStats stats;
    Renderer renderer;
    EXPECT_EQ(frame(scene_of(a, b), renderer, &stats), reference);
    EXPECT_EQ(cache->stats().resident_bytes, one_resident) << "each cube loaded once for both models";
    // On the GPU, one copy of the cubes too: what one model drawn twice holds (the view's buffers,
    // its band ends, fades and draw commands, counted per draw in both cases). Two models each with
    // their own blocks would hold twice the pool's pages.
    EXPECT_EQ(stats.bytes_resident, one_gpu);
    a.reset();
    EXPECT_EQ(frame(scene_of(nullptr, b), renderer), frame(scene_of(nullptr, HlodModel::load(test::bunny_hlod())), reference_renderer))
        << "the model left draws on alone";
    EXPECT_EQ(cache->stats().resident_bytes, one_resident) << "its cubes stay while a model reads them";
    const auto c = HlodModel::open(copy, cache);
    EXPECT_EQ(frame(scene_of(b, c), renderer), reference);
    EXPECT_GT(cache->stats().resident_bytes, one_resident + one_resident / 2) << "a copy of the file is another file";
    b.reset();
    frame(scene_of(nullptr, c), renderer);
    EXPECT_LT(cache->stats().resident_bytes, one_resident + one_resident / 2) << "the cubes went with the last model reading them";
    cache->set_budget(budget);
}

// Prefetch (issue 16 §1): frames at one view told the pose a coming frame will have load what that
// view selects, so that its first frame draws no stand-in; without being told, that first frame does.
// Each view is held until the cache is idle: nothing taken in, started or waiting for a frame.
TEST_F(StreamingRender, AViewToldThePoseToComeHasItResidentWhenItArrives) {
    StreamCache& cache = *StreamCache::shared();
    const uint64_t budget = cache.budget();
    const uint64_t model_bytes = decoded_bytes(*HlodModel::load(test::bunny_hlod()));
    cache.set_budget(2 * model_bytes);  // both views fit; 5 % of it pins the coarse levels only
    auto first_frame_there = [&](bool told) {
        const auto model = HlodModel::open(test::bunny_hlod());
        model->set_pixel_error(1.0);
        auto root = std::make_shared<Group>();
        root->add(model);
        const double size = model->header().root_size;
        Camera far, near;
        aim(far, *model, centre_of(*model) + size * glm::dvec3(2.0, 0.6, 2.4));
        aim(near, *model, centre_of(*model) + size * glm::dvec3(-0.25, 0.1, 0.3));
        gl::Framebuffer target({.width = far.width, .height = far.height, .samples = 1});
        Renderer renderer;
        RenderSettings settings;
        if (told) settings.upcoming = {{near.position, near.orientation, near.fov_y_degrees}};
        bool idle = false;
        for (int frame = 0; frame < 1000 && !idle; ++frame) {
            const FrameStats stats = renderer.render(*root, far, target, settings);
            const StreamCache::Stats s = cache.stats();
            idle = stats.frames_unconverged == 0 && stats.loaded == 0 && s.in_flight == 0 && s.prefetch_waiting == 0;
            cache.wait_for_a_load();
        }
        EXPECT_TRUE(idle);
        return renderer.render(*root, near, target, RenderSettings{});
    };
    const FrameStats untold = first_frame_there(false), told = first_frame_there(true);
    EXPECT_GT(untold.stand_ins, 0u) << "the near view needs cubes the far one does not";
    EXPECT_GT(untold.frames_unconverged, 0u);
    EXPECT_EQ(told.stand_ins, 0u);
    EXPECT_EQ(told.frames_unconverged, 0u);
    cache.set_budget(budget);
}

// The GPU pool follows residency cube by cube (hlod_model_draw.cpp): one renderer through a fly-in
// under a quarter of the model's bytes, its cubes placed in and freed from the pool's pages over and
// over. On every frame the pool holds every resident cube's block and little more (a pool that never
// freed would hold every cube ever placed, far more); after the churn a full-detail frame from the
// same renderer equals the model loaded whole.
TEST_F(StreamingRender, OneRendererThroughAFlyInThatEvictsKeepsItsPoolToTheResidentCubes) {
    StreamCache& cache = *StreamCache::shared();
    const uint64_t budget = cache.budget();
    const std::vector<float> reference = full_detail_frame(HlodModel::load(test::bunny_hlod()));
    const uint64_t model_bytes = decoded_bytes(*HlodModel::load(test::bunny_hlod()));
    cache.set_budget(model_bytes / 4);
    const auto model = HlodModel::open(test::bunny_hlod());
    model->set_pixel_error(1.0);
    auto root = std::make_shared<Group>();
    root->add(model);
    const double size = model->header().root_size;
    const bool colors = model->header().has_colors();
    auto gpu_bytes = [&](const CubeData& d) { return HlodModel::gpu_block_bytes(d.vertex_count(), d.parents.size(), d.indices.size(), colors); };
    // The pool's own buffers beside the blocks: per cube its record, links, band ends, fade and colour
    // offsets; and the frame's drawn indices and draw commands (room for twice the most cubes a frame
    // drew), its pages' unused room, at most a page (1 MiB at this budget), and the fragments between
    // blocks.
    const uint64_t fixed = model->cubes().size() * (16 + 28 * 4 + 8 + 4 + 8);
    const uint64_t slack = uint64_t(2) << 20;
    Renderer renderer;
    RenderSettings interactive;
    uint64_t ever_placed = 0, most_drawn = 0;
    std::set<const CubeData*> seen;
    // Fly-ins, in and out, until the pool has placed far more than a page (however the loads fall on
    // a busy machine), or a bound on the frames.
    for (int frame = 0; frame < 2000 && ever_placed <= (uint64_t(3) << 20); ++frame) {
        const int step = frame % 160, in = step < 80 ? step : 160 - step;
        const double t = in / 80.0, angle = 4.0 * t, distance = size * (3.0 * (1 - t) + 0.55 * t);
        Camera camera;
        aim(camera, *model, centre_of(*model) + distance * glm::dvec3(std::sin(angle), 0.3, std::cos(angle)));
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        const FrameStats stats = renderer.render(*root, camera, target, interactive);
        uint64_t placed = 0;
        for (const HlodCube& cube : model->cubes()) {
            if (!cube.data) continue;
            placed += gpu_bytes(*cube.data);
            if (seen.insert(cube.data.get()).second) ever_placed += gpu_bytes(*cube.data);
        }
        cache.wait_for_a_load();
        if (stats.cubes == 0) continue;  // nothing drawn yet: no pool
        most_drawn = std::max(most_drawn, stats.cubes);
        ASSERT_GE(stats.bytes_resident, placed + fixed) << "frame " << frame;
        ASSERT_LE(stats.bytes_resident, placed + fixed + slack) << "frame " << frame;
    }
    EXPECT_GT(cache.stats().evicted, 0u);
    // A budget of just the model's tables evicts all but the root, which is always pinned and was
    // placed first, in the first page: the pool gives the rest of its pages back. A pool that never
    // freed would hold every block ever placed.
    cache.set_budget(cache.stats().held_bytes);
    Camera far;
    aim(far, *model, centre_of(*model) + 3 * size * glm::dvec3(0, 0.3, 1));
    gl::Framebuffer far_target({.width = far.width, .height = far.height, .samples = 1});
    renderer.render(*root, far, far_target, interactive);  // its update evicts
    const FrameStats shrunk = renderer.render(*root, far, far_target, interactive);  // its draw frees
    uint64_t placed = 0;
    for (const HlodCube& cube : model->cubes())
        if (cube.data) placed += gpu_bytes(*cube.data);
    const uint64_t frame_buffers = 2 * most_drawn * (4 + 20);  // drawn indices and draw commands
    EXPECT_LE(shrunk.bytes_resident, fixed + frame_buffers + (uint64_t(1) << 20)) << "one page left";
    EXPECT_GE(shrunk.bytes_resident, placed + fixed);
    EXPECT_GT(ever_placed, (uint64_t(3) << 20)) << "the fly-ins placed too little to tell a pool that frees (one page left) from one that does not";
    cache.set_budget(budget);
    Camera camera;
    aim(camera, *model, centre_of(*model) + size * glm::dvec3(0.2, 0.15, 0.45));
    gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
    RenderSettings full;
    full.full_detail = true;
    renderer.render(*root, camera, target, full);
    EXPECT_EQ(target.read_color(), reference);
}

// Interactive frames morph with a κ that changes from frame to frame (stand-ins capped, children
// fading in), of which the GPU takes in only what changed (upload_kappas in hlod_model_draw.cpp):
// through a fly-in that loads as it goes, every drawn vertex's morphed position on the GPU equals the
// CPU twin's for that frame's κ, bit for bit.
TEST_F(StreamingRender, EveryFrameOfAFlyInThatLoadsMorphsOnTheGpuBitForBitLikeTheCpuTwin) {
    StreamCache& cache = *StreamCache::shared();
    const auto model = HlodModel::open(test::bunny_hlod());
    model->set_pixel_error(1.0);
    model->set_capture_morph(true);
    auto root = std::make_shared<Group>();
    root->add(model);
    const double size = model->header().root_size;
    Renderer renderer;
    Kappas previous;
    int overlaid = 0, changed_over_the_same_base = 0;
    uint64_t vertices = 0, mismatches = 0;
    for (int frame = 0; frame < 60; ++frame) {
        const double t = frame / 60.0, angle = 3.0 * t, distance = size * (2.5 * (1 - t) + 0.5 * t);
        Camera camera;
        aim(camera, *model, centre_of(*model) + distance * glm::dvec3(std::sin(angle), 0.3, std::cos(angle)));
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        renderer.render(*root, camera, target, RenderSettings{});
        const Kappas kappa = model->captured_kappas();
        cache.wait_for_a_load();  // each frame sees some loads arrive, not all
        if (!kappa) continue;
        overlaid += kappa->base != nullptr;
        changed_over_the_same_base += previous && kappa != previous && &kappa->root() == &previous->root();
        previous = kappa;
        const HlodModel::LatticeAnchor anchor = model->anchor_for(glm::dmat4(1.0), camera.position);
        std::vector<glm::vec3> cpu;
        for (uint32_t c = 0; c < model->cubes().size(); ++c) {
            const std::vector<glm::vec4>* gpu = model->captured_morph(c);
            if (!gpu) continue;
            model->morphed_positions(c, anchor, *kappa, cpu);
            const auto& indices = model->cubes()[c].data->indices;
            for (const uint32_t v : std::set<uint32_t>(indices.begin(), indices.end())) {
                const glm::vec3 drawn((*gpu)[v]);
                mismatches += std::memcmp(&drawn, &cpu[v], sizeof drawn) != 0;
                ++vertices;
            }
        }
    }
    EXPECT_EQ(mismatches, 0u) << "of " << vertices << " vertices";
    EXPECT_GT(overlaid, 5) << "frames with stand-ins or fades";
    EXPECT_GT(changed_over_the_same_base, 5) << "frames whose κ the GPU took in as changes to the last one's";
}

// A model the view has left is not culled, so it does not take in what the cache evicts when a frame
// culls it: it must let go of the evicted cubes at once all the same (StreamSource::residency_changed),
// or the scene holds more than the budget counts. Two copies of the scan far apart: close-ups of one,
// then of the other, under a budget that holds one at a time.
TEST_F(StreamingRender, AModelOutOfViewLetsGoOfTheCubesTheCacheEvicts) {
    StreamCache& cache = *StreamCache::shared();
    const uint64_t budget = cache.budget();
    test::TempDir dir;
    std::filesystem::copy_file(test::bunny_hlod(), dir / "a.hlod");
    std::filesystem::copy_file(test::bunny_hlod(), dir / "b.hlod");
    // A budget that holds one close-up's working set and a half beside the two models' tables.
    cache.set_budget(2 * decoded_bytes(*HlodModel::load(test::bunny_hlod())));
    uint64_t working_set = 0, tables = 0;
    {
        const auto probe = HlodModel::open(test::bunny_hlod());
        tables = cache.stats().held_bytes;
        full_detail_frame(probe, &working_set);
    }
    cache.set_budget(working_set * 3 / 2 + 2 * tables);
    const auto a = HlodModel::open(dir / "a.hlod"), b = HlodModel::open(dir / "b.hlod");
    EXPECT_EQ(cache.stats().held_bytes, 2 * tables) << "two files: two sets of tables";
    const double size = a->header().root_size;
    auto root = std::make_shared<Group>();
    for (const auto& [model, x] : {std::pair{a, 0.0}, std::pair{b, 20 * size}}) {
        model->set_pixel_error(1.0);
        auto place = std::make_shared<Transform>();
        place->set_matrix(glm::translate(glm::dmat4(1.0), glm::dvec3(x, 0, 0)));
        place->add(model);
        root->add(place);
    }
    auto held = [](const HlodModel& model) {
        uint64_t bytes = 0;
        for (const HlodCube& cube : model.cubes())
            if (cube.data) bytes += HlodModel::cube_bytes(*cube.data);
        return bytes;
    };
    Renderer renderer;
    RenderSettings full;
    full.full_detail = true;
    const uint64_t evicted_before = cache.stats().evicted;
    for (int view = 0; view < 4; ++view) {
        const double x = view % 2 == 0 ? 0.0 : 20 * size;
        const double angle = 1.3 * view;
        Camera camera;
        aim(camera, *a, centre_of(*a) + glm::dvec3(x, 0, 0) + 0.5 * size * glm::dvec3(std::sin(angle), 0.2, std::cos(angle)));
        camera.look_at(camera.position, centre_of(*a) + glm::dvec3(x, 0, 0));
        gl::Framebuffer target({.width = camera.width, .height = camera.height, .samples = 1});
        const FrameStats stats = renderer.render(*root, camera, target, full);
        EXPECT_EQ(stats.stand_ins, 0u);
        // Exact: what the two models hold is what the cache counts, the one out of view included.
        EXPECT_EQ(held(*a) + held(*b), cache.stats().resident_bytes) << "view " << view;
    }
    EXPECT_GT(cache.stats().evicted, evicted_before) << "the close-ups did not evict: nothing was tested";
    cache.set_budget(budget);
}

}  // namespace
}  // namespace strata

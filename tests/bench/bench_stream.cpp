// The streaming benchmark (issue 16 §3): a .hlod opened by its node table under a hard budget, headless,
// at 1 pixel of error. Prints its figures; asserts nothing. Each part runs in a child process of its
// own, so that its peak RSS is its own.
//
//   bench_stream --model M.hlod [--memory 1G] [--size 1280x720] [--frames 2000] [--instances 10]
//                [--soak 1000] [--soak-laps 10] [--soak-memory SIZE] [--capture 60] [--load-rate BYTES_PER_S] [--no-whole] [--shared]
//                [--only open|museum|soak|capture]
//
// --only runs that one part in this process (no child: for a profiler such as heaptrack); the museum
// then skips its holes.
//
// - open: time to open, to the first frame (interactive: what is resident), to converge (interactive
//   frames until nothing stands in, fades or is asked for) and to a full-detail frame from a cold
//   cache; peak RSS against the budget; beside loading the model whole (unless --no-whole).
// - museum: --instances copies of the model in a row under transforms, each opened from a copy of the
//   file of its own (distinct files: nothing shared) or, with --shared, all from the one file (its
//   cubes shared); the budget a tenth of their decoded size (or --memory if smaller), a flythrough of --frames interactive frames that cuts to
//   another copy every 200 frames: frame time median and p95, frames to converge after each cut,
//   peak RSS and where the memory went at the highest RSS sampled (the cache's bytes, the renderer's
//   GPU buffers beside the cubes' blocks, what malloc holds); and hole pixels: every 50th frame is drawn again, in another process, with one copy of
//   the model loaded whole under each instance's transform, both on magenta; a pixel the reference
//   covers that the streamed frame left magenta is a hole.
// - soak: --soak full-detail frames, dropped after reading back, in --soak-laps laps of one closed path
//   under --soak-memory (default --memory; below what a lap visits, the cache evicts all along): per
//   lap, the peak RSS within it and what it holds beside the cache's bytes (which a leak or
//   fragmentation grows and a cache filling toward its budget does not), and at its end, back at the
//   same pose, RSS, the cache's bytes, malloc's bytes in use and the GPU buffers; least-squares slopes
//   from the second lap on; each lap's loads and evictions.
// - capture: --capture full-detail frames of a path, with a cold cache, a warm one and three budgets
//   (the largest working set, twice it, --memory): frames with bytes that differ from the first run,
//   and the first few of them.
#include <malloc.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "nodes/hlod_model.h"
#include "preprocess/byte_size.h"

namespace {

using Clock = std::chrono::steady_clock;
using strata::Camera;
using strata::FrameStats;
using strata::RenderSettings;

double ms_since(Clock::time_point start) { return std::chrono::duration<double, std::milli>(Clock::now() - start).count(); }

double quantile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    const double at = q * double(v.size() - 1);
    const size_t i = size_t(at);
    return i + 1 < v.size() ? v[i] + (at - double(i)) * (v[i + 1] - v[i]) : v[i];
}

// Resident set size now and at its peak (VmRSS, VmHWM), in bytes.
uint64_t status_bytes(const char* field) {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind(field, 0) == 0) return std::stoull(line.substr(std::strlen(field))) * 1024;
    return 0;
}
uint64_t rss() { return status_bytes("VmRSS:"); }
uint64_t peak_rss() { return status_bytes("VmHWM:"); }

std::string mib(uint64_t bytes) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f MiB", double(bytes) / double(1 << 20));
    return text;
}

struct Options {
    std::string model;
    uint64_t memory = uint64_t(1) << 30;
    int width = 1280, height = 720, frames = 2000, instances = 10, soak = 1000, soak_laps = 10, capture = 60;
    uint64_t soak_memory = 0;  // the soak's budget; 0: --memory
    double load_rate = 0;
    bool whole = true;
    bool shared = false;
    std::vector<std::string> instance_files;  // the museum's: copies of the model, or the model itself
    std::string only;  // one part, in this process
};

bool in_process = false;  // --only: the part runs here

// Runs `part` in a child process (its own GL context, cache and peak RSS), or here with --only; false
// if it failed.
bool run_part(const char* name, const std::function<void()>& part) {
    std::fflush(stdout);
    auto run = [&] {
        try {
            part();
            return true;
        } catch (const std::exception& e) {
            std::fprintf(stderr, "bench_stream: %s: %s\n", name, e.what());
            return false;
        }
    };
    if (in_process) return run();
    const pid_t pid = fork();
    if (pid < 0) return false;
    if (pid == 0) {
        const bool ok = run();
        std::fflush(stdout);
        _exit(ok ? 0 : 1);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// A camera framing `bounds` from `distance` radii along a direction turned `angle` about +Y.
void aim(Camera& camera, const Options& o, const strata::Box& bounds, double angle, double distance, double height = 0.35) {
    camera.width = o.width, camera.height = o.height, camera.fov_y_degrees = 50;
    const glm::dvec3 c = bounds.center();
    const double r = bounds.radius();
    camera.look_at(c + r * distance * glm::normalize(glm::dvec3(std::sin(angle), height, std::cos(angle))), c);
}

// The process's cache with `budget` and the loads at --load-rate.
void set_streaming(const Options& o, uint64_t budget) {
    strata::StreamCache::shared()->set_budget(budget);
    strata::StreamCache::shared()->set_load_rate(o.load_rate);
}

// The model at 1 pixel of error alone in `scene`, seen from 1.6 radii off.
void view_of(const Options& o, strata::Group& scene, const std::shared_ptr<strata::HlodModel>& model, Camera& camera) {
    model->set_pixel_error(1.0);
    scene.add(model);
    aim(camera, o, model->bound(), 0.6, 1.6);
}

// Interactive frames until the view has converged (or `limit` frames); the frames it took.
int frames_to_converge(strata::Renderer& renderer, strata::Node& scene, const Camera& camera, strata::gl::Framebuffer& target,
                       int limit, FrameStats* last = nullptr) {
    for (int f = 1; f <= limit; ++f) {
        const FrameStats stats = renderer.render(scene, camera, target);
        if (last) *last = stats;
        if (stats.frames_unconverged == 0) return f;
        strata::StreamCache::shared()->wait_for_a_load();
    }
    return -1;
}

void part_open(const Options& o) {
    auto context = strata::gl::create_headless_context();
    set_streaming(o, o.memory);
    const uint64_t rss_before = rss();
    const auto start = Clock::now();
    auto model = strata::HlodModel::open(o.model);
    const double open_ms = ms_since(start);
    strata::Group scene;
    Camera camera;
    view_of(o, scene, model, camera);
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    renderer.render(scene, camera, target);
    glFinish();
    const double first_ms = ms_since(start);
    FrameStats last;
    const int frames = frames_to_converge(renderer, scene, camera, target, 100000, &last);
    glFinish();
    const double converge_ms = ms_since(start);
    std::printf("open (streamed, budget %s%s): open %.1f ms, first frame at %.1f ms, converged after %d frames at %.1f ms "
                "(%" PRIu64 " triangles, %" PRIu64 " cubes); resident %s, tables %s (%.0f bytes per cube of the model's %zu); peak RSS %s "
                "(%s before opening; goal: budget + 200 MiB)\n",
                mib(o.memory).c_str(), o.load_rate > 0 ? (", loads at " + mib(uint64_t(o.load_rate)) + "/s").c_str() : "", open_ms, first_ms,
                frames, converge_ms, last.triangles, last.cubes, mib(last.memory_resident).c_str(), mib(last.memory_tables).c_str(),
                double(last.memory_tables) / double(model->cubes().size()), model->cubes().size(), mib(peak_rss()).c_str(),
                mib(rss_before).c_str());
}

void part_open_full_detail(const Options& o) {
    auto context = strata::gl::create_headless_context();
    set_streaming(o, o.memory);
    const auto start = Clock::now();
    strata::Group scene;
    Camera camera;
    view_of(o, scene, strata::HlodModel::open(o.model), camera);
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    RenderSettings full;
    full.full_detail = true;
    const FrameStats stats = renderer.render(scene, camera, target, full);
    glFinish();
    std::printf("open (streamed, full detail from a cold cache): %.1f ms to the frame (%" PRIu64 " triangles); peak RSS %s\n",
                ms_since(start), stats.triangles, mib(peak_rss()).c_str());
}

void part_whole(const Options& o) {
    auto context = strata::gl::create_headless_context();
    const auto start = Clock::now();
    auto model = strata::HlodModel::load(o.model);
    const double load_ms = ms_since(start);
    strata::Group scene;
    Camera camera;
    view_of(o, scene, model, camera);
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    const FrameStats stats = renderer.render(scene, camera, target);
    glFinish();
    std::printf("open (loaded whole): load %.1f ms, first frame at %.1f ms (%" PRIu64 " triangles); peak RSS %s\n", load_ms, ms_since(start),
                stats.triangles, mib(peak_rss()).c_str());
}

// The museum: instances in a row along x, each turned and scaled a little differently.
struct Museum {
    std::shared_ptr<strata::Group> scene = std::make_shared<strata::Group>();
    std::vector<std::shared_ptr<strata::Transform>> places;
    strata::Box bounds;
    uint64_t decoded = 0;  // every distinct file's cubes, decoded
};

Museum museum(const Options& o) {
    Museum m;
    const auto probe = strata::HlodModel::open(o.model);
    for (const strata::HlodCube& cube : probe->cubes()) m.decoded += strata::HlodModel::cube_bytes_bound(probe->header(), cube.node, probe->texture_bytes());
    if (!o.shared) m.decoded *= uint64_t(o.instances);
    const strata::Box b = probe->bound();
    const double spacing = 2.5 * b.radius();
    for (int i = 0; i < o.instances; ++i) {
        auto model = strata::HlodModel::open(o.instance_files[size_t(i)]);
        model->set_pixel_error(1.0);
        auto place = std::make_shared<strata::Transform>();
        glm::dmat4 matrix = glm::translate(glm::dmat4(1.0), glm::dvec3(spacing * i, 0, 0));
        matrix = glm::rotate(matrix, 0.4 * i, glm::dvec3(0, 1, 0));
        matrix = glm::scale(matrix, glm::dvec3(1.0 - 0.03 * i));
        matrix = glm::translate(matrix, -b.center());
        place->set_matrix(matrix);
        place->add(model);
        m.scene->add(place);
        m.places.push_back(place);
    }
    m.bounds = m.scene->bound();
    return m;
}

// The museum's camera at frame f: every 200 frames a cut to another instance, held still for
// kHoldFrames frames (where convergence is timed), then a slow orbit of it, in and out.
constexpr int kHoldFrames = 60;
void museum_camera(const Options& o, const Museum& m, int f, Camera& camera) {
    const int instance = (f / 200 * 3) % o.instances;
    const double t = double(std::max(f % 200 - kHoldFrames, 0)) / (200 - kHoldFrames);
    aim(camera, o, m.places[size_t(instance)]->bound(), 2 * glm::pi<double>() * t, 1.2 + 0.8 * std::cos(2 * glm::pi<double>() * t));
}

bool is_magenta(const std::vector<float>& rgba, size_t p) { return rgba[p] == 1 && rgba[p + 1] == 0 && rgba[p + 2] == 1; }

// Every 50th frame's pixels left magenta (nothing drawn), for part_holes: the frame, then a byte a pixel.
std::string holes_file() { return "/tmp/bench_stream_" + std::to_string(getppid()) + "_uncovered.bin"; }

void part_museum(const Options& o) {
    auto context = strata::gl::create_headless_context();
    const Museum m = museum(o);
    const uint64_t budget = std::min(o.memory, m.decoded / 10);
    set_streaming(o, budget);
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    std::vector<double> frame_ms, converge_frames;
    std::ofstream uncovered(holes_file(), std::ios::binary | std::ios::trunc);
    int since_cut = 0;
    bool converged_since_cut = false;
    std::string hold_report;  // per cut, at the end of its still view
    char held_line[4096];
    std::string at_peak;  // where the memory went when RSS last peaked
    uint64_t peak_seen = 0;
    for (int f = 0; f < o.frames; ++f) {
        Camera camera;
        museum_camera(o, m, f, camera);
        if (f % 200 == 0) {
            if (f > 0 && !converged_since_cut) converge_frames.push_back(-1);
            since_cut = 0;
            converged_since_cut = false;
        }
        RenderSettings settings;
        settings.background = glm::vec4(1, 0, 1, 1);
        const auto start = Clock::now();
        const FrameStats stats = renderer.render(*m.scene, camera, target, settings);
        glFinish();
        frame_ms.push_back(ms_since(start));
        ++since_cut;
        if (!converged_since_cut && stats.frames_unconverged == 0) {
            converged_since_cut = true;
            converge_frames.push_back(since_cut);
        }
        if (f % 10 == 0 && rss() > peak_seen) {
            peak_seen = rss();
            const struct mallinfo2 heap = mallinfo2();
            char line[512];
            std::snprintf(line, sizeof line,
                          "frame %d: RSS %s; the cache holds %s (%s of it GPU blocks) beside %s of the models' tables; the "
                          "renderer's GPU buffers (pool pages and tables) %s; malloc holds %s from the system, %s of it in use, %s free "
                          "in its heaps",
                          f, mib(peak_seen).c_str(), mib(stats.memory_resident).c_str(), mib(stats.memory_resident_gpu).c_str(),
                          mib(stats.memory_tables).c_str(),
                          mib(stats.bytes_resident).c_str(), mib(heap.arena + heap.hblkhd).c_str(), mib(heap.uordblks + heap.hblkhd).c_str(),
                          mib(heap.fordblks).c_str());
            at_peak = line;
        }
        if (f % 200 == kHoldFrames - 1) {  // the end of the still view: what keeps it from converging
            const strata::StreamCache::Stats cache = strata::StreamCache::shared()->stats();
            std::snprintf(held_line, sizeof held_line, "%s%s%d: %s, %" PRIu64 " stand-ins, %" PRIu64 " loads pending, %s resident, %s short",
                          hold_report.c_str(), hold_report.empty() ? "" : "; ", f / 200, converged_since_cut ? "converged" : "not converged",
                          stats.stand_ins, stats.loads_pending, mib(cache.resident_bytes).c_str(), mib(cache.shortfall).c_str());
            hold_report = held_line;
        }
        if (f % 50 == 49) {
            const std::vector<float> shown = target.read_color();
            std::vector<char> mask(shown.size() / 4);
            for (size_t p = 0; p < shown.size(); p += 4) mask[p / 4] = is_magenta(shown, p);
            uncovered.write(reinterpret_cast<const char*>(&f), sizeof f);
            uncovered.write(mask.data(), std::streamsize(mask.size()));
        }
    }
    std::vector<double> converged;
    int never = 0;
    for (const double c : converge_frames) c > 0 ? converged.push_back(c) : (void)++never;
    std::printf("museum: %d instances, %s decoded (%.1f x the budget of %s), %d interactive frames at %dx%d: frame time median "
                "%.1f ms, p95 %.1f ms; frames to converge after a cut: median %.0f, max %.0f (%d of %zu cuts did not within 200 "
                "frames); peak RSS %s\n",
                o.instances, mib(m.decoded).c_str(), double(m.decoded) / double(budget), mib(budget).c_str(), o.frames, o.width,
                o.height, quantile(frame_ms, 0.5), quantile(frame_ms, 0.95), quantile(converged, 0.5), quantile(converged, 1.0),
                never, converge_frames.size(), mib(peak_rss()).c_str());
    std::printf("museum cuts, after %d still frames: %s\n", kHoldFrames, hold_report.c_str());
    std::printf("museum memory at the highest RSS sampled (every 10th frame), %s\n", at_peak.c_str());
}

// The museum's holes: the same frames drawn with one copy of the model loaded whole under every
// instance's transform (the all-resident reference); a pixel it covers that the streamed frame left
// magenta is a hole.
void part_holes(const Options& o) {
    auto context = strata::gl::create_headless_context();
    const Museum m = museum(o);  // for the cameras
    auto whole = strata::HlodModel::load(o.model);
    whole->set_pixel_error(1.0);
    strata::Group reference;
    for (const auto& place : m.places) {
        auto copy = std::make_shared<strata::Transform>();
        copy->set_matrix(place->matrix());
        copy->add(whole);
        reference.add(copy);
    }
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    std::ifstream uncovered(holes_file(), std::ios::binary);
    uint64_t holes = 0, enclosed = 0, covered = 0, frames = 0;
    int f = 0;
    std::vector<char> mask(size_t(o.width) * size_t(o.height));
    while (uncovered.read(reinterpret_cast<char*>(&f), sizeof f) && uncovered.read(mask.data(), std::streamsize(mask.size()))) {
        Camera camera;
        museum_camera(o, m, f, camera);
        RenderSettings settings;
        settings.background = glm::vec4(1, 0, 1, 1);
        renderer.render(reference, camera, target, settings);
        const std::vector<float> drawn = target.read_color();
        const size_t w = size_t(o.width), h = size_t(o.height);
        auto shown_at = [&](size_t x, size_t y) { return mask[y * w + x] == 0; };
        for (size_t y = 0; y < h; ++y)
            for (size_t x = 0; x < w; ++x) {
                if (is_magenta(drawn, 4 * (y * w + x))) continue;
                ++covered;
                if (shown_at(x, y)) continue;
                ++holes;
                // Inside what the streamed frame drew (its neighbours on both sides of a row or a
                // column drawn): a crack; else at the edge of a stand-in's coarser silhouette.
                const bool row = x > 0 && x + 1 < w && shown_at(x - 1, y) && shown_at(x + 1, y);
                const bool column = y > 0 && y + 1 < h && shown_at(x, y - 1) && shown_at(x, y + 1);
                enclosed += row || column;
            }
        ++frames;
    }
    std::remove(holes_file().c_str());
    std::printf("museum holes: %" PRIu64 " pixels the all-resident frames cover were left uncovered, of %" PRIu64 ", in %" PRIu64
                " frames (every 50th); %" PRIu64 " of them enclosed by drawn pixels (cracks or thin gaps), the rest at the silhouettes of coarser "
                "stand-ins\n",
                holes, covered, frames, enclosed);
}

// The soak's camera at `phase` ∈ [0, 1) of a lap: once around the model, closing in and backing off
// three times, so that a lap ends where it began and every lap asks for the same cubes.
void soak_pose(Camera& camera, const Options& o, const strata::Box& bounds, double phase) {
    const double turn = 2 * glm::pi<double>() * phase;
    aim(camera, o, bounds, turn, 1.1 + 0.6 * std::sin(3 * turn), 0.35 + 0.15 * std::cos(2 * turn));
}

// Resets VmHWM to the RSS now, so that peak_rss() tells the peak from here on; false where the kernel
// does not let it.
bool reset_peak_rss() {
    std::ofstream clear("/proc/self/clear_refs");
    return bool(clear << "5" << std::flush);
}

// The least-squares slope of `v` (one value per lap of `lap` frames), in MiB per 1000 frames.
double slope_per_1000_frames(const std::vector<double>& v, int lap) {
    const double n = double(v.size()), mean_x = (n - 1) / 2;
    double mean_y = 0, xy = 0, xx = 0;
    for (double y : v) mean_y += y / n;
    for (size_t k = 0; k < v.size(); ++k) xy += (double(k) - mean_x) * (v[k] - mean_y), xx += (double(k) - mean_x) * (double(k) - mean_x);
    return xx > 0 ? xy / xx / lap * 1000.0 / double(1 << 20) : 0;
}

void part_soak(const Options& o) {
    auto context = strata::gl::create_headless_context();
    const uint64_t budget = o.soak_memory ? o.soak_memory : o.memory;
    strata::StreamCache::shared()->set_budget(budget);
    auto model = strata::HlodModel::open(o.model);
    model->set_pixel_error(1.0);
    strata::Group scene;
    scene.add(model);
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    RenderSettings full;
    full.full_detail = true;
    // Per lap: the peak RSS within it, and at its end, the camera back where it began: RSS, what the
    // cache held (cubes and tables), what malloc has in use, the renderer's GPU buffers; its loads and
    // evictions.
    struct Sample {
        uint64_t peak, rss, held, in_use, gpu_buffers, loaded, evicted;
    };
    std::vector<Sample> laps;
    const int lap = std::max(1, o.soak / std::max(o.soak_laps, 1));
    uint64_t loaded = 0, evicted = 0, peak = 0;
    const bool peaks = reset_peak_rss();
    for (int f = 0; f < o.soak; ++f) {
        Camera camera;
        soak_pose(camera, o, model->bound(), double(f % lap) / double(lap));
        const FrameStats stats = renderer.render(scene, camera, target, full);
        (void)target.read_color();  // dropped, as a capture loop drops a frame once written
        loaded += stats.loaded, evicted += stats.evicted;
        if (f % lap != lap - 1) continue;
        const struct mallinfo2 heap = mallinfo2();
        laps.push_back({peak_rss(), rss(), stats.memory_resident + stats.memory_tables, heap.uordblks + heap.hblkhd, stats.bytes_resident,
                        loaded, evicted});
        peak = std::max(peak, laps.back().peak);
        loaded = evicted = 0;
        if (peaks) reset_peak_rss();
    }
    if (laps.empty()) return;
    // Slopes from the second lap on: the first fills the cache and warms the driver; after it, every
    // lap asks for the same cubes, so flat memory means the same bytes lap after lap. The peak within
    // a lap is steadier than RSS at one frame, which moves with what the driver holds for that frame.
    auto series = [&](const char* what, auto field) {
        std::string text;
        std::vector<double> after_first;
        for (size_t k = 0; k < laps.size(); ++k) {
            text += (text.empty() ? "" : " ") + std::to_string(int(std::lround(double(field(laps[k])) / double(1 << 20))));
            if (k > 0) after_first.push_back(double(field(laps[k])));
        }
        std::printf("soak: %-27s %s MiB (slope from the second lap %+.2f MiB per 1000 frames)\n", what, text.c_str(),
                    slope_per_1000_frames(after_first, lap));
    };
    std::printf("soak: %d full-detail frames at %dx%d under %s, %zu laps of %d frames along the same path; per lap:\n", o.soak, o.width,
                o.height, mib(budget).c_str(), laps.size(), lap);
    if (peaks) series("peak RSS within the lap", [](const Sample& s) { return s.peak; });
    series("RSS at its end", [](const Sample& s) { return s.rss; });
    series("the cache (cubes, tables)", [](const Sample& s) { return s.held; });
    if (peaks) series("peak RSS beside the cache", [](const Sample& s) { return s.peak - std::min(s.peak, s.held); });
    series("malloc in use at its end", [](const Sample& s) { return s.in_use; });
    series("renderer's GPU buffers", [](const Sample& s) { return s.gpu_buffers; });
    std::string churn;
    for (const Sample& s : laps) churn += (churn.empty() ? "" : " ") + std::to_string(s.loaded) + "/" + std::to_string(s.evicted);
    std::printf("soak: cubes loaded/evicted per lap %s; peak RSS %s\n", churn.c_str(), mib(peaks ? peak : peak_rss()).c_str());
}

// FNV-1a over a frame's bytes.
uint64_t digest(const std::vector<float>& pixels) {
    uint64_t h = 1469598103934665603ull;
    const auto* bytes = reinterpret_cast<const unsigned char*>(pixels.data());
    for (size_t i = 0; i < pixels.size() * sizeof(float); ++i) h = (h ^ bytes[i]) * 1099511628211ull;
    return h;
}

// The capture's frames' digests under a budget, from a cold cache and then (warm) again; the
// largest memory resident after a frame, and the model's tables beside it.
void capture_run(const Options& o, uint64_t budget, std::vector<uint64_t>& cold, std::vector<uint64_t>& warm, uint64_t& working_set,
                 uint64_t& tables) {
    strata::StreamCache::shared()->set_budget(budget);
    auto model = strata::HlodModel::open(o.model);
    model->set_pixel_error(1.0);
    strata::Group scene;
    scene.add(model);
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    RenderSettings full;
    full.full_detail = true;
    working_set = 0;
    for (std::vector<uint64_t>* run : {&cold, &warm}) {
        run->clear();
        for (int f = 0; f < o.capture; ++f) {
            Camera camera;
            const double t = double(f) / std::max(o.capture, 1);
            aim(camera, o, model->bound(), 2 * glm::pi<double>() * t, 1.0 + 0.7 * std::cos(2 * glm::pi<double>() * t));
            const FrameStats stats = renderer.render(scene, camera, target, full);
            working_set = std::max(working_set, stats.memory_resident);
            tables = stats.memory_tables;
            run->push_back(digest(target.read_color()));
        }
    }
}

void part_capture(const Options& o) {
    auto context = strata::gl::create_headless_context();
    std::vector<uint64_t> reference, warm, cold_b, warm_b;
    uint64_t working_set = 0, tables = 0, ignored = 0;
    capture_run(o, o.memory, reference, warm, working_set, tables);
    // How many frames differ from the reference, and the first few of them.
    auto differing = [&](const std::vector<uint64_t>& run) {
        std::string frames;
        size_t n = 0;
        for (size_t f = 0; f < run.size(); ++f)
            if (run[f] != reference[f] && ++n <= 5) frames += (n == 1 ? " (frame " : ", ") + std::to_string(f);
        return std::to_string(n) + (n > 5 ? frames + ", …)" : n > 0 ? frames + ")" : "");
    };
    std::printf("capture: %d full-detail frames at %dx%d; frames differing from the cold run under %s: warm %s", o.capture, o.width,
                o.height, mib(o.memory).c_str(), differing(warm).c_str());
    // The working set bounds a frame's cubes; a load also reserves its cube's bound while in flight;
    // the model's tables count beside them.
    for (const uint64_t budget : {working_set + working_set / 8 + tables, 2 * working_set + tables}) {
        capture_run(o, budget, cold_b, warm_b, ignored, ignored);
        std::printf(", budget %s: cold %s, warm %s", mib(budget).c_str(), differing(cold_b).c_str(), differing(warm_b).c_str());
    }
    std::printf(" (largest resident after a frame %s, beside %s of tables)\n", mib(working_set).c_str(), mib(tables).c_str());
}

bool parse(int argc, char** argv, Options& o) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
        if (a == "--model") o.model = value();
        else if (a == "--memory") o.memory = strata::parse_byte_size(value());
        else if (a == "--size") {
            if (std::sscanf(value().c_str(), "%dx%d", &o.width, &o.height) != 2) return false;
        } else if (a == "--frames") o.frames = std::stoi(value());
        else if (a == "--instances") o.instances = std::max(1, std::stoi(value()));
        else if (a == "--soak") o.soak = std::stoi(value());
        else if (a == "--soak-laps") o.soak_laps = std::stoi(value());
        else if (a == "--soak-memory") o.soak_memory = strata::parse_byte_size(value());
        else if (a == "--capture") o.capture = std::stoi(value());
        else if (a == "--load-rate") o.load_rate = std::stod(value());
        else if (a == "--no-whole") o.whole = false;
        else if (a == "--shared") o.shared = true;
        else if (a == "--only") o.only = value();
        else return false;
    }
    const bool known = o.only.empty() || o.only == "open" || o.only == "museum" || o.only == "soak" || o.only == "capture";
    return !o.model.empty() && known;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    try {
        if (!parse(argc, argv, o)) {
            std::fprintf(stderr, "usage: bench_stream --model M.hlod [--memory 1G] [--size 1280x720] [--frames 2000] [--instances 10] "
                                 "[--soak 1000] [--soak-laps 10] [--soak-memory SIZE] [--capture 60] [--load-rate BYTES_PER_S] [--no-whole] [--shared] "
                                 "[--only open|museum|soak|capture]\n");
            return 2;
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_stream: %s\n", e.what());
        return 2;
    }
    std::printf("bench_stream: %s at %dx%d, 1 pixel of error, llvmpipe or the GPU's driver; times are wall clock\n", o.model.c_str(),
                o.width, o.height);
    in_process = !o.only.empty();
    auto runs = [&](const char* part) { return o.only.empty() || o.only == part; };
    bool ok = true;
    if (runs("open")) {
        ok &= run_part("open", [&] { part_open(o); });
        if (!in_process) ok &= run_part("open, full detail", [&] { part_open_full_detail(o); });
        if (o.whole && !in_process) ok &= run_part("whole", [&] { part_whole(o); });
    }
    if (o.frames > 0 && runs("museum")) {
        // Distinct files: a copy of the model per instance, in a directory of its own (removed after).
        std::filesystem::path copies;
        if (!o.shared) copies = std::filesystem::temp_directory_path() / ("bench_stream-" + std::to_string(::getpid()));
        for (int i = 0; i < o.instances; ++i) {
            if (o.shared) {
                o.instance_files.push_back(o.model);
                continue;
            }
            std::filesystem::create_directories(copies);
            o.instance_files.push_back((copies / ("instance" + std::to_string(i) + ".hlod")).string());
            std::filesystem::copy_file(o.model, o.instance_files.back(), std::filesystem::copy_options::overwrite_existing);
        }
        std::printf("museum files: %s\n", o.shared ? "one, shared by every instance" : "a copy of the model per instance");
        ok &= run_part("museum", [&] { part_museum(o); }) && (in_process || run_part("museum holes", [&] { part_holes(o); }));
        if (!copies.empty()) std::filesystem::remove_all(copies);
    }
    if (o.soak > 0 && runs("soak")) ok &= run_part("soak", [&] { part_soak(o); });
    if (o.capture > 0 && runs("capture")) ok &= run_part("capture", [&] { part_capture(o); });
    return ok ? 0 : 1;
}

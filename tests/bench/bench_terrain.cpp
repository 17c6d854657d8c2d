// The terrain rendering benchmark (issue 17 §5): a terrain built from a DEM, streamed under a memory
// budget, flown over at 1280×720 along two fixed paths: low (a straight line across the terrain at a
// clearance above the ground the model's heights give, looking ahead and a little down) and high (a
// circle at a tenth of the terrain's extent above it, looking at the centre). Per path: triangles drawn
// per covered pixel at the pixel error asked (goal ≤ 2), frame times against the full grid (every cube
// of the finest level in view), and the bytes resident against the budget. Medians over the frames,
// each a full-detail frame (every cube it needs loaded first, the wait not counted in its time). Asserts
// nothing.
//
//   bench_terrain --model TERRAIN.hlod [--frames 24] [--size 1280x720] [--pixel-error 1] [--budget 512M]
//                 [--clearance 50] [--no-full]
//
// A frame's time is from the start of culling to glFinish() returning, after the cubes it needs are
// resident (a second render of the same view).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <glm/gtc/constants.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "nodes/hlod_model.h"
#include "preprocess/byte_size.h"
#include "tests/bench/bench_stats.h"

namespace {

using Clock = std::chrono::steady_clock;

using strata::bench::median;

struct Options {
    std::string model;
    int frames = 24, width = 1280, height = 720;
    double pixel_error = 1.0, clearance = 50;
    uint64_t budget = uint64_t(512) << 20;
    bool full = true;
};

enum class Flight { low, high };

// The ground under (x, y), or the lowest height where the raster has none.
double ground(const strata::HlodModel& model, double x, double y) {
    return model.height_at(x, y).value_or(model.bound().lo.z);
}

void place_camera(strata::Camera& camera, const strata::HlodModel& model, const Options& o, Flight flight, int frame) {
    camera.width = o.width;
    camera.height = o.height;
    camera.fov_y_degrees = 50;
    const strata::Box b = model.bound();
    const glm::dvec3 c = b.center(), size = b.hi - b.lo;
    const double t = (frame + 0.5) / o.frames;
    if (flight == Flight::low) {  // south-west to north-east across the middle 80 %
        const glm::dvec2 from(b.lo.x + 0.1 * size.x, b.lo.y + 0.1 * size.y), to(b.lo.x + 0.9 * size.x, b.lo.y + 0.9 * size.y);
        const glm::dvec2 at = from + t * (to - from), ahead = at + 0.02 * (to - from);
        const double eye_z = ground(model, at.x, at.y) + o.clearance;
        camera.look_at({at.x, at.y, eye_z}, {ahead.x, ahead.y, ground(model, ahead.x, ahead.y)}, {0, 0, 1});
    } else {
        const double angle = 2 * glm::pi<double>() * t, r = 0.35 * std::max(size.x, size.y);
        camera.look_at({c.x + r * std::cos(angle), c.y + r * std::sin(angle), b.hi.z + 0.1 * std::max(size.x, size.y)}, {c.x, c.y, b.lo.z},
                       {0, 0, 1});
    }
}

struct Series {
    std::vector<double> frame_ms, triangles, per_pixel, resident;
};

Series run(strata::Group& scene, strata::HlodModel& model, const Options& o, Flight flight) {
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    Series s;
    for (int f = 0; f < o.frames; ++f) {
        strata::Camera camera;
        place_camera(camera, model, o, flight, f);
        renderer.render(scene, camera, target, {.full_detail = true});  // loads what the view needs
        glFinish();
        const auto start = Clock::now();
        const strata::FrameStats stats = renderer.render(scene, camera, target, {.full_detail = true});
        glFinish();
        s.frame_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        const std::vector<float> depth = target.read_depth();  // reversed Z: the background stays 0
        const double covered = double(std::count_if(depth.begin(), depth.end(), [](float z) { return z > 0; }));
        s.triangles.push_back(double(stats.triangles));
        s.per_pixel.push_back(covered > 0 ? double(stats.triangles) / covered : 0);
        s.resident.push_back(double(stats.memory_resident + stats.memory_tables));
    }
    return s;
}

bool parse(int argc, char** argv, Options& o) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : ""; };
        if (a == "--model") o.model = next();
        else if (a == "--frames") o.frames = std::atoi(next());
        else if (a == "--pixel-error") o.pixel_error = std::atof(next());
        else if (a == "--clearance") o.clearance = std::atof(next());
        else if (a == "--no-full") o.full = false;
        else if (a == "--budget") o.budget = strata::parse_byte_size(next());
        else if (a == "--size") {
            if (std::sscanf(next(), "%dx%d", &o.width, &o.height) != 2) return false;
        } else return false;
    }
    return !o.model.empty() && o.frames > 0 && o.budget > 0;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    if (!parse(argc, argv, o)) {
        std::fprintf(stderr, "usage: bench_terrain --model TERRAIN.hlod [--frames N] [--size WxH] [--pixel-error P] [--budget SIZE] "
                             "[--clearance M] [--no-full]\n");
        return 2;
    }
    try {
        auto context = strata::gl::create_headless_context();
        std::printf("device: %s\nmodel: %s, budget %s, %dx%d, %d frames a flight\n", context->renderer().c_str(), o.model.c_str(),
                    strata::describe_bytes(o.budget).c_str(), o.width, o.height, o.frames);
        // The renderer streams through the process's cache: its budget is the one measured against.
        strata::StreamCache::shared()->set_budget(o.budget);
        auto model = strata::HlodModel::open(o.model);
        strata::Group scene;
        scene.add(model);
        for (const Flight flight : {Flight::low, Flight::high}) {
            const char* name = flight == Flight::low ? "low" : "high";
            model->set_pixel_error(o.pixel_error);
            const Series hlod = run(scene, *model, o, flight);
            std::printf("%-4s HLOD (%.2g px): %.0f triangles, %.2f per covered pixel (goal ≤ 2), frame %.1f ms, resident %s of %s "
                        "(most %s)\n",
                        name, o.pixel_error, median(hlod.triangles), median(hlod.per_pixel), median(hlod.frame_ms),
                        strata::describe_bytes(uint64_t(median(hlod.resident))).c_str(), strata::describe_bytes(o.budget).c_str(),
                        strata::describe_bytes(uint64_t(*std::max_element(hlod.resident.begin(), hlod.resident.end()))).c_str());
            if (!o.full) continue;
            model->set_kappa0(1e9);  // every cube in view at the finest level: the full grid
            const Series full = run(scene, *model, o, flight);
            std::printf("%-4s full grid:    %.0f triangles, frame %.1f ms: the HLOD draws %.1f× fewer triangles, %.1f× faster\n", name,
                        median(full.triangles), median(full.frame_ms), median(full.triangles) / median(hlod.triangles),
                        median(full.frame_ms) / median(hlod.frame_ms));
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_terrain: %s\n", e.what());
        return 1;
    }
    return 0;
}

// The rendering benchmark (issue 3 §7): the builder benchmark's ≥ 19 M-triangle model at 1280×720,
// headless, along a fixed camera path, drawn as an HLOD at ≤ 1 pixel of screen-space error and as the
// full mesh. Prints triangles drawn, frame times and the CPU time of culling and selection beside
// their targets; asserts nothing.
//
//   bench_render --model DIR/bunny_x256.hlod --mesh DIR/bunny_x256.ply [--frames 24] [--size 1280x720]
//                [--pixel-error 1] [--no-full]
//
// Make the inputs with `bench_build --keep DIR` and `strata build DIR/bunny_x256.ply -o DIR/bunny_x256.hlod`.
// A frame's time is from the start of culling to glFinish() returning.
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
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "tests/bench/bench_stats.h"

namespace {

using Clock = std::chrono::steady_clock;

using strata::bench::median;

struct Options {
    std::string model, mesh;
    int frames = 24, width = 1280, height = 720;
    double pixel_error = 1.0;
    bool full = true;
};

// A fixed path: once around the model, swinging from three bounding radii away in to half a radius
// from its surface and back, always looking at its centre.
void place_camera(strata::Camera& camera, const strata::Box& bounds, const Options& o, int frame) {
    camera.width = o.width;
    camera.height = o.height;
    camera.fov_y_degrees = 50;
    const double t = double(frame) / o.frames, angle = 2 * glm::pi<double>() * t;
    const double r = bounds.radius() * (1.5 + 1.5 * std::cos(angle));
    const glm::dvec3 c = bounds.center();
    camera.look_at(c + glm::dvec3(std::sin(angle) * (bounds.radius() + r), 0.3 * bounds.radius(),
                                  std::cos(angle) * (bounds.radius() + r)),
                   c);
}

struct Series {
    std::vector<double> frame_ms, cull_ms, triangles;
};

Series run(strata::Node& scene, const Options& o, const strata::Box& bounds) {
    strata::gl::Framebuffer target({.width = o.width, .height = o.height, .samples = 1});
    strata::Renderer renderer;
    Series s;
    for (int f = -1; f < o.frames; ++f) {  // frame −1 uploads and warms up
        strata::Camera camera;
        place_camera(camera, bounds, o, std::max(f, 0));
        const auto start = Clock::now();
        const strata::FrameStats stats = renderer.render(scene, camera, target);
        glFinish();
        if (f < 0) continue;
        s.frame_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
        s.cull_ms.push_back(stats.cull_ms);
        s.triangles.push_back(double(stats.triangles));
    }
    return s;
}

bool parse(int argc, char** argv, Options& o) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : ""; };
        if (a == "--model") o.model = next();
        else if (a == "--mesh") o.mesh = next();
        else if (a == "--frames") o.frames = std::atoi(next());
        else if (a == "--pixel-error") o.pixel_error = std::atof(next());
        else if (a == "--no-full") o.full = false;
        else if (a == "--size") {
            if (std::sscanf(next(), "%dx%d", &o.width, &o.height) != 2) return false;
        } else return false;
    }
    return !o.model.empty() && (!o.full || !o.mesh.empty()) && o.frames > 0;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    if (!parse(argc, argv, o)) {
        std::fprintf(stderr, "usage: bench_render --model FILE.hlod --mesh FILE.ply [--frames N] [--size WxH] "
                             "[--pixel-error P] [--no-full]\n");
        return 2;
    }
    try {
        auto context = strata::gl::create_headless_context();
        std::printf("device: %s\n", context->renderer().c_str());
        Series hlod, full;
        strata::Box bounds;
        {
            auto model = strata::HlodModel::load(o.model);
            model->set_pixel_error(o.pixel_error);
            bounds = model->bound();
            strata::Group scene;
            scene.add(model);
            hlod = run(scene, o, bounds);
        }
        std::printf("HLOD (%.2g px):   %.0f triangles, frame %.1f ms, cull + selection %.3f ms (medians of %d frames)\n",
                    o.pixel_error, median(hlod.triangles), median(hlod.frame_ms), median(hlod.cull_ms), o.frames);
        if (o.full) {
            strata::Group scene;
            scene.add(strata::Geometry::load(o.mesh));
            full = run(scene, o, bounds);
            std::printf("full mesh:        %.0f triangles, frame %.1f ms\n", median(full.triangles), median(full.frame_ms));
            std::printf("triangles:        %.1f× fewer (target ≥ 10)\n", median(full.triangles) / median(hlod.triangles));
            std::printf("frame time:       %.1f× faster (target ≥ 5)\n", median(full.frame_ms) / median(hlod.frame_ms));
        }
        std::printf("cull + selection: %.3f ms per frame (target ≤ 0.5)\n", median(hlod.cull_ms));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_render: %s\n", e.what());
        return 1;
    }
    return 0;
}

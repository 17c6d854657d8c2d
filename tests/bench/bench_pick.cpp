// The picking benchmark: the builder benchmark's ≥ 19 M-triangle model at 1280×720 and 1 pixel of
// screen-space error, picked at random pixels of the rectangle the model's bound covers on screen (so
// that most picks hit), in views along bench_render's camera path (far, middle and close up) and in an
// orthographic view. Each pick is timed from the pixel to the
// answer: the ray, the selection along it, the morph and the triangle tests. Prints the median, p95 and
// maximum beside the target, in wall time and in the thread's CPU time (which leaves out the time other
// processes take the core away: on a busy machine the wall-time maximum is theirs); asserts nothing.
// Needs no GPU: picking runs on the CPU twin.
//
//   bench_pick --model DIR/bunny_x256.hlod [--views 8] [--picks 200] [--size 1280x720] [--pixel-error 1]
//
// Make the model with `bench_build --keep DIR` and `strata build DIR/bunny_x256.ply -o DIR/bunny_x256.hlod`.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <glm/gtc/constants.hpp>

#include "engine/scene/pick.h"
#include "nodes/hlod_model.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Options {
    std::string model;
    int views = 8, picks = 200, width = 1280, height = 720;
    double pixel_error = 1.0;
};

// This thread's CPU time: what a pick costs itself, whatever else the machine runs.
double thread_cpu_ms() {
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// The value below which `share` of the sorted values lie (nearest rank).
double percentile(const std::vector<double>& sorted, double share) {
    if (sorted.empty()) return 0;
    const size_t rank = size_t(std::ceil(share * double(sorted.size())));
    return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
}

void print_summary(const char* what, std::vector<double> ms) {
    std::sort(ms.begin(), ms.end());
    std::printf("%s median %.3f ms, p95 %.3f ms, max %.3f ms (target ≤ 5)\n", what, percentile(ms, 0.5),
                percentile(ms, 0.95), ms.back());
}

// View `v` of o.views: bench_render's path (once around the model, from three bounding radii away in
// to half a radius from its surface and back, looking at its centre); the last view is orthographic,
// framing the whole model.
void place_camera(strata::Camera& camera, const strata::Box& bounds, const Options& o, int v) {
    camera.width = o.width;
    camera.height = o.height;
    camera.fov_y_degrees = 50;
    const double t = double(v) / std::max(o.views - 1, 1), angle = 2 * glm::pi<double>() * t;
    const double r = bounds.radius() * (1.5 + 1.5 * std::cos(angle));
    const glm::dvec3 c = bounds.center();
    camera.look_at(c + glm::dvec3(std::sin(angle) * (bounds.radius() + r), 0.3 * bounds.radius(),
                                  std::cos(angle) * (bounds.radius() + r)),
                   c);
    if (v == o.views - 1) {
        camera.projection = strata::ProjectionKind::orthographic;
        camera.frame(bounds);
    }
}

// The pixels the corners of `box` project to, as a rectangle clamped to the image: lo and hi corners.
std::pair<glm::dvec2, glm::dvec2> screen_rectangle(const strata::Camera& camera, const strata::Box& box) {
    const auto [near, far] = camera.clip_planes_for(box);
    const glm::dmat4 clip_from_world = camera.projection_matrix(near, far) * camera.view_matrix();
    const glm::dvec2 size(camera.width, camera.height);
    glm::dvec2 lo = size, hi(0.0);
    for (int corner = 0; corner < 8; ++corner) {
        const glm::dvec3 p{corner & 1 ? box.hi.x : box.lo.x, corner & 2 ? box.hi.y : box.lo.y, corner & 4 ? box.hi.z : box.lo.z};
        const glm::dvec4 clip = clip_from_world * glm::dvec4(p, 1.0);
        if (clip.w <= 0) return {glm::dvec2(0.0), size};  // a corner behind the eye: the box may cover any pixel
        const glm::dvec2 pixel = (glm::dvec2(clip.x, -clip.y) / clip.w + 1.0) / 2.0 * size;
        lo = glm::min(lo, pixel);
        hi = glm::max(hi, pixel);
    }
    return {glm::clamp(lo, glm::dvec2(0.0), size), glm::clamp(hi, glm::dvec2(0.0), size)};
}

bool parse(int argc, char** argv, Options& o) {
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&]() -> const char* { return i + 1 < argc ? argv[++i] : ""; };
        if (a == "--model") o.model = next();
        else if (a == "--views") o.views = std::atoi(next());
        else if (a == "--picks") o.picks = std::atoi(next());
        else if (a == "--pixel-error") o.pixel_error = std::atof(next());
        else if (a == "--size") {
            if (std::sscanf(next(), "%dx%d", &o.width, &o.height) != 2) return false;
        } else return false;
    }
    return !o.model.empty() && o.views > 0 && o.picks > 0 && o.width > 0 && o.height > 0;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    if (!parse(argc, argv, o)) {
        std::fprintf(stderr, "usage: bench_pick --model FILE.hlod [--views N] [--picks N] [--size WxH] [--pixel-error P]\n");
        return 2;
    }
    try {
        auto model = strata::HlodModel::load(o.model);
        model->set_pixel_error(o.pixel_error);
        strata::Group scene;
        scene.add(model);
        std::printf("model: %llu input triangles, %zu cubes, levels 0 … %u\n",
                    static_cast<unsigned long long>(model->header().input_triangles), model->cubes().size(),
                    model->header().max_level);
        std::mt19937 random(2024);  // the same pixels every run
        std::vector<double> wall_ms, cpu_ms, hit_wall_ms;
        for (int v = 0; v < o.views; ++v) {
            strata::Camera camera;
            place_camera(camera, model->bound(), o, v);
            const auto [lo, hi] = screen_rectangle(camera, model->bound());
            std::uniform_real_distribution<double> across(lo.x, hi.x), down(lo.y, hi.y);
            std::vector<double> view_ms;
            int hits = 0;
            for (int p = 0; p < o.picks; ++p) {
                const double x = across(random), y = down(random);
                const double cpu_start = thread_cpu_ms();
                const auto start = Clock::now();
                const auto hit = strata::pick(scene, camera, x, y);
                const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
                cpu_ms.push_back(thread_cpu_ms() - cpu_start);
                view_ms.push_back(ms);
                if (hit) hit_wall_ms.push_back(ms), ++hits;
            }
            wall_ms.insert(wall_ms.end(), view_ms.begin(), view_ms.end());
            std::sort(view_ms.begin(), view_ms.end());
            std::printf("view %d (%s): %3d of %d picks hit, median %.3f ms, max %.3f ms\n", v,
                        camera.projection == strata::ProjectionKind::orthographic ? "orthographic" : "perspective", hits,
                        o.picks, percentile(view_ms, 0.5), view_ms.back());
        }
        std::printf("%zu picks, %zu hits\n", wall_ms.size(), hit_wall_ms.size());
        print_summary("all picks, wall time:", wall_ms);
        if (!hit_wall_ms.empty()) print_summary("hits, wall time:     ", hit_wall_ms);
        print_summary("all picks, CPU time: ", cpu_ms);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_pick: %s\n", e.what());
        return 1;
    }
    return 0;
}

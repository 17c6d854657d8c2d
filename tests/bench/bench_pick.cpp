// The picking benchmark: the builder benchmark's ≥ 19 M-triangle model at 1280×720 and 1 pixel of
// screen-space error, picked at random pixels of the rectangle the model's bound covers on screen (so
// that most picks hit), in views along bench_render's camera path (far, middle and close up) and in an
// orthographic view. Each pick is timed from the pixel to the
// answer: the ray, the selection along it, the morph and the triangle tests. Prints the median, p95 and
// maximum beside the target; asserts nothing. Needs no GPU: picking runs on the CPU twin.
//
//   bench_pick --model DIR/bunny_x256.hlod [--views 8] [--picks 200] [--size 1280x720] [--pixel-error 1]
//
// Make the model with `bench_build --keep DIR` and `strata build DIR/bunny_x256.ply -o DIR/bunny_x256.hlod`.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
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

// The value below which `share` of the sorted values lie (nearest rank).
double percentile(const std::vector<double>& sorted, double share) {
    if (sorted.empty()) return 0;
    const size_t rank = size_t(std::ceil(share * double(sorted.size())));
    return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
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
        std::vector<double> all_ms, hit_ms;
        for (int v = 0; v < o.views; ++v) {
            strata::Camera camera;
            place_camera(camera, model->bound(), o, v);
            const auto [lo, hi] = screen_rectangle(camera, model->bound());
            std::uniform_real_distribution<double> across(lo.x, hi.x), down(lo.y, hi.y);
            std::vector<double> view_ms;
            int hits = 0;
            for (int p = 0; p < o.picks; ++p) {
                const double x = across(random), y = down(random);
                const auto start = Clock::now();
                const auto hit = strata::pick(scene, camera, x, y);
                const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
                view_ms.push_back(ms);
                if (hit) hit_ms.push_back(ms), ++hits;
            }
            all_ms.insert(all_ms.end(), view_ms.begin(), view_ms.end());
            std::sort(view_ms.begin(), view_ms.end());
            std::printf("view %d (%s): %3d of %d picks hit, median %.3f ms, max %.3f ms\n", v,
                        camera.projection == strata::ProjectionKind::orthographic ? "orthographic" : "perspective", hits,
                        o.picks, percentile(view_ms, 0.5), view_ms.back());
        }
        std::sort(all_ms.begin(), all_ms.end());
        std::sort(hit_ms.begin(), hit_ms.end());
        std::printf("all %zu picks:    median %.3f ms, p95 %.3f ms, max %.3f ms (target ≤ 5)\n", all_ms.size(),
                    percentile(all_ms, 0.5), percentile(all_ms, 0.95), all_ms.back());
        if (!hit_ms.empty())
            std::printf("the %zu hits:     median %.3f ms, p95 %.3f ms, max %.3f ms (target ≤ 5)\n", hit_ms.size(),
                        percentile(hit_ms, 0.5), percentile(hit_ms, 0.95), hit_ms.back());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_pick: %s\n", e.what());
        return 1;
    }
    return 0;
}

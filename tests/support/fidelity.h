// The fidelity measurement (DESIGN.md §6, §8): an HLOD model and the full-resolution mesh it was built
// from, rendered headless with the same camera through the real renderer; each covered pixel's depth
// read back (eye-space Z, as the EXR output holds it) and turned into its 3D point; that point's exact
// distance to the other surface converted to pixels with the largest magnification the projection
// has at the point.
//
//   forward:  each pixel the HLOD covers, its point to the full mesh (what --pixel-error promises);
//   backward: each pixel the full mesh covers, its point to the triangles the HLOD draws for the
//             camera, morphed as the shader morphs them (HlodModel::drawn_positions, the CPU twin);
//   noise:    each pixel the full mesh covers, its point to the full mesh itself: all the read-back
//             and reconstruction contribute (float depth, rasterization), the floor under the others.
//
// Pixels per unit at a point: the largest singular value of the 2×3 Jacobian of the point → pixel map.
// In view coordinates (x, y, −z), z the view depth, with f = height / (2·tan(fov_y/2)) pixels at unit
// depth, u = f·x/z and v = f·y/z give J = (f/z)·[[1, 0, −a], [0, 1, −b]] with a = x/z, b = y/z; J·Jᵀ has
// the eigenvalues 1 and 1 + a² + b², so σ_max = (f/z)·√(1 + a² + b²): off the axis a displacement
// along the view ray moves the pixel too. Orthographic: height / ortho_height everywhere.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "engine/scene/camera.h"
#include "engine/scene/node.h"
#include "nodes/hlod_model.h"
#include "preprocess/mesh.h"
#include "preprocess/surface_distance.h"

namespace strata::test {

// One direction's pixel errors over one view.
struct PixelErrors {
    size_t pixels = 0;  // covered pixels measured
    double p50 = 0, p99 = 0, p999 = 0, max = 0;
    size_t within = 0;  // pixels whose error is at most the tolerance
    double within_share() const { return pixels ? double(within) / double(pixels) : 1.0; }
};

// Nearest-rank percentiles of `errors` (in pixels) and how many are ≤ `tolerance`.
PixelErrors summarize(std::vector<double> errors, double tolerance);

struct FidelityReport {
    PixelErrors forward, backward, noise;
    uint64_t hlod_triangles = 0;  // drawn by the renderer (after frustum culling)
    uint64_t hlod_cubes = 0;
    uint64_t full_triangles = 0;
    std::vector<uint32_t> cubes_per_level;  // the drawn cubes, by level
    double hlod_frame_ms = 0, full_frame_ms = 0;  // render() to glFinish() returning
    double measure_ms = 0;  // CPU, after the read-back: reconstruction, reference triangles, distances
};

// A covered pixel's 3D point in the model's lattice frame and the pixels per model unit there.
struct CoveredPoint {
    glm::dvec3 point;
    double pixels_per_unit;
};

// The points of an image's covered pixels (finite depth), rendered with `camera` at the pixel
// centres, shifted by −`lattice_origin` from the world frame.
std::vector<CoveredPoint> covered_points(const Image& image, const Camera& camera, const glm::dvec3& lattice_origin);

// `count` seeded views of a model with bounds `bounds`, of every kind in turn: far (the whole model small),
// oblique (a few radii away), close (a few percent of the radius off a vertex of `mesh`, up to 60° off
// its normal), grazing (2° to 10° above the tangent plane there), and orthographic (framed, zoomed).
// (Cameras are nodes, which do not copy.)
std::vector<std::unique_ptr<Camera>> fidelity_views(const Box& bounds, const Mesh& mesh, int count, int width, int height, uint32_t seed);

// A surface the measurement finds distances to: float positions, as the meshes hold them, in a frame
// whose origin lies at `origin` in the model's lattice frame, and the tree over its triangles. It owns
// the vectors the tree views, so it is neither copied nor moved (a function returns it as a prvalue).
class MeasuredSurface {
public:
    MeasuredSurface(std::vector<float> positions, std::vector<uint32_t> indices, const glm::dvec3& origin);
    MeasuredSurface(const MeasuredSurface&) = delete;
    MeasuredSurface& operator=(const MeasuredSurface&) = delete;

    // The nearest triangle to a point of the lattice frame; `hint` as TriangleTree::nearest takes it.
    TriangleTree::Nearest nearest(const glm::dvec3& point, uint32_t hint = ~0u) const;

private:
    std::vector<float> positions_;
    std::vector<uint32_t> indices_;
    glm::dvec3 origin_;
    TriangleTree tree_;  // declared after the vectors it views, so built after them
};

class FidelityMeter {
public:
    // `model` with its pixel error (or κ0) set, at the origin of the world; `full` the mesh it was
    // built from. Copies the full mesh's triangles and builds their tree. Needs a current GL context, as measure()
    // does.
    // Distances are found on `threads` threads (0: one per core).
    FidelityMeter(std::shared_ptr<HlodModel> model, const Mesh& full, unsigned threads = 0);

    // Renders both with `camera` (one sample per pixel: depth at the pixel centre) and measures.
    FidelityReport measure(const Camera& camera, double tolerance_pixels);

private:
    // The triangles the model draws for `camera` with culling off (culling only drops cubes wholly
    // outside the view, which could otherwise hold the nearest drawn surface of a pixel at the border).
    MeasuredSurface drawn_surface(const Camera& camera) const;
    std::vector<uint32_t> cubes_per_level(const Camera& camera) const;
    // Renders `scene` into the target, timed to glFinish(), and reads its depth back.
    Image render(Node& scene, const Camera& camera, FrameStats& stats, double& frame_ms);
    std::vector<double> pixel_errors(const std::vector<CoveredPoint>& points, const MeasuredSurface& surface) const;

    std::shared_ptr<HlodModel> model_;
    MeasuredSurface full_surface_;
    Group hlod_scene_, full_scene_;
    Renderer renderer_;
    std::unique_ptr<gl::Framebuffer> target_;
    unsigned threads_;
};

}  // namespace strata::test

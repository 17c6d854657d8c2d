#include "tests/support/fidelity.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include <glm/gtc/constants.hpp>

#include "engine/scene/frustum.h"
#include "nodes/geometry.h"
#include "preprocess/parallel.h"

namespace strata::test {

namespace {

using Clock = std::chrono::steady_clock;

double milliseconds_since(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Where a mesh's frame (its float positions' zero) lies in the model's lattice frame.
glm::dvec3 frame_in_lattice(const Mesh& mesh, const glm::dvec3& lattice_origin) {
    return glm::dvec3(mesh.origin[0], mesh.origin[1], mesh.origin[2]) - lattice_origin;
}

// The eye as the renderer derives it from the view matrix.
glm::dvec3 eye_of(const Camera& camera) { return glm::dvec3(glm::inverse(camera.view_matrix())[3]); }

}  // namespace

PixelErrors summarize(std::vector<double> errors, double tolerance) {
    PixelErrors out;
    out.pixels = errors.size();
    if (errors.empty()) return out;
    std::sort(errors.begin(), errors.end());
    auto percentile = [&](double q) {
        const size_t rank = size_t(std::ceil(q * double(errors.size())));
        return errors[std::min(errors.size() - 1, rank == 0 ? 0 : rank - 1)];
    };
    out.p50 = percentile(0.5);
    out.p99 = percentile(0.99);
    out.p999 = percentile(0.999);
    out.max = errors.back();
    out.within = size_t(std::upper_bound(errors.begin(), errors.end(), tolerance) - errors.begin());
    return out;
}

std::vector<CoveredPoint> covered_points(const Image& image, const Camera& camera, const glm::dvec3& lattice_origin) {
    const bool perspective = camera.projection == ProjectionKind::perspective;
    const double tan_half_y = std::tan(glm::radians(camera.fov_y_degrees) / 2);
    // Half the image's extent in view units: at unit depth (perspective) or everywhere (orthographic).
    const double half_h = perspective ? tan_half_y : camera.ortho_height / 2, half_w = half_h * camera.aspect();
    const double focal = camera.height / (2 * half_h);  // pixels per unit at unit depth, or everywhere
    const glm::dmat4 world_from_view = glm::inverse(camera.view_matrix());
    std::vector<CoveredPoint> out;
    for (int y = 0; y < image.height; ++y) {
        for (int x = 0; x < image.width; ++x) {
            const double z = image.depth[size_t(y) * image.width + x];  // view depth; rows top to bottom
            if (!std::isfinite(z)) continue;
            const double ndc_x = 2 * (x + 0.5) / image.width - 1, ndc_y = 1 - 2 * (y + 0.5) / image.height;
            const double a = ndc_x * half_w, b = ndc_y * half_h;  // x/z and y/z (perspective)
            const glm::dvec3 in_view = perspective ? glm::dvec3(a * z, b * z, -z) : glm::dvec3(a, b, -z);
            const double pixels_per_unit = perspective ? focal / z * std::sqrt(1 + a * a + b * b) : focal;
            out.push_back({glm::dvec3(world_from_view * glm::dvec4(in_view, 1.0)) - lattice_origin, pixels_per_unit});
        }
    }
    return out;
}

std::vector<std::unique_ptr<Camera>> fidelity_views(const Box& bounds, const Mesh& mesh, int count, int width, int height, uint32_t seed) {
    Mesh with_normals = mesh;
    if (!with_normals.has_normals()) compute_vertex_normals(with_normals);
    const double radius = bounds.radius();
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0, 1);
    std::uniform_int_distribution<size_t> vertex(0, mesh.vertex_count() - 1);
    auto direction = [&] {
        const double z = 2 * unit(rng) - 1, phi = 2 * glm::pi<double>() * unit(rng);
        return glm::dvec3(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
    };
    const glm::dvec3 origin(mesh.origin[0], mesh.origin[1], mesh.origin[2]);
    auto surface_point = [&](glm::dvec3& normal) {
        const size_t v = vertex(rng);
        normal = glm::normalize(glm::dvec3(with_normals.normals[3 * v], with_normals.normals[3 * v + 1], with_normals.normals[3 * v + 2]));
        return origin + glm::dvec3(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
    };
    std::vector<std::unique_ptr<Camera>> out;
    for (int i = 0; i < count; ++i) {
        Camera& camera = *out.emplace_back(std::make_unique<Camera>());
        camera.width = width;
        camera.height = height;
        glm::dvec3 normal;
        switch (i % 5) {
        case 0:
            camera.look_at(bounds.center() + direction() * radius * (3 + 17 * unit(rng)), bounds.center());
            break;
        case 1:
            camera.look_at(bounds.center() + direction() * radius * (1.2 + 2 * unit(rng)), bounds.center() + 0.3 * radius * direction());
            break;
        case 2: {
            const glm::dvec3 p = surface_point(normal);
            const glm::dvec3 tilt = glm::normalize(glm::cross(normal, direction()));
            const double angle = glm::radians(60.0) * unit(rng);
            camera.look_at(p + (std::cos(angle) * normal + std::sin(angle) * tilt) * radius * (0.03 + 0.2 * unit(rng)), p);
            break;
        }
        case 3: {
            const glm::dvec3 p = surface_point(normal);
            const glm::dvec3 tangent = glm::normalize(glm::cross(normal, direction()));
            const double elevation = glm::radians(2 + 8 * unit(rng));
            camera.look_at(p + (std::cos(elevation) * tangent + std::sin(elevation) * normal) * radius * (0.1 + 0.4 * unit(rng)), p);
            break;
        }
        default:
            camera.projection = ProjectionKind::orthographic;
            camera.look_at(bounds.center() + direction(), bounds.center());
            camera.frame(bounds);
            camera.ortho_height *= 0.3 + 0.7 * unit(rng);
            break;
        }
    }
    return out;
}

MeasuredSurface::MeasuredSurface(std::vector<float> positions, std::vector<uint32_t> indices, const glm::dvec3& origin)
    : positions_(std::move(positions)), indices_(std::move(indices)), origin_(origin),
      tree_(SurfaceView{positions_, indices_}, {}) {}

TriangleTree::Nearest MeasuredSurface::nearest(const glm::dvec3& point, uint32_t hint) const {
    // In the surface's own frame, in double: the float positions are not rounded again by a shift.
    const glm::dvec3 local = point - origin_;
    const double p[3] = {local.x, local.y, local.z};
    return tree_.nearest(p, hint);
}

FidelityMeter::FidelityMeter(std::shared_ptr<HlodModel> model, const Mesh& full, unsigned threads)
    : model_(std::move(model)),
      full_surface_(full.positions, full.indices, frame_in_lattice(full, model_->origin())),
      threads_(resolve_thread_count(int(threads))) {
    hlod_scene_.add(model_);
    full_scene_.add(Geometry::from_mesh(full));
}

Image FidelityMeter::render(Node& scene, const Camera& camera, FrameStats& stats, double& frame_ms) {
    if (!target_ || target_->width() != camera.width || target_->height() != camera.height)
        target_ = std::make_unique<gl::Framebuffer>(gl::FramebufferFormat{.width = camera.width, .height = camera.height, .samples = 1});
    const auto start = Clock::now();
    stats = renderer_.render(scene, camera, *target_);
    glFinish();
    frame_ms = milliseconds_since(start);
    return renderer_.read_image(*target_);
}

MeasuredSurface FidelityMeter::drawn_surface(const Camera& camera) const {
    const glm::dvec3 eye = eye_of(camera);
    std::vector<uint32_t> cubes;
    model_->select(model_->view_for(camera, eye), cubes);
    const HlodModel::MorphInputs inputs = model_->morph_inputs(PickContext{camera, glm::dmat4(1.0), eye});
    std::vector<float> positions;
    std::vector<uint32_t> indices;
    std::vector<glm::vec3> drawn;
    for (const uint32_t c : cubes) {
        model_->drawn_positions(c, inputs, drawn);
        const uint32_t base = uint32_t(positions.size() / 3);
        for (const glm::vec3& x : drawn) positions.insert(positions.end(), {x.x, x.y, x.z});
        for (const uint32_t i : model_->cubes()[c].data->indices) indices.push_back(base + i);
    }
    // Drawn positions are measured from the anchor, E in the lattice frame.
    return MeasuredSurface(std::move(positions), std::move(indices), inputs.anchor.origin);
}

std::vector<uint32_t> FidelityMeter::cubes_per_level(const Camera& camera) const {
    // The selection the cull pass makes: the view's frustum in the model's lattice frame.
    const auto [near, far] = camera.clip_planes_for(hlod_scene_.bound());
    const Frustum frustum = Frustum::from_matrix(camera.projection_matrix(near, far) * camera.view_matrix())
                                .in_child_frame(model_->lattice_to_node());
    HlodView view = model_->view_for(camera, eye_of(camera));
    view.frustum = &frustum;
    std::vector<uint32_t> cubes;
    model_->select(view, cubes);
    std::vector<uint32_t> per_level(model_->header().max_level + 1, 0);
    for (const uint32_t c : cubes) ++per_level[model_->cubes()[c].node.level];
    return per_level;
}

std::vector<double> FidelityMeter::pixel_errors(const std::vector<CoveredPoint>& points, const MeasuredSurface& surface) const {
    std::vector<double> errors(points.size());
    constexpr size_t kChunk = 1024;
    parallel_for((points.size() + kChunk - 1) / kChunk, threads_, [&](size_t chunk, unsigned) {
        // Points come in image order: the previous pixel's nearest triangle is a close first guess.
        uint32_t previous = ~0u;
        for (size_t i = chunk * kChunk; i < std::min(points.size(), (chunk + 1) * kChunk); ++i) {
            const TriangleTree::Nearest nearest = surface.nearest(points[i].point, previous);
            errors[i] = nearest.distance * points[i].pixels_per_unit;
            previous = nearest.triangle;
        }
    });
    return errors;
}

FidelityReport FidelityMeter::measure(const Camera& camera, double tolerance_pixels) {
    FidelityReport report;
    FrameStats hlod_stats, full_stats;
    const Image hlod = render(hlod_scene_, camera, hlod_stats, report.hlod_frame_ms);
    const Image full = render(full_scene_, camera, full_stats, report.full_frame_ms);
    report.hlod_triangles = hlod_stats.triangles;
    report.hlod_cubes = hlod_stats.cubes;
    report.full_triangles = full_stats.triangles;

    const auto start = Clock::now();
    report.cubes_per_level = cubes_per_level(camera);
    const std::vector<CoveredPoint> on_hlod = covered_points(hlod, camera, model_->origin());
    const std::vector<CoveredPoint> on_full = covered_points(full, camera, model_->origin());
    report.forward = summarize(pixel_errors(on_hlod, full_surface_), tolerance_pixels);
    report.backward = summarize(pixel_errors(on_full, drawn_surface(camera)), tolerance_pixels);
    report.noise = summarize(pixel_errors(on_full, full_surface_), tolerance_pixels);
    report.measure_ms = milliseconds_since(start);
    return report;
}

}  // namespace strata::test

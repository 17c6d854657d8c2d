#include "nodes/geometry.h"

#include <cmath>

#include "engine/scene/cull_visitor.h"
#include "preprocess/mesh_io.h"

namespace strata {

std::shared_ptr<Geometry> Geometry::load(const std::filesystem::path& path) {
    auto geometry = from_mesh(read_mesh(path));
    geometry->set_name(path.stem().string());
    geometry->source_ = path;
    return geometry;
}

std::shared_ptr<Geometry> Geometry::from_mesh(Mesh mesh) {
    std::shared_ptr<Geometry> geometry(new Geometry());
    if (!mesh.has_normals()) compute_vertex_normals(mesh);
    geometry->mesh_ = std::move(mesh);
    return geometry;
}

std::shared_ptr<Geometry> Geometry::plane(const glm::dvec3& center, const glm::dvec3& up, double width, double depth) {
    const glm::dvec3 n = glm::normalize(up);
    // Width runs along x projected onto the plane (along y for a plane facing ±x), depth across it.
    const glm::dvec3 axis = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 u = glm::normalize(axis - n * glm::dot(axis, n)) * (width / 2);
    const glm::dvec3 v = glm::normalize(glm::cross(n, u)) * (depth / 2);
    Mesh mesh;
    for (const glm::dvec3& corner : {center - u - v, center + u - v, center + u + v, center - u + v}) {
        mesh.positions.insert(mesh.positions.end(), {float(corner.x), float(corner.y), float(corner.z)});
        mesh.normals.insert(mesh.normals.end(), {float(n.x), float(n.y), float(n.z)});
    }
    // Counter-clockwise seen from the side the normal points to.
    const bool ccw = glm::dot(glm::cross(u, v), n) > 0;
    mesh.indices = ccw ? std::vector<uint32_t>{0, 1, 2, 0, 2, 3} : std::vector<uint32_t>{0, 2, 1, 0, 3, 2};
    auto geometry = from_mesh(std::move(mesh));
    geometry->set_name("plane");
    geometry->source_ = PlaneSource{center, up, width, depth};
    return geometry;
}

Box Geometry::compute_bound() const {
    Box box;
    for (size_t v = 0; v < mesh_.vertex_count(); ++v)
        box.expand(origin() + glm::dvec3(mesh_.positions[3 * v], mesh_.positions[3 * v + 1], mesh_.positions[3 * v + 2]));
    return box;
}

void Geometry::cull(CullVisitor& cull) {
    if (mesh_.triangle_count() > 0) cull.add(*this);
}

// Every triangle, no acceleration structure: Geometry holds the few-triangle meshes beside scans
// (floors, plinths, reference objects) and the pick has already tested the bound; a mesh large enough
// for this to matter belongs in an HLOD model.
std::optional<SurfaceHit> Geometry::intersect(const Ray& ray, const PickContext&) const {
    const std::vector<float>& p = mesh_.positions;
    return nearest_triangle(ray, mesh_.indices, [&](uint32_t v) { return origin() + glm::dvec3(p[3 * v], p[3 * v + 1], p[3 * v + 2]); });
}

void compute_vertex_normals(Mesh& mesh) {
    mesh.normals.assign(mesh.positions.size(), 0.0f);
    auto at = [&](uint32_t v) { return glm::vec3(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]); };
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const uint32_t* corner = &mesh.indices[t];
        const glm::vec3 n = glm::cross(at(corner[1]) - at(corner[0]), at(corner[2]) - at(corner[0]));
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k) mesh.normals[3 * size_t(corner[c]) + k] += n[k];
    }
    for (size_t v = 0; v < mesh.vertex_count(); ++v) {
        float* n = &mesh.normals[3 * v];
        const float length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (length > 0) n[0] /= length, n[1] /= length, n[2] /= length;
    }
}

}  // namespace strata

// Geometry: an indexed triangle mesh with a material, the "other geometry" beside scans (a floor, a
// plinth, a reference object). Loaded through the importer of preprocess/ or built in code.
#pragma once

#include <filesystem>
#include <memory>
#include <variant>

#include <glm/glm.hpp>

#include "engine/scene/drawable.h"
#include "preprocess/mesh.h"

namespace strata {

struct Material {
    glm::vec4 base_color{0.8f, 0.8f, 0.8f, 1.0f};  // linear; multiplies the vertex colours if any
};

// What Geometry::plane was given.
struct PlaneSource {
    glm::dvec3 center, up;
    double width, depth;
};
// Where a geometry's mesh came from, so that a saved scene can rebuild it: the file as given to load(),
// the plane's parameters, or nothing for a mesh built in code.
using GeometrySource = std::variant<std::monostate, std::filesystem::path, PlaneSource>;

class Geometry : public Drawable {
public:
    // Any format read_mesh reads (PLY, OBJ, OFF, STL); throws naming the file on bad input.
    static std::shared_ptr<Geometry> load(const std::filesystem::path& path);
    // Takes the mesh; computes area-weighted vertex normals when it has none.
    static std::shared_ptr<Geometry> from_mesh(Mesh mesh);
    // A flat rectangle centred at `center`, facing `up` (a floor): `width` along x as seen in the
    // plane (y for a plane facing ±x), `depth` across.
    static std::shared_ptr<Geometry> plane(const glm::dvec3& center, const glm::dvec3& up, double width, double depth);

    const Mesh& mesh() const { return mesh_; }
    // Where the mesh's float positions are measured from, in the node's frame.
    glm::dvec3 origin() const { return {mesh_.origin[0], mesh_.origin[1], mesh_.origin[2]}; }
    const GeometrySource& source() const { return source_; }
    Material material;

    void cull(CullVisitor& cull) override;
    void draw(DrawContext& context, const DrawItem& item) override;
    std::optional<SurfaceHit> intersect(const Ray& ray, const PickContext& context) const override;

protected:
    Box compute_bound() const override;

private:
    Geometry() = default;
    Mesh mesh_;
    GeometrySource source_;
};

// Area-weighted vertex normals (each triangle adds its cross product to its three corners).
void compute_vertex_normals(Mesh& mesh);

}  // namespace strata

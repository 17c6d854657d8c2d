// The Geometry node: loading through the importer, built-in shapes, normals, bounds and culling.
#include <gtest/gtest.h>

#include <fstream>

#include "engine/scene/cull_visitor.h"
#include "nodes/geometry.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

TEST(Geometry, LoadsAMeshFileAndComputesNormals) {
    test::TempDir dir;
    {
        std::ofstream off(dir / "tetra.off");
        off << "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
    }
    auto geometry = Geometry::load(dir / "tetra.off");
    EXPECT_EQ(geometry->name(), "tetra");
    EXPECT_EQ(geometry->mesh().triangle_count(), 4u);
    ASSERT_TRUE(geometry->mesh().has_normals());
    // The corner at the origin sees three faces facing −x, −y, −z: its normal points away from +xyz.
    const float* n = &geometry->mesh().normals[0];
    EXPECT_NEAR(n[0], -1 / std::sqrt(3.0f), 1e-6f);
    EXPECT_NEAR(n[1], -1 / std::sqrt(3.0f), 1e-6f);
    EXPECT_NEAR(n[2], -1 / std::sqrt(3.0f), 1e-6f);
    EXPECT_EQ(geometry->bound().lo, glm::dvec3(0, 0, 0));
    EXPECT_EQ(geometry->bound().hi, glm::dvec3(1, 1, 1));
    EXPECT_THROW(Geometry::load(dir / "missing.ply"), std::runtime_error);
}

TEST(Geometry, SurveyCoordinatesKeepTheirOrigin) {
    // A reader keeps UTM-sized coordinates as a double origin plus small floats; bound and pick add it.
    Mesh mesh;
    mesh.origin = {512000, 5412000, 0};
    mesh.positions = {345.678f, 345.123f, 300, 346.678f, 345.123f, 300, 345.678f, 346.123f, 300};
    mesh.indices = {0, 1, 2};
    auto geometry = Geometry::from_mesh(mesh);
    EXPECT_NEAR(geometry->bound().lo.x, 512345.678, 1e-4);
    EXPECT_NEAR(geometry->bound().hi.y, 5412346.123, 1e-4);
    const Camera camera;
    const PickContext context{camera, glm::dmat4(1.0), {512345.9, 5412345.3, 400}};
    const auto hit = geometry->intersect(Ray{{512345.9, 5412345.3, 400}, {0, 0, -1}}, context);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->t, 100, 1e-6);
    EXPECT_FALSE(geometry->intersect(Ray{{345.9, 345.3, 400}, {0, 0, -1}}, context).has_value());
}

TEST(Geometry, PlaneFacesUpAndCoversItsExtent) {
    auto floor = Geometry::plane({1, 0, 2}, {0, 1, 0}, 4, 6);
    const Mesh& m = floor->mesh();
    ASSERT_EQ(m.triangle_count(), 2u);
    EXPECT_NEAR(floor->bound().lo.x, -1, 1e-6);
    EXPECT_NEAR(floor->bound().hi.x, 3, 1e-6);
    EXPECT_NEAR(floor->bound().lo.z, -1, 1e-6);
    EXPECT_NEAR(floor->bound().hi.z, 5, 1e-6);
    auto wall = Geometry::plane({0, 0, 0}, {1, 0, 0}, 4, 6);
    EXPECT_NEAR(wall->bound().hi.y, 2, 1e-6);
    EXPECT_NEAR(wall->bound().hi.z, 3, 1e-6);
    EXPECT_NEAR(floor->bound().hi.y, 0, 1e-6);
    // Both triangles wind counter-clockwise seen from above.
    for (size_t t = 0; t < 6; t += 3) {
        auto p = [&](uint32_t v) { return glm::vec3(m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]); };
        const glm::vec3 normal = glm::cross(p(m.indices[t + 1]) - p(m.indices[t]), p(m.indices[t + 2]) - p(m.indices[t]));
        EXPECT_GT(normal.y, 0);
    }
}

TEST(Geometry, EmitsOneDrawItemWhenInView) {
    auto root = std::make_shared<Group>();
    root->add(Geometry::plane({0, 0, -10}, {0, 0, 1}, 2, 2));
    Camera camera;
    camera.look_at({0, 0, 0}, {0, 0, -1});
    RenderList list;
    CullVisitor cull(camera, camera.view_matrix(), camera.projection_matrix(0.1, 100), list);
    root->accept(cull);
    EXPECT_EQ(list.opaque.size(), 1u);
    camera.look_at({0, 0, 0}, {0, 0, 1});
    RenderList behind;
    CullVisitor away(camera, camera.view_matrix(), camera.projection_matrix(0.1, 100), behind);
    root->accept(away);
    EXPECT_TRUE(behind.opaque.empty());
}

}  // namespace
}  // namespace strata

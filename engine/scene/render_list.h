// What a cull pass produces and the renderer consumes: draw items in bins, and the lights.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <glm/glm.hpp>

namespace strata {

class Drawable;

struct DrawItem {
    Drawable* drawable;
    glm::dmat4 model;  // the drawable's frame → world
    double depth;      // along the view direction, of the bound's centre: the draw order
    uint32_t first;    // the drawable's own range in RenderList::item_data (the HLOD model's cubes)
    uint32_t count;
    std::shared_ptr<const void> state;  // what the drawable decided while culling, for its draw (or null)
};

struct LightItem {
    glm::dvec3 direction;  // world frame, unit, from the light towards the scene
    glm::vec3 radiance;    // colour × intensity
};

struct RenderList {
    std::vector<DrawItem> opaque;
    std::vector<uint32_t> item_data;
    std::vector<LightItem> lights;
    glm::vec3 ambient{0, 0, 0};
    bool has_ambient = false;

    void clear() {
        opaque.clear();
        item_data.clear();
        lights.clear();
        ambient = {0, 0, 0};
        has_ambient = false;
    }
    // Opaque front to back (fewer shaded fragments); ties keep the traversal order.
    void sort();
};

}  // namespace strata

// The pop check (DESIGN.md §6) on the GPU: a cube drawn just outside its switch distance and its
// children drawn just inside it, seen straight down from above the cube's cell, give the same image.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "engine/scene/cull_visitor.h"
#include "nodes/hlod_model.h"

namespace strata::test {

// Share of pixels whose RGBA (4 floats a pixel) differ by more than `tolerance` in some channel.
inline double differing(const std::vector<float>& a, const std::vector<float>& b, float tolerance) {
    size_t differ = 0;
    for (size_t p = 0; p < a.size(); p += 4)
        for (size_t c = 0; c < 4; ++c)
            if (std::abs(a[p + c] - b[p + c]) > tolerance) {
                ++differ;
                break;
            }
    return double(differ) / double(a.size() / 4);
}

// The level's cube with the most triangles: a busy piece of surface.
inline uint32_t busiest_cube(const HlodModel& model, uint32_t level) {
    uint32_t chosen = kNoCube;
    for (uint32_t c = 0; c < model.cubes().size(); ++c) {
        const HlodCube& cube = model.cubes()[c];
        if (cube.node.level == level && (chosen == kNoCube || cube.data->triangle_count() > model.cubes()[chosen].data->triangle_count()))
            chosen = c;
    }
    return chosen;
}

struct PopFrames {
    std::vector<float> before, after;  // 200 × 200 RGBA
    bool before_selected = false, after_selected = false;  // whether the cube itself was drawn
};

// `root` (holding `model`, loaded whole, in its own frame) seen from κ0·s_l above `cube`'s cell just
// outside and just inside that distance, with the morph or without.
inline PopFrames pop_frames(Node& root, HlodModel& model, uint32_t cube, double kappa0, bool morph) {
    const Box cell = model.cell(model.cubes()[cube].node);
    const double s = model.header().cube_size(model.cubes()[cube].node.level);
    const glm::dvec3 centre = cell.center() + model.origin();  // the lattice-frame cell sits at O + cell
    model.set_morph(morph);
    auto render_from = [&](double factor, bool& selected) {
        Camera camera;
        camera.width = camera.height = 200;
        camera.fov_y_degrees = 40;
        camera.look_at({centre.x, centre.y, cell.hi.z + model.origin().z + kappa0 * s * factor}, centre);
        RenderList list;
        auto [near, far] = camera.clip_planes_for(root.bound());
        CullVisitor cull(camera, camera.view_matrix(), camera.projection_matrix(near, far), list);
        root.accept(cull);
        selected = false;
        for (uint32_t c : list.item_data) selected |= c == cube;
        gl::Framebuffer target({.width = 200, .height = 200, .samples = 1});
        Renderer renderer;
        renderer.render(root, camera, target);
        return target.read_color();
    };
    PopFrames frames;
    frames.before = render_from(1 + 1e-6, frames.before_selected);
    frames.after = render_from(1 - 1e-6, frames.after_selected);
    return frames;
}

}  // namespace strata::test

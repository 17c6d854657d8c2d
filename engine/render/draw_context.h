// What a Drawable's draw() gets from the renderer: the view, the frame's statistics, the GPU cache,
// the shading code every program shares (lights in a uniform block, the fragment outputs), and the
// draws it submits (engine/render/draw_call.h): drawables issue no GL of their own.
#pragma once

#include <cstdint>

#include <glm/glm.hpp>

#include "engine/gl/vertex_array.h"
#include "engine/render/draw_call.h"
#include "engine/render/gpu_cache.h"
#include "engine/scene/camera.h"
#include "engine/scene/render_list.h"

namespace strata {

struct FrameStats {
    uint64_t draw_items = 0;
    uint64_t draw_calls = 0;
    uint64_t triangles = 0;
    uint64_t cubes = 0;          // HLOD cubes drawn
    uint64_t nodes_culled = 0;
    uint64_t stand_ins = 0;        // streamed HLOD cubes standing in for children not yet loaded (drawn, or holding drawn ones back)
    uint64_t fading = 0;           // streamed HLOD cubes whose children are fading in, or held back beside them
    uint64_t loads_pending = 0;    // streamed cubes the view asked for that are loading or waiting for room
    uint64_t memory_resident = 0;  // bytes streamed models hold (CPU and GPU), after this frame's update
    uint64_t memory_resident_gpu = 0;  // of those, on the GPU
    uint64_t memory_tables = 0;  // bytes open streamed models keep per cube (CPU and GPU), in the budget beside the cubes
    uint64_t loaded = 0, evicted = 0;  // streamed cubes that arrived and that left in this frame's update
    // Frames since the view last converged: 0 when this frame drew no stand-in, had nothing fading in
    // and asked for nothing (what a full-detail frame would draw), else one more than the last frame's.
    uint64_t frames_unconverged = 0;
    double cull_ms = 0;          // CPU: traversal, selection and sorting; full detail: and waiting for the cubes
    double draw_ms = 0;          // CPU: issuing the draws (the GPU may still be working)
    double gpu_ms = -1;          // GPU: the draws, from a timer query; −1 unless asked for
    uint64_t bytes_resident = 0; // GPU memory of the drawables drawn (what several draw from, counted once)
};

struct DrawContext {
    const Camera& camera;
    glm::dmat4 view;
    glm::dmat4 projection;
    glm::dvec3 eye;  // world frame
    const RenderList& list;  // the draw items' data (an HLOD item's cubes)
    GpuCache& cache;
    FrameStats& stats;
    gl::VertexArray& vertex_array;  // attribute-less: holds the index buffer of the call drawn

    // `index_count` indices of call.indices from the first.
    void draw_elements(const DrawCall& call, uint32_t index_count);
    // `count` IndexedDrawCommands of `commands` from the `first`, one multi-draw.
    void draw_indirect(const DrawCall& call, const gl::Buffer& commands, uint64_t first, uint32_t count);
    // `instances` instances of `vertices` vertices, without indices.
    void draw_instanced(const DrawCall& call, uint32_t vertices, uint32_t instances);
    // `groups` work groups of call.program, a compute program (its storage bound as for a draw); what it
    // writes to storage buffers is visible to the draws and dispatches after it.
    void dispatch(const DrawCall& call, uint32_t groups);

private:
    void bind_resources(const DrawCall& call);
    void apply(const DrawCall& call);
    void restore(const DrawCall& call);
};

// GLSL shared by every scene program's fragment stage: the lights block (binding 0, filled by the
// renderer) and Lambert shading. The outputs are gl::fragment_outputs_glsl.
extern const char* const kShadingGlsl;
// GLSL: srgb_to_linear(), for 8-bit colours as scans store them.
extern const char* const kSrgbGlsl;
inline constexpr unsigned kLightsBinding = 0;
inline constexpr int kMaxLights = 8;

}  // namespace strata

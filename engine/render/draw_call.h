// What a drawable asks the GPU to draw, without touching GL itself (sokol's "apply bindings, then
// draw"): a program, the storage buffers it reads by binding, textures by unit, an index buffer, the primitive and the
// fill. DrawContext submits it, binds what it names, draws, counts the call and puts back what it
// changed (fill mode, the indirect buffer), so no drawable leaves state for the next one.
#pragma once

#include <array>
#include <cstdint>

#include "engine/gl/buffer.h"
#include "engine/gl/program.h"

namespace strata {

enum class Primitive : uint8_t { triangles, lines };

inline constexpr uint32_t kStorageBindings = 16;
inline constexpr uint32_t kTextureUnits = 4;

struct DrawCall {
    const gl::Program& program;
    std::array<const gl::Buffer*, kStorageBindings> storage{};  // by binding; null: left as it is
    std::array<GLuint, kTextureUnits> textures{};  // textures by unit (any target); 0: left as it is
    const gl::Buffer* indices = nullptr;  // 32-bit indices, for indexed draws
    Primitive primitive = Primitive::triangles;
    bool wireframe = false;  // edges only
};

// One indexed draw of an indirect buffer, as glMultiDrawElementsIndirect reads it.
struct IndexedDrawCommand {
    uint32_t count;           // indices
    uint32_t instance_count;
    uint32_t first_index;     // into the index buffer, in indices
    int32_t base_vertex;      // added to each index: gl_VertexID
    uint32_t base_instance;   // gl_BaseInstanceARB
};

}  // namespace strata

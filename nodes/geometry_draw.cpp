// Geometry on the GPU: positions, normals and colours in storage buffers pulled by gl_VertexID, one
// indexed draw per item, shaded like the scans beside it.
#include <stdexcept>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/buffer.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/program.h"
#include "engine/render/draw_context.h"
#include "engine/scene/render_list.h"
#include "nodes/geometry.h"

namespace strata {

namespace {

const char* const kVertexGlsl = R"(
layout(std430, binding = 1) readonly buffer Positions { float positions[]; };
layout(std430, binding = 2) readonly buffer Normals { float normals[]; };
layout(std430, binding = 3) readonly buffer Colors { uint colors[]; };

uniform mat4 clip_from_local;
uniform mat3 world_from_local_normal;
uniform bool has_colors;
uniform vec4 base_color;

out vec3 v_normal;
out vec4 v_color;

vec3 at(int v) { return vec3(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]); }

void main() {
    gl_Position = clip_from_local * vec4(at(gl_VertexID), 1.0);
    v_normal = world_from_local_normal * vec3(normals[3 * gl_VertexID], normals[3 * gl_VertexID + 1], normals[3 * gl_VertexID + 2]);
    vec4 color = base_color;
    if (has_colors) {
        vec4 c = unpackUnorm4x8(colors[gl_VertexID]);
        color *= vec4(srgb_to_linear(c.rgb), c.a);
    }
    v_color = color;
}
)";

const char* const kFragmentGlsl = R"(
in vec3 v_normal;
in vec4 v_color;
uniform uint node_id;

void main() {
    vec3 n = normalize(gl_FrontFacing ? v_normal : -v_normal);
    out_color = vec4(shade(v_color.rgb, n), v_color.a);
    out_normal = vec4(n, 0.0);
    out_level = -1.0;  // not an HLOD cube
    out_node_id = node_id;
}
)";

constexpr uint32_t kProgramKey = 1;  // the program all Geometry nodes share, in the GPU cache

struct GeometryProgram : GpuCache::Entry {
    gl::Program program = gl::Program::graphics(
        "geometry", std::string("#version 450\n") + kSrgbGlsl + kVertexGlsl,
        std::string("#version 450\n") + gl::fragment_outputs_glsl + kShadingGlsl + kFragmentGlsl);
};

struct GeometryGpu : GpuCache::Entry {
    gl::Buffer positions, normals, colors, indices;
};

std::unique_ptr<GeometryGpu> upload(const Mesh& mesh, const std::string& name) {
    // One storage buffer per attribute: a mesh past the driver's binding size cannot be drawn whole.
    const uint64_t max_block = gl::max_storage_block_bytes();
    if (mesh.positions.size() * sizeof(float) > max_block)
        throw std::runtime_error("mesh '" + name + "' has " + std::to_string(mesh.vertex_count()) +
                                 " vertices, more than this OpenGL driver binds at once (" +
                                 std::to_string(max_block / 12) + "): build it into a .hlod model instead");
    auto gpu = std::make_unique<GeometryGpu>();
    gpu->positions = gl::Buffer(mesh.positions, gl::kFixedStorage);
    gpu->normals = gl::Buffer(mesh.normals, gl::kFixedStorage);
    std::vector<uint32_t> colors{0xffffffffu};  // bound even when absent: one word, never read
    if (mesh.has_colors()) {
        colors.clear();
        for (size_t i = 0; i + 3 < mesh.colors.size(); i += 4)
            colors.push_back(mesh.colors[i] | mesh.colors[i + 1] << 8 | mesh.colors[i + 2] << 16 |
                             uint32_t(mesh.colors[i + 3]) << 24);
    }
    gpu->colors = gl::Buffer(colors, gl::kFixedStorage);
    gpu->indices = gl::Buffer(mesh.indices, gl::kFixedStorage);
    return gpu;
}

}  // namespace

void Geometry::draw(DrawContext& context, const DrawItem& item) {
    const gl::Program& program =
        context.cache.get_shared<GeometryProgram>(kProgramKey, [] { return std::make_unique<GeometryProgram>(); }).program;
    GeometryGpu& gpu = context.cache.get<GeometryGpu>(*this, [&] { return upload(mesh_, name()); });
    // The mesh's float positions are relative to its double-precision origin (survey coordinates).
    program.set("clip_from_local", glm::mat4(context.projection * context.view * item.model * glm::translate(glm::dmat4(1.0), origin())));
    program.set("world_from_local_normal", glm::mat3(glm::transpose(glm::inverse(glm::dmat3(item.model)))));
    program.set("has_colors", int(mesh_.has_colors()));
    program.set("base_color", material.base_color);
    program.set("node_id", unsigned(id()));
    DrawCall call{.program = program, .indices = &gpu.indices};
    call.storage[1] = &gpu.positions, call.storage[2] = &gpu.normals, call.storage[3] = &gpu.colors;
    context.draw_elements(call, uint32_t(mesh_.indices.size()));
    context.stats.triangles += mesh_.triangle_count();
    context.stats.bytes_resident += gpu.positions.size() + gpu.normals.size() + gpu.colors.size() + gpu.indices.size();
}

}  // namespace strata

// An embedding's seams on the GPU: the triangles the stitch emits for the view (its CPU twin), each
// vertex a position from its owner's lattice anchor and the owner's index, drawn through the owner's
// clip_from_anchor composed exactly as HlodModel composes it, with gl_Position invariant in both
// programs, so that a seam vertex lands on the very bits its owner's vertex does.
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/buffer.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/program.h"
#include "engine/render/draw_context.h"
#include "engine/scene/render_list.h"
#include "nodes/terrain.h"

namespace strata {

namespace {

const char* const kSeamVertexGlsl = R"(
// xyz: the position from the owner's anchor; w: the owner (0 the ground, 1 the skirt, 2 the site).
layout(std430, binding = 1) readonly buffer Seams { vec4 seams[]; };
uniform mat4 clip_from_anchor[3];
uniform mat4 world_from_anchor[3];
out vec3 v_world;
invariant gl_Position;

void main() {
    vec4 seam = seams[gl_VertexID];
    int owner = int(seam.w);
    precise vec3 position = seam.xyz;
    gl_Position = clip_from_anchor[owner] * vec4(position, 1.0);
    v_world = (world_from_anchor[owner] * vec4(seam.xyz, 1.0)).xyz;
}
)";

const char* const kSeamFragmentGlsl = R"(
in vec3 v_world;
uniform vec4 base_color;
uniform uint node_id;

void main() {
    // Slivers along the join: their own face's normal (toward the eye).
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    out_color = vec4(shade(base_color.rgb, n), base_color.a);
    out_normal = vec4(n, 0.0);
    out_level = -1.0;
    out_node_id = node_id;
}
)";

constexpr uint32_t kSeamProgramKey = 4;  // in the GPU cache, beside Geometry's program (1), the HLOD programs (2) and their pool (3)

struct SeamProgram : GpuCache::Entry {
    gl::Program program = gl::Program::graphics("embedding seams", std::string("#version 450\n") + kSeamVertexGlsl,
                                                std::string("#version 450\n") + gl::fragment_outputs_glsl + kShadingGlsl + kSeamFragmentGlsl);
};

struct SeamGpu : GpuCache::Entry {
    gl::Buffer seams;
};

}  // namespace

void EmbeddingSeams::draw(DrawContext& context, const DrawItem& item) {
    const auto& views = *std::static_pointer_cast<const Embedding::ViewSelections>(item.state);
    const EmbeddedModels& m = embedding_.stitch().models();
    // Each owner's frame as the cull pass composed it: the site's under its placement.
    const glm::dmat4 world_from_node[3] = {item.model, item.model, item.model * embedding_.placement()->matrix()};
    const HlodModel* owners[3] = {m.terrain.get(), m.skirt.get(), m.site.get()};
    const Embedding::Selection* selections[3] = {&views.terrain, &views.skirt, &views.site};
    HlodModel::MorphInputs inputs[3];
    std::array<glm::mat4, 3> clip_from_anchor, world_from_anchor;
    for (int o = 0; o < 3; ++o) {
        const HlodModel& owner = *owners[o];
        inputs[o] = {owner.anchor_for(world_from_node[o], context.eye), selections[o]->kappa, owner.morphs_for(context.camera)};
        // As set_view_uniforms composes it (hlod_model_draw.cpp), to the bit.
        const glm::dmat4 world_from_lattice = world_from_node[o] * owner.lattice_to_node();
        const glm::dmat4 anchor = glm::translate(glm::dmat4(1.0), inputs[o].anchor.origin);
        clip_from_anchor[size_t(o)] = glm::mat4(context.projection * context.view * world_from_lattice * anchor);
        world_from_anchor[size_t(o)] = glm::mat4(world_from_lattice * anchor);
    }
    std::vector<StitchTriangle> triangles;
    embedding_.stitch().seams({views.terrain.cubes, &inputs[0]}, {views.skirt.cubes, &inputs[1]}, {views.site.cubes, &inputs[2]}, triangles);
    if (triangles.empty()) return;
    std::vector<glm::vec4> seams;
    seams.reserve(3 * triangles.size());
    for (const StitchTriangle& t : triangles)
        for (const StitchVertex& v : t) seams.emplace_back(v.position, float(v.owner));

    const gl::Program& program =
        context.cache.get_shared<SeamProgram>(kSeamProgramKey, [] { return std::make_unique<SeamProgram>(); }).program;
    SeamGpu& gpu = context.cache.get<SeamGpu>(*this, [] { return std::make_unique<SeamGpu>(); });
    const uint64_t bytes = seams.size() * sizeof(glm::vec4);
    if (gpu.seams.size() < bytes) gpu.seams = gl::Buffer(2 * bytes, gl::kDynamicStorage);
    gpu.seams.upload(seams);
    program.set("clip_from_anchor", std::span<const glm::mat4>(clip_from_anchor));
    program.set("world_from_anchor", std::span<const glm::mat4>(world_from_anchor));
    // The ground's colour, untextured (hlod_model_draw.cpp); under the ground's debug views the stitch
    // shows in a colour of its own (hot pink, which the level palette lacks), and in wireframe its edges.
    const HlodDebugView debug = m.terrain->debug_view();
    program.set("base_color", debug == HlodDebugView::none ? glm::vec4(0.6f, 0.57f, 0.52f, 1.0f) : glm::vec4(1.0f, 0.1f, 0.55f, 1.0f));
    program.set("node_id", unsigned(m.terrain->id()));
    DrawCall call{.program = program, .wireframe = debug == HlodDebugView::wireframe};
    call.storage[1] = &gpu.seams;
    context.draw_instanced(call, uint32_t(seams.size()), 1);
    context.stats.triangles += triangles.size();
    context.stats.bytes_resident += gpu.seams.size();
}

}  // namespace strata

// An embedding's seams on the GPU: the triangles the stitch emits for the view (its CPU twin), each
// vertex a position from its owner's lattice anchor and the owner's index, drawn through the owner's
// clip_from_anchor composed exactly as HlodModel composes it, with gl_Position invariant in both
// programs, so that a seam vertex lands on the very bits its owner's vertex does. On a textured terrain
// they show the ground's imagery under them, else the ground's untextured colour.
#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/buffer.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/object_name.h"
#include "engine/gl/program.h"
#include "engine/gl/texture_layers.h"
#include "engine/render/draw_context.h"
#include "engine/scene/render_list.h"
#include "nodes/terrain.h"
#include "preprocess/cube_textures.h"
#include "preprocess/imagery_sampler.h"

namespace strata {

namespace {

const char* const kSeamVertexGlsl = R"(
// xyz: the position from the owner's anchor; w: the owner (0 the ground, 1 the skirt, 2 the site).
layout(std430, binding = 1) readonly buffer Seams { vec4 seams[]; };
uniform mat4 clip_from_anchor[3];
uniform mat4 world_from_anchor[3];
uniform mat4 imagery_from_anchor[3];  // to the zone's imagery's texture coordinates (its x and y)
out vec3 v_world;
out vec2 v_imagery_uv;
invariant gl_Position;

void main() {
    vec4 seam = seams[gl_VertexID];
    int owner = int(seam.w);
    precise vec3 position = seam.xyz;
    gl_Position = clip_from_anchor[owner] * vec4(position, 1.0);
    v_world = (world_from_anchor[owner] * vec4(seam.xyz, 1.0)).xyz;
    v_imagery_uv = (imagery_from_anchor[owner] * vec4(seam.xyz, 1.0)).xy;
}
)";

const char* const kSeamFragmentGlsl = R"(
in vec3 v_world;
in vec2 v_imagery_uv;
uniform vec4 base_color;
uniform bool textured;
uniform uint node_id;
layout(binding = 0) uniform sampler2D imagery;  // sRGB: sampled in linear light, as the ground's textures

void main() {
    // Slivers along the join: their own face's normal (toward the eye).
    vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
    vec3 color = textured ? texture(imagery, v_imagery_uv).rgb : base_color.rgb;
    out_color = vec4(shade(color, n), base_color.a);
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

// The ground's imagery over the zone, for the seams: one small texture per embedding, made once, at the
// finest terrain level whose texels over the skirt's box fit in kMostImageryTexels a side. A texture
// rather than a colour per seam vertex: the seams change every frame while the zone's imagery does not,
// and a ring seam's vertices are the grid's, which slide along the border as they morph, so a vertex
// colour would have to be looked up again per vertex per frame; texture coordinates are an affine
// function of the position, which the shader applies from the same anchor as gl_Position.
constexpr uint32_t kMostImageryTexels = 1024;

struct SeamImagery {
    gl::ObjectName<gl::DeleteTexture> texture;
    glm::dmat4 uv_from_node{1.0};  // the terrain's node frame (its model x, y) → the texture's coordinates
    uint64_t bytes = 0;
};

SeamImagery make_seam_imagery(const HlodModel& terrain, const HlodModel& skirt) {
    // The skirt covers the zone, and its model coordinates are the terrain's: its box (else its root cube's).
    const HlodHeader& h = skirt.header();
    const double lo[2] = {h.has_bounds ? h.bounds_lo[0] : h.origin[0], h.has_bounds ? h.bounds_lo[1] : h.origin[1]};
    const double hi[2] = {h.has_bounds ? h.bounds_hi[0] : h.origin[0] + h.root_size, h.has_bounds ? h.bounds_hi[1] : h.origin[1] + h.root_size};
    const auto& cubes = terrain.cubes();
    ImagerySampler sampler(terrain.header(), *terrain.textures(), cubes.size(), [&](uint64_t n) -> const HlodNode& { return cubes[n].node; }, lo, hi);
    const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    uint32_t level = terrain.header().max_level;
    while (level > 0 && extent / sampler.texel_spacing(level) > kMostImageryTexels) --level;
    const double step = sampler.texel_spacing(level);
    // A texel beyond the box on each side.
    const TexelGrid grid{lo[0] - step / 2, lo[1] - step / 2, step, uint32_t(std::ceil((hi[0] - lo[0]) / step)) + 2,
                         uint32_t(std::ceil((hi[1] - lo[1]) / step)) + 2};
    const std::vector<uint8_t> rgb = sampler.sample(level, grid);
    // RGBA: GL makes mips only of a colour-renderable format, which SRGB8 alone is not.
    std::vector<uint8_t> rgba(rgb.size() / 3 * 4, 255);
    for (size_t t = 0; t < rgb.size() / 3; ++t) std::copy_n(&rgb[3 * t], 3, &rgba[4 * t]);

    SeamImagery out;
    GLuint name = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &name);
    out.texture = gl::ObjectName<gl::DeleteTexture>(name);
    const GLsizei mips = GLsizei(std::bit_width(std::max(grid.columns, grid.rows)));
    glTextureStorage2D(name, mips, GL_SRGB8_ALPHA8, GLsizei(grid.columns), GLsizei(grid.rows));
    glTextureSubImage2D(name, 0, 0, 0, GLsizei(grid.columns), GLsizei(grid.rows), GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    glGenerateTextureMipmap(name);
    glTextureParameteri(name, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(name, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(name, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(name, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl::check_gl("making an embedding's seam imagery");
    // Texel (c, r) covers [x0 + (c − ½)·step, x0 + (c + ½)·step] × likewise in y.
    out.uv_from_node = glm::scale(glm::dmat4(1.0), glm::dvec3(1 / (step * grid.columns), 1 / (step * grid.rows), 1.0)) *
                       glm::translate(glm::dmat4(1.0), glm::dvec3(step / 2 - grid.x0, step / 2 - grid.y0, 0.0));
    out.bytes = rgba.size() * 4 / 3;  // with its mips
    return out;
}

struct SeamGpu : GpuCache::Entry {
    gl::Buffer seams;
    std::optional<SeamImagery> imagery;  // made on the first frame that draws a textured terrain's seams
};

}  // namespace

void EmbeddingSeams::draw(DrawContext& context, const DrawItem& item) {
    const auto& views = *std::static_pointer_cast<const Embedding::ViewSelections>(item.state);
    const EmbeddedModels& m = embedding_.stitch().models();
    // Each owner's frame as the cull pass composed it: the site's under its placement.
    const glm::dmat4 world_from_node[3] = {item.model, item.model, item.model * embedding_.placement()->matrix()};
    const HlodModel* owners[3] = {m.terrain.get(), m.skirt.get(), m.site.get()};
    const Embedding::Selection* selections[3] = {&views.terrain, &views.skirt, &views.site};
    // And in the terrain's node frame, where the zone's imagery lies.
    const glm::dmat4 terrain_from_node[3] = {glm::dmat4(1.0), glm::dmat4(1.0), embedding_.placement()->matrix()};
    HlodModel::MorphInputs inputs[3];
    std::array<glm::mat4, 3> clip_from_anchor, world_from_anchor;
    std::array<glm::dmat4, 3> terrain_from_anchor;
    for (int o = 0; o < 3; ++o) {
        const HlodModel& owner = *owners[o];
        inputs[o] = {owner.anchor_for(world_from_node[o], context.eye), selections[o]->kappa, owner.morphs_for(context.camera)};
        // As set_view_uniforms composes it (hlod_model_draw.cpp), to the bit.
        const glm::dmat4 world_from_lattice = world_from_node[o] * owner.lattice_to_node();
        const glm::dmat4 anchor = glm::translate(glm::dmat4(1.0), inputs[o].anchor.origin);
        clip_from_anchor[size_t(o)] = glm::mat4(context.projection * context.view * world_from_lattice * anchor);
        world_from_anchor[size_t(o)] = glm::mat4(world_from_lattice * anchor);
        terrain_from_anchor[size_t(o)] = terrain_from_node[o] * owner.lattice_to_node() * anchor;
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
    // A textured ground's seams show its imagery, as the ground does (hlod_model_draw.cpp: textured
    // unless a debug view colours it, or the driver cannot sample its textures).
    const bool textured = debug == HlodDebugView::none && m.terrain->textures() && gl::TextureLayers::supported();
    program.set("textured", int(textured));
    if (textured) {
        if (!gpu.imagery) gpu.imagery = make_seam_imagery(*m.terrain, *m.skirt);
        std::array<glm::mat4, 3> imagery_from_anchor;
        for (size_t o = 0; o < 3; ++o) imagery_from_anchor[o] = glm::mat4(gpu.imagery->uv_from_node * terrain_from_anchor[o]);
        program.set("imagery_from_anchor", std::span<const glm::mat4>(imagery_from_anchor));
        call.textures[0] = gpu.imagery->texture.get();
        context.stats.bytes_resident += gpu.imagery->bytes;
    }
    context.draw_instanced(call, uint32_t(seams.size()), 1);
    context.stats.triangles += triangles.size();
    context.stats.bytes_resident += gpu.seams.size();
}

}  // namespace strata

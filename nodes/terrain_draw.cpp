// An embedding's seams on the GPU: the triangles the stitch makes for the view, as its owners' vertices
// (EmbeddingStitch::seam_vertices), each vertex morphed by its owner's own code from its own records in
// a compute pass (HlodModel::morph_on_gpu; EmbeddingStitch::seams is its CPU twin), then drawn through
// the owner's clip_from_anchor composed exactly as HlodModel composes it, with gl_Position invariant in
// both programs, so that a seam vertex lands on the very bits its owner's vertex does. On a textured terrain
// they show the ground's imagery under them, else the ground's untextured colour.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/buffer.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/program.h"
#include "engine/gl/texture.h"
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
    gl::Texture texture;
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
    std::vector<uint8_t> rgba(rgb.size() / 3 * 4, 255);
    for (size_t t = 0; t < rgb.size() / 3; ++t) std::copy_n(&rgb[3 * t], 3, &rgba[4 * t]);

    SeamImagery out;
    out.texture = gl::Texture::srgb_image(rgba, int(grid.columns), int(grid.rows));
    // Texel (c, r) covers [x0 + (c − ½)·step, x0 + (c + ½)·step] × likewise in y.
    out.uv_from_node = glm::scale(glm::dmat4(1.0), glm::dvec3(1 / (step * grid.columns), 1 / (step * grid.rows), 1.0)) *
                       glm::translate(glm::dmat4(1.0), glm::dvec3(step / 2 - grid.x0, step / 2 - grid.y0, 0.0));
    out.bytes = rgba.size() * 4 / 3;  // with its mips
    return out;
}

// The owners of an embedding's seams as one view draws them: the ground, the skirt and the site (the
// site under its placement), each with its morph's inputs and its frames from its lattice anchor.
struct Owners {
    const HlodModel* models[3];
    HlodModel::MorphInputs inputs[3];
    std::array<glm::mat4, 3> clip_from_anchor, world_from_anchor;
    std::array<glm::dmat4, 3> terrain_from_anchor;  // the terrain's node frame, where the zone's imagery lies
};

// One instance's seams in this frame, from prepare() to draw(): a terrain under two transforms draws two.
struct SeamInstance {
    const void* item = nullptr;  // its draw item's state, which each instance's cull makes its own
    gl::Buffer seams;
    uint32_t vertices = 0;  // what prepare() morphed into `seams`: 3 a triangle
    Owners owners;
};

struct SeamGpu : GpuCache::Entry {
    std::vector<SeamInstance> instances;  // their buffers kept from frame to frame
    size_t used = 0;                      // in the frame `frame`
    uint64_t frame = ~uint64_t(0);
    std::optional<SeamImagery> imagery;  // made on the first frame that draws a textured terrain's seams

    SeamInstance& take(uint64_t now, const void* item) {
        if (frame != now) frame = now, used = 0;
        if (used == instances.size()) instances.emplace_back();
        SeamInstance& instance = instances[used++];
        instance.item = item;
        return instance;
    }
    const SeamInstance* find(uint64_t now, const void* item) const {
        for (size_t i = 0; frame == now && i < used; ++i)
            if (instances[i].item == item) return &instances[i];
        return nullptr;
    }
};

Owners owners_for(const Embedding& embedding, const DrawContext& context, const DrawItem& item) {
    const auto& views = *std::static_pointer_cast<const Embedding::ViewSelections>(item.state);
    const EmbeddedModels& m = embedding.stitch().models();
    const glm::dmat4 placement = embedding.placement()->matrix();
    // Each owner's frame as the cull pass composed it: the site's under its placement.
    const glm::dmat4 world_from_node[3] = {item.model, item.model, item.model * placement};
    const glm::dmat4 terrain_from_node[3] = {glm::dmat4(1.0), glm::dmat4(1.0), placement};
    const Embedding::Selection* selections[3] = {&views.terrain, &views.skirt, &views.site};
    Owners out{{m.terrain.get(), m.skirt.get(), m.site.get()}, {}, {}, {}, {}};
    for (size_t o = 0; o < 3; ++o) {
        const HlodModel& owner = *out.models[o];
        out.inputs[o] = {owner.anchor_for(world_from_node[o], context.eye), selections[o]->kappa, owner.morphs_for(context.camera)};
        // As set_view_uniforms composes it (hlod_model_draw.cpp), to the bit.
        const glm::dmat4 world_from_lattice = world_from_node[o] * owner.lattice_to_node();
        const glm::dmat4 anchor = glm::translate(glm::dmat4(1.0), out.inputs[o].anchor.origin);
        out.clip_from_anchor[o] = glm::mat4(context.projection * context.view * world_from_lattice * anchor);
        out.world_from_anchor[o] = glm::mat4(world_from_lattice * anchor);
        out.terrain_from_anchor[o] = terrain_from_node[o] * owner.lattice_to_node() * anchor;
    }
    return out;
}

}  // namespace

void EmbeddingSeams::prepare(DrawContext& context, const DrawItem& item) {
    const auto& views = *std::static_pointer_cast<const Embedding::ViewSelections>(item.state);
    SeamGpu& gpu = context.cache.get<SeamGpu>(*this, [] { return std::make_unique<SeamGpu>(); });
    SeamInstance& instance = gpu.take(context.cache.frame(), item.state.get());
    std::vector<StitchRefTriangle> triangles;
    embedding_.stitch().seam_vertices(views.terrain.cubes, views.skirt.cubes, views.site.cubes, triangles);
    // Each seam vertex morphed on the GPU by its owner's own code from its own records, into its place.
    instance.owners = owners_for(embedding_, context, item);
    const Owners& owners = instance.owners;
    std::array<std::vector<HlodModel::GpuVertex>, 3> asked;
    instance.vertices = 0;
    for (const StitchRefTriangle& t : triangles)
        for (const StitchRef& r : t) asked[size_t(r.owner)].push_back({r.cube, r.vertex, instance.vertices++});
    const uint64_t bytes = uint64_t(instance.vertices) * sizeof(glm::vec4);
    if (instance.seams.size() < bytes) instance.seams = gl::Buffer(2 * bytes, gl::kDynamicStorage);
    for (size_t o = 0; o < 3; ++o) owners.models[o]->morph_on_gpu(context, owners.inputs[o], asked[o], instance.seams, float(o));
    if (capture_) captured_ = instance.vertices ? instance.seams.download<glm::vec4>(instance.vertices) : std::vector<glm::vec4>();
}

void EmbeddingSeams::draw(DrawContext& context, const DrawItem& item) {
    SeamGpu& gpu = context.cache.get<SeamGpu>(*this, [] { return std::make_unique<SeamGpu>(); });
    const SeamInstance* instance = gpu.find(context.cache.frame(), item.state.get());
    if (!instance || instance->vertices == 0) return;
    const EmbeddedModels& m = embedding_.stitch().models();
    const Owners& owners = instance->owners;
    const gl::Program& program =
        context.cache.get_shared<SeamProgram>(kSeamProgramKey, [] { return std::make_unique<SeamProgram>(); }).program;
    program.set("clip_from_anchor", std::span<const glm::mat4>(owners.clip_from_anchor));
    program.set("world_from_anchor", std::span<const glm::mat4>(owners.world_from_anchor));
    // The ground's colour, untextured (hlod_model_draw.cpp); under the ground's debug views the stitch
    // shows in a colour of its own (hot pink, which the level palette lacks), and in wireframe its edges.
    const HlodDebugView debug = m.terrain->debug_view();
    program.set("base_color", debug == HlodDebugView::none ? glm::vec4(0.6f, 0.57f, 0.52f, 1.0f) : glm::vec4(1.0f, 0.1f, 0.55f, 1.0f));
    program.set("node_id", unsigned(m.terrain->id()));
    DrawCall call{.program = program, .wireframe = debug == HlodDebugView::wireframe};
    call.storage[1] = &instance->seams;
    // A textured ground's seams show its imagery, as the ground does (hlod_model_draw.cpp: textured
    // unless a debug view colours it, or the driver cannot sample its textures).
    const bool textured = debug == HlodDebugView::none && m.terrain->textures() && gl::TextureLayers::supported();
    program.set("textured", int(textured));
    if (textured) {
        if (!gpu.imagery) gpu.imagery = make_seam_imagery(*m.terrain, *m.skirt);
        std::array<glm::mat4, 3> imagery_from_anchor;
        for (size_t o = 0; o < 3; ++o) imagery_from_anchor[o] = glm::mat4(gpu.imagery->uv_from_node * owners.terrain_from_anchor[o]);
        program.set("imagery_from_anchor", std::span<const glm::mat4>(imagery_from_anchor));
        call.textures[0] = gpu.imagery->texture.id();
        context.stats.bytes_resident += gpu.imagery->bytes;
    }
    context.draw_instanced(call, instance->vertices, 1);
    context.stats.triangles += instance->vertices / 3;
    context.stats.bytes_resident += instance->seams.size();
}

}  // namespace strata

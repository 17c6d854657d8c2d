// The HLOD model on the GPU (DESIGN.md §3): each resident cube one block of the scene's buffer pool
// (its vertex and parent records, colours and indices, pulled by gl_VertexID), placed when the cube
// arrives and freed when it leaves, once for every model drawing the same cubes (HlodModel::cube_owner);
// the selected cubes drawn in the selection's order, a multi-draw per run of them on one pool page,
// submitted through the DrawContext; the morph in the vertex shader, in the same float operations as
// HlodModel::morphed_positions.
#include <algorithm>
#include <array>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <span>
#include <string>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/gl/buffer.h"
#include "engine/gl/buffer_pool.h"
#include "engine/gl/framebuffer.h"
#include "engine/gl/program.h"
#include "engine/gl/texture_layers.h"
#include "engine/render/draw_context.h"
#include "engine/scene/render_list.h"
#include "nodes/hlod_model.h"
#include "preprocess/cube_textures.h"

namespace strata {

namespace {

constexpr int kMaxLevels = int(kMaxHlodLevels);  // the uniform arrays' size

// Colour-by-level, for the levels view and the cube boxes (linear).
const char* const kLevelPaletteGlsl = R"(
const vec3 level_palette[8] = vec3[8](vec3(0.90, 0.25, 0.20), vec3(0.95, 0.60, 0.15), vec3(0.90, 0.85, 0.20),
    vec3(0.35, 0.75, 0.30), vec3(0.20, 0.70, 0.75), vec3(0.25, 0.40, 0.85), vec3(0.55, 0.30, 0.80),
    vec3(0.85, 0.35, 0.65));
)";

// The morph (DESIGN.md §3), shared by the surface's vertex shader and the seams' morph pass
// (HlodModel::morph_on_gpu): in the same float operations as HlodModel::morphed_positions.
const char* const kMorphGlsl = R"(
// Per cube: level, cell i, j, k. Per vertex: x | y << 16, z, octahedral normal (u | v << 16), index
// of its parent's record in the page. Per parent: the same, without the index. Bindings 2 to 5 are one
// pool page seen as records and as colour words (cube_block in hlod_model_draw.cpp).
layout(std430, binding = 1) readonly buffer Cubes { uvec4 cubes[]; };
layout(std430, binding = 2) readonly buffer Vertices { uvec4 vertices[]; };
layout(std430, binding = 3) readonly buffer Parents { uvec4 parents[]; };
// Per cube: its 27 neighbours of its level (HlodModel::neighbours), then its parent; 0xffffffff: none.
layout(std430, binding = 8) readonly buffer Links { uint links[]; };
// Per cube: where its level's vertices may start to morph, and where its children's must have ended
// (CubeKappas::band_ends).
layout(std430, binding = 9) readonly buffer BandEnds { vec2 band_ends[]; };
// Per cube: how far its children's vertices near it have faded in (CubeKappas::fade_of).
layout(std430, binding = 11) readonly buffer Fades { float fades[]; };

uniform vec3 eye;  // from E
uniform ivec3 anchor_steps;  // A, on level 0's lattice
uniform vec3 anchor_rest;
uniform float lattice_step[16];
uniform float parent_step[16];
uniform int overhang;  // HlodModel::overhang_steps
uniform float morph_span[16];  // HlodModel::morph_span_limit
uniform bool morph;

ivec3 lattice_steps(uvec4 record, uvec3 cell) {
    ivec3 stored = ivec3(record.x & 0xffffu, record.x >> 16, record.y & 0xffffu);
    return stored + ivec3(cell << 15) - 16384;
}

const uint no_cube = 0xffffffffu;

// HlodModel::morph_band and morph_lambda, in the same operations: a vertex's band from the cubes whose
// cells, grown by the overhang, hold it (shift 15: its own level's cells; 16: its parent level's).
uint slot(ivec3 cell, ivec3 home) {
    ivec3 o = clamp(cell - home, -1, 1) + 1;
    return uint(o.x + 3 * o.y + 9 * o.z);
}

float morph_lambda(uint cube, uint level, uvec3 cell, ivec3 q, float d) {
    uint parent = links[cube * 28u + 27u];
    if (parent == no_cube) return 1.0;
    float start = band_ends[cube].x, end = band_ends[parent].y, fade = fades[parent];
    ivec3 home = ivec3(cell), lo = (q - overhang) >> 15, hi = (q + overhang) >> 15;
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                uint m = links[cube * 28u + slot(ivec3(x, y, z), home)];
                if (m != no_cube) start = max(start, band_ends[m].x);
            }
    home = ivec3(cell >> 1), lo = (q - overhang) >> 16, hi = (q + overhang) >> 16;
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                uint m = links[parent * 28u + slot(ivec3(x, y, z), home)];
                if (m != no_cube) {
                    end = min(end, band_ends[m].y);
                    fade = min(fade, fades[m]);
                }
            }
    int exponent;
    frexp(min(end - start, morph_span[level]), exponent);
    precise float lambda = clamp((end - d) * ldexp(1.0, 1 - exponent), 0.0, 1.0) * fade;
    return lambda;
}

// Vertex record `unit` of cube `index` (the cube's table entry), from the anchor E, and its λ.
vec3 morphed_position(uint index, uint unit, out float lambda) {
    uvec4 cube = cubes[index];
    uint level = cube.x;
    uvec4 own = vertices[unit];
    uvec4 parent = parents[own.w];
    ivec3 q = lattice_steps(own, cube.yzw);
    int parent_level = level == 0u ? 0 : int(level) - 1;
    precise vec3 w = vec3(q - (anchor_steps << int(level))) * lattice_step[level] + anchor_rest;
    precise vec3 p = vec3(lattice_steps(parent, cube.yzw >> 1) - (anchor_steps << parent_level)) * parent_step[level] + anchor_rest;
    vec3 offset = abs(w - eye);
    float d = max(max(offset.x, offset.y), offset.z);
    precise float l = morph ? morph_lambda(index, level, cube.yzw, q, d) : 1.0;
    lambda = l;
    // The ends exactly (Lemma 2), the mix in between without fused multiply-adds, as on the CPU; a
    // vertex at its parent's very position (a locked boundary's) stays there bit for bit.
    precise vec3 position = l >= 1.0 || p == w ? w : l <= 0.0 ? p : p * (1.0 - l) + w * l;
    return position;
}
)";

const char* const kVertexGlsl = R"(
layout(std430, binding = 4) readonly buffer VertexColors { uint vertex_colors[]; };
layout(std430, binding = 5) readonly buffer ParentColors { uint parent_colors[]; };
// Per cube: what to add to a vertex's and to a parent's record index for its colour word.
layout(std430, binding = 10) readonly buffer ColorOffsets { ivec2 color_offsets[]; };
layout(std430, binding = 7) writeonly buffer Capture { vec4 captured[]; };  // HlodModel::set_capture_morph
// Per cube: its texture's layer in its page of texture layers (a textured model).
layout(std430, binding = 12) readonly buffer TextureLayers { uint texture_layers[]; };

uniform mat4 clip_from_anchor;  // HlodModel::LatticeAnchor: positions are drawn from E, near the eye
uniform mat3 world_from_lattice_normal;
uniform bool has_colors;
uniform bool color_by_level;
uniform bool color_by_residency;
uniform vec4 base_color;  // linear
uniform bool capture;
uniform bool textured;
uniform float texture_margin;  // planar mapping: a texture covers its cube's cell grown by this (÷ s_l)

out vec3 v_normal;
out vec4 v_color;
flat out float v_level;
// The texture coordinates of the morphed position in the cube's texture and in its parent's, the
// layers of both, and the morph's λ, which blends them as it blends the positions.
out vec2 v_own_uv;
out vec2 v_parent_uv;
flat out uvec2 v_layers;
out float v_lambda;

vec3 octahedral_normal(uint bits) {
    const float scale = 2047.0;
    float x = max(float(bitfieldExtract(int(bits), 0, 16)) / scale, -1.0);
    float y = max(float(bitfieldExtract(int(bits), 16, 16)) / scale, -1.0);
    float z = 1.0 - abs(x) - abs(y);
    if (z < 0.0) {
        float ox = (1.0 - abs(y)) * (x >= 0.0 ? 1.0 : -1.0);
        float oy = (1.0 - abs(x)) * (y >= 0.0 ? 1.0 : -1.0);
        x = ox; y = oy;
    }
    return normalize(vec3(x, y, z));
}


// An embedding's seams compute gl_Position from the same floats by the same expression (terrain_draw.cpp).
invariant gl_Position;

void main() {
    uint index = uint(gl_BaseInstanceARB);
    uvec4 cube = cubes[index];
    uint level = cube.x;
    uvec4 own = vertices[gl_VertexID];
    uvec4 parent = parents[own.w];
    float lambda;
    precise vec3 position = morphed_position(index, uint(gl_VertexID), lambda);
    gl_Position = clip_from_anchor * vec4(position, 1.0);
    if (capture) captured[gl_VertexID] = vec4(position, lambda);

    vec3 n = mix(octahedral_normal(parent.z), octahedral_normal(own.z), lambda);
    v_normal = world_from_lattice_normal * n;
    if (textured) {
        // In the cube's cell's units from its corner: its own stored steps, and its parent's in the
        // parent's (twice as long) from the parent cell's corner. Small integers, exact in float.
        uvec2 half_cell = cube.yz & 1u;
        vec2 own_at = vec2(ivec2(own.x & 0xffffu, own.x >> 16) - 16384);
        vec2 parent_at = vec2(ivec2(parent.x & 0xffffu, parent.x >> 16) - 16384) * 2.0 - vec2(half_cell << 15);
        vec2 at = mix(parent_at, own_at, lambda) / 32768.0;
        float span = 1.0 + 2.0 * texture_margin;
        v_own_uv = (at + texture_margin) / span;
        v_parent_uv = ((at + vec2(half_cell)) * 0.5 + texture_margin) / span;
        uint parent_cube = links[index * 28u + 27u];
        v_layers = uvec2(texture_layers[index], texture_layers[parent_cube == no_cube ? index : parent_cube]);
    }
    v_lambda = lambda;
    vec4 color = textured ? vec4(1.0) : base_color;
    if (has_colors) {  // scans store sRGB-encoded 8-bit colours
        ivec2 offsets = color_offsets[index];
        vec4 c = mix(unpackUnorm4x8(parent_colors[int(own.w) + offsets.y]),
                     unpackUnorm4x8(vertex_colors[gl_VertexID + offsets.x]), lambda);
        color *= vec4(srgb_to_linear(c.rgb), c.a);
    }
    if (color_by_level) color = vec4(level_palette[level % 8u], 1.0);
    // A capped cube (a stand-in, or held back beside one) has a band end of 0 (HlodModel::select).
    if (color_by_residency) color = band_ends[index].y == 0.0 ? vec4(0.95, 0.45, 0.08, 1.0) : vec4(0.30, 0.45, 0.60, 1.0);
    v_color = color;
    v_level = float(level);
}
)";

const char* const kFragmentGlsl = R"(
in vec3 v_normal;
in vec4 v_color;
flat in float v_level;
in vec2 v_own_uv;
in vec2 v_parent_uv;
flat in uvec2 v_layers;
in float v_lambda;
uniform uint node_id;
uniform bool textured;
// The pages holding this draw's cubes' textures and their parents' (sRGB: sampled in linear light).
layout(binding = 0) uniform sampler2DArray own_textures;
layout(binding = 1) uniform sampler2DArray parent_textures;

void main() {
    vec3 n = normalize(gl_FrontFacing ? v_normal : -v_normal);
    vec4 color = v_color;
    if (textured) {
        vec3 own = texture(own_textures, vec3(v_own_uv, float(v_layers.x))).rgb;
        vec3 parent = texture(parent_textures, vec3(v_parent_uv, float(v_layers.y))).rgb;
        color.rgb *= mix(parent, own, v_lambda);
    }
    out_color = vec4(shade(color.rgb, n), color.a);
    out_normal = vec4(n, 0.0);
    out_level = v_level;
    out_node_id = node_id;
}
)";

// The cube-boxes view: the 12 edges of each drawn cube's cell, one instance per cube, coloured by level.
const char* const kBoxVertexGlsl = R"(
layout(std430, binding = 1) readonly buffer Cubes { uvec4 cubes[]; };
layout(std430, binding = 6) readonly buffer Drawn { uint drawn[]; };
uniform mat4 clip_from_lattice;
uniform float cube_size[16];
flat out vec3 v_color;
void main() {
    uvec4 cube = cubes[drawn[gl_InstanceID]];
    // Edge e (0..11) runs along axis e / 4; the other two axes take the corner bits of e % 4.
    int edge = gl_VertexID / 2, axis = edge / 4, bits = edge % 4;
    vec3 corner;
    corner[axis] = float(gl_VertexID % 2);
    corner[(axis + 1) % 3] = float(bits & 1);
    corner[(axis + 2) % 3] = float(bits >> 1);
    gl_Position = clip_from_lattice * vec4((vec3(cube.yzw) + corner) * cube_size[cube.x], 1.0);
    v_color = level_palette[cube.x % 8u];
}
)";

const char* const kBoxFragmentGlsl = R"(
flat in vec3 v_color;
void main() {
    out_color = vec4(v_color, 1.0);
    out_normal = vec4(0.0);
    out_level = -1.0;
    out_node_id = 0u;
}
)";

std::string vertex_source() {
    return std::string("#version 450\n#extension GL_ARB_shader_draw_parameters : require\n") + kSrgbGlsl +
           kLevelPaletteGlsl + kMorphGlsl + kVertexGlsl;
}

// The seams' morph pass (HlodModel::morph_on_gpu): per vertex asked for, its morphed position from the
// anchor into the output at the place asked, w the tag given (the seams' owner).
const char* const kMorphPassGlsl = R"(
layout(local_size_x = 64) in;
layout(std430, binding = 13) readonly buffer Asked { uvec4 asked[]; };  // {cube, vertex record, output place, 0}
layout(std430, binding = 14) writeonly buffer Morphed { vec4 morphed[]; };
uniform uint asked_count;
uniform float tag;

void main() {
    uint k = gl_GlobalInvocationID.x;
    if (k >= asked_count) return;
    uvec4 a = asked[k];
    float lambda;
    precise vec3 position = morphed_position(a.x, a.y, lambda);
    morphed[a.z] = vec4(position, tag);
}
)";

std::string morph_pass_source() { return std::string("#version 450\n") + kMorphGlsl + kMorphPassGlsl; }

std::string fragment_source() {
    return std::string("#version 450\n") + gl::fragment_outputs_glsl + kShadingGlsl + kFragmentGlsl;
}

// The programs every HLOD model shares, kept in the GPU cache under one key.
constexpr uint32_t kProgramsKey = 2;
struct HlodPrograms : GpuCache::Entry {
    gl::Program surface = gl::Program::graphics("hlod", vertex_source(), fragment_source());
    gl::Program morph = gl::Program::compute("hlod morph pass", morph_pass_source());
    gl::Program boxes = gl::Program::graphics("hlod cube boxes", std::string("#version 450\n") + kLevelPaletteGlsl + kBoxVertexGlsl,
                                              std::string("#version 450\n") + gl::fragment_outputs_glsl + kBoxFragmentGlsl);
};

// Where a cube's block holds each part, in pool units from its start: its vertex records, its parent
// records, then (with colours) a colour word per vertex and per parent, then its indices, each part
// starting on a whole unit.
struct CubeBlock {
    uint64_t parents, vertex_colors, parent_colors, indices, units;
};

CubeBlock cube_block(uint64_t vertices, uint64_t parents, uint64_t indices, bool colors) {
    constexpr uint64_t per_unit = gl::BufferPool::kUnitBytes / 4;  // colour words and indices per unit
    CubeBlock b{};
    b.parents = vertices;
    b.vertex_colors = b.parents + parents;
    b.parent_colors = b.vertex_colors + (colors ? (vertices + per_unit - 1) / per_unit : 0);
    b.indices = b.parent_colors + (colors ? (parents + per_unit - 1) / per_unit : 0);
    b.units = b.indices + std::max<uint64_t>(1, (indices + per_unit - 1) / per_unit);
    return b;
}

// A resident cube on the GPU: the data its block was made from (`alive` tells when the cache and
// every model have let go of it; while it is held, `data` cannot name another cube's data), the block
// and its draw command.
struct PlacedCube {
    const CubeData* data = nullptr;
    std::weak_ptr<const CubeData> alive;
    gl::BufferPool::Block block;
    gl::TextureLayers::Layer texture;  // a textured model's
    IndexedDrawCommand command{};
};

struct CubesGpu;

// The scene's pool (one per renderer): every HLOD model's cube blocks, so that what its pages hold
// beyond the blocks is one scene's slack, not one per model; and the owners placing blocks in it.
constexpr uint32_t kPoolKey = 3;
struct ScenePool : GpuCache::Entry {
    std::shared_ptr<gl::BufferPool> pool;
    std::vector<CubesGpu*> owners;
    uint64_t counted_frame = ~uint64_t(0);  // the frame whose statistics have counted its pages
    uint64_t swept_frame = ~uint64_t(0);    // the frame that last freed the blocks of evicted cubes
};

// The cubes of one owner (HlodModel::cube_owner: a file streamed through a cache, or a model loaded
// whole) on the GPU: a block per resident cube and the per-cube tables that do not depend on the
// view, shared by every model drawing those cubes.
struct CubesGpu : GpuCache::Entry {
    CubesGpu(ScenePool& scene, bool with_colors) : scene_pool(scene), pool(scene.pool), colors(with_colors) {
        scene_pool.owners.push_back(this);
    }
    ~CubesGpu() override {
        for (PlacedCube& cube : placed) pool->free(cube.block);
        std::erase(scene_pool.owners, this);
    }
    // Frees the cube's block and texture layer.
    void unplace(PlacedCube& cube) {
        pool->free(cube.block);
        if (textures) textures->free(cube.texture);
        cube = {};
    }
    ScenePool& scene_pool;  // outlives its owners: the GPU cache drops shared entries last
    std::shared_ptr<gl::BufferPool> pool;
    bool colors;
    std::unique_ptr<gl::TextureLayers> textures;  // a textured model's
    gl::Buffer texture_layers;                    // per cube: its layer in its page
    uint64_t synced = ~uint64_t(0);      // the residency version last synced to (HlodModel::residency_version)
    std::vector<PlacedCube> placed;      // per cube
    std::vector<uint32_t> placed_cubes;  // the cubes with a block, in no order
    gl::Buffer cubes;
    gl::Buffer links;          // per cube: neighbours and parent
    gl::Buffer color_offsets;  // per cube
    uint64_t counted_frame = ~uint64_t(0);
    uint64_t fixed_bytes() const {
        return cubes.size() + links.size() + color_offsets.size() + texture_layers.size() + (textures ? textures->capacity_bytes() : 0);
    }
};

// What one model draws its view with: the κ and fades of its selection, and this frame's draws.
struct HlodGpu : GpuCache::Entry {
    gl::Buffer band_ends;  // per cube, of `kappas`
    gl::Buffer fades;      // per cube, of `kappas`
    Kappas kappas;
    // Sized to the frames drawn so far, not to the model (a frame draws a few thousand of its cubes).
    gl::Buffer drawn;     // this frame's cubes, for the boxes view
    gl::Buffer commands;  // this frame's, in the selection's order
    gl::Buffer asked;     // the vertices the seams' morph pass was last asked for (HlodModel::morph_on_gpu)
    // This frame's draws: consecutive cubes on one pool page whose textures, and whose parents'
    // textures, lie on one page of layers each.
    struct Run {
        uint32_t page, own_textures, parent_textures, commands;
        bool same_pages(const Run& other) const {
            return page == other.page && own_textures == other.own_textures && parent_textures == other.parent_textures;
        }
    };
    std::vector<Run> runs;
    uint64_t fixed_bytes() const { return band_ends.size() + fades.size() + drawn.size() + commands.size(); }
};

// `buffer` with room for at least `bytes`: made anew, twice as large as asked, when it has less.
void reserve(gl::Buffer& buffer, uint64_t bytes) {
    if (buffer.size() < bytes) buffer = gl::Buffer(2 * bytes, gl::kDynamicStorage);
}

uint32_t pack_pair(uint32_t low, uint32_t high) { return (low & 0xffffu) | high << 16; }

// Uploads a resident cube into a new block of the pool and makes its draw command.
void place_cube(CubesGpu& gpu, const std::shared_ptr<const CubeData>& data, uint32_t index) {
    const CubeData& c = *data;
    const bool colors = gpu.colors;
    const CubeBlock layout = cube_block(c.vertex_count(), c.parents.size(), c.indices.size(), colors);
    PlacedCube& placed = gpu.placed[index];
    placed.block = gpu.pool->allocate(layout.units);
    placed.data = data.get();
    placed.alive = data;
    const uint64_t base = placed.block.offset;
    std::vector<std::array<uint32_t, 4>> units(layout.units, {0, 0, 0, 0});
    for (uint32_t v = 0; v < c.vertex_count(); ++v) {
        const uint16_t* q = &c.vertices.positions[3 * size_t(v)];
        const int16_t* n = &c.vertices.normals[2 * size_t(v)];
        units[v] = {pack_pair(q[0], q[1]), q[2], pack_pair(uint16_t(n[0]), uint16_t(n[1])), uint32_t(base + layout.parents + c.parent_of[v])};
    }
    for (uint32_t p = 0; p < c.parents.size(); ++p) {
        const uint16_t* q = &c.parents.positions[3 * size_t(p)];
        const int16_t* n = &c.parents.normals[2 * size_t(p)];
        units[layout.parents + p] = {pack_pair(q[0], q[1]), q[2], pack_pair(uint16_t(n[0]), uint16_t(n[1])), 0};
    }
    uint32_t* words = units.front().data();
    auto put_colors = [&](const std::vector<uint8_t>& rgba, uint64_t first_unit) {
        for (size_t i = 0; i + 3 < rgba.size(); i += 4)
            words[4 * first_unit + i / 4] = rgba[i] | rgba[i + 1] << 8 | rgba[i + 2] << 16 | uint32_t(rgba[i + 3]) << 24;
    };
    std::array<int32_t, 2> color_offsets{0, 0};
    if (colors) {
        put_colors(c.vertices.colors, layout.vertex_colors);
        put_colors(c.parents.colors, layout.parent_colors);
        color_offsets = {int32_t(4 * (base + layout.vertex_colors) - base), int32_t(4 * (base + layout.parent_colors) - (base + layout.parents))};
    }
    std::copy(c.indices.begin(), c.indices.end(), words + 4 * layout.indices);
    gpu.pool->upload(placed.block, 0, units.data(), units.size() * gl::BufferPool::kUnitBytes);
    if (gpu.textures && !placed.texture && !c.texture.empty()) {  // a block moved between pages keeps its layer
        placed.texture = gpu.textures->allocate();
        gpu.textures->upload(placed.texture, c.texture);
        gpu.texture_layers.upload(index * sizeof(uint32_t), &placed.texture.layer, sizeof(uint32_t));
    }
    gpu.color_offsets.upload(index * sizeof(color_offsets), &color_offsets, sizeof(color_offsets));
    placed.command = {uint32_t(c.indices.size()), 1, uint32_t(4 * (base + layout.indices)), int32_t(base), index};
}

// Brings the blocks to the residency of the models drawing the cubes (one tree, one version): placed
// for cubes that arrived (or whose data changed), freed for cubes that left. Only the cubes that
// changed are uploaded.
void sync_blocks(const HlodModel& model, CubesGpu& gpu) {
    if (gpu.synced == model.residency_version()) return;
    gpu.synced = model.residency_version();
    const auto& cubes = model.cubes();
    gpu.placed_cubes.clear();
    for (uint32_t c = 0; c < cubes.size(); ++c) {
        PlacedCube& placed = gpu.placed[c];
        if (placed.data != cubes[c].data.get()) {
            gpu.unplace(placed);
            if (cubes[c].data) place_cube(gpu, cubes[c].data, c);
        }
        if (placed.block) gpu.placed_cubes.push_back(c);
    }
    gl::check_gl("uploading HLOD cubes");
}

// Once a frame, for every owner in the scene's pool, drawn this frame or not: frees the blocks of
// cubes the cache and the models have let go of (a model outside the view is not drawn, and would
// keep them until it is), and places the blocks on the page the pool is emptying again, elsewhere
// (BufferPool::retiring_page): what keeps the pages near what the resident cubes hold.
void sweep_pool(ScenePool& scene) {
    for (CubesGpu* owner : scene.owners) {
        const uint32_t retiring = scene.pool->retiring_page();
        std::erase_if(owner->placed_cubes, [&](uint32_t c) {
            PlacedCube& placed = owner->placed[c];
            const std::shared_ptr<const CubeData> data = placed.alive.lock();
            if (data && placed.block.page != retiring) return false;
            if (!data) {
                owner->unplace(placed);
                return true;
            }
            const gl::TextureLayers::Layer texture = placed.texture;  // only the block moves
            scene.pool->free(placed.block);
            placed = {};
            placed.texture = texture;
            place_cube(*owner, data, c);
            return false;
        });
    }
    gl::check_gl("freeing and moving HLOD cubes' blocks");
}

// The scene pool's page: a 64th of a streamed model's budget (1 to 16 MiB), so that what the pages
// hold beyond their cubes' own bytes stays small beside the budget; 16 MiB for models loaded whole.
uint64_t pool_page_bytes(const HlodModel& model) {
    constexpr uint64_t MiB = uint64_t(1) << 20;
    if (const StreamCache* cache = model.stream_cache()) return std::clamp(cache->budget() / 64, MiB, 16 * MiB);
    return 16 * MiB;
}

// A page of texture layers: an eighth of a streamed model's budget (8 to 256 MiB), so that a frame's
// cubes lie on few pages and draw in few runs; never more than all the model's cubes' textures.
uint64_t texture_page_bytes(const HlodModel& model) {
    constexpr uint64_t MiB = uint64_t(1) << 20;
    const uint64_t all = model.cubes().size() * model.texture_bytes();
    if (const StreamCache* cache = model.stream_cache()) return std::min(std::clamp(cache->budget() / 8, 8 * MiB, 256 * MiB), all);
    return std::min(all, 256 * MiB);
}

std::unique_ptr<CubesGpu> make_cubes_gpu(const HlodModel& model, ScenePool& pool) {
    auto gpu = std::make_unique<CubesGpu>(pool, model.header().has_colors());
    const auto& cubes = model.cubes();
    if (const CubeTextures* textures = model.textures()) {
        if (gl::TextureLayers::supported()) {
            gpu->textures = std::make_unique<gl::TextureLayers>(textures->layout().size, texture_page_bytes(model));
            gpu->texture_layers = gl::Buffer(cubes.size() * sizeof(uint32_t), gl::kDynamicStorage);
        } else {  // as a reader that skips its textures would (FORMAT.md §4.9)
            std::fprintf(stderr, "strata: %s: drawn without its textures: this OpenGL driver cannot sample BC1 (S3TC) sRGB textures\n",
                         model.path().c_str());
        }
    }
    std::vector<std::array<uint32_t, 4>> records;
    for (const HlodCube& c : cubes) records.push_back({c.node.level, c.node.i, c.node.j, c.node.k});
    gpu->cubes = gl::Buffer(records, gl::kFixedStorage);
    std::vector<uint32_t> links;
    links.reserve(cubes.size() * 28);
    for (uint32_t c = 0; c < cubes.size(); ++c) {
        links.insert(links.end(), model.neighbours(c).begin(), model.neighbours(c).end());
        links.push_back(model.parent(c));
    }
    gpu->links = gl::Buffer(links, gl::kFixedStorage);
    gpu->color_offsets = gl::Buffer(cubes.size() * sizeof(std::array<int32_t, 2>), gl::kDynamicStorage);
    gpu->placed.resize(cubes.size());
    gpu->placed_cubes.reserve(cubes.size());  // each cube once at most: what gpu_tables_per_owner counts
    gl::check_gl("making an HLOD model's buffers");
    return gpu;
}

std::unique_ptr<HlodGpu> make_gpu(const HlodModel& model) {
    auto gpu = std::make_unique<HlodGpu>();
    const size_t cubes = model.cubes().size();
    gpu->band_ends = gl::Buffer(cubes * sizeof(std::array<float, 2>), gl::kDynamicStorage);
    gpu->fades = gl::Buffer(cubes * sizeof(float), gl::kDynamicStorage);
    gl::check_gl("making an HLOD model's buffers");
    return gpu;
}

// Brings the GPU's band ends and fades to `kappas`: whole when its root (CubeKappas::root) is not
// the last one's, else only the cubes the last one or it overrides, so that a frame uploads what its
// stand-ins and fades change rather than a table of all the model's cubes.
void upload_kappas(HlodGpu& gpu, Kappas kappas) {
    auto put = [&](uint32_t c) {  // the cube's values under `kappas`
        const std::array<float, 2> ends = kappas->band_end(c);
        const float fade = kappas->fade_of(c);
        gpu.band_ends.upload(c * sizeof(ends), &ends, sizeof(ends));
        gpu.fades.upload(c * sizeof(fade), &fade, sizeof(fade));
    };
    const CubeKappas& root = kappas->root();
    if (!gpu.kappas || &gpu.kappas->root() != &root) {
        gpu.band_ends.upload(root.band_ends);
        gpu.fades.upload(std::vector<float>(root.band_ends.size(), 1.0f));
    } else {
        gpu.kappas->for_each_override(put);  // what the last one changed: back to the root's, or on to the new
    }
    kappas->for_each_override(put);
    gpu.kappas = std::move(kappas);
}

// What kMorphGlsl reads besides its buffers: the anchor, the model's lattice steps and morph limits, and
// whether it morphs; and the band ends and fades of `kappa` (the κ the selection morphs with, capped
// while cubes are missing; a new one for a new image size, field of view, target or capping).
void set_morph_uniforms(const HlodModel& model, const gl::Program& program, HlodGpu& gpu, const HlodModel::LatticeAnchor& anchor,
                        Kappas kappa, bool morph) {
    program.set("eye", anchor.eye);
    program.set("anchor_steps", anchor.steps);
    program.set("anchor_rest", anchor.rest);
    if (kappa != gpu.kappas) upload_kappas(gpu, std::move(kappa));
    const HlodHeader& h = model.header();
    std::array<float, kMaxLevels> step{}, parent_step{}, span{};
    for (uint32_t l = 0; l <= h.max_level; ++l) {
        step[l] = h.lattice_step(l);
        parent_step[l] = h.lattice_step(l == 0 ? 0 : l - 1);
        span[l] = model.morph_span_limit(l);
    }
    program.set("morph_span", std::span<const float>(span));
    program.set("lattice_step", std::span<const float>(step));
    program.set("parent_step", std::span<const float>(parent_step));
    program.set("overhang", int(model.overhang_steps()));
    program.set("morph", int(morph));
}

void set_view_uniforms(const HlodModel& model, const gl::Program& program, const CubesGpu& cubes, HlodGpu& gpu, const DrawContext& context,
                       const DrawItem& item) {
    const glm::dmat4 world_from_lattice = item.model * model.lattice_to_node();
    const HlodModel::LatticeAnchor anchor = model.anchor_for(item.model, context.eye);
    // Composed in double, then rounded once: the distance from the model's origin to the eye cancels
    // before going to float, and the positions are small (measured from E, at the eye).
    program.set("clip_from_anchor", glm::mat4(context.projection * context.view * world_from_lattice * glm::translate(glm::dmat4(1.0), anchor.origin)));
    program.set("world_from_lattice_normal", glm::mat3(glm::transpose(glm::inverse(glm::dmat3(world_from_lattice)))));
    set_morph_uniforms(model, program, gpu, anchor, std::static_pointer_cast<const HlodModel::DrawState>(item.state)->morph,
                       model.morphs_for(context.camera));
    const HlodHeader& h = model.header();
    program.set("has_colors", int(h.has_colors()));
    program.set("color_by_level", int(model.debug_view() == HlodDebugView::levels));
    program.set("color_by_residency", int(model.debug_view() == HlodDebugView::residency));
    program.set("base_color", glm::vec4(0.6f, 0.57f, 0.52f, 1.0f));  // linear: a warm stone grey
    program.set("node_id", unsigned(model.id()));
    program.set("capture", int(model.capture_morph()));
    const bool debug_colours = model.debug_view() == HlodDebugView::levels || model.debug_view() == HlodDebugView::residency;
    program.set("textured", int(cubes.textures && !debug_colours));
    if (model.textures()) program.set("texture_margin", model.textures()->layout().margin);
}

void draw_boxes(const HlodModel& model, const gl::Program& p, const CubesGpu& cubes, HlodGpu& gpu, DrawContext& context,
                const DrawItem& item) {
    const HlodHeader& header = model.header();
    reserve(gpu.drawn, item.count * sizeof(uint32_t));
    gpu.drawn.upload(0, &context.list.item_data[item.first], item.count * sizeof(uint32_t));
    std::array<float, kMaxLevels> size{};
    for (uint32_t l = 0; l <= header.max_level; ++l) size[l] = float(header.cube_size(l));
    p.set("clip_from_lattice", glm::mat4(context.projection * context.view * item.model * model.lattice_to_node()));
    p.set("cube_size", std::span<const float>(size));
    DrawCall call{.program = p, .primitive = Primitive::lines};
    call.storage[1] = &cubes.cubes, call.storage[6] = &gpu.drawn;
    context.draw_instanced(call, 24, item.count);
}

// What the frame's statistics count of the GPU memory behind a model: its own buffers; and, once a
// frame however many models draw from them, its cubes' tables and the scene pool's pages.
uint64_t bytes_to_count(const HlodGpu& gpu, CubesGpu& cubes, ScenePool& pool, const GpuCache& cache) {
    uint64_t bytes = gpu.fixed_bytes();
    if (std::exchange(cubes.counted_frame, cache.frame()) != cache.frame()) bytes += cubes.fixed_bytes();
    if (std::exchange(pool.counted_frame, cache.frame()) != cache.frame()) bytes += pool.pool->capacity_bytes();
    return bytes;
}

// A model's GPU state for a frame: the shared programs, the scene's pool, its cubes' blocks (placed as
// its residency is now) and its own tables.
struct ModelGpu {
    const HlodPrograms& programs;
    ScenePool& pool;
    CubesGpu& cubes;
    HlodGpu& gpu;
};

ModelGpu model_gpu(const HlodModel& model, DrawContext& context) {
    const HlodPrograms& programs = context.cache.get_shared<HlodPrograms>(kProgramsKey, [] { return std::make_unique<HlodPrograms>(); });
    ScenePool& pool = context.cache.get_shared<ScenePool>(kPoolKey, [&] {
        auto entry = std::make_unique<ScenePool>();
        entry->pool = std::make_shared<gl::BufferPool>(pool_page_bytes(model));
        return entry;
    });
    pool.pool->set_page_bytes(pool_page_bytes(model));
    CubesGpu& cubes = context.cache.get_owned<CubesGpu>(model.cube_owner(), [&] { return make_cubes_gpu(model, pool); });
    HlodGpu& gpu = context.cache.get<HlodGpu>(model, [&] { return make_gpu(model); });
    sync_blocks(model, cubes);
    if (std::exchange(pool.swept_frame, context.cache.frame()) != context.cache.frame()) sweep_pool(pool);
    return {programs, pool, cubes, gpu};
}

}  // namespace

HlodModel::TableBytes HlodModel::gpu_tables_per_owner(uint64_t cubes) {
    // Per cube: its record, links, colour offsets and (a textured model's) texture layer on the GPU;
    // its placement and place in placed_cubes (reserved whole) on the CPU.
    const uint64_t gpu = cubes * (sizeof(std::array<uint32_t, 4>) + 28 * sizeof(uint32_t) + sizeof(std::array<int32_t, 2>) + sizeof(uint32_t));
    return {gpu + cubes * (sizeof(PlacedCube) + sizeof(uint32_t)), gpu};
}

HlodModel::TableBytes HlodModel::gpu_tables_per_model(uint64_t cubes) {
    const uint64_t gpu = cubes * (sizeof(std::array<float, 2>) + sizeof(float));  // band ends and fades
    return {gpu, gpu};
}

uint64_t HlodModel::gpu_block_bytes(uint64_t vertices, uint64_t parents, uint64_t indices, bool colors) {
    return cube_block(vertices, parents, indices, colors).units * gl::BufferPool::kUnitBytes;
}

void HlodModel::morph_on_gpu(DrawContext& context, const MorphInputs& inputs, std::span<const GpuVertex> asked, const gl::Buffer& out,
                             float tag) const {
    if (asked.empty()) return;
    const auto [programs, pool, cubes, gpu] = model_gpu(*this, context);
    const gl::Program& program = programs.morph;
    set_morph_uniforms(*this, program, gpu, inputs.anchor, inputs.kappa, inputs.morph);
    program.set("tag", tag);
    // A vertex's morph reads its records on its cube's page: a dispatch per page.
    std::map<uint32_t, std::vector<std::array<uint32_t, 4>>> by_page;
    for (const GpuVertex& v : asked) {
        const PlacedCube& placed = cubes.placed.at(v.cube);
        if (!placed.block) throw std::logic_error(path().string() + ": morph_on_gpu asked for a cube that is not resident");
        by_page[placed.block.page].push_back({v.cube, uint32_t(placed.block.offset + v.vertex), v.place, 0});
    }
    for (const auto& [page, list] : by_page) {
        reserve(gpu.asked, list.size() * sizeof(list[0]));
        gpu.asked.upload(list);
        program.set("asked_count", unsigned(list.size()));
        DrawCall call{.program = program};
        call.storage[1] = &cubes.cubes, call.storage[8] = &cubes.links, call.storage[9] = &gpu.band_ends, call.storage[11] = &gpu.fades;
        call.storage[2] = call.storage[3] = &pool.pool->page(page);
        call.storage[13] = &gpu.asked, call.storage[14] = &out;
        context.dispatch(call, uint32_t((list.size() + 63) / 64));
    }
}

void HlodModel::draw(DrawContext& context, const DrawItem& item) {
    const auto [programs, pool, cubes, gpu] = model_gpu(*this, context);
    set_view_uniforms(*this, programs.surface, cubes, gpu, context, item);

    // This frame's commands in the selection's order (front to back) in one indirect buffer, drawn as
    // runs of consecutive cubes on one page. The order is what the frame depends on where triangles
    // tie in depth (cube borders), so it must not follow where the pool happened to place the cubes:
    // a capture gives the same bytes whatever the cache held before.
    // A cube whose triangles the selection hook hides draws the runs it keeps, a command each.
    const DrawState& state = *std::static_pointer_cast<const DrawState>(item.state);
    std::vector<IndexedDrawCommand> commands;
    commands.reserve(item.count);
    gpu.runs.clear();
    for (uint32_t k = 0; k < item.count; ++k) {
        const uint32_t c = context.list.item_data[item.first + k];
        const PlacedCube& placed = cubes.placed[c];
        const uint32_t parent = this->parent(c);
        const PlacedCube& parent_placed = parent == kNoCube || !cubes.placed[parent].texture ? placed : cubes.placed[parent];
        const HlodGpu::Run run{placed.block.page, placed.texture.page, parent_placed.texture.page, 0};
        if (gpu.runs.empty() || !gpu.runs.back().same_pages(run)) gpu.runs.push_back(run);
        const auto kept = state.runs ? state.runs->find(c) : CubeRuns::const_iterator{};
        if (state.runs && kept != state.runs->end()) {
            for (const auto& part : kept->second) {
                IndexedDrawCommand command = placed.command;
                command.first_index += part[0];
                command.count = part[1];
                commands.push_back(command);
                ++gpu.runs.back().commands;
                context.stats.triangles += command.count / 3;
            }
        } else {
            commands.push_back(placed.command);
            ++gpu.runs.back().commands;
            context.stats.triangles += placed.command.count / 3;
        }
    }
    if (!commands.empty()) {
        reserve(gpu.commands, commands.size() * sizeof(IndexedDrawCommand));
        gpu.commands.upload(commands);
    }
    context.stats.cubes += item.count;
    context.stats.bytes_resident += bytes_to_count(gpu, cubes, pool, context.cache);
    if (capture_morph_) {
        captured_.clear();
        captured_kappas_ = state.morph;
    }
    DrawCall call{.program = programs.surface, .wireframe = debug_view_ == HlodDebugView::wireframe};
    call.storage[1] = &cubes.cubes, call.storage[8] = &cubes.links, call.storage[10] = &cubes.color_offsets;
    call.storage[9] = &gpu.band_ends, call.storage[11] = &gpu.fades;
    size_t first_command = 0;
    call.storage[12] = &cubes.texture_layers;
    for (const HlodGpu::Run& run : gpu.runs) {
        const uint32_t count = run.commands;
        const gl::Buffer& page = pool.pool->page(run.page);
        call.storage[2] = call.storage[3] = call.storage[4] = call.storage[5] = call.indices = &page;
        if (cubes.textures && run.own_textures != ~0u) {
            call.textures[0] = cubes.textures->page(run.own_textures);
            call.textures[1] = cubes.textures->page(run.parent_textures);
        }
        gl::Buffer capture;
        if (capture_morph_) {
            capture = gl::Buffer(page.size(), gl::kDynamicStorage);  // a vec4 per 16-byte unit
            call.storage[7] = &capture;
        }
        context.draw_indirect(call, gpu.commands, first_command, count);
        if (capture_morph_) {
            const auto values = capture.download<glm::vec4>(capture.size() / sizeof(glm::vec4));
            for (size_t k = first_command; k < first_command + count; ++k) {
                const IndexedDrawCommand& command = commands[k];
                const auto first = values.begin() + command.base_vertex;
                captured_[command.base_instance].assign(first, first + tree_->cubes[command.base_instance].data->vertex_count());
            }
        }
        first_command += count;
    }
    if (show_boxes_) draw_boxes(*this, programs.boxes, cubes, gpu, context, item);
}

}  // namespace strata

// The HLOD model as a scene-graph node (DESIGN.md §3): loads a .hlod, selects the coarsest suitable
// cubes for the eye in the node's own frame, culls cubes against the frustum, and morphs each vertex
// toward its parent. The CPU twin of the morph (morphed_positions) computes exactly what the shader
// draws, for the crack check, picking and measurements.
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/camera.h"
#include "engine/scene/drawable.h"
#include "engine/scene/frustum.h"
#include "engine/stream/stream_cache.h"
#include "preprocess/hlod_format.h"

namespace strata {

struct Lookahead;  // engine/scene/cull_visitor.h
namespace gl {
class Buffer;  // engine/gl/buffer.h
}
class Georeference;     // preprocess/georeference.h
class TerrainHeights;   // preprocess/terrain_heights.h
class CubeTextures;     // preprocess/cube_textures.h

// Colour-by-level and the like: what the shader shows instead of (or over) the shaded surface.
// residency: cubes that stand in for data still loading (and those held back beside them) in orange,
// the rest in blue-grey.
enum class HlodDebugView { none, levels, wireframe, residency };
inline constexpr const char* kHlodDebugViewNames = "none, levels, wireframe, residency";
const char* debug_view_name(HlodDebugView view);
std::optional<HlodDebugView> debug_view_named(std::string_view name);

struct HlodCube {
    HlodNode node;
    std::shared_ptr<const CubeData> data;  // null while the cube is not resident
    std::array<uint32_t, 8> children;  // cube index per octant, or kNoCube
};

inline constexpr uint32_t kNoCube = ~0u;
inline constexpr uint32_t kMaxHlodLevels = 16;  // the format allows levels 0 … 15

// κ for one view, one per cube (nodes/README.md, "Selection"): a cube c of level l is suitable when
// d∞(eye, cell_c) ≥ κ_c·s_l. Each cube also lends its κ to the morph bands of the vertices near it:
// `band_ends[c]` holds where vertices of its level may start to morph, (1 + κ_c + σ0)·s_l, and where
// vertices of its children's level must have reached their parents, (κ_c − σ0)·s_l, as the floats the
// shader reads.
struct CubeKappas {
    std::vector<double> kappa;
    std::vector<std::array<float, 2>> band_ends;
    // Or the κ a view morphs with (HlodModel::select), over a base: the base's but for the `capped`
    // cubes, whose band's far end is 0, and with the fades of `fading`, the cubes whose children are
    // still fading in (nodes/README.md, "Stand-ins": a vertex's λ is scaled by the least fade of the
    // cubes that set its band's end; every other fade is 1). The arrays above stay empty; both lists
    // are sorted by cube. So what a frame makes and uploads follows its stand-ins and fades, not the
    // model's cubes.
    std::shared_ptr<const CubeKappas> base;
    std::vector<uint32_t> capped;
    std::vector<std::pair<uint32_t, float>> fading;

    double operator[](uint32_t cube) const { return base ? (*base)[cube] : kappa[cube]; }
    std::array<float, 2> band_end(uint32_t cube) const;
    float fade_of(uint32_t cube) const;
    // The one at the bottom of the bases, which holds the arrays.
    const CubeKappas& root() const { return base ? base->root() : *this; }
    // The cubes whose band ends or fades may differ from root()'s (maybe twice).
    template <class Visit>
    void for_each_override(Visit&& visit) const {
        for (const uint32_t c : capped) visit(c);
        for (const auto& entry : fading) visit(entry.first);
        if (base) base->for_each_override(visit);
    }
};
using Kappas = std::shared_ptr<const CubeKappas>;

// Where and how one selection looks, in the model's lattice frame (model units, origin at O).
struct HlodView {
    glm::dvec3 eye;
    Kappas kappa;
    const Frustum* frustum = nullptr;  // nullptr: no culling
    uint8_t plane_mask = kAllPlanes;
    // ≥ 0: every cube of this level (or the finest there is) instead of the distance rule: what an
    // orthographic view needs, whose pixels have one size at any distance.
    int fixed_level = -1;
    // An interactive view: the model's own fades (HlodModel::fade(), no other vector), below 1 for cubes
    // whose children are still fading in; such cubes hold their neighbours' children back as stand-ins
    // do. nullptr: none (full detail, a model loaded whole).
    const std::vector<float>* fade = nullptr;
};

class HlodModel : public Drawable {
    // What the models showing one file's cubes share: one per file streamed through a cache, so that
    // ten instances of a scan hold its per-cube tables once (and count them once in the budget); one
    // per model loaded whole. The octree from the node table, which cubes are resident with their
    // data, and the κ last computed.
    struct Tree {
        HlodHeader header;
        std::vector<HlodCube> cubes;
        uint32_t root = 0;
        std::vector<double> level_error;                   // ε_l
        std::vector<std::array<uint32_t, 27>> neighbours;  // per cube
        std::vector<uint32_t> parent;                      // per cube
        std::vector<uint32_t> finest_first;                // cube indices, finest level first
        std::vector<uint8_t> resident, lacks_child;        // per cube: lacks_child, resident without a child
        uint64_t residency_version = 0;                    // counts changes of residency
        uint64_t synced = ~uint64_t(0);                    // streamed: the source's version last taken in
        // The κ last computed, most recent first, with what each was computed from (a gain, or −κ0 for
        // a uniform κ): two, so that models of the file viewed two ways (an editor's view and a
        // capture's, two pixel errors) do not compute theirs anew each frame.
        static constexpr size_t kCachedKappas = 2;
        std::mutex kappas_mutex;
        std::array<std::pair<double, Kappas>, kCachedKappas> kappas;
        // The κ for `key`, made by `make` unless cached.
        Kappas cached_kappas(double key, const std::function<Kappas()>& make);

        // Whether one of the cube's children is not resident under `resident` (a flag per cube).
        bool lacks_a_child(const std::vector<uint8_t>& resident, uint32_t cube) const;
        // Throws std::invalid_argument as HlodModel::set_residency does.
        void set_residency(std::vector<uint8_t> resident);
        // Streamed: takes in what the cache loaded or evicted since the last call.
        void sync(const StreamCache& cache, uint32_t source);
        // Streamed: takes in the cubes that came in or left (StreamSource::residency_changed), in time
        // proportional to the changes; a tree that has not synced yet takes it all.
        void take_changes(const StreamCache& cache, uint32_t source, const std::vector<uint32_t>& cubes, uint64_t version);
        // What its per-cube tables hold in CPU memory (the cubes' data aside).
        uint64_t table_bytes() const;
        // Where the model lies on the Earth, when it has a CRS; a terrain's heights, when it keeps them.
        std::shared_ptr<const Georeference> georeference;
        std::shared_ptr<const TerrainHeights> heights;
        std::shared_ptr<const CubeTextures> textures;  // section TXTR
        uint64_t texture_bytes() const;                // HlodModel::texture_bytes
    };

public:
    // Reads and decodes every cube (checksums checked); throws std::runtime_error naming the file.
    static std::shared_ptr<HlodModel> load(const std::filesystem::path& path);
    // Opens a model for streaming (DESIGN.md §7): reads the header and the node table only. Cubes load
    // on the cache's threads as views ask for them (cull() asks for the children a stand-in lacks),
    // each with its parent; meanwhile stand-ins draw (set_residency). The coarse levels whose cubes fit
    // in 5 % of the budget together stay resident, chosen again when the budget changes. Throws
    // std::runtime_error naming the file.
    static std::shared_ptr<HlodModel> open(const std::filesystem::path& path,
                                           std::shared_ptr<StreamCache> cache = StreamCache::shared());
    ~HlodModel() override;
    // Streamed: takes in what the cache loaded or evicted since the last call (the cubes' data and
    // set_residency) for every model on the file; cull() calls it. Render thread.
    void sync_residency();
    // What a cube takes once resident, in CPU and GPU memory together: a bound from the node table's
    // counts and its texture's bytes (texture_bytes()), and the exact figure for decoded data. The
    // streaming budget counts these.
    static uint64_t cube_bytes_bound(const HlodHeader& header, const HlodNode& node, uint64_t texture_bytes);
    static uint64_t cube_bytes(const CubeData& data);
    // Of those, what it takes on the GPU: a bound from the node table, and exactly once decoded.
    static uint64_t cube_gpu_bytes_bound(const HlodHeader& header, const HlodNode& node, uint64_t texture_bytes);
    static uint64_t cube_gpu_bytes(const CubeData& data);
    // The textures every cube carries (section TXTR): null for an untextured model.
    const CubeTextures* textures() const { return tree_->textures.get(); }
    // The bytes of one cube's texture, decoded (its BC1 mip chain); 0 for an untextured model.
    uint64_t texture_bytes() const;
    // What the GPU side keeps per cube beside the cubes' blocks (hlod_model_draw.cpp), in CPU and GPU
    // memory together and the GPU's share of that: once for all the models drawing one owner's cubes
    // (cube_owner), and once per model.
    struct TableBytes {
        uint64_t bytes = 0, gpu_bytes = 0;
    };
    static TableBytes gpu_tables_per_owner(uint64_t cubes);
    static TableBytes gpu_tables_per_model(uint64_t cubes);
    // What a cube's block in the GPU pool takes (hlod_model_draw.cpp lays it out).
    static uint64_t gpu_block_bytes(uint64_t vertices, uint64_t parents, uint64_t indices, bool colors);
    // The cache a streamed model loads through; null for a model loaded whole.
    const StreamCache* stream_cache() const { return stream_ ? &stream_->cache : nullptr; }
    // What this model's cube data belongs to: models with the same owner hold the very same cubes and
    // residency (models opened on one file through one cache share one copy of each cube, counted once
    // in the budget), so the GPU keeps one block per cube for all of them. A model loaded whole owns
    // its own.
    std::shared_ptr<const void> cube_owner() const;

    const HlodHeader& header() const { return tree_->header; }
    // Where the model lies on the Earth (model coordinates to its CRS and to longitude and latitude);
    // null when it has no CRS.
    const Georeference* georeference() const { return tree_->georeference.get(); }
    // A terrain's ground height at model (x, y): the raster's value (exact at sample centres, bilinear
    // between them in the raster's grid), read from the model's heights whether cubes are resident or
    // not. Nothing outside the raster or on nodata. Throws std::runtime_error when the model keeps no
    // heights (not a terrain, or built before they were kept) or their bytes are corrupt.
    std::optional<double> height_at(double x, double y) const;
    const std::vector<HlodCube>& cubes() const { return tree_->cubes; }
    uint32_t root() const { return tree_->root; }
    const std::filesystem::path& path() const { return path_; }

    // One κ0 for every cube, or a target screen-space error in pixels, which sets κ per cube and per
    // view from the cubes' error bounds (nodes/README.md, "Selection"). Either keeps every
    // κ ≥ 1 + 3σ0 + 0.25 (DESIGN.md §3).
    void set_kappa0(double kappa0);
    void set_pixel_error(double pixels);
    double pixel_error() const { return pixel_error_; }  // 0 when κ0 was set instead
    double kappa0() const { return kappa0_; }             // as set (and clamped) by set_kappa0
    // κ for a camera: the uniform κ0, or what the pixel error needs for its image and field of view
    // (computed once per image size, field of view and pixel error, then shared).
    Kappas kappas_for(const Camera& camera) const;
    // The same κ for every cube, as set_kappa0 gives (without its clamp).
    Kappas uniform_kappas(double kappa) const;
    double min_kappa0() const { return 1.0 + 3.0 * header().sigma0 + 0.25; }
    // ε_l: the largest error bound of level l's cubes over their size.
    double level_error(uint32_t level) const { return tree_->level_error[level]; }
    // Which cubes' data is at hand (DESIGN.md §7, nodes/README.md "Stand-ins"): every cube once loaded
    // whole. A cube is resident only with its parent. A resident cube that is not suitable but lacks a
    // child stands in for its whole sibling group; the selection caps the cubes around such a
    // stand-in, level by level, so that drawn neighbours still differ by at most one level, and gives
    // the capped cubes a band end of 0 so that the cut stays watertight. set_residency throws
    // std::invalid_argument on a resident cube whose parent is not, or a list of the wrong length.
    void set_residency(std::vector<uint8_t> resident);
    bool resident(uint32_t cube) const { return tree_->resident[cube] != 0; }
    uint64_t residency_version() const { return tree_->residency_version; }  // counts changes of residency, for every model on the tree
    // Interactive frames: per cube, 1 once settled; 0 while capped; then 1/kFadeFrames more
    // each frame, so that children that arrive late (and cubes no longer held back) fade in
    // (nodes/README.md, "Stand-ins"). cull() advances it; full-detail frames ignore it.
    const std::vector<float>& fade() const { return fade_; }
    static constexpr int kFadeFrames = 4;
    // The cube's neighbours of its own level, the 3 × 3 × 3 around it (itself in the middle) at
    // (di + 1) + 3(dj + 1) + 9(dk + 1), kNoCube where there is none; and its parent (kNoCube: the root).
    const std::array<uint32_t, 27>& neighbours(uint32_t cube) const { return tree_->neighbours[cube]; }
    uint32_t parent(uint32_t cube) const { return tree_->parent[cube]; }

    // What the owner of a model sees of each of its views and may hide in them (a terrain hides the
    // cells under the meshes embedded in it: nodes/terrain.h). cull() and picking call the hook with the
    // view's selection and the κ it morphs with; it returns, for each cube whose triangles it hides, the
    // runs of the cube's index list drawn instead ({first index, index count}), or null to draw every
    // cube whole.
    using CubeRuns = std::unordered_map<uint32_t, std::vector<std::array<uint32_t, 2>>>;
    using SelectionHook = std::function<std::shared_ptr<const CubeRuns>(std::span<const uint32_t> selection, const Kappas& morph)>;
    void set_selection_hook(SelectionHook hook) { hook_ = std::move(hook); }
    // What a draw item of the model carries: the κ it morphs with and the runs the hook gave.
    struct DrawState {
        Kappas morph;
        std::shared_ptr<const CubeRuns> runs;
    };

    bool morph() const { return morph_; }
    void set_morph(bool on) { morph_ = on; }
    HlodDebugView debug_view() const { return debug_view_; }
    void set_debug_view(HlodDebugView view) { debug_view_ = view; }
    bool show_cube_boxes() const { return show_boxes_; }
    void set_show_cube_boxes(bool on) { show_boxes_ = on; }

    // The node's frame is the scan's own coordinates; the lattice frame is those minus O, which keeps
    // decoded floats small (survey coordinates would lose millimetres in float).
    glm::dmat4 lattice_to_node() const;
    glm::dvec3 origin() const { return {header().origin[0], header().origin[1], header().origin[2]}; }

    // What a selection rests on beside the cubes it draws: the cubes it capped, and every cube it
    // asked about (drawn, refined, or asked whether it caps a neighbour, which may lie outside the
    // frustum), whose residency decides what it draws.
    struct SelectionBasis {
        std::vector<uint32_t> capped, examined;
    };
    // The coarsest suitable cubes (DESIGN.md §3) that meet the frustum, front to back, and the stand-ins
    // for cubes not resident. `morph`, if given, receives the κ to morph them with: view.kappa, with the
    // band ends of the cubes the view caps set to 0 (the same pointer when it caps none).
    // `basis`, if given, receives what the selection rests on.
    void select(const HlodView& view, std::vector<uint32_t>& out, Kappas* morph = nullptr, SelectionBasis* basis = nullptr) const;
    // A cube's cell in the lattice frame.
    Box cell(const HlodNode& node) const;
    // The box around everything a cube draws, morphed or not: its cell grown by 1.5·σ0·s_l (the
    // vertices' overhang plus the morph's travel). Selection culls against it; picking tests rays on it.
    Box cull_box(const HlodNode& node) const;

    // Where drawn positions are measured from (issue 17: no float32 jitter on a terrain 1 000 km wide):
    // a point E at the eye, in the lattice frame. A is E in whole steps of level 0's lattice, and
    // rest = A·h_0 − E (at most half of h_0 = 2^-15·s_0); a vertex at steps q of level l is drawn at
    // (q − 2^l·A)·h_l + rest from E, exact in float within 2^24 steps of the eye however far the eye is
    // from the model's origin. One A for all levels (h_l = 2^-l·h_0 exactly) keeps a vertex that two
    // levels share at the same bits in both, so that levels still meet without cracks. The shader and
    // the CPU twin both compute so; the transform to the screen adds E back in double.
    struct LatticeAnchor {
        glm::dvec3 origin{0.0};  // E, lattice frame
        glm::vec3 eye{0.0f};     // the eye, from E
        glm::ivec3 steps{0};     // A, level 0's steps
        glm::vec3 rest{0.0f};
    };
    // The anchor for an eye at `eye` in the lattice frame (E there too, as the renderer has it; or E at
    // `origin`, so that views from two eyes can be compared in one frame), or at `eye_world` seen through
    // `world_from_node`.
    LatticeAnchor anchor_at(const glm::dvec3& eye) const { return anchor_at(eye, eye); }
    LatticeAnchor anchor_at(const glm::dvec3& eye, const glm::dvec3& origin) const;
    LatticeAnchor anchor_for(const glm::dmat4& world_from_node, const glm::dvec3& eye_world) const;
    // A point at lattice steps `q` of `level`, from the anchor's E, as the shader computes it.
    glm::vec3 anchored_position(uint32_t level, const glm::ivec3& q, const LatticeAnchor& anchor) const;
    // The CPU twin of the morph shader: the positions a cube's vertices are drawn at in a perspective
    // view, from the anchor's E (anchor_for(), kappas_for()), bit-identical to the shader's arithmetic.
    void morphed_positions(uint32_t cube, const LatticeAnchor& anchor, const CubeKappas& kappa, std::vector<glm::vec3>& out) const;
    // A cube's vertex decoded, unmorphed, in the lattice frame: q·h_l, the float operations of
    // decode_coordinate less the origin (kept in the node's matrix instead).
    glm::vec3 vertex_position(const HlodCube& cube, uint32_t v) const;
    // A vertex's coordinates on its level's lattice, counted from O in steps h_l (DESIGN.md §2), and
    // an entry of its parent table's on the parent level's (the root's own at level 0).
    glm::ivec3 lattice_steps(const HlodCube& cube, uint32_t v) const;
    glm::ivec3 parent_lattice_steps(const HlodCube& cube, uint32_t p) const;
    // The morph band of a vertex of `cube` at lattice steps `q` (nodes/README.md, "Selection"): from the
    // largest start of the cubes of its level whose cell, grown by σ0·s_l, holds it, to the smallest end
    // of such cubes of the parent level. A function of the vertex's position alone, so that every cube
    // sharing the vertex morphs it alike.
    struct MorphBand {
        float start, end;
        float fade = 1.0f;  // the least fade of the cubes that set `end`
    };
    MorphBand morph_band(uint32_t cube, const glm::ivec3& q, const CubeKappas& kappa) const;
    // λ at d∞ distance d from the eye: clamp((end − d)·2^−k, 0, 1), 2^k the largest power of two within
    // both the band's span and morph_span_limit, so that the morph happens at the band's far end,
    // where the parent is nearly suitable itself, and the product is exact on CPU and GPU alike
    // (GLSL's division is not correctly rounded); times the band's fade. 1 at the root, which has no
    // parent.
    float morph_lambda(uint32_t cube, const glm::ivec3& q, float d, const CubeKappas& kappa) const;
    // The morph's longest run, kMorphCubes·s_l: a vertex of level l morphs over at most that much of
    // the eye's distance, just before its parent's cube becomes suitable.
    static constexpr double kMorphCubes = 1.0;
    float morph_span_limit(uint32_t level) const { return float(kMorphCubes * header().cube_size(level)); }
    // ⌈σ0·2^15⌉: how far a vertex may lie outside its cell, in steps of its level's lattice.
    int32_t overhang_steps() const;
    // Whether a view morphs at all (an orthographic view draws one level everywhere: nothing to morph).
    bool morphs_for(const Camera& camera) const;
    // The selection's view for `camera` with the eye at `eye` in the node's frame, without culling:
    // cull(), intersect() and measurements (tests/support/fidelity.h) select alike through it.
    HlodView view_for(const Camera& camera, const glm::dvec3& eye) const;
    // What the shader gets for a view, gathered once, and the positions a cube's vertices are drawn at
    // for it (the CPU twin when it morphs, the decoded positions when not): the drawn triangles.
    struct MorphInputs {
        LatticeAnchor anchor;
        Kappas kappa;
        bool morph;
    };
    // `drawn`, if given, receives the view's selection.
    MorphInputs morph_inputs(const PickContext& view, std::vector<uint32_t>* drawn = nullptr) const;
    void drawn_positions(uint32_t cube, const MorphInputs& inputs, std::vector<glm::vec3>& out) const;
    // The same on the GPU, for the vertices `asked` ({cube, vertex}; resident cubes): each morphed by this
    // model's own morph code from its own records, as its vertex shader draws it for `inputs`, and written
    // from the anchor into `out` (vec4s) at its `place`, w = `tag`. An embedding's seams are drawn from
    // these, so a seam vertex is its owner's vertex to the bit (nodes/terrain_draw.cpp).
    struct GpuVertex {
        uint32_t cube, vertex, place;
    };
    void morph_on_gpu(DrawContext& context, const MorphInputs& inputs, std::span<const GpuVertex> asked, const gl::Buffer& out, float tag) const;
    // The level an orthographic camera draws: the coarsest whose error stays within the pixel error
    // (1 pixel when κ0 was set instead).
    int orthographic_level(const Camera& camera) const;

    // Verification of the GPU path: while on, each draw also copies every drawn vertex's morphed
    // lattice-frame position and λ back from the shader, per cube (in the cube's vertex order).
    void set_capture_morph(bool on) { capture_morph_ = on; }
    bool capture_morph() const { return capture_morph_; }
    const std::vector<glm::vec4>* captured_morph(uint32_t cube) const;
    // The κ the captured draw morphed with (its draw item's state).
    const Kappas& captured_kappas() const { return captured_kappas_; }

    void cull(CullVisitor& cull) override;
    void draw(DrawContext& context, const DrawItem& item) override;
    // Against the triangles as drawn for the camera: its selection, morphed as the shader morphs
    // (hlod_model_pick.cpp).
    std::optional<SurfaceHit> intersect(const Ray& ray, const PickContext& context) const override;

protected:
    Box compute_bound() const override { return bound_; }

private:
    HlodModel() = default;
    // Whether the selection draws this cube rather than going down to its children.
    bool suitable(uint32_t cube, const HlodView& view) const;
    // The cubes a view caps (nodes/README.md, "Stand-ins"), found as the selection asks: a cube is
    // capped when it stands in (resident, not suitable, lacking a child) or a neighbour of its parent
    // is capped. Memoized for one view.
    class Capping {
    public:
        Capping(const HlodModel& model, const HlodView& view) : model_(model), view_(view) {}
        bool capped(uint32_t cube);
        // The cubes found capped so far, and all those asked about.
        SelectionBasis basis() const;
        // view.kappa with the band ends of `capped` (basis().capped) set to 0, and the view's fades.
        Kappas morph_kappas(const std::vector<uint32_t>& capped) const;

    private:
        const HlodModel& model_;
        const HlodView& view_;
        std::unordered_map<uint32_t, bool> memo_;
    };
    // Whether the selection draws this cube when it reaches it: capped, or suitable.
    bool drawn_here(uint32_t cube, const HlodView& view, Capping& capping) const;
    // κ per cube from a pixel error's gain (pixels per unit of error at unit distance), nested.
    std::vector<double> kappas_for_gain(double gain) const;
    Kappas make_kappas(std::vector<double> kappa) const;
    void select_from(uint32_t cube, const HlodView& view, Capping& capping, uint8_t mask, std::vector<uint32_t>& out) const;

    std::filesystem::path path_;
    std::shared_ptr<Tree> tree_;
    Box bound_;  // of every level's vertices, in the node's frame
    // Streamed: the cache and this model's source in it, shared by every model open on the same file
    // through the same cache (with the tree).
    class CubeSource;
    struct SharedSource;
    struct Stream {
        std::shared_ptr<const SharedSource> shared;
        StreamCache& cache;
        StreamCache::SourceId source;
        StreamCache::Held tables;  // this model's own per-cube state, counted in the budget
    };
    std::unique_ptr<Stream> stream_;
    // The octree from the node table (links, neighbours, errors), which it takes from the file; cube
    // data is not read.
    static std::shared_ptr<Tree> read_octree(HlodFile& file);
    // Reads what the optional sections give a model: its georeference, a terrain's heights, its textures.
    static void read_optional_sections(Tree& tree, const std::shared_ptr<const HlodFile>& file);
    // Takes `tree` as this model's, named after the file.
    void adopt(std::shared_ptr<Tree> tree, const std::filesystem::path& path);
    // Streamed: asks the cache for the children of every cube the selection rests on (`examined`,
    // SelectionBasis) that stands in, drawn or not: one outside the frustum caps the drawn cubes
    // beside it. The children of drawn stand-ins come first. For an interactive frame these are
    // requests, and what it draws is marked used; a full-detail frame marks everything it rests on,
    // so that loading what it waits for never evicts what it needs; a view to come prefetches.
    // Returns how many stand in.
    enum class Ask { interactive, full_detail, prefetch };
    uint64_t request_refinement(const HlodView& view, const std::vector<uint32_t>& drawn, const std::vector<uint32_t>& examined,
                                Ask ask) const;
    // Streamed: prefetches what a coming view's selection lacks (one level a frame, as for the view).
    void prefetch_for(const Lookahead& ahead, const glm::dmat4& world_from_node) const;
    std::vector<float> fade_;                            // per cube, see fade()
    std::vector<uint32_t> fading_;                       // the cubes whose fade is below 1
    // Ends an interactive frame's fades: the cubes capped in it to 0, the others fading a step on.
    void advance_fades(const std::vector<uint32_t>& capped);
    double kappa0_ = 2.0;
    double pixel_error_ = 0;  // > 0: κ0 follows from it per view
    bool morph_ = true;
    HlodDebugView debug_view_ = HlodDebugView::none;
    bool show_boxes_ = false;
    std::vector<uint32_t> selection_;  // scratch for cull(); a draw item's state is a DrawState
    SelectionHook hook_;
    bool capture_morph_ = false;
    std::unordered_map<uint32_t, std::vector<glm::vec4>> captured_;  // filled by draw() while capturing
    Kappas captured_kappas_;
};

}  // namespace strata

// The HLOD model as a scene-graph node (DESIGN.md §3): loads a .hlod, selects the coarsest suitable
// cubes for the eye in the node's own frame, culls cubes against the frustum, and morphs each vertex
// toward its parent. The CPU twin of the morph (morphed_positions) computes exactly what the shader
// draws, for the crack check, picking and measurements.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <unordered_map>
#include <vector>

#include <glm/glm.hpp>

#include "engine/scene/camera.h"
#include "engine/scene/drawable.h"
#include "engine/scene/frustum.h"
#include "preprocess/hlod_format.h"

namespace strata {

// Colour-by-level and the like: what the shader shows instead of (or over) the shaded surface.
enum class HlodDebugView { none, levels, wireframe };

struct HlodCube {
    HlodNode node;
    CubeData data;
    std::array<uint32_t, 8> children;  // cube index per octant, or kNoCube
};

inline constexpr uint32_t kNoCube = ~0u;
inline constexpr uint32_t kMaxHlodLevels = 16;  // the format allows levels 0 … 15

// κ_l, the selection's distance factor per level: a cube of level l is suitable when d∞(eye, cell) ≥
// κ_l·s_l (nodes/README.md, "Selection"). A single number stands for the same κ at every level.
struct LevelKappas {
    std::array<double, kMaxHlodLevels> value{};
    LevelKappas() = default;
    LevelKappas(double uniform) { value.fill(uniform); }  // NOLINT: a number is a uniform κ
    double operator[](uint32_t level) const { return value[level]; }
};

// Where and how one selection looks, in the model's lattice frame (model units, origin at O).
struct HlodView {
    glm::dvec3 eye;
    LevelKappas kappa;
    const Frustum* frustum = nullptr;  // nullptr: no culling
    uint8_t plane_mask = kAllPlanes;
    // ≥ 0: every cube of this level (or the finest there is) instead of the distance rule: what an
    // orthographic view needs, whose pixels have one size at any distance.
    int fixed_level = -1;
};

class HlodModel : public Drawable {
public:
    // Reads and decodes every cube (checksums checked); throws std::runtime_error naming the file.
    static std::shared_ptr<HlodModel> load(const std::filesystem::path& path);

    const HlodHeader& header() const { return header_; }
    const std::vector<HlodCube>& cubes() const { return cubes_; }
    uint32_t root() const { return root_; }
    const std::filesystem::path& path() const { return path_; }

    // One κ0 for every level, or a target screen-space error in pixels, which sets κ_l per level and
    // per view from the levels' error bounds (nodes/README.md, "Selection"). Either keeps every
    // κ_l ≥ 1 + 3σ0 + 0.25 (DESIGN.md §3).
    void set_kappa0(double kappa0);
    void set_pixel_error(double pixels);
    double pixel_error() const { return pixel_error_; }  // 0 when κ0 was set instead
    double kappa0() const { return kappa0_; }             // as set (and clamped) by set_kappa0
    // κ_l for a camera: the uniform κ0, or what the pixel error needs for its image and field of view.
    LevelKappas kappas_for(const Camera& camera) const;
    double min_kappa0() const { return 1.0 + 3.0 * header_.sigma0 + 0.25; }
    // ε_l: the largest error bound of level l's cubes over their size.
    double level_error(uint32_t level) const { return level_error_[level]; }

    bool morph() const { return morph_; }
    void set_morph(bool on) { morph_ = on; }
    HlodDebugView debug_view() const { return debug_view_; }
    void set_debug_view(HlodDebugView view) { debug_view_ = view; }
    bool show_cube_boxes() const { return show_boxes_; }
    void set_show_cube_boxes(bool on) { show_boxes_ = on; }

    // The node's frame is the scan's own coordinates; the lattice frame is those minus O, which keeps
    // decoded floats small (survey coordinates would lose millimetres in float).
    glm::dmat4 lattice_to_node() const;
    glm::dvec3 origin() const { return {header_.origin[0], header_.origin[1], header_.origin[2]}; }

    // The coarsest suitable cubes (DESIGN.md §3) that meet the frustum, front to back.
    void select(const HlodView& view, std::vector<uint32_t>& out) const;
    // A cube's cell in the lattice frame.
    Box cell(const HlodNode& node) const;
    // The box around everything a cube draws, morphed or not: its cell grown by 1.5·σ0·s_l (the
    // vertices' overhang plus the morph's travel). Selection culls against it; picking tests rays on it.
    Box cull_box(const HlodNode& node) const;

    // The CPU twin of the morph shader: the positions a cube's vertices are drawn at in a perspective
    // view, for shader_eye() and kappas_for(), bit-identical to the shader's arithmetic.
    void morphed_positions(uint32_t cube, const glm::vec3& eye, const LevelKappas& kappa, std::vector<glm::vec3>& out) const;
    // Decoded, unmorphed lattice-frame positions of a cube's vertices, and of its parent table.
    glm::vec3 vertex_position(const HlodCube& cube, uint32_t v) const;
    glm::vec3 parent_position(const HlodCube& cube, uint32_t p) const;
    // The morph band of a level: λ = clamp((end − d)·inverse_span, 0, 1), inverse_span = 1/(end − start).
    // A multiplication by the reciprocal, because GLSL's division is not correctly rounded.
    struct MorphBand {
        float start, end, inverse_span;
    };
    // Level l's band runs from (1 + κ_l + σ0)·s_l to (κ_{l−1} − σ0)·s_{l−1}.
    MorphBand morph_band(uint32_t level, const LevelKappas& kappa) const;
    // What the shader gets for a view, so that the CPU twin can be fed exactly the same: the eye in
    // the lattice frame as a float (the bands come from morph_band), and whether it morphs at all (an
    // orthographic view draws one level everywhere: nothing to morph).
    glm::vec3 shader_eye(const glm::dmat4& world_from_node, const glm::dvec3& eye_world) const;
    bool morphs_for(const Camera& camera) const;
    // The selection's view for `camera` with the eye at `eye` in the node's frame, without culling:
    // cull(), intersect() and measurements (tests/support/fidelity.h) select alike through it.
    HlodView view_for(const Camera& camera, const glm::dvec3& eye) const;
    // What the shader gets for a view, gathered once, and the positions a cube's vertices are drawn at
    // for it (the CPU twin when it morphs, the decoded positions when not): the drawn triangles.
    struct MorphInputs {
        glm::vec3 eye;
        LevelKappas kappa;
        bool morph;
    };
    MorphInputs morph_inputs(const PickContext& view) const;
    void drawn_positions(uint32_t cube, const MorphInputs& inputs, std::vector<glm::vec3>& out) const;
    // The level an orthographic camera draws: the coarsest whose error stays within the pixel error
    // (1 pixel when κ0 was set instead).
    int orthographic_level(const Camera& camera) const;

    // Verification of the GPU path: while on, each draw also copies every drawn vertex's morphed
    // lattice-frame position and λ back from the shader, per cube (in the cube's vertex order).
    void set_capture_morph(bool on) { capture_morph_ = on; }
    bool capture_morph() const { return capture_morph_; }
    const std::vector<glm::vec4>* captured_morph(uint32_t cube) const;

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
    bool suitable(const HlodNode& node, const HlodView& view) const;
    void select_from(uint32_t cube, const HlodView& view, uint8_t mask, std::vector<uint32_t>& out) const;

    std::filesystem::path path_;
    HlodHeader header_;
    std::vector<HlodCube> cubes_;
    uint32_t root_ = 0;
    Box bound_;  // of every level's vertices, in the node's frame
    std::vector<double> level_error_;  // ε_l
    double kappa0_ = 2.0;
    double pixel_error_ = 0;  // > 0: κ0 follows from it per view
    bool morph_ = true;
    HlodDebugView debug_view_ = HlodDebugView::none;
    bool show_boxes_ = false;
    std::vector<uint32_t> selection_;  // scratch for cull()
    bool capture_morph_ = false;
    std::unordered_map<uint32_t, std::vector<glm::vec4>> captured_;  // filled by draw() while capturing
};

}  // namespace strata

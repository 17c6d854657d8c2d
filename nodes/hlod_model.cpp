#include "nodes/hlod_model.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/scene/cull_visitor.h"

namespace strata {

namespace {

uint32_t octant_of(const HlodNode& child) { return (child.i & 1) | (child.j & 1) << 1 | (child.k & 1) << 2; }

// The lattice-frame coordinate of a stored value: q·h_l with q = stored + 2^15·cell − 2^14. The same
// float operations as decode_coordinate, less the origin (kept in the node's matrix instead).
float lattice_coordinate(const HlodHeader& h, uint32_t level, uint32_t cell, uint16_t stored) {
    const int32_t q = int32_t(stored) + int32_t(cell << kLatticeBits) - kLatticeBias;
    return float(q) * h.lattice_step(level);
}

// d∞ from a point to a box: 0 inside.
double box_distance(const glm::dvec3& p, const Box& box) {
    const glm::dvec3 outside = glm::max(glm::max(box.lo - p, p - box.hi), glm::dvec3(0.0));
    return std::max({outside.x, outside.y, outside.z});
}

}  // namespace

std::shared_ptr<HlodModel> HlodModel::load(const std::filesystem::path& path) {
    HlodFile file(path);
    std::shared_ptr<HlodModel> model(new HlodModel());
    model->path_ = path;
    model->header_ = file.header();
    model->set_name(path.stem().string());
    model->set_kappa0(2.0);  // the default, raised to what this model's σ0 needs for its morph
    const auto& nodes = file.nodes();
    if (nodes.empty()) throw std::runtime_error(path.string() + ": the model has no cubes");

    // Octree links: each cube finds its children by (level, i, j, k).
    std::map<std::array<uint32_t, 4>, uint32_t> index;
    model->cubes_.resize(nodes.size());
    for (uint32_t c = 0; c < nodes.size(); ++c) {
        HlodCube& cube = model->cubes_[c];
        cube.node = nodes[c];
        cube.children.fill(kNoCube);
        index[{nodes[c].level, nodes[c].i, nodes[c].j, nodes[c].k}] = c;
    }
    if (!index.count({0, 0, 0, 0})) throw std::runtime_error(path.string() + ": the model has no root cube");
    for (uint32_t c = 0; c < nodes.size(); ++c) {
        const HlodNode& n = nodes[c];
        if (n.level == 0) continue;
        auto parent = index.find({n.level - 1, n.i / 2, n.j / 2, n.k / 2});
        if (parent == index.end())
            throw std::runtime_error(path.string() + ": " + describe_cube(n) + " has no parent cube");
        model->cubes_[parent->second].children[octant_of(n)] = c;
    }
    model->root_ = index[{0, 0, 0, 0}];

    // Coarse to fine, so each cube finds its parents' vertices already decoded.
    std::vector<uint32_t> order(nodes.size());
    for (uint32_t c = 0; c < nodes.size(); ++c) order[c] = c;
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return nodes[a].level < nodes[b].level; });
    for (uint32_t c : order) {
        HlodCube& cube = model->cubes_[c];
        cube.data = file.read_cube(cube.node);
        const HlodNode& n = cube.node;
        const CubeData& parent =
            n.level == 0 ? cube.data : model->cubes_[index.at({n.level - 1, n.i / 2, n.j / 2, n.k / 2})].data;
        resolve_parents(cube.data, parent.vertices, path.string() + ": " + describe_cube(n));
    }
    model->level_error_.assign(model->header_.max_level + 1, 0.0);
    for (const HlodNode& n : nodes) {
        double& worst = model->level_error_[n.level];
        worst = std::max(worst, double(n.error) / model->header_.cube_size(n.level));
    }
    for (HlodCube& cube : model->cubes_) {
        for (uint32_t v = 0; v < cube.data.vertex_count(); ++v) {
            const glm::vec3 p = model->vertex_position(cube, v);
            model->bound_.expand(glm::dvec3(p) + model->origin());
        }
    }
    return model;
}

void HlodModel::set_kappa0(double kappa0) {
    if (!(kappa0 > 0)) throw std::invalid_argument("κ0 must be positive");
    kappa0_ = std::max(kappa0, min_kappa0());
    pixel_error_ = 0;
}

void HlodModel::set_pixel_error(double pixels) {
    if (!(pixels > 0)) throw std::invalid_argument("the pixel error must be positive");
    pixel_error_ = pixels;
}

LevelKappas HlodModel::kappas_for(const Camera& camera) const {
    if (pixel_error_ <= 0 || camera.projection != ProjectionKind::perspective) return LevelKappas(kappa0_);
    // Pixels per unit of error at unit distance, over P, at the image's corner: the projection's
    // largest magnification at a point r away and θ off the axis is (f/r)/cos²θ, and inside the image
    // 1/cos²θ ≤ 1 + tan²(θx/2) + tan²(θy/2).
    const double tx = camera.tan_half_fov_x(), ty = std::tan(glm::radians(camera.fov_y_degrees) / 2);
    const double focal = camera.width / (2 * tx);
    const double gain = 1 + focal * (1 + tx * tx + ty * ty) / pixel_error_;  // the 1: the error's own extent
    const double sigma0 = header_.sigma0;
    LevelKappas kappa;
    for (uint32_t l = 0; l <= header_.max_level; ++l) {
        // A cube draws within 1.5·σ0·s_l of its cell (the vertices' overhang, then the morph's travel),
        // so its nearest drawn point is (κ_l − 1.5σ0)·s_l away; where its vertices morph, farther than
        // (1 + κ_l + σ0)·s_l, the parent level's bound (2ε_{l−1}·s_l) must hold too.
        double need = 1.5 * sigma0 + level_error_[l] * gain;
        if (l > 0) need = std::max(need, 2 * level_error_[l - 1] * gain - 1 - sigma0);
        kappa.value[l] = std::max(need, min_kappa0());
    }
    // Nesting (nodes/README.md): κ_l ≤ 2κ_{l−1} − 1 − 3σ0 − 0.25 keeps each morph band a quarter cube
    // wide and neighbours within a level; raising a coarser κ keeps its promise.
    for (uint32_t l = header_.max_level; l > 0; --l)
        kappa.value[l - 1] = std::max(kappa.value[l - 1], (kappa.value[l] + 1.25 + 3 * sigma0) / 2);
    return kappa;
}

glm::dmat4 HlodModel::lattice_to_node() const { return glm::translate(glm::dmat4(1.0), origin()); }

Box HlodModel::cell(const HlodNode& node) const {
    const double s = header_.cube_size(node.level);
    const glm::dvec3 lo = glm::dvec3(node.i, node.j, node.k) * s;
    return Box::from(lo, lo + glm::dvec3(s));
}

Box HlodModel::cull_box(const HlodNode& node) const {
    const Box cell_box = cell(node);
    const glm::dvec3 grow(1.5 * header_.sigma0 * header_.cube_size(node.level));
    return Box::from(cell_box.lo - grow, cell_box.hi + grow);
}

HlodView HlodModel::view_for(const Camera& camera, const glm::dvec3& eye) const {
    HlodView view{eye - origin(), kappas_for(camera)};
    if (camera.projection == ProjectionKind::orthographic) view.fixed_level = orthographic_level(camera);
    return view;
}

bool HlodModel::suitable(const HlodNode& node, const HlodView& view) const {
    if (node.level == header_.max_level) return true;
    if (view.fixed_level >= 0) return int(node.level) >= view.fixed_level;
    return box_distance(view.eye, cell(node)) >= view.kappa[node.level] * header_.cube_size(node.level);
}

void HlodModel::select(const HlodView& view, std::vector<uint32_t>& out) const {
    out.clear();
    select_from(root_, view, view.plane_mask, out);
}

void HlodModel::select_from(uint32_t c, const HlodView& view, uint8_t mask, std::vector<uint32_t>& out) const {
    const HlodCube& cube = cubes_[c];
    if (view.frustum && mask && !intersects(*view.frustum, cull_box(cube.node), mask)) return;
    if (suitable(cube.node, view)) {
        out.push_back(c);
        return;
    }
    // Front to back: the octant on the eye's side of the centre first, then the rest in an order in
    // which no octant comes before one that could hide it.
    const glm::dvec3 centre = cell(cube.node).center();
    const uint32_t near = (view.eye.x >= centre.x) | (view.eye.y >= centre.y) << 1 | (view.eye.z >= centre.z) << 2;
    for (uint32_t k = 0; k < 8; ++k) {
        const uint32_t child = cube.children[near ^ k];
        if (child != kNoCube) select_from(child, view, mask, out);
    }
}

glm::vec3 HlodModel::vertex_position(const HlodCube& cube, uint32_t v) const {
    const uint16_t* q = &cube.data.vertices.positions[3 * size_t(v)];
    const HlodNode& n = cube.node;
    return {lattice_coordinate(header_, n.level, n.i, q[0]), lattice_coordinate(header_, n.level, n.j, q[1]),
            lattice_coordinate(header_, n.level, n.k, q[2])};
}

glm::vec3 HlodModel::parent_position(const HlodCube& cube, uint32_t p) const {
    const uint16_t* q = &cube.data.parents.positions[3 * size_t(p)];
    const HlodNode& n = cube.node;
    // At level 0 the table is the root's own vertices: decode it on the root's lattice (cell 0 / 2 = 0).
    const uint32_t level = n.level == 0 ? 0 : n.level - 1;
    return {lattice_coordinate(header_, level, n.i / 2, q[0]), lattice_coordinate(header_, level, n.j / 2, q[1]),
            lattice_coordinate(header_, level, n.k / 2, q[2])};
}

HlodModel::MorphBand HlodModel::morph_band(uint32_t level, const LevelKappas& kappa) const {
    const double s = header_.cube_size(level), sigma0 = header_.sigma0;
    const double parent_kappa = kappa[level == 0 ? 0 : level - 1];  // the root morphs onto itself
    const float start = float((1.0 + kappa[level] + sigma0) * s), end = float((parent_kappa - sigma0) * 2.0 * s);
    return {start, end, 1.0f / (end - start)};
}

void HlodModel::morphed_positions(uint32_t c, const glm::vec3& eye, const LevelKappas& kappa, std::vector<glm::vec3>& out) const {
    const HlodCube& cube = cubes_[c];
    const MorphBand band = morph_band(cube.node.level, kappa);
    out.resize(cube.data.vertex_count());
    for (uint32_t v = 0; v < out.size(); ++v) {
        const glm::vec3 w = vertex_position(cube, v);
        if (!morph_) {
            out[v] = w;
            continue;
        }
        const glm::vec3 parent = parent_position(cube, cube.data.parent_of[v]);
        const glm::vec3 offset = glm::abs(w - eye);
        const float d = std::max(std::max(offset.x, offset.y), offset.z);
        const float lambda = std::clamp((band.end - d) * band.inverse_span, 0.0f, 1.0f);  // as the shader
        // The ends exactly (Lemma 2 needs λ = 0 to give P(w) and λ = 1 to give w), GLSL's mix between.
        out[v] = lambda >= 1.0f ? w : lambda <= 0.0f ? parent : parent * (1.0f - lambda) + w * lambda;
    }
}

glm::vec3 HlodModel::shader_eye(const glm::dmat4& world_from_node, const glm::dvec3& eye_world) const {
    return glm::vec3(glm::inverse(world_from_node * lattice_to_node()) * glm::dvec4(eye_world, 1.0));
}

bool HlodModel::morphs_for(const Camera& camera) const {
    return morph_ && camera.projection == ProjectionKind::perspective;
}

int HlodModel::orthographic_level(const Camera& camera) const {
    const double pixel = camera.ortho_height / camera.height;  // model units per pixel
    const double allowed = (pixel_error_ > 0 ? pixel_error_ : 1.0) * pixel;
    int level = 0;
    while (level < int(header_.max_level) && level_error_[size_t(level)] * header_.cube_size(level) > allowed) ++level;
    return level;
}

const std::vector<glm::vec4>* HlodModel::captured_morph(uint32_t cube) const {
    auto it = captured_.find(cube);
    return it == captured_.end() ? nullptr : &it->second;
}

void HlodModel::cull(CullVisitor& cull) {
    const Frustum frustum = cull.local_frustum().in_child_frame(lattice_to_node());
    HlodView view = view_for(cull.camera(), cull.local_eye());
    if (cull.frustum_culling()) {
        view.frustum = &frustum;
        view.plane_mask = cull.plane_mask();
    }
    select(view, selection_);
    if (!selection_.empty()) cull.add(*this, selection_.data(), uint32_t(selection_.size()));
}

}  // namespace strata

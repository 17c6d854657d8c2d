#include "nodes/hlod_model.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>
#include <unordered_map>
#include <stdexcept>

#include <glm/gtc/matrix_transform.hpp>

#include "engine/scene/cull_visitor.h"
#include "preprocess/cube_textures.h"
#include "preprocess/georeference.h"
#include "preprocess/terrain_heights.h"

namespace strata {

namespace {

uint32_t octant_of(const HlodNode& child) { return (child.i & 1) | (child.j & 1) << 1 | (child.k & 1) << 2; }

// d∞ from a point to a box: 0 inside.
double box_distance(const glm::dvec3& p, const Box& box) {
    const glm::dvec3 outside = glm::max(glm::max(box.lo - p, p - box.hi), glm::dvec3(0.0));
    return std::max({outside.x, outside.y, outside.z});
}

}  // namespace

std::shared_ptr<HlodModel::Tree> HlodModel::read_octree(HlodFile& file) {
    auto tree = std::make_shared<Tree>();
    Tree& t = *tree;
    t.header = file.header();
    const std::vector<HlodNode> nodes = file.take_nodes();
    const std::string name = file.path().string();
    if (nodes.empty()) throw std::runtime_error(name + ": the model has no cubes");

    // Octree links: each cube finds its parent, children and neighbours by (level, i, j, k).
    std::unordered_map<uint64_t, uint32_t> index;
    auto key = [](uint32_t level, uint32_t i, uint32_t j, uint32_t k) {
        return uint64_t(level) << 48 | uint64_t(i) << 32 | uint64_t(j) << 16 | uint64_t(k);
    };
    auto find = [&](uint32_t level, int64_t i, int64_t j, int64_t k) {
        if (i < 0 || j < 0 || k < 0) return kNoCube;
        const auto it = index.find(key(level, uint32_t(i), uint32_t(j), uint32_t(k)));
        return it == index.end() ? kNoCube : it->second;
    };
    t.cubes.resize(nodes.size());
    for (uint32_t c = 0; c < nodes.size(); ++c) {
        HlodCube& cube = t.cubes[c];
        cube.node = nodes[c];
        cube.children.fill(kNoCube);
        index[key(nodes[c].level, nodes[c].i, nodes[c].j, nodes[c].k)] = c;
    }
    if (find(0, 0, 0, 0) == kNoCube) throw std::runtime_error(name + ": the model has no root cube");
    t.parent.assign(nodes.size(), kNoCube);
    t.neighbours.resize(nodes.size());
    for (uint32_t c = 0; c < nodes.size(); ++c) {
        const HlodNode& n = nodes[c];
        for (int d = 0; d < 27; ++d)
            t.neighbours[c][d] = find(n.level, int64_t(n.i) + d % 3 - 1, int64_t(n.j) + d / 3 % 3 - 1, int64_t(n.k) + d / 9 - 1);
        if (n.level == 0) continue;
        const uint32_t parent = find(n.level - 1, n.i / 2, n.j / 2, n.k / 2);
        if (parent == kNoCube) throw std::runtime_error(name + ": " + describe_cube(n) + " has no parent cube");
        t.cubes[parent].children[octant_of(n)] = c;
        t.parent[c] = parent;
    }
    t.root = find(0, 0, 0, 0);
    t.finest_first.resize(nodes.size());
    for (uint32_t c = 0; c < nodes.size(); ++c) t.finest_first[c] = c;
    std::stable_sort(t.finest_first.begin(), t.finest_first.end(), [&](uint32_t a, uint32_t b) { return nodes[a].level > nodes[b].level; });
    t.resident.assign(nodes.size(), 0);
    t.lacks_child.assign(nodes.size(), 0);
    t.level_error.assign(t.header.max_level + 1, 0.0);
    for (const HlodNode& n : nodes) {
        double& worst = t.level_error[n.level];
        worst = std::max(worst, double(n.error) / t.header.cube_size(n.level));
    }
    return tree;
}

uint64_t HlodModel::Tree::table_bytes() const {
    auto held = [](const auto& v) { return uint64_t(v.capacity()) * sizeof(v[0]); };
    return held(cubes) + held(level_error) + held(neighbours) + held(parent) + held(finest_first) + held(resident) + held(lacks_child) +
           (textures ? textures->index_bytes() : 0);
}

void HlodModel::adopt(std::shared_ptr<Tree> tree, const std::filesystem::path& path) {
    tree_ = std::move(tree);
    path_ = path;
    set_name(path_.stem().string());
    set_kappa0(2.0);  // the default, raised to what this model's σ0 needs for its morph
    fade_.assign(tree_->cubes.size(), 1.0f);
}

void HlodModel::read_optional_sections(Tree& tree, const std::shared_ptr<const HlodFile>& file) {
    if (!tree.header.crs.empty()) tree.georeference = std::make_shared<Georeference>(tree.header, file->path().string());
    if (const HlodSection* heights = file->find_section(kHeightsTag); heights && tree.header.terrain)
        tree.heights = std::make_shared<TerrainHeights>(file, *heights);
    if (const HlodSection* textures = file->find_section(kTexturesTag))
        tree.textures = std::make_shared<CubeTextures>(file, *textures, tree.cubes.size());
}

uint64_t HlodModel::Tree::texture_bytes() const { return textures ? textures->layout().chain_bytes() : 0; }

uint64_t HlodModel::texture_bytes() const { return tree_->texture_bytes(); }

std::optional<double> HlodModel::height_at(double x, double y) const {
    const Georeference* geo = georeference();
    if (!tree_->heights || !geo)
        throw std::runtime_error(path_.string() + (header().terrain ? ": a terrain built before Strata kept heights; rebuild it from its raster"
                                                                      : ": not a terrain built from an elevation raster, so it has no ground heights"));
    if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
    // In the ecef frame the ground point under (x, y) depends on its height: a few rounds settle it,
    // each estimating the height from the grid's nearest part.
    const TerrainHeights& heights = *tree_->heights;
    double estimate = 0;
    const int rounds = header().terrain->frame == uint32_t(TerrainFrameKind::ecef) ? 4 : 1;
    for (int round = 1; round < rounds; ++round) {
        const std::array<double, 2> at = *geo->raster_position(x, y, estimate);
        const double column = std::clamp(at[0], 0.0, double(heights.columns() - 1)), row = std::clamp(at[1], 0.0, double(heights.rows() - 1));
        estimate = heights.at(column, row).value_or(estimate);
    }
    const std::array<double, 2> at = *geo->raster_position(x, y, estimate);
    return heights.at(at[0], at[1]);
}

std::shared_ptr<HlodModel> HlodModel::load(const std::filesystem::path& path) {
    const auto shared_file = std::make_shared<HlodFile>(path);
    HlodFile& file = *shared_file;
    std::shared_ptr<HlodModel> model(new HlodModel());
    std::shared_ptr<Tree> octree = read_octree(file);
    read_optional_sections(*octree, shared_file);
    model->adopt(std::move(octree), file.path());
    Tree& tree = *model->tree_;
    // Coarse to fine, so each cube finds its parents' vertices already decoded.
    for (auto c = tree.finest_first.rbegin(); c != tree.finest_first.rend(); ++c) {
        HlodCube& cube = tree.cubes[*c];
        auto data = std::make_shared<CubeData>(file.read_cube(cube.node));
        if (tree.textures) data->texture = tree.textures->read(*c, cube.node);
        const uint32_t parent = tree.parent[*c];
        resolve_parents(*data, parent == kNoCube ? data->vertices : tree.cubes[parent].data->vertices,
                        path.string() + ": " + describe_cube(cube.node));
        cube.data = std::move(data);
    }
    model->set_residency(std::vector<uint8_t>(tree.cubes.size(), 1));
    for (HlodCube& cube : tree.cubes) {
        for (uint32_t v = 0; v < cube.data->vertex_count(); ++v) {
            const glm::vec3 p = model->vertex_position(cube, v);
            model->bound_.expand(glm::dvec3(p) + model->origin());
        }
    }
    return model;
}

namespace {

// What one CubeKappas of a tree's (Tree::cached_kappas) holds for `cubes` cubes: κ and band ends.
uint64_t kappas_bytes(uint64_t cubes) { return cubes * (sizeof(double) + sizeof(std::array<float, 2>)); }

}  // namespace

// A streamed model's cubes as the cache loads them: read by offset (HlodFile reads are thread-safe),
// checksum checked, decoded, and given their parents' vertices from the parent the cache hands over.
// The nodes and links come from the file's tree (the loader threads read its nodes, which never
// change, while the render thread sets its cubes' data); what the cache loads or evicts, the tree
// takes in at once.
class HlodModel::CubeSource : public StreamSource {
public:
    CubeSource(std::shared_ptr<const HlodFile> file, std::shared_ptr<Tree> tree) : file_(std::move(file)), tree_(std::move(tree)) {}
    // The cache it was added to, as `source`: what residency_changed reads.
    void added_to(const StreamCache& cache, StreamCache::SourceId source) {
        cache_ = &cache;
        source_ = source;
    }
    uint32_t item_count() const override { return uint32_t(tree_->cubes.size()); }
    uint32_t parent(uint32_t cube) const override { return tree_->parent[cube]; }
    uint64_t item_bytes(uint32_t cube) const override { return cube_bytes_bound(tree_->header, tree_->cubes[cube].node, tree_->texture_bytes()); }
    uint64_t item_gpu_bytes(uint32_t cube) const override {
        return cube_gpu_bytes_bound(tree_->header, tree_->cubes[cube].node, tree_->texture_bytes());
    }
    // The coarse levels whose cubes fit in 5 % of the budget together; the root always, since nothing
    // is drawn without it.
    std::vector<uint32_t> pinned_items(uint64_t budget) const override {
        const auto& cubes = tree_->cubes;
        std::vector<uint64_t> level_bytes(tree_->header.max_level + 1, 0);
        for (uint32_t c = 0; c < cubes.size(); ++c) level_bytes[cubes[c].node.level] += item_bytes(c);
        uint64_t pinned = 0;
        uint32_t levels = 0;
        while (levels < level_bytes.size() && pinned + level_bytes[levels] <= budget / 20) pinned += level_bytes[levels++];
        std::vector<uint32_t> chosen;
        for (uint32_t c = 0; c < cubes.size(); ++c)
            if (cubes[c].node.level < std::max(levels, 1u)) chosen.push_back(c);
        return chosen;
    }
    Loaded load(uint32_t cube, const std::shared_ptr<const void>& parent) override {
        const HlodNode& node = tree_->cubes[cube].node;
        auto data = std::make_shared<CubeData>(file_->read_cube(node));
        if (tree_->textures) data->texture = tree_->textures->read(cube, node);
        const auto* parent_data = static_cast<const CubeData*>(parent.get());
        resolve_parents(*data, parent_data ? parent_data->vertices : data->vertices,
                        file_->path().string() + ": " + describe_cube(node));
        for (VertexArrays* arrays : {&data->vertices, &data->parents}) {  // what it holds is what it counts
            arrays->positions.shrink_to_fit(), arrays->normals.shrink_to_fit();
            arrays->colors.shrink_to_fit(), arrays->uvs.shrink_to_fit();
        }
        data->parent_of.shrink_to_fit(), data->parent_vertex.shrink_to_fit(), data->indices.shrink_to_fit();
        const uint64_t bytes = cube_bytes(*data), gpu_bytes = cube_gpu_bytes(*data);
        return {std::shared_ptr<const CubeData>(std::move(data)), bytes, gpu_bytes};
    }
    // Whether a model on the tree is drawn or not: one outside the view would otherwise hold on to
    // the cubes the cache evicted (and their GPU blocks) until a frame next culls it, beyond the budget.
    void residency_changed(const std::vector<uint32_t>& cubes, uint64_t version) override {
        try {
            tree_->take_changes(*cache_, source_, cubes, version);
        } catch (...) {  // out of memory: the cache may not be thrown at; the next cull takes it all in
            tree_->synced = ~uint64_t(0);
        }
    }

private:
    std::shared_ptr<const HlodFile> file_;
    std::shared_ptr<Tree> tree_;
    const StreamCache* cache_ = nullptr;
    StreamCache::SourceId source_ = 0;
};

// A streamed file's source in a cache and the tree its models share, removed with the last model
// that reads it. Models opening a file already open through the same cache (found by the file's
// identity, whatever the path) take the same source and tree: its cubes load once, count once and are
// drawn from one copy, and its per-cube tables are held (and counted in the budget) once.
struct HlodModel::SharedSource {
    std::shared_ptr<StreamCache> cache;
    std::shared_ptr<Tree> tree;
    StreamCache::Held tables;  // the tree (its node table included), two κ and the GPU tables of the cubes
    StreamCache::SourceId source = 0;
    HlodFile::Identity file;
    ~SharedSource() { cache->remove(source); }

    static std::shared_ptr<const SharedSource> find(const StreamCache& cache, const HlodFile::Identity& file) {
        std::lock_guard lock(registry_mutex);
        std::erase_if(registry, [](const auto& weak) { return weak.expired(); });
        for (const auto& weak : registry)
            if (auto shared = weak.lock(); shared && shared->cache.get() == &cache && shared->file == file) return shared;
        return nullptr;
    }
    static std::shared_ptr<const SharedSource> add(const std::shared_ptr<StreamCache>& cache, const std::shared_ptr<const HlodFile>& file,
                                                   std::shared_ptr<Tree> tree) {
        const uint64_t cubes = tree->cubes.size();
        const TableBytes gpu = gpu_tables_per_owner(cubes);
        StreamCache::Held tables = cache->hold(tree->table_bytes() + Tree::kCachedKappas * kappas_bytes(cubes) + gpu.bytes, gpu.gpu_bytes,
                                               file->path().string() + ": the tables of its " + std::to_string(cubes) + " cubes");
        auto cube_source = std::make_shared<CubeSource>(file, tree);
        const StreamCache::SourceId source = cache->add(cube_source);
        cube_source->added_to(*cache, source);
        std::shared_ptr<const SharedSource> shared(new SharedSource{cache, std::move(tree), std::move(tables), source, file->identity()});
        std::lock_guard lock(registry_mutex);
        registry.push_back(shared);
        return shared;
    }

    static inline std::mutex registry_mutex;
    static inline std::vector<std::weak_ptr<const SharedSource>> registry;
};

uint64_t HlodModel::cube_bytes(const CubeData& d) {
    auto held = [](const auto& v) { return uint64_t(v.capacity()) * sizeof(v[0]); };
    auto arrays = [&](const VertexArrays& a) { return held(a.positions) + held(a.normals) + held(a.colors) + held(a.uvs); };
    const uint64_t cpu = arrays(d.vertices) + arrays(d.parents) + held(d.parent_vertex) + held(d.indices) + held(d.parent_of) + held(d.texture);
    return cpu + cube_gpu_bytes(d);
}

uint64_t HlodModel::cube_gpu_bytes(const CubeData& d) {
    // The texture takes a layer of its owner's texture arrays, exactly its BC1 chain's bytes.
    return gpu_block_bytes(d.vertices.size(), d.parents.size(), d.indices.size(), !d.vertices.colors.empty()) + d.texture.size();
}

uint64_t HlodModel::cube_gpu_bytes_bound(const HlodHeader& header, const HlodNode& node, uint64_t texture_bytes) {
    return gpu_block_bytes(node.vertex_count, node.vertex_count, 3 * uint64_t(node.triangle_count), header.has_colors()) + texture_bytes;
}

uint64_t HlodModel::cube_bytes_bound(const HlodHeader& header, const HlodNode& node, uint64_t texture_bytes) {
    // Per vertex, for itself and for its parent's copy (at most one per vertex): positions, normals,
    // colours, UVs; then its parent index and entry, the indices, and the GPU block.
    const uint64_t attributes = 3 * 2 + 2 * 2 + (header.has_colors() ? 4 : 0) + (header.has_uvs() ? 8 : 0);
    const uint64_t cpu = (2 * attributes + 4 + 4) * uint64_t(node.vertex_count) + 3 * 4 * uint64_t(node.triangle_count);
    return cpu + texture_bytes + cube_gpu_bytes_bound(header, node, texture_bytes);
}

std::shared_ptr<HlodModel> HlodModel::open(const std::filesystem::path& path, std::shared_ptr<StreamCache> cache) {
    auto file = std::make_shared<HlodFile>(path);
    std::shared_ptr<const SharedSource> shared = SharedSource::find(*cache, file->identity());
    if (!shared) {  // nothing resident yet
        std::shared_ptr<Tree> tree = read_octree(*file);
        read_optional_sections(*tree, file);
        shared = SharedSource::add(cache, file, std::move(tree));
    }
    std::shared_ptr<HlodModel> model(new HlodModel());
    model->adopt(shared->tree, file->path());
    // The bound, before any cube is read: the input's box (BNDS) grown by the coarsest lattice's
    // rounding, else the finest cubes' cells grown by the vertices' overhang.
    const HlodHeader& h = model->header();
    const uint32_t finest = h.max_level;
    if (h.has_bounds) {
        const glm::dvec3 rounding(h.lattice_step(0));
        model->bound_.expand(glm::dvec3(h.bounds_lo[0], h.bounds_lo[1], h.bounds_lo[2]) - rounding);
        model->bound_.expand(glm::dvec3(h.bounds_hi[0], h.bounds_hi[1], h.bounds_hi[2]) + rounding);
    } else {
        const glm::dvec3 grow(h.sigma0 * h.cube_size(finest));
        for (const HlodCube& cube : model->cubes())
            if (cube.node.level == finest) {
                const Box cell = model->cell(cube.node);
                model->bound_.expand(cell.lo - grow + model->origin());
                model->bound_.expand(cell.hi + grow + model->origin());
            }
    }
    // Its own per-cube state: its fades, and the band ends and fades it morphs with on the GPU (on
    // the CPU, what a frame changes of them follows its stand-ins and fades: CubeKappas::base).
    const uint64_t cubes = model->cubes().size();
    const TableBytes gpu = gpu_tables_per_model(cubes);
    StreamCache::Held tables = cache->hold(uint64_t(model->fade_.capacity()) * sizeof(float) + gpu.bytes,
                                           gpu.gpu_bytes, file->path().string() + ": a model's tables for its " + std::to_string(cubes) + " cubes");
    model->stream_ = std::make_unique<Stream>(Stream{shared, *cache, shared->source, std::move(tables)});
    return model;
}

const char* debug_view_name(HlodDebugView view) {
    static const char* const names[] = {"none", "levels", "wireframe", "residency"};
    return names[int(view)];
}

std::optional<HlodDebugView> debug_view_named(std::string_view name) {
    for (const HlodDebugView view : {HlodDebugView::none, HlodDebugView::levels, HlodDebugView::wireframe, HlodDebugView::residency})
        if (name == debug_view_name(view)) return view;
    return std::nullopt;
}

HlodModel::~HlodModel() = default;

std::shared_ptr<const void> HlodModel::cube_owner() const { return tree_; }

void HlodModel::sync_residency() { tree_->sync(stream_->cache, stream_->source); }

void HlodModel::Tree::sync(const StreamCache& cache, uint32_t source) {
    const uint64_t version = cache.version(source);
    if (version == synced) return;
    synced = version;
    std::vector<uint8_t> now(cubes.size());
    for (uint32_t c = 0; c < cubes.size(); ++c) {
        cubes[c].data = std::static_pointer_cast<const CubeData>(cache.value(source, c));
        now[c] = cubes[c].data != nullptr;
    }
    set_residency(std::move(now));
}

bool HlodModel::Tree::lacks_a_child(const std::vector<uint8_t>& flags, uint32_t cube) const {
    for (const uint32_t child : cubes[cube].children)
        if (child != kNoCube && !flags[child]) return true;
    return false;
}

void HlodModel::Tree::take_changes(const StreamCache& cache, uint32_t source, const std::vector<uint32_t>& changed, uint64_t version) {
    if (synced == ~uint64_t(0)) return sync(cache, source);  // never synced: take it all
    for (const uint32_t c : changed) {
        cubes[c].data = std::static_pointer_cast<const CubeData>(cache.value(source, c));
        resident[c] = cubes[c].data != nullptr;
    }
    for (const uint32_t c : changed)
        for (const uint32_t cube : {c, parent[c]})
            if (cube != kNoCube) lacks_child[cube] = resident[cube] && lacks_a_child(resident, cube);
    synced = version;
    ++residency_version;
}

uint64_t HlodModel::request_refinement(const HlodView& view, const std::vector<uint32_t>& drawn, const std::vector<uint32_t>& examined,
                                       Ask ask) const {
    StreamCache& cache = stream_->cache;
    auto ask_for = [&](uint32_t cube, double priority) {
        if (ask == Ask::prefetch) cache.prefetch(stream_->source, cube, priority);
        else cache.request(stream_->source, cube, priority);
    };
    if (!tree_->resident[tree_->root]) ask_for(tree_->root, INFINITY);
    if (ask != Ask::prefetch)
        for (const uint32_t c : drawn) cache.touch(stream_->source, c);
    std::vector<uint32_t> drawn_sorted = drawn;
    std::sort(drawn_sorted.begin(), drawn_sorted.end());
    uint64_t stand_ins = 0;
    for (const uint32_t c : examined) {
        if (!tree_->resident[c]) continue;
        const bool unsuitable = !suitable(c, view);
        if (ask == Ask::full_detail) {  // an unsuitable cube needs all its children: without one it stands in
            cache.touch(stream_->source, c);
            if (unsuitable)
                for (const uint32_t child : tree_->cubes[c].children)
                    if (child != kNoCube && tree_->resident[child]) cache.touch(stream_->source, child);
        }
        if (!tree_->lacks_child[c] || !unsuitable) continue;
        ++stand_ins;
        // A stand-in closer than its switch distance: the nearer it is, the sooner its children. That
        // ratio is above 1 for an unsuitable cube; below 1 for one not drawn, so that they come after.
        const double s = tree_->header.cube_size(tree_->cubes[c].node.level);
        double priority = (*view.kappa)[c] * s / std::max(box_distance(view.eye, cell(tree_->cubes[c].node)), 1e-6 * s);
        if (!std::binary_search(drawn_sorted.begin(), drawn_sorted.end(), c)) priority /= 1 + priority;
        for (const uint32_t child : tree_->cubes[c].children)
            if (child != kNoCube && !tree_->resident[child]) ask_for(child, priority);
    }
    return stand_ins;
}

void HlodModel::prefetch_for(const Lookahead& ahead, const glm::dmat4& world_from_node) const {
    const glm::dvec3 eye(glm::inverse(world_from_node) * glm::dvec4(ahead.camera->position, 1.0));
    HlodView view = view_for(*ahead.camera, eye);
    const Frustum frustum = Frustum::from_matrix(ahead.clip_from_world * world_from_node * lattice_to_node());
    view.frustum = &frustum;
    std::vector<uint32_t> drawn;
    SelectionBasis basis;
    select(view, drawn, nullptr, &basis);
    request_refinement(view, drawn, basis.examined, Ask::prefetch);
}

void HlodModel::set_residency(std::vector<uint8_t> resident) { tree_->set_residency(std::move(resident)); }

void HlodModel::Tree::set_residency(std::vector<uint8_t> flags) {
    if (flags.size() != cubes.size()) throw std::invalid_argument("residency: one flag per cube is needed");
    std::vector<uint8_t> lacks(cubes.size(), 0);
    for (uint32_t c = 0; c < cubes.size(); ++c) {
        if (flags[c] && parent[c] != kNoCube && !flags[parent[c]])
            throw std::invalid_argument("residency: " + describe_cube(cubes[c].node) + " is resident without its parent");
        lacks[c] = flags[c] && lacks_a_child(flags, c);
    }
    resident = std::move(flags);
    lacks_child = std::move(lacks);
    ++residency_version;
}

void HlodModel::advance_fades(const std::vector<uint32_t>& capped) {
    for (const uint32_t c : fading_) fade_[c] = std::min(1.0f, fade_[c] + 1.0f / float(kFadeFrames));  // exact steps
    std::erase_if(fading_, [&](uint32_t c) { return fade_[c] >= 1.0f; });
    for (const uint32_t c : capped) {
        if (fade_[c] >= 1.0f) fading_.push_back(c);
        fade_[c] = 0.0f;
    }
}

bool HlodModel::Capping::capped(uint32_t c) {
    if (const auto it = memo_.find(c); it != memo_.end()) return it->second;
    bool capped = model_.tree_->lacks_child[c] && !model_.suitable(c, view_);
    // A capped cube of the parent's level next to this one keeps it from refining, so that nothing drawn
    // beside that cube is two levels finer; so does one whose children are still fading in, so that
    // nothing finer is drawn beside vertices that are not yet at λ = 1.
    if (const uint32_t parent = model_.tree_->parent[c]; !capped && parent != kNoCube)
        for (const uint32_t n : model_.tree_->neighbours[parent])
            if (n != kNoCube && ((view_.fade && (*view_.fade)[n] < 1.0f) || this->capped(n))) {
                capped = true;
                break;
            }
    memo_.emplace(c, capped);
    return capped;
}

HlodModel::SelectionBasis HlodModel::Capping::basis() const {
    SelectionBasis basis;
    basis.examined.reserve(memo_.size());
    for (const auto& [cube, is_capped] : memo_) {
        basis.examined.push_back(cube);
        if (is_capped) basis.capped.push_back(cube);
    }
    return basis;
}

Kappas HlodModel::Capping::morph_kappas(const std::vector<uint32_t>& capped) const {
    const bool fading = view_.fade && !model_.fading_.empty();
    if (capped.empty() && !fading) return view_.kappa;
    auto out = std::make_shared<CubeKappas>();
    out->base = view_.kappa;
    out->capped = capped;  // what it holds stays on its parents
    std::sort(out->capped.begin(), out->capped.end());
    if (fading) {
        for (const uint32_t c : model_.fading_) out->fading.push_back({c, (*view_.fade)[c]});
        std::sort(out->fading.begin(), out->fading.end());
    }
    return out;
}

std::array<float, 2> CubeKappas::band_end(uint32_t cube) const {
    if (!base) return band_ends[cube];
    std::array<float, 2> ends = base->band_end(cube);
    if (std::binary_search(capped.begin(), capped.end(), cube)) ends[1] = 0.0f;
    return ends;
}

float CubeKappas::fade_of(uint32_t cube) const {
    if (!base) return 1.0f;
    const auto it = std::lower_bound(fading.begin(), fading.end(), cube, [](const auto& entry, uint32_t c) { return entry.first < c; });
    return it != fading.end() && it->first == cube ? it->second : base->fade_of(cube);
}

bool HlodModel::drawn_here(uint32_t c, const HlodView& view, Capping& capping) const {
    // Capping is asked of every cube reached, so that the morph knows the ends of all the cubes that
    // hold a drawn vertex (its cube's parent's neighbours).
    const bool capped = capping.capped(c);
    return capped || suitable(c, view);
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

Kappas HlodModel::kappas_for(const Camera& camera) const {
    if (pixel_error_ <= 0 || camera.projection != ProjectionKind::perspective) return uniform_kappas(kappa0_);
    // Pixels per unit of error at unit distance, over P, at the image's corner: the projection's
    // largest magnification at a point r away and θ off the axis is (f/r)/cos²θ, and inside the image
    // 1/cos²θ ≤ 1 + tan²(θx/2) + tan²(θy/2).
    const double tx = camera.tan_half_fov_x(), ty = std::tan(glm::radians(camera.fov_y_degrees) / 2);
    const double focal = camera.width / (2 * tx);
    const double gain = 1 + focal * (1 + tx * tx + ty * ty) / pixel_error_;  // the 1: the error's own extent
    return tree_->cached_kappas(gain, [&] { return make_kappas(kappas_for_gain(gain)); });
}

Kappas HlodModel::uniform_kappas(double kappa) const {
    return tree_->cached_kappas(-kappa, [&] { return make_kappas(std::vector<double>(tree_->cubes.size(), kappa)); });
}

Kappas HlodModel::Tree::cached_kappas(double key, const std::function<Kappas()>& make) {
    const std::lock_guard lock(kappas_mutex);
    for (size_t k = 0; k < kappas.size(); ++k)
        if (kappas[k].second && kappas[k].first == key) {
            std::rotate(kappas.begin(), kappas.begin() + ptrdiff_t(k), kappas.begin() + ptrdiff_t(k) + 1);  // most recent first
            return kappas.front().second;
        }
    std::rotate(kappas.begin(), kappas.end() - 1, kappas.end());  // the least recent makes way
    kappas.front() = {key, make()};
    return kappas.front().second;
}

std::vector<double> HlodModel::kappas_for_gain(double gain) const {
    const double sigma0 = tree_->header.sigma0;
    std::vector<double> kappa(tree_->cubes.size(), min_kappa0());
    for (uint32_t c = 0; c < tree_->cubes.size(); ++c) {
        // The full resolution is exempt. A coarser cube c draws within 1.5·σ0·s_l of its cell (the
        // vertices' overhang, then the morph's travel), so its nearest drawn point is (κ_c − 1.5σ0)·s_l
        // away: its own bound needs κ_c ≥ 1.5σ0 + g·e_c/s_l. The children of c and of its neighbours
        // morph toward them within kMorphCubes·s_{l+1} of c's band end, (κ_c − σ0)·s_l, when c holds
        // their vertices: their parents' bounds need κ_c ≥ σ0 + kMorphCubes/2 + g·e_n/s_l for every
        // neighbour n, which also covers c's own bound.
        const HlodNode& node = tree_->cubes[c].node;
        if (node.level == tree_->header.max_level) continue;
        double worst = 0;
        for (const uint32_t n : tree_->neighbours[c])
            if (n != kNoCube) worst = std::max(worst, double(tree_->cubes[n].node.error));
        kappa[c] = std::max(kappa[c], sigma0 + kMorphCubes / 2 + worst / tree_->header.cube_size(node.level) * gain);
    }
    // Nesting (nodes/README.md): a cube's κ is at most 2κ − 1 − 3σ0 − 0.25 of its parent and of its
    // parent's neighbours, which keeps each vertex's morph band a quarter cube wide and neighbouring
    // drawn cubes within a level; raising a coarser κ keeps its promise. Finest first, so each cube
    // is final before it raises the level above.
    for (const uint32_t c : tree_->finest_first) {
        if (tree_->parent[c] == kNoCube) continue;
        const double least = (kappa[c] + 1.25 + 3 * sigma0) / 2;
        for (const uint32_t n : tree_->neighbours[tree_->parent[c]])
            if (n != kNoCube) kappa[n] = std::max(kappa[n], least);
    }
    return kappa;
}

Kappas HlodModel::make_kappas(std::vector<double> kappa) const {
    auto out = std::make_shared<CubeKappas>();
    out->band_ends.resize(kappa.size());
    const double sigma0 = tree_->header.sigma0;
    for (uint32_t c = 0; c < kappa.size(); ++c) {
        const double s = tree_->header.cube_size(tree_->cubes[c].node.level);
        out->band_ends[c] = {float((1.0 + kappa[c] + sigma0) * s), float((kappa[c] - sigma0) * s)};
    }
    out->kappa = std::move(kappa);
    return out;
}

glm::dmat4 HlodModel::lattice_to_node() const { return glm::translate(glm::dmat4(1.0), origin()); }

Box HlodModel::cell(const HlodNode& node) const {
    const double s = tree_->header.cube_size(node.level);
    const glm::dvec3 lo = glm::dvec3(node.i, node.j, node.k) * s;
    return Box::from(lo, lo + glm::dvec3(s));
}

Box HlodModel::cull_box(const HlodNode& node) const {
    const Box cell_box = cell(node);
    const glm::dvec3 grow(1.5 * tree_->header.sigma0 * tree_->header.cube_size(node.level));
    return Box::from(cell_box.lo - grow, cell_box.hi + grow);
}

HlodView HlodModel::view_for(const Camera& camera, const glm::dvec3& eye) const {
    HlodView view{eye - origin(), kappas_for(camera)};
    if (camera.projection == ProjectionKind::orthographic) view.fixed_level = orthographic_level(camera);
    return view;
}

bool HlodModel::suitable(uint32_t cube, const HlodView& view) const {
    const HlodNode& node = tree_->cubes[cube].node;
    if (node.level == tree_->header.max_level) return true;
    if (view.fixed_level >= 0) return int(node.level) >= view.fixed_level;
    return box_distance(view.eye, cell(node)) >= (*view.kappa)[cube] * tree_->header.cube_size(node.level);
}

void HlodModel::select(const HlodView& view, std::vector<uint32_t>& out, Kappas* morph, SelectionBasis* basis) const {
    out.clear();
    Capping capping(*this, view);
    select_from(tree_->root, view, capping, view.plane_mask, out);
    if (!morph && !basis) return;
    SelectionBasis found = capping.basis();
    if (morph) *morph = capping.morph_kappas(found.capped);
    if (basis) *basis = std::move(found);
}

void HlodModel::select_from(uint32_t c, const HlodView& view, Capping& capping, uint8_t mask, std::vector<uint32_t>& out) const {
    const HlodCube& cube = tree_->cubes[c];
    if (!tree_->resident[c]) return;  // only the root can be reached so: its parent would stand in
    if (view.frustum && mask && !intersects(*view.frustum, cull_box(cube.node), mask)) return;
    if (drawn_here(c, view, capping)) {
        out.push_back(c);
        return;
    }
    // Front to back: the octant on the eye's side of the centre first, then the rest in an order in
    // which no octant comes before one that could hide it.
    const glm::dvec3 centre = cell(cube.node).center();
    const uint32_t near = (view.eye.x >= centre.x) | (view.eye.y >= centre.y) << 1 | (view.eye.z >= centre.z) << 2;
    for (uint32_t k = 0; k < 8; ++k) {
        const uint32_t child = cube.children[near ^ k];
        if (child != kNoCube) select_from(child, view, capping, mask, out);
    }
}

glm::ivec3 HlodModel::lattice_steps(const HlodCube& cube, uint32_t v) const {
    const uint16_t* q = &cube.data->vertices.positions[3 * size_t(v)];
    const HlodNode& n = cube.node;
    return glm::ivec3(q[0], q[1], q[2]) + glm::ivec3(int32_t(n.i << kLatticeBits), int32_t(n.j << kLatticeBits), int32_t(n.k << kLatticeBits)) -
           kLatticeBias;
}

glm::vec3 HlodModel::vertex_position(const HlodCube& cube, uint32_t v) const {
    return glm::vec3(lattice_steps(cube, v)) * tree_->header.lattice_step(cube.node.level);
}

int32_t HlodModel::overhang_steps() const {
    return int32_t(std::ceil(double(tree_->header.sigma0) * double(1 << kLatticeBits)));
}

namespace {

// Each cell of a level whose box grown by `reach` lattice steps holds the point at steps q, as its
// neighbour slot around `home` (a cell of that level, 2^shift steps wide): offsets clamped to ±1,
// which a vertex within its overhang never needs (2·reach < 2^shift).
template <class Visit>
void for_each_cell_holding(const glm::ivec3& q, int32_t reach, int shift, const glm::ivec3& home, Visit&& visit) {
    const glm::ivec3 lo = (q - reach) >> shift, hi = (q + reach) >> shift;
    for (int z = lo.z; z <= hi.z; ++z)
        for (int y = lo.y; y <= hi.y; ++y)
            for (int x = lo.x; x <= hi.x; ++x) {
                const glm::ivec3 slot = glm::clamp(glm::ivec3(x, y, z) - home, -1, 1) + 1;
                visit(slot.x + 3 * slot.y + 9 * slot.z);
            }
}

}  // namespace

HlodModel::MorphBand HlodModel::morph_band(uint32_t c, const glm::ivec3& q, const CubeKappas& kappa) const {
    const HlodNode& n = tree_->cubes[c].node;
    const uint32_t parent = tree_->parent[c];
    if (parent == kNoCube) return {kappa.band_end(c)[0], INFINITY};  // the root: nothing to morph toward
    // The vertex's own cube and its parent always hold it; their neighbours may too.
    MorphBand band{kappa.band_end(c)[0], kappa.band_end(parent)[1], kappa.fade_of(parent)};
    const glm::ivec3 cell(n.i, n.j, n.k);
    for_each_cell_holding(q, overhang_steps(), kLatticeBits, cell, [&](int slot) {
        if (const uint32_t m = tree_->neighbours[c][size_t(slot)]; m != kNoCube) band.start = std::max(band.start, kappa.band_end(m)[0]);
    });
    for_each_cell_holding(q, overhang_steps(), kLatticeBits + 1, cell >> 1, [&](int slot) {
        if (const uint32_t m = tree_->neighbours[parent][size_t(slot)]; m != kNoCube) {
            band.end = std::min(band.end, kappa.band_end(m)[1]);
            band.fade = std::min(band.fade, kappa.fade_of(m));
        }
    });
    return band;
}

float HlodModel::morph_lambda(uint32_t c, const glm::ivec3& q, float d, const CubeKappas& kappa) const {
    if (tree_->parent[c] == kNoCube) return 1.0f;
    const MorphBand band = morph_band(c, q, kappa);
    int exponent = 0;
    // span = m·2^exponent, m in [0.5, 1)
    std::frexp(std::min(band.end - band.start, morph_span_limit(tree_->cubes[c].node.level)), &exponent);
    return std::clamp((band.end - d) * std::ldexp(1.0f, 1 - exponent), 0.0f, 1.0f) * band.fade;  // as the shader
}

glm::ivec3 HlodModel::parent_lattice_steps(const HlodCube& cube, uint32_t p) const {
    const uint16_t* q = &cube.data->parents.positions[3 * size_t(p)];
    const HlodNode& n = cube.node;
    return glm::ivec3(q[0], q[1], q[2]) +
           glm::ivec3(int32_t((n.i / 2) << kLatticeBits), int32_t((n.j / 2) << kLatticeBits), int32_t((n.k / 2) << kLatticeBits)) - kLatticeBias;
}

HlodModel::LatticeAnchor HlodModel::anchor_at(const glm::dvec3& eye, const glm::dvec3& origin) const {
    LatticeAnchor a;
    // A singular transform makes the eye NaN: anchor at the model's origin rather than convert NaN to int.
    a.origin = glm::any(glm::isnan(origin)) || glm::any(glm::isinf(origin)) ? glm::dvec3(0.0) : origin;
    a.eye = glm::vec3(eye - a.origin);
    const double step = double(header().lattice_step(0));
    // Within the root cube's steps and a cube beyond, so that q − 2^l·A cannot overflow at any level
    // (q lies in [−2^14, 2^30 + 2^15)): an eye farther out draws the model off by what it is beyond,
    // where the model is far away and tiny.
    const glm::dvec3 steps = glm::clamp(glm::round(a.origin / step), glm::dvec3(-(1 << 14)), glm::dvec3(1 << 15));
    a.steps = glm::ivec3(steps);
    a.rest = glm::vec3(steps * step - a.origin);
    return a;
}

HlodModel::LatticeAnchor HlodModel::anchor_for(const glm::dmat4& world_from_node, const glm::dvec3& eye_world) const {
    return anchor_at(glm::dvec3(glm::inverse(world_from_node * lattice_to_node()) * glm::dvec4(eye_world, 1.0)));
}

glm::vec3 HlodModel::anchored_position(uint32_t level, const glm::ivec3& q, const LatticeAnchor& anchor) const {
    const glm::vec3 steps(q - anchor.steps * (1 << level));         // exact below 2^24 steps
    const glm::vec3 scaled = steps * header().lattice_step(level);  // two statements: no fused multiply-add
    return scaled + anchor.rest;
}

void HlodModel::morphed_positions(uint32_t c, const LatticeAnchor& anchor, const CubeKappas& kappa, std::vector<glm::vec3>& out) const {
    const HlodCube& cube = tree_->cubes[c];
    const uint32_t level = cube.node.level, parent_level = level == 0 ? 0 : level - 1;
    out.resize(cube.data->vertex_count());
    for (uint32_t v = 0; v < out.size(); ++v) {
        const glm::vec3 w = anchored_position(level, lattice_steps(cube, v), anchor);
        if (!morph_) {
            out[v] = w;
            continue;
        }
        const glm::vec3 parent = anchored_position(parent_level, parent_lattice_steps(cube, cube.data->parent_of[v]), anchor);
        const glm::vec3 offset = glm::abs(w - anchor.eye);
        const float d = std::max(std::max(offset.x, offset.y), offset.z);
        const float lambda = morph_lambda(c, lattice_steps(cube, v), d, kappa);
        // The ends exactly (Lemma 2 needs λ = 0 to give P(w) and λ = 1 to give w), GLSL's mix between;
        // a vertex at its parent's very position (a locked boundary's) stays there bit for bit, so that
        // an embedding's seams do not depend on the level its site is drawn at.
        out[v] = lambda >= 1.0f || parent == w ? w : lambda <= 0.0f ? parent : parent * (1.0f - lambda) + w * lambda;
    }
}

bool HlodModel::morphs_for(const Camera& camera) const {
    return morph_ && camera.projection == ProjectionKind::perspective;
}

int HlodModel::orthographic_level(const Camera& camera) const {
    const double pixel = camera.ortho_height / camera.height;  // model units per pixel
    const double allowed = (pixel_error_ > 0 ? pixel_error_ : 1.0) * pixel;
    int level = 0;
    while (level < int(tree_->header.max_level) && tree_->level_error[size_t(level)] * tree_->header.cube_size(level) > allowed) ++level;
    return level;
}

const std::vector<glm::vec4>* HlodModel::captured_morph(uint32_t cube) const {
    auto it = captured_.find(cube);
    return it == captured_.end() ? nullptr : &it->second;
}

void HlodModel::cull(CullVisitor& cull) {
    if (stream_) sync_residency();
    const Frustum frustum = cull.local_frustum().in_child_frame(lattice_to_node());
    HlodView view = view_for(cull.camera(), cull.local_eye());
    if (cull.frustum_culling()) {
        view.frustum = &frustum;
        view.plane_mask = cull.plane_mask();
    }
    // Interactive frames fade in what arrives (a streamed model's cubes, or a residency set by hand);
    // full-detail ones draw the cut a model loaded whole draws.
    const bool fades = !cull.full_detail();
    if (fades) view.fade = &fade_;
    Kappas morph;
    SelectionBasis basis;  // what streaming asks for and fades follow; a model loaded whole drawn at full detail needs neither
    select(view, selection_, &morph, stream_ || fades ? &basis : nullptr);
    if (stream_) {
        cull.count_stand_ins(request_refinement(view, selection_, basis.examined, fades ? Ask::interactive : Ask::full_detail));
        for (const Lookahead& ahead : cull.lookahead()) prefetch_for(ahead, cull.model());
    }
    if (fades) {
        advance_fades(basis.capped);
        cull.count_fading(fading_.size());
    }
    if (selection_.empty()) return;
    auto runs = hook_ ? hook_(selection_, morph) : nullptr;
    cull.add(*this, selection_.data(), uint32_t(selection_.size()), std::make_shared<const DrawState>(DrawState{std::move(morph), std::move(runs)}));
}

}  // namespace strata

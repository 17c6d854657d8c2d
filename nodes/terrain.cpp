#include "nodes/terrain.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <set>
#include <stdexcept>

#include "engine/scene/cull_visitor.h"
#include "engine/scene/visitor.h"
#include "preprocess/embedding.h"
#include "preprocess/embedding_file.h"

namespace strata {

namespace {

using Runs = std::vector<std::array<uint32_t, 2>>;  // {first index, index count}, in order

// What both of two lists of runs keep.
Runs common_runs(const Runs& a, const Runs& b) {
    Runs out;
    size_t i = 0, j = 0;
    while (i < a.size() && j < b.size()) {
        const uint32_t first = std::max(a[i][0], b[j][0]);
        const uint32_t end_a = a[i][0] + a[i][1], end_b = b[j][0] + b[j][1];
        if (first < std::min(end_a, end_b)) out.push_back({first, std::min(end_a, end_b) - first});
        (end_a < end_b ? i : j)++;
    }
    return out;
}

}  // namespace

Embedding::Embedding(EmbeddedModels models, const std::string& name)
    : stitch_(models, name),
      skirt_(std::const_pointer_cast<HlodModel>(models.skirt)),
      site_(std::const_pointer_cast<HlodModel>(models.site)),
      placement_(std::make_shared<Transform>()),
      seams_(std::make_shared<EmbeddingSeams>(*this)) {
    set_name(name);
    placement_->set_matrix(models.site_to_terrain);
    placement_->add(site_);
    add(skirt_);
    add(placement_);
    add(seams_);
    // The skirt's and the site's selections, for the seams.
    skirt_->set_selection_hook([this](std::span<const uint32_t> cubes, const Kappas& kappa) {
        selections_.skirt = {{cubes.begin(), cubes.end()}, kappa};
        return std::shared_ptr<const HlodModel::CubeRuns>();
    });
    site_->set_selection_hook([this](std::span<const uint32_t> cubes, const Kappas& kappa) {
        selections_.site = {{cubes.begin(), cubes.end()}, kappa};
        return std::shared_ptr<const HlodModel::CubeRuns>();
    });
}

Embedding::~Embedding() {
    skirt_->set_selection_hook(nullptr);
    site_->set_selection_hook(nullptr);
}

void Embedding::begin_view() {
    selections_ = {};
    drawn_ = false;
}

void Embedding::traverse(NodeVisitor& visitor) {
    if (drawn_) Group::traverse(visitor);
}

void Embedding::take_ground_selection(std::span<const uint32_t> cubes, const Kappas& kappa, HlodModel::CubeRuns& hidden) {
    selections_.terrain = {{cubes.begin(), cubes.end()}, kappa};
    std::vector<uint32_t> hiding;
    drawn_ = stitch_.drawn_with(cubes, &hiding);
    if (!drawn_) return;
    for (const uint32_t c : hiding) {
        const EmbeddingStitch::TerrainCube& cube = stitch_.terrain_cube(c);
        const auto [entry, added] = hidden.try_emplace(c, cube.kept);
        if (!added) entry->second = common_runs(entry->second, cube.kept);  // under two embeddings
    }
}

void EmbeddingSeams::cull(CullVisitor& cull) {
    const Embedding::ViewSelections& views = embedding_.selections();
    if (!embedding_.drawn() || !views.terrain.kappa || !views.skirt.kappa || !views.site.kappa) return;
    cull.add(*this, nullptr, 0, std::make_shared<const Embedding::ViewSelections>(views));
}

Box EmbeddingSeams::compute_bound() const { return embedding_.skirt()->bound(); }

Terrain::Terrain(std::shared_ptr<HlodModel> ground) : ground_(std::move(ground)) {
    if (!ground_->header().terrain || !ground_->georeference())
        throw std::runtime_error(ground_->path().string() + ": not a terrain built from an elevation raster, which meshes can be embedded in");
    add(ground_);
    ground_->set_selection_hook([this](std::span<const uint32_t> cubes, const Kappas& kappa) { return take_ground_selection(cubes, kappa); });
}

Terrain::~Terrain() { ground_->set_selection_hook(nullptr); }

std::shared_ptr<Embedding> Terrain::embed(std::shared_ptr<HlodModel> skirt, std::shared_ptr<HlodModel> site, const glm::dmat4& site_to_terrain,
                                          uint32_t drawn_from, CellCovers zone, const std::string& name) {
    // Zones that share a cell would lay two skirts over it; zones that only touch are joined through
    // the grid edge between them, which both ring seams weld to.
    const int64_t columns = int64_t(ground_->header().terrain->columns), rows = int64_t(ground_->header().terrain->rows);
    std::set<std::pair<int64_t, int64_t>> cells;
    for_each_finest_cell(zone, columns, rows, [&](int64_t x, int64_t y) { cells.insert({x, y}); });
    for (const auto& other : embeddings()) {
        bool shared = false;
        for_each_finest_cell(other->stitch().models().zone, columns, rows, [&](int64_t x, int64_t y) { shared = shared || cells.count({x, y}); });
        if (shared)
            throw std::runtime_error(name + ": its zone overlaps the zone of " + other->name() +
                                     ", embedded in the same terrain: two skirts cannot cover one cell (embed the two sites as one mesh)");
    }
    EmbeddedModels models{ground_, std::move(skirt), std::move(site), site_to_terrain, drawn_from, std::move(zone)};
    auto embedding = std::make_shared<Embedding>(std::move(models), name);
    add(embedding);
    return embedding;
}

NodePtr Terrain::load_embedding(const std::filesystem::path& file) {
    const HlodFile embedding_file(file);
    const EmbeddingRecord record = read_embedding(embedding_file);
    check_embedded_terrain(record, file, HlodFile(ground_->path()));
    const std::filesystem::path site_path = embedded_path(file, record.site_file);
    check_embedded_site(record, file, HlodFile(site_path));
    auto site = HlodModel::open(site_path);
    site->set_pixel_error(ground_->pixel_error() > 0 ? ground_->pixel_error() : 1.0);
    NodePtr node;
    if (record.standing) {
        auto placement = std::make_shared<Transform>();
        placement->set_matrix(record.placement);
        placement->set_name(file.stem().string());
        placement->add(std::move(site));
        add(placement);
        node = placement;
    } else {
        auto skirt = HlodModel::open(file);
        skirt->set_pixel_error(site->pixel_error());
        node = embed(std::move(skirt), std::move(site), record.placement, record.zone_level, record.zone, file.stem().string());
    }
    files_[node.get()] = file;
    return node;
}

SitePlacement Terrain::placement(const Node* child) const {
    const std::filesystem::path& file = loaded_file(child);
    const EmbeddingRecord record = read_embedding(HlodFile(file));
    const std::filesystem::path site = embedded_path(file, record.site_file);
    return placement_of(TerrainSite::open(ground_->path()), open_site(site), record.placement, site.string());
}

NodePtr Terrain::move_embedding(const Node* child, const SitePlacement& placement, const Progress& progress) {
    const Remake remake = remake_for(child);
    EmbedSettings settings;
    settings.placement = placement;
    build_embedding(remake.terrain, remake.site, remake.remade, settings, progress);
    return replace_embedding(child, remake.remade);
}

Terrain::Remake Terrain::remake_for(const Node* child) const {
    const std::filesystem::path& file = loaded_file(child);
    const EmbeddingRecord record = read_embedding(HlodFile(file));
    // Beside the file, so that the names it stores (relative to its folder) stay right; a name of its
    // own, should two remakes of one file run at once (the editor's Move and a script's).
    static std::atomic<uint64_t> remakes{0};
    const std::string unique = std::to_string(::getpid()) + "." + std::to_string(++remakes);
    return {ground_->path(), embedded_path(file, record.site_file), file.string() + ".remade." + unique};
}

NodePtr Terrain::replace_embedding(const Node* child, const std::filesystem::path& remade) {
    namespace fs = std::filesystem;
    std::error_code ignored;
    fs::path file, kept;
    try {
        file = loaded_file(child);
        // The file as it is, kept under another name until the new one loads (a hard link keeps the old
        // bytes for free; the loaded child reads them through its own open handle either way).
        kept = file.string() + ".before-move";
        fs::remove(kept, ignored);
        std::error_code linked;
        fs::create_hard_link(file, kept, linked);
        if (linked) fs::copy_file(file, kept);
    } catch (...) {
        fs::remove(remade, ignored);
        throw;
    }
    const NodePtr old = *std::find_if(children().begin(), children().end(), [&](const NodePtr& c) { return c.get() == child; });
    try {
        fs::rename(remade, file);
        remove_embedding(old.get());
        NodePtr moved = load_embedding(file);
        fs::remove(kept);
        return moved;
    } catch (...) {
        fs::rename(kept, file, ignored);
        fs::remove(kept, ignored);
        fs::remove(remade, ignored);
        if (std::find(children().begin(), children().end(), old) == children().end()) {
            add(old);
            files_[old.get()] = file;
        }
        throw;
    }
}

bool Terrain::remove_embedding(const Node* embedding) {
    if (embedding == ground_.get() || !remove(embedding)) return false;
    files_.erase(embedding);
    return true;
}

const std::filesystem::path* Terrain::embedding_file(const Node* child) const {
    const auto file = files_.find(child);
    const bool held = std::any_of(children().begin(), children().end(), [&](const NodePtr& c) { return c.get() == child; });
    return file != files_.end() && held ? &file->second : nullptr;
}

const std::filesystem::path& Terrain::loaded_file(const Node* child) const {
    const std::filesystem::path* file = embedding_file(child);
    if (!file) throw std::runtime_error((child ? child->name() : std::string("(none)")) + ": not an embedding of " + name() + " loaded from a file");
    return *file;
}

std::vector<std::shared_ptr<Embedding>> Terrain::embeddings() const {
    std::vector<std::shared_ptr<Embedding>> out;
    for (const NodePtr& child : children())
        if (auto embedding = std::dynamic_pointer_cast<Embedding>(child)) out.push_back(std::move(embedding));
    return out;
}

void Terrain::traverse(NodeVisitor& visitor) {
    for (const auto& embedding : embeddings()) embedding->begin_view();
    Group::traverse(visitor);
}

std::shared_ptr<const HlodModel::CubeRuns> Terrain::take_ground_selection(std::span<const uint32_t> cubes, const Kappas& kappa) {
    auto hidden = std::make_shared<HlodModel::CubeRuns>();
    for (const auto& embedding : embeddings()) embedding->take_ground_selection(cubes, kappa, *hidden);
    return hidden->empty() ? nullptr : hidden;
}

}  // namespace strata

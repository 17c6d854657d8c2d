#include "nodes/embedding_stitch.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "preprocess/embedding.h"
#include "preprocess/georeference.h"

namespace strata {

namespace {

uint64_t sample_key(int64_t column, int64_t row) { return uint64_t(column) << 32 | uint64_t(uint32_t(row)); }

// Level-0 lattice steps (within ±2^20 of the root: its 2^15 steps and the overhang) as one key.
uint64_t lattice_key(const glm::ivec3& q) {
    constexpr int32_t kBias = 1 << 20;
    return uint64_t(uint32_t(q.x + kBias)) << 42 | uint64_t(uint32_t(q.y + kBias)) << 21 | uint64_t(uint32_t(q.z + kBias));
}

// A level-l vertex's level-0 lattice steps, when it lies on level 0's lattice (a locked boundary's
// vertices are stored there at every level: FORMAT.md §6).
std::optional<glm::ivec3> level0_steps(const glm::ivec3& q, uint32_t level) {
    const int32_t below = (1 << level) - 1;
    if ((q.x & below) || (q.y & below) || (q.z & below)) return std::nullopt;
    return glm::ivec3(q.x >> level, q.y >> level, q.z >> level);
}

// (level, cell, which of its two triangles) as one key: the claims' index.
uint64_t claim_key(uint32_t level, int64_t cell_x, int64_t cell_y, int triangle) {
    return uint64_t(level) << 60 | uint64_t(triangle) << 59 | uint64_t(cell_x) << 30 | uint64_t(cell_y);
}

// The root's open boundary: its directed edges (in its triangles' order) that no other triangle uses,
// between vertices named by their level-0 lattice steps, and a node-frame position per such vertex.
struct RootBoundary {
    std::unordered_map<uint64_t, uint64_t> next;  // from → to
    std::unordered_map<uint64_t, glm::dvec3> position;
    std::unordered_map<uint64_t, glm::ivec3> steps;
};

RootBoundary root_boundary(const HlodModel& model) {
    // Read from the file: a streamed model may not hold its root yet.
    const HlodCube& resident = model.cubes()[model.root()];
    const HlodCube root{resident.node, resident.data ? resident.data : std::make_shared<const CubeData>(HlodFile(model.path()).read_cube(resident.node)),
                        resident.children};
    std::vector<uint64_t> key(root.data->vertex_count());
    for (uint32_t v = 0; v < key.size(); ++v) key[v] = lattice_key(model.lattice_steps(root, v));
    std::map<std::pair<uint64_t, uint64_t>, int> uses;
    const auto& indices = root.data->indices;
    for (size_t t = 0; t + 2 < indices.size(); t += 3) {
        const uint64_t k[3] = {key[indices[t]], key[indices[t + 1]], key[indices[t + 2]]};
        if (k[0] == k[1] || k[1] == k[2] || k[0] == k[2]) continue;  // collapsed
        for (int e = 0; e < 3; ++e) ++uses[{k[e], k[(e + 1) % 3]}];
    }
    RootBoundary boundary;
    for (const auto& [edge, count] : uses)
        if (!uses.count({edge.second, edge.first}) && count == 1) boundary.next[edge.first] = edge.second;
    const glm::dmat4 to_node = model.lattice_to_node();
    for (uint32_t v = 0; v < key.size(); ++v) {
        if (boundary.next.count(key[v])) {
            boundary.position[key[v]] = glm::dvec3(to_node * glm::dvec4(glm::dvec3(model.vertex_position(root, v)), 1.0));
            boundary.steps[key[v]] = model.lattice_steps(root, v);
        }
    }
    return boundary;
}

// The sample of a level-`level` vertex at fractional raster position `at` along one axis of `samples`:
// the level keeps the multiples of its step and the last sample (terrain_pyramid.h).
int64_t level_sample(double at, uint32_t level, uint32_t finest, int64_t samples) {
    const int64_t step = int64_t(1) << (finest - level);
    const int64_t multiple = std::clamp(int64_t(std::llround(at / double(step))) * step, int64_t(0), samples - 1);
    return std::abs(at - double(samples - 1)) < std::abs(at - double(multiple)) ? samples - 1 : multiple;
}

}  // namespace

EmbeddingStitch::EmbeddingStitch(EmbeddedModels models, std::string what) : models_(std::move(models)) {
    const HlodHeader& header = models_.terrain->header();
    if (!header.terrain || !models_.terrain->georeference())
        throw std::runtime_error(what + ": the model it is embedded in is not a terrain built from an elevation raster");
    columns_ = int64_t(header.terrain->columns);
    rows_ = int64_t(header.terrain->rows);
    finest_ = header.max_level;
    if (models_.drawn_from == 0 || models_.drawn_from > finest_ || models_.zone.size != int64_t(1) << (finest_ - models_.drawn_from + 1))
        throw std::runtime_error(what + ": its zone's cells are not those of the level before the one it is drawn from");
    flip_ = raster_turns_over(*models_.terrain->georeference());
    loops_ = zone_border(models_.zone, columns_, rows_);
    for (const auto& loop : loops_) {
        loop_first_.push_back(step_count_);
        step_count_ += loop.size();
        for (const BorderStep& step : loop) border_sample_.try_emplace(sample_key(step.column, step.row), uint32_t(border_sample_.size()));
    }
    match_skirt(what);
    match_site(what);
    claim_steps();
}

void EmbeddingStitch::match_skirt(const std::string& what) {
    const HlodModel& skirt = *models_.skirt;
    const Georeference& geo = *models_.terrain->georeference();
    RootBoundary boundary = root_boundary(skirt);
    if (boundary.next.empty()) throw std::runtime_error(what + ": its skirt has no boundary");
    // Each of the border's samples is a point of the skirt's outer boundary, within its quantization.
    const double tolerance = double(skirt.header().lattice_step(0));
    std::vector<uint8_t> reached(border_sample_.size(), 0);  // border sample s is skirt point s
    std::vector<uint64_t> inner;
    for (const auto& [key, at] : boundary.position) {
        const auto raster = geo.raster_position(at.x, at.y, at.z);
        bool on_border = false;
        if (raster) {
            const int64_t column = std::llround((*raster)[0]), row = std::llround((*raster)[1]);
            const auto sample = border_sample_.find(sample_key(column, row));
            const auto exact = sample == border_sample_.end() ? std::nullopt : geo.sample_position(double(column), double(row), at.z);
            if (exact && std::abs((*exact)[0] - at.x) <= tolerance && std::abs((*exact)[1] - at.y) <= tolerance) {
                if (reached[sample->second]++)
                    throw std::runtime_error(what + ": two points of its skirt lie at the raster sample (" + std::to_string(column) + ", " +
                                             std::to_string(row) + ")");
                skirt_point_[key] = sample->second;
                on_border = true;
            }
        }
        if (!on_border) inner.push_back(key);
    }
    if (std::count(reached.begin(), reached.end(), 0) != 0)
        throw std::runtime_error(what + ": its skirt does not reach every sample of its zone's border (a skirt built for another zone?)");
    std::sort(inner.begin(), inner.end());
    for (const uint64_t key : inner) skirt_point_[key] = uint32_t(border_sample_.size() + skirt_inner_.size()), skirt_inner_.push_back(key);
    skirt_next_ = std::move(boundary.next);
    skirt_position_ = std::move(boundary.position);
}

void EmbeddingStitch::match_site(const std::string& what) {
    const HlodModel& site = *models_.site;
    const RootBoundary boundary = root_boundary(site);
    // The skirt's inner points by where they lie, in cells of the matching tolerance: the site's
    // boundary vertex and its copy in the skirt were both quantized from one position.
    const double scale = std::cbrt(std::abs(glm::determinant(glm::dmat3(models_.site_to_terrain))));
    const double tolerance = double(models_.skirt->header().lattice_step(0)) + scale * double(site.header().lattice_step(0));
    auto cell_of = [&](const glm::dvec3& p) { return glm::i64vec3(glm::floor(p / tolerance)); };
    std::map<std::array<int64_t, 3>, std::vector<uint64_t>> near;
    for (const uint64_t key : skirt_inner_) {
        const glm::i64vec3 c = cell_of(skirt_position_.at(key));
        near[{c.x, c.y, c.z}].push_back(key);
    }
    std::unordered_map<uint64_t, uint64_t> copy;  // site boundary vertex → skirt inner point (keys)
    std::set<uint64_t> taken;
    for (const auto& [key, at] : boundary.position) {
        const glm::dvec3 placed = glm::dvec3(models_.site_to_terrain * glm::dvec4(at, 1.0));
        const glm::i64vec3 c = cell_of(placed);
        double best = tolerance * 1.8;  // within a cell's diagonal of the two quantizations
        uint64_t found = 0;
        bool any = false;
        for (int64_t dz = -1; dz <= 1; ++dz)
            for (int64_t dy = -1; dy <= 1; ++dy)
                for (int64_t dx = -1; dx <= 1; ++dx) {
                    const auto bucket = near.find({c.x + dx, c.y + dy, c.z + dz});
                    if (bucket == near.end()) continue;
                    for (const uint64_t k : bucket->second)
                        if (const double d = glm::length(skirt_position_.at(k) - placed); d <= best) best = d, found = k, any = true;
                }
        if (!any) continue;
        if (!taken.insert(found).second) throw std::runtime_error(what + ": two of its boundary vertices meet one point of its skirt");
        copy[key] = found;
    }
    // The site's boundary loops: the one whose vertices all have copies is embedded; loops with none
    // are holes, left open (preprocess/footprint.h); a loop with some is a site moved since its skirt was made.
    std::set<uint64_t> seen;
    for (const auto& entry : boundary.next) {
        const uint64_t start = entry.first;
        if (seen.count(start)) continue;
        std::vector<uint64_t> loop;
        for (uint64_t at = start; seen.insert(at).second;) {
            loop.push_back(at);
            const auto next = boundary.next.find(at);
            if (next == boundary.next.end()) break;
            at = next->second;
        }
        const size_t copied = size_t(std::count_if(loop.begin(), loop.end(), [&](uint64_t k) { return copy.count(k) != 0; }));
        if (copied == 0) continue;
        if (copied != loop.size() || !site_boundary_.empty())
            throw std::runtime_error(what + ": its boundary no longer meets its skirt (the site moved or was rebuilt since the embedding was made)");
        for (const uint64_t key : loop) {
            site_point_[lattice_key(boundary.steps.at(key))] = uint32_t(site_boundary_.size());
            site_boundary_.push_back({skirt_point_.at(copy.at(key)), {}});
        }
    }
    if (site_boundary_.empty()) throw std::runtime_error(what + ": no boundary of the site meets its skirt");
    // The crossings. The skirt's inner boundary runs against the site's when both face up (from the copy
    // of a vertex's next back to the copy of the vertex), with it when the site's faces are wound the
    // other way.
    const size_t n = site_boundary_.size();
    std::unordered_map<uint32_t, uint64_t> key_of_point;
    for (const auto& [key, point] : skirt_point_) key_of_point[point] = key;
    std::unordered_map<uint32_t, uint32_t> vertex_of_point;
    for (uint32_t v = 0; v < n; ++v) vertex_of_point[site_boundary_[v].skirt_point] = v;
    // The points strictly between the copies of `from` and `to` along the skirt's boundary, or nullopt
    // when another of the site's vertices comes first.
    auto between = [&](uint32_t from, uint32_t to) -> std::optional<std::vector<uint32_t>> {
        std::vector<uint32_t> points;
        for (uint32_t at = from;;) {
            const auto next = skirt_next_.find(key_of_point.at(at));
            if (next == skirt_next_.end() || points.size() > skirt_inner_.size())
                throw std::runtime_error(what + ": its skirt's inner boundary is not closed");
            at = skirt_point_.at(next->second);
            if (at == to) return points;
            if (vertex_of_point.count(at)) return std::nullopt;
            points.push_back(at);
        }
    };
    const bool against = between(site_boundary_[1 % n].skirt_point, site_boundary_[0].skirt_point).has_value();
    for (uint32_t v = 0; v < n; ++v) {
        const uint32_t here = site_boundary_[v].skirt_point, there = site_boundary_[(v + 1) % n].skirt_point;
        std::optional<std::vector<uint32_t>> points = against ? between(there, here) : between(here, there);
        if (!points) throw std::runtime_error(what + ": its skirt's inner boundary does not follow the site's");
        if (against) std::reverse(points->begin(), points->end());
        site_boundary_[v].crossings = std::move(*points);  // from the vertex's side
    }
}

void EmbeddingStitch::claim_steps() {
    // The grid triangle beside each step at each level the embedding is drawn at: the cell holding the
    // step's outside finest cell; triangle 0 {min, (c, r + 1), max} holds a cell's sides at its min column
    // and max row, triangle 1 the others (terrain_pyramid.h).
    for (size_t l = 0; l < loops_.size(); ++l) {
        const auto& loop = loops_[l];
        for (size_t i = 0; i < loop.size(); ++i) {
            const BorderStep& step = loop[i];
            if (!step.seamed()) continue;
            const BorderStep& next = loop[(i + 1) % loop.size()];
            const bool along_row = next.row == step.row;
            const int triangle = along_row ? (step.outside_row == step.row ? 1 : 0) : (step.outside_column == step.column ? 0 : 1);
            for (uint32_t level = models_.drawn_from; level <= finest_; ++level) {
                const uint32_t shift = finest_ - level;
                claims_[claim_key(level, step.outside_column >> shift, step.outside_row >> shift, triangle)].push_back(uint32_t(loop_first_[l] + i));
            }
        }
    }
}

const EmbeddingStitch::TerrainCube& EmbeddingStitch::terrain_cube(uint32_t c) const {
    std::lock_guard lock(mutex_);
    if (const auto found = terrain_cubes_.find(c); found != terrain_cubes_.end()) return found->second;
    const HlodModel& terrain = *models_.terrain;
    const Georeference& geo = *terrain.georeference();
    const HlodCube& cube = terrain.cubes()[c];
    const uint32_t level = cube.node.level;
    const glm::dmat4 to_node = terrain.lattice_to_node();
    TerrainCube out;
    // The zone's finest cells' box, grown by one cell: triangles meeting it are near.
    const CellCovers& zone = models_.zone;
    const int64_t x0 = zone.first_x * zone.size - 1, y0 = zone.first_y * zone.size - 1;
    const int64_t x1 = (zone.first_x + zone.width) * zone.size + 1, y1 = (zone.first_y + zone.height) * zone.size + 1;
    // Most cubes lie far from the zone: their cell's corners say so without a look at their vertices
    // (a zone cell more of margin for a frame whose raster is not a plane of the model's).
    {
        const Box box = terrain.cull_box(cube.node);
        double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
        for (int corner = 0; corner < 4; ++corner) {
            const glm::dvec3 at = glm::dvec3(to_node * glm::dvec4(corner & 1 ? box.hi.x : box.lo.x, corner & 2 ? box.hi.y : box.lo.y, box.lo.z, 1.0));
            if (const auto raster = geo.raster_position(at.x, at.y, at.z))
                for (int a = 0; a < 2; ++a) lo[a] = std::min(lo[a], (*raster)[a]), hi[a] = std::max(hi[a], (*raster)[a]);
        }
        const double margin = double(zone.size);
        if (hi[0] + margin < double(x0) || lo[0] - margin > double(x1) || hi[1] + margin < double(y0) || lo[1] - margin > double(y1)) {
            out.kept.push_back({0, uint32_t(cube.data->indices.size())});
            return terrain_cubes_.emplace(c, std::move(out)).first->second;
        }
    }
    // Each vertex's sample.
    std::vector<std::array<int64_t, 2>> sample(cube.data->vertex_count());
    for (uint32_t v = 0; v < sample.size(); ++v) {
        const glm::dvec3 at = glm::dvec3(to_node * glm::dvec4(glm::dvec3(terrain.vertex_position(cube, v)), 1.0));
        const auto raster = geo.raster_position(at.x, at.y, at.z);
        sample[v] = raster ? std::array<int64_t, 2>{level_sample((*raster)[0], level, finest_, columns_), level_sample((*raster)[1], level, finest_, rows_)}
                           : std::array<int64_t, 2>{-1, -1};
        if (const auto border = border_sample_.find(sample_key(sample[v][0], sample[v][1])); raster && border != border_sample_.end())
            out.border_samples.push_back({v, border->second});
    }
    const auto& indices = cube.data->indices;
    const bool maskable = level >= models_.drawn_from;
    for (uint32_t t = 0; t + 2 < indices.size(); t += 3) {
        const auto& a = sample[indices[t]];
        const auto& b = sample[indices[t + 1]];
        const auto& d = sample[indices[t + 2]];
        const int64_t cmin = std::min({a[0], b[0], d[0]}), cmax = std::max({a[0], b[0], d[0]});
        const int64_t rmin = std::min({a[1], b[1], d[1]}), rmax = std::max({a[1], b[1], d[1]});
        bool hidden = false;
        if (cmin >= 0 && rmin >= 0 && cmax >= x0 && cmin <= x1 && rmax >= y0 && rmin <= y1) {
            out.near_zone = true;
            if (maskable) {
                // A level-l cell lies in one zone cell (l ≥ m > the zone's level): its min corner says which.
                hidden = zone.at(cmin / zone.size, rmin / zone.size) != CellCover::none;
                const uint32_t shift = finest_ - level;
                const bool first = (a[0] == cmin && a[1] > rmin) || (b[0] == cmin && b[1] > rmin) || (d[0] == cmin && d[1] > rmin);
                if (const auto claim = claims_.find(claim_key(level, cmin >> shift, rmin >> shift, first ? 0 : 1)); claim != claims_.end())
                    out.steps.insert(out.steps.end(), claim->second.begin(), claim->second.end());
            }
        }
        if (hidden) {
            out.hides = true;
            continue;
        }
        if (!out.kept.empty() && out.kept.back()[0] + out.kept.back()[1] == t)
            out.kept.back()[1] += 3;
        else
            out.kept.push_back({t, 3});
    }
    return terrain_cubes_.emplace(c, std::move(out)).first->second;
}

bool EmbeddingStitch::drawn_with(std::span<const uint32_t> terrain_cubes, std::vector<uint32_t>* hiding) const {
    for (const uint32_t c : terrain_cubes) {
        const TerrainCube& cube = terrain_cube(c);
        if (!cube.near_zone) continue;
        if (models_.terrain->cubes()[c].node.level < models_.drawn_from) return false;
        if (hiding && cube.hides) hiding->push_back(c);
    }
    return true;
}

EmbeddingStitch::CubePoints EmbeddingStitch::find_points(const HlodModel& model, uint32_t c,
                                                           const std::unordered_map<uint64_t, uint32_t>& ids) const {
    const HlodCube& cube = model.cubes()[c];
    CubePoints out;
    for (uint32_t v = 0; v < cube.data->vertex_count(); ++v)
        if (const auto q0 = level0_steps(model.lattice_steps(cube, v), cube.node.level))
            if (const auto found = ids.find(lattice_key(*q0)); found != ids.end()) out.points.push_back({v, found->second});
    return out;
}

const EmbeddingStitch::CubePoints& EmbeddingStitch::skirt_cube(uint32_t c) const {
    std::lock_guard lock(mutex_);
    if (const auto found = skirt_cubes_.find(c); found != skirt_cubes_.end()) return found->second;
    return skirt_cubes_.emplace(c, find_points(*models_.skirt, c, skirt_point_)).first->second;
}

const EmbeddingStitch::CubePoints& EmbeddingStitch::site_cube(uint32_t c) const {
    std::lock_guard lock(mutex_);
    if (const auto found = site_cubes_.find(c); found != site_cubes_.end()) return found->second;
    return site_cubes_.emplace(c, find_points(*models_.site, c, site_point_)).first->second;
}

void EmbeddingStitch::seam_vertices(std::span<const uint32_t> terrain_cubes, std::span<const uint32_t> skirt_cubes,
                                    std::span<const uint32_t> site_cubes, std::vector<StitchRefTriangle>& out) const {
    // The grid: each step's level, and the border's samples as each level draws them.
    std::vector<int32_t> step_level(step_count_, -1);
    std::unordered_map<uint64_t, StitchRef> grid;  // (level, sample) → vertex
    for (const uint32_t c : terrain_cubes) {
        const TerrainCube& cube = terrain_cube(c);
        const uint32_t level = models_.terrain->cubes()[c].node.level;
        for (const uint32_t s : cube.steps) step_level[s] = int32_t(level);
        for (const auto& [v, sample] : cube.border_samples) grid[uint64_t(level) << 32 | sample] = {StitchOwner::terrain, c, v};
    }
    std::unordered_map<uint32_t, StitchRef> skirt_at, site_at;  // point → vertex
    for (const uint32_t c : skirt_cubes)
        for (const auto& [v, point] : skirt_cube(c).points) skirt_at[point] = {StitchOwner::skirt, c, v};
    for (const uint32_t c : site_cubes)
        for (const auto& [v, point] : site_cube(c).points) site_at[point] = {StitchOwner::site, c, v};

    // The ring seam.
    std::vector<std::array<SeamVertex, 3>> ring;
    for (size_t l = 0; l < loops_.size(); ++l) {
        for (size_t i = 0; i < loops_[l].size(); ++i) {
            const int32_t level = step_level[loop_first_[l] + i];
            if (level < 0) continue;
            ring.clear();
            ring_seam_step(loops_[l], i, uint32_t(level), finest_, columns_, rows_, ring);
            for (const auto& triangle : ring) {
                StitchRefTriangle t;
                bool whole = true;
                for (int k = 0; k < 3 && whole; ++k) {
                    const SeamVertex& v = triangle[size_t(k)];
                    const auto sample = border_sample_.find(sample_key(v.column, v.row));
                    if (sample == border_sample_.end()) {
                        whole = false;
                    } else if (v.grid) {
                        const auto at = grid.find(uint64_t(v.level) << 32 | sample->second);
                        whole = at != grid.end();
                        if (whole) t[size_t(k)] = at->second;
                    } else {
                        const auto at = skirt_at.find(sample->second);
                        whole = at != skirt_at.end();
                        if (whole) t[size_t(k)] = at->second;
                    }
                }
                if (!whole) continue;
                if (flip_) std::swap(t[1], t[2]);
                out.push_back(t);
            }
        }
    }

    // The boundary seam: per site boundary edge a → b, a fan from a over b and the skirt's copies from
    // b's back to a's (through the crossings between).
    const size_t n = site_boundary_.size();
    std::vector<StitchRef> copies;
    for (uint32_t a = 0; a < n; ++a) {
        const uint32_t b = uint32_t((a + 1) % n);
        const auto site_a = site_at.find(a), site_b = site_at.find(b);
        if (site_a == site_at.end() || site_b == site_at.end()) continue;
        std::vector<uint32_t> path{site_boundary_[b].skirt_point};
        const auto& crossings = site_boundary_[a].crossings;
        path.insert(path.end(), crossings.rbegin(), crossings.rend());
        path.push_back(site_boundary_[a].skirt_point);
        copies.clear();
        for (const uint32_t p : path) {
            const auto at = skirt_at.find(p);
            if (at == skirt_at.end()) break;
            copies.push_back(at->second);
        }
        if (copies.size() != path.size()) continue;
        out.push_back({site_a->second, site_b->second, copies.front()});
        for (size_t k = 0; k + 1 < copies.size(); ++k) out.push_back({site_a->second, copies[k], copies[k + 1]});
    }
}

void EmbeddingStitch::seams(const ModelView& terrain, const ModelView& skirt, const ModelView& site, std::vector<StitchTriangle>& out) const {
    std::vector<StitchRefTriangle> refs;
    seam_vertices(terrain.cubes, skirt.cubes, site.cubes, refs);
    // Each owner's cube morphed once, as its shader morphs it.
    const ModelView* views[3] = {&terrain, &skirt, &site};
    const HlodModel* owners[3] = {models_.terrain.get(), models_.skirt.get(), models_.site.get()};
    std::map<std::pair<int, uint32_t>, std::vector<glm::vec3>> drawn;
    auto position = [&](const StitchRef& r) {
        const int o = int(r.owner);
        auto [at, added] = drawn.try_emplace({o, r.cube});
        if (added) owners[o]->drawn_positions(r.cube, *views[o]->inputs, at->second);
        return at->second[r.vertex];
    };
    for (const StitchRefTriangle& t : refs) out.push_back({StitchVertex{t[0].owner, position(t[0])}, StitchVertex{t[1].owner, position(t[1])}, StitchVertex{t[2].owner, position(t[2])}});
}

}  // namespace strata

#include "preprocess/terrain_cubes.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "preprocess/mesh.h"
#include "preprocess/parallel.h"

namespace strata::terrain {

using build::CubeKey;

uint64_t parent_vertex(const TerrainLevel& finer, const TerrainLevel& coarse, uint64_t v) {
    return coarse.vertex(finer.columns.parent(v % finer.width()), finer.rows.parent(v / finer.width()));
}

namespace {

// The level's triangles by cube, each cube's in row order (consecutive cells nearly always share a cube).
std::unordered_map<CubeKey, std::vector<uint64_t>> triangles_by_cube(const TerrainLevel& level) {
    std::unordered_map<CubeKey, std::vector<uint64_t>> by_cube;
    CubeKey last_key = kNoTriangle;
    std::vector<uint64_t>* last = nullptr;
    for (uint64_t triangle = 0; triangle < level.cube.size(); ++triangle) {
        const CubeKey key = level.cube[triangle];
        if (key == kNoTriangle) continue;
        if (key != last_key) last = &by_cube[key], last_key = key;  // elements keep their place when the map grows
        last->push_back(triangle);
    }
    return by_cube;
}

}  // namespace

void in_row_order(Cube& cube) {
    std::vector<uint32_t> order(cube.vertices.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return cube.vertices[a] < cube.vertices[b]; });
    std::vector<uint32_t> place(order.size());
    std::vector<uint64_t> sorted(order.size());
    for (uint32_t v = 0; v < order.size(); ++v) place[order[v]] = v, sorted[v] = cube.vertices[order[v]];
    cube.vertices.swap(sorted);
    for (uint32_t& index : cube.triangles) index = place[index];
}

namespace {

// One cube from its triangles (2·cell + t, row order): grouped by the child they came from, each group
// in row order, the vertices in row order (as its grid payload lists them, FORMAT.md §5.1). `number`:
// kUnnumbered per level vertex, and left so.
Cube make_cube(CubeKey key, const std::vector<uint64_t>& triangles, const TerrainLevel& level, const TerrainLevel* finer,
               std::vector<uint32_t>& number) {
    Cube cube;
    cube.key = key;
    const size_t cells_per_row = level.width() - 1;
    std::vector<uint8_t> octant(triangles.size(), 0);
    if (finer)
        for (size_t t = 0; t < triangles.size(); ++t) {
            const uint64_t cell = triangles[t] / 2;
            const uint64_t preimage = preimage_cell(*finer, level, size_t(cell % cells_per_row), size_t(cell / cells_per_row));
            octant[t] = uint8_t(build::octant(finer->cube[2 * preimage + triangles[t] % 2]));
        }
    for (uint8_t o : octant) cube.child_counts[o]++;
    std::array<uint32_t, 8> next{};
    for (uint32_t o = 1; o < 8; ++o) next[o] = next[o - 1] + cube.child_counts[o - 1];
    cube.triangles.resize(3 * triangles.size());
    for (size_t t = 0; t < triangles.size(); ++t) {
        const uint64_t cell = triangles[t] / 2;
        const uint32_t place = next[octant[t]]++;
        const std::array<uint64_t, 3> corners = level.corners(size_t(cell % cells_per_row), size_t(cell / cells_per_row), int(triangles[t] % 2));
        for (int c = 0; c < 3; ++c) {
            uint32_t& n = number[corners[size_t(c)]];
            if (n == kUnnumbered) n = uint32_t(cube.vertices.size()), cube.vertices.push_back(corners[size_t(c)]);
            cube.triangles[3 * size_t(place) + size_t(c)] = n;
        }
    }
    for (uint64_t v : cube.vertices) number[v] = kUnnumbered;
    in_row_order(cube);
    return cube;
}

double lookup(const CubeDistances* distances, CubeKey key) {
    if (!distances) return 0;
    auto it = distances->find(key);
    return it == distances->end() ? 0.0 : it->second;
}

}  // namespace

std::vector<Cube> level_cubes(const TerrainLevel& level, const TerrainLevel* finer, const std::vector<Cube>& children,
                              std::vector<uint32_t>& number, const std::function<bool(CubeKey)>& owned) {
    std::unordered_map<CubeKey, std::vector<uint64_t>> by_cube = triangles_by_cube(level);
    for (const Cube& child : children) by_cube[build::parent_key(child.key)];
    std::vector<CubeKey> keys;
    for (const auto& entry : by_cube)
        if (owned(entry.first)) keys.push_back(entry.first);
    std::sort(keys.begin(), keys.end());
    std::vector<Cube> cubes;
    for (CubeKey key : keys) cubes.push_back(make_cube(key, by_cube[key], level, finer, number));
    return cubes;
}

CubeEncoder::CubeEncoder(const build::Frame& f, std::string name, HlodWriter& writer, std::vector<build::CubeErrors>& errors,
                         std::vector<LevelStats>& levels, std::mutex& output_lock, unsigned threads, uint32_t height_shift)
    : f_(f), name_(std::move(name)), writer_(writer), errors_(errors), levels_(levels), output_lock_(output_lock), threads_(threads),
      height_shift_(height_shift) {}

void CubeEncoder::start_level(const TerrainLevel& level, const CubeDistances* forward, const CubeDistances* coverage) {
    normals_ = lattice_normals(level, f_);
    forward_ = forward, coverage_ = coverage;
}

void CubeEncoder::write(const std::vector<const Cube*>& cubes, std::vector<CubeContent>& content, uint32_t level) {
    std::vector<std::vector<uint8_t>> payloads(cubes.size());
    parallel_for(cubes.size(), threads_, [&](size_t c, unsigned) {
        payloads[c] = encode_grid_cube(content[c].data, content[c].grid);
        content[c] = CubeContent();  // its memory back as soon as it is packed
    });
    std::lock_guard lock(output_lock_);
    LevelStats& stats = levels_.at(level);
    stats.level = level;
    for (size_t c = 0; c < cubes.size(); ++c) {
        const CubeKey key = cubes[c]->key;
        HlodNode node;
        node.level = level;
        node.i = build::key_i(key), node.j = build::key_j(key), node.k = build::key_k(key);
        node.vertex_count = uint32_t(cubes[c]->vertices.size()), node.triangle_count = uint32_t(cubes[c]->triangles.size() / 3);
        writer_.add_cube(node, payloads[c]);
        errors_.push_back({node.level, node.i, node.j, node.k, float(lookup(forward_, key)), float(lookup(coverage_, key))});
        stats.cubes++, stats.vertices += node.vertex_count, stats.triangles += node.triangle_count, stats.bytes += payloads[c].size();
    }
}

CubeContent CubeEncoder::cube_data(const Cube& cube, const TerrainLevel& level, const TerrainLevel* coarse, const std::vector<uint32_t>* parent_number) {
    const uint32_t l = level.level, cell[3] = {build::key_i(cube.key), build::key_j(cube.key), build::key_k(cube.key)};
    const double size = f_.cube_size(l);
    CubeContent content;
    CubeData& data = content.data;
    const size_t n = cube.vertices.size();
    content.grid.height_shift = height_shift_;
    content.grid.rows_run_north = level.rows_run_north;
    content.grid.samples.resize(n);
    data.vertices.positions.resize(3 * n);
    data.vertices.normals.resize(2 * n);
    data.parent_vertex.resize(n);
    for (size_t v = 0; v < n; ++v) {
        const uint64_t id = cube.vertices[v];
        const double* p = level.at(id);
        content.grid.samples[v] = {uint32_t(id % level.width()), uint32_t(id / level.width())};
        for (int a = 0; a < 3; ++a) {
            const double low = f_.origin[a] + cell[a] * size;
            const double outside = std::max({0.0, low - p[a], p[a] - low - size}) / size;
            needed_ = std::max(needed_, outside);
            if (a < 2) overhang_xy_ = std::max(overhang_xy_, outside);
            const int64_t stored = build::lattice_offset(f_, p[a], a, l, cell[a]);
            if (stored < 0 || stored > 0xFFFF)
                throw InputError(name_ + ": ground too steep for its cubes (a vertex of level " + std::to_string(l) +
                                 " lies half a cube outside its cell); build with larger cubes (--cube-cells)");
            data.vertices.positions[3 * v + size_t(a)] = uint16_t(stored);
        }
        data.vertices.normals[2 * v] = normals_[2 * id], data.vertices.normals[2 * v + 1] = normals_[2 * id + 1];
        if (!coarse) {
            data.parent_vertex[v] = uint32_t(v);
            continue;
        }
        const uint64_t parent = parent_vertex(level, *coarse, id);
        data.parent_vertex[v] = (*parent_number)[parent];
        const double* q = coarse->at(parent);
        for (int a = 0; a < 3; ++a) {
            needed_ = std::max(needed_, std::abs(p[a] - q[a]) / f_.cube_size(l + 1));
            // A morphing vertex lies between v and P(v): the texture must reach its parent too.
            const double low = f_.origin[a] + cell[a] * size;
            if (a < 2) overhang_xy_ = std::max(overhang_xy_, std::max({0.0, low - q[a], q[a] - low - size}) / size);
        }
    }
    data.indices = cube.triangles;
    data.child_triangle_counts = cube.child_counts;
    return content;
}


// Gives each parent the vertices its children need and it lacks, then encodes the children, parent by
// parent: a parent's vertex order is final once its children's are. `number`: as for make_cube.
void encode_children(std::vector<Cube>& parents, const std::vector<Cube>& children, const TerrainLevel& finer,
                     const TerrainLevel& coarse, std::vector<uint32_t>& number, CubeEncoder& encoder) {
    std::unordered_map<CubeKey, std::vector<uint32_t>> children_of;
    for (uint32_t c = 0; c < children.size(); ++c) children_of[build::parent_key(children[c].key)].push_back(c);
    std::vector<const Cube*> order;
    std::vector<CubeContent> data;
    for (Cube& parent : parents) {
        for (uint64_t v : parent.vertices) number[v] = 0;  // only whether it is there, for now
        const std::vector<uint32_t>& mine = children_of[parent.key];
        for (uint32_t c : mine)
            for (uint64_t v : children[c].vertices) {
                const uint64_t p = parent_vertex(finer, coarse, v);
                if (number[p] == kUnnumbered) number[p] = 0, parent.vertices.push_back(p);
            }
        in_row_order(parent);
        for (uint32_t v = 0; v < parent.vertices.size(); ++v) number[parent.vertices[v]] = v;
        for (uint32_t c : mine) {
            order.push_back(&children[c]);
            data.push_back(encoder.cube_data(children[c], finer, &coarse, &number));
        }
        for (uint64_t v : parent.vertices) number[v] = kUnnumbered;
    }
    encoder.write(order, data, finer.level);
}

}  // namespace strata::terrain

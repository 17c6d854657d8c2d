#include "preprocess/hlod_builder.h"

#include "preprocess/hlod_format.h"
#include "preprocess/index_map.h"
#include "preprocess/parallel.h"
#include "preprocess/quadric.h"
#include "preprocess/radix_sort.h"
#include "preprocess/simplify.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>

namespace strata {
namespace {

// Attribute weights in the collapse cost, against distances measured in cube sizes: a full-range
// colour change costs like moving a tenth of a cube; a UV change of 1 like moving half a cube.
constexpr float kColorWeight = 0.1f;
constexpr float kUvWeight = 0.5f;
// Scanned normals (level L only; coarser levels' normals come from their own triangles): a reversal
// costs like moving a fifth of a cube.
constexpr float kNormalWeight = 0.1f;
// The 16-bit lattice holds a cell plus an overhang below half a cell on each side.
constexpr float kMaxSigma0 = 0.45f;
constexpr int kMaxLevels = 15;  // keeps the lattice integer q = 2^15·cell + … within 31 bits

// ---- cubes -----------------------------------------------------------------------------------

using CubeKey = uint64_t;  // k, j, i in 21 bits each: sorting keys orders cubes k-major
CubeKey make_key(uint64_t i, uint64_t j, uint64_t k) { return (k << 42) | (j << 21) | i; }
uint32_t key_i(CubeKey key) { return uint32_t(key & 0x1FFFFF); }
uint32_t key_j(CubeKey key) { return uint32_t((key >> 21) & 0x1FFFFF); }
uint32_t key_k(CubeKey key) { return uint32_t(key >> 42); }
CubeKey parent_key(CubeKey key) { return make_key(key_i(key) >> 1, key_j(key) >> 1, key_k(key) >> 1); }
uint32_t octant(CubeKey key) { return (key_i(key) & 1) | (key_j(key) & 1) << 1 | (key_k(key) & 1) << 2; }

struct Cube {
    CubeKey key = 0;
    uint32_t first = 0, count = 0;                // triangle range in Level::triangles
    std::array<uint32_t, 8> child_counts{};       // how that range splits by the child it came from
    float error = 0;                              // against M_L, model units
};

// One level M_l: wedges (vertex + attributes), the points (positions) they sit on, triangles grouped by cube.
struct Level {
    uint32_t level = 0;
    std::vector<float> positions;                 // 3 per wedge
    std::vector<uint8_t> colors;                  // 4 per wedge, or empty
    std::vector<float> uvs;                       // 2 per wedge, or empty
    std::vector<std::array<int16_t, 2>> normals;  // per wedge, octahedral
    bool scanned_normals = false;                 // normals came with the input (an attribute to keep)
    std::vector<uint32_t> wedge_point;
    uint32_t point_count = 0;
    std::vector<uint32_t> triangles;
    std::vector<Cube> cubes;                      // in key order

    uint32_t wedge_count() const { return uint32_t(wedge_point.size()); }
};

struct Frame {
    double origin[3];
    double root_size;
    uint32_t max_level;
    uint32_t block;
    float sigma0;
    double cube_size(uint32_t level) const { return root_size / double(uint64_t(1) << level); }
};

// Adds the wall time of its scope to a counter.
class StageTimer {
public:
    explicit StageTimer(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
    ~StageTimer() { total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

private:
    double& total_;
    std::chrono::steady_clock::time_point start_;
};

// ---- setting up level L -------------------------------------------------------------------


Frame make_frame(const Mesh& mesh, const std::string& source) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < mesh.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) {
            double x = mesh.positions[3 * v + a];
            if (!std::isfinite(x))
                throw InputError(source + ": vertex " + std::to_string(v) + " has a non-finite coordinate");
            lo[a] = std::min(lo[a], x), hi[a] = std::max(hi[a], x);
        }
    // The frame lives in the mesh's float space (partition, lattice and simplifier all measure float
    // positions against it); the true origin, mesh.origin + f.origin, is what the header records.
    Frame f{};
    for (int a = 0; a < 3; ++a) f.origin[a] = lo[a];
    f.root_size = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    if (!(f.root_size > 0)) throw InputError(source + ": every vertex lies at one point");
    return f;
}

// Points: one per distinct position, shared by the seam copies (wedges) that sit on it.
uint32_t weld_points(const std::vector<float>& positions, std::vector<uint32_t>& wedge_point) {
    const uint32_t wedges = uint32_t(positions.size() / 3);
    wedge_point.resize(wedges);
    IndexMap first_wedge(wedges);
    uint32_t points = 0;
    std::vector<uint32_t> point_of_first(wedges);
    for (uint32_t w = 0; w < wedges; ++w) {
        uint32_t bits[3];
        for (int a = 0; a < 3; ++a) {
            float x = positions[3 * w + a] + 0.0f;  // −0 → +0
            std::memcpy(&bits[a], &x, 4);
        }
        uint64_t hash = (uint64_t(bits[0]) * 73856093u) ^ (uint64_t(bits[1]) * 19349663u) ^ (uint64_t(bits[2]) * 83492791u);
        uint32_t found = first_wedge.find_or_insert(hash, w, [&](uint32_t other) {
            return std::memcmp(&positions[3 * other], &positions[3 * w], 12) == 0 ||
                   (positions[3 * other] == positions[3 * w] && positions[3 * other + 1] == positions[3 * w + 1] &&
                    positions[3 * other + 2] == positions[3 * w + 2]);
        });
        if (found == w) point_of_first[w] = points++;
        wedge_point[w] = point_of_first[found];
    }
    return points;
}

std::array<int64_t, 3> cell_of(const Frame& f, const float* a, const float* b, const float* c, uint32_t level) {
    const double scale = double(uint64_t(1) << level) / f.root_size;
    const int64_t last = int64_t(1) << level;
    std::array<int64_t, 3> cell;
    for (int x = 0; x < 3; ++x) {
        double bary = (double(a[x]) + double(b[x]) + double(c[x])) / 3.0;
        cell[x] = std::clamp<int64_t>(int64_t(std::floor((bary - f.origin[x]) * scale)), 0, last - 1);
    }
    return cell;
}

// Smallest L at which the typical triangle's cell (the load-weighted mean Σn²/Σn over a sample)
// holds at most `leaf` triangles.
uint32_t choose_levels(const Mesh& mesh, const Frame& f, int leaf) {
    const size_t triangles = mesh.triangle_count();
    const size_t stride = std::max<size_t>(1, triangles / 65536);
    std::vector<CubeKey> keys;
    for (uint32_t level = 0; level < kMaxLevels; ++level) {
        keys.clear();
        for (size_t t = 0; t < triangles; t += stride) {
            const uint32_t* tri = &mesh.indices[3 * t];
            auto c = cell_of(f, &mesh.positions[3 * tri[0]], &mesh.positions[3 * tri[1]], &mesh.positions[3 * tri[2]], level);
            keys.push_back(make_key(c[0], c[1], c[2]));
        }
        std::sort(keys.begin(), keys.end());
        double weighted = 0;
        for (size_t i = 0, j; i < keys.size(); i = j) {
            for (j = i; j < keys.size() && keys[j] == keys[i]; ++j) {
            }
            weighted += double(j - i) * double(j - i);
        }
        double typical = weighted / double(keys.size()) * double(stride);
        if (typical <= leaf) return level;
    }
    return kMaxLevels;
}

// Longest edge in the max norm, the quantity constraint 1 bounds by σ0·s_L.
double longest_edge(const Mesh& mesh) {
    float longest = 0;
    for (size_t t = 0; t < mesh.indices.size(); t += 3)
        for (int c = 0; c < 3; ++c) {
            const float* a = &mesh.positions[3 * mesh.indices[t + c]];
            const float* b = &mesh.positions[3 * mesh.indices[t + (c + 1) % 3]];
            longest = std::max({longest, std::fabs(a[0] - b[0]), std::fabs(a[1] - b[1]), std::fabs(a[2] - b[2])});
        }
    return longest;
}

// Level L: every triangle in the cell of its barycenter; triangles are never cut (000 §3.2.3).
Level partition(Mesh& mesh, const Frame& f, bool positions_may_repeat, unsigned threads) {
    const uint32_t L = f.max_level;
    const size_t triangles = mesh.triangle_count();
    // Sort by the dense linear index k·4^L + j·2^L + i (same order as CubeKey, fewer bits to sort).
    std::vector<uint64_t> linear(triangles);
    constexpr size_t kChunk = 1 << 16;
    parallel_for((triangles + kChunk - 1) / kChunk, threads, [&](size_t chunk, unsigned) {
        for (size_t t = chunk * kChunk; t < std::min(triangles, (chunk + 1) * kChunk); ++t) {
            const uint32_t* tri = &mesh.indices[3 * t];
            auto c = cell_of(f, &mesh.positions[3 * tri[0]], &mesh.positions[3 * tri[1]], &mesh.positions[3 * tri[2]], L);
            linear[t] = uint64_t(c[2]) << (2 * L) | uint64_t(c[1]) << L | uint64_t(c[0]);
        }
    });
    std::vector<uint32_t> order(triangles);
    std::iota(order.begin(), order.end(), 0u);
    radix_sort_ids(linear, order, int(3 * L));
    const uint64_t mask = (uint64_t(1) << L) - 1;
    auto key_of = [&](uint32_t t) { return make_key(linear[t] & mask, (linear[t] >> L) & mask, linear[t] >> (2 * L)); };

    Level level;
    level.level = L;
    level.triangles.resize(3 * triangles);
    parallel_for((triangles + kChunk - 1) / kChunk, threads, [&](size_t chunk, unsigned) {
        for (size_t t = chunk * kChunk; t < std::min(triangles, (chunk + 1) * kChunk); ++t)
            std::memcpy(&level.triangles[3 * t], &mesh.indices[3 * size_t(order[t])], 12);
    });
    for (size_t t = 0; t < triangles; ++t) {
        if (t == 0 || linear[order[t]] != linear[order[t - 1]]) level.cubes.push_back(Cube{key_of(order[t]), uint32_t(t), 0, {}, 0});
        ++level.cubes.back().count;
    }
    for (Cube& c : level.cubes) c.child_counts[0] = c.count;
    std::vector<uint32_t>().swap(mesh.indices);
    // A welded mesh with no attribute but position has one wedge per point.
    const bool one_wedge_per_point = !positions_may_repeat;
    level.positions = std::move(mesh.positions);
    level.colors = std::move(mesh.colors);
    level.uvs = std::move(mesh.uvs);
    if (one_wedge_per_point) {
        level.wedge_point.resize(level.positions.size() / 3);
        std::iota(level.wedge_point.begin(), level.wedge_point.end(), 0u);
        level.point_count = level.wedge_count();
    } else {
        level.point_count = weld_points(level.positions, level.wedge_point);
    }
    return level;
}

// Area-weighted vertex normals over every triangle of the level, across cube and block borders,
// shared by the seam copies of a point (000 §4.2.5).
void compute_normals(Level& level) {
    std::vector<float> sum(3 * size_t(level.point_count), 0.0f);
    for (size_t t = 0; t < level.triangles.size(); t += 3) {
        const float* p[3];
        for (int c = 0; c < 3; ++c) p[c] = &level.positions[3 * level.triangles[t + c]];
        Vec3 a{p[0][0], p[0][1], p[0][2]}, b{p[1][0], p[1][1], p[1][2]}, d{p[2][0], p[2][1], p[2][2]};
        Vec3 n = cross(b - a, d - a);  // length = twice the area: the area weighting
        for (int c = 0; c < 3; ++c) {
            float* s = &sum[3 * size_t(level.wedge_point[level.triangles[t + c]])];
            s[0] += n.x, s[1] += n.y, s[2] += n.z;
        }
    }
    level.normals.resize(level.wedge_count());
    for (uint32_t w = 0; w < level.wedge_count(); ++w) {
        const float* s = &sum[3 * size_t(level.wedge_point[w])];
        level.normals[w] = encode_normal(s[0], s[1], s[2]);
    }
}

void take_input_normals(Level& level, const std::vector<float>& normals) {
    level.scanned_normals = true;
    level.normals.resize(level.wedge_count());
    for (uint32_t w = 0; w < level.wedge_count(); ++w)
        level.normals[w] = encode_normal(normals[3 * w], normals[3 * w + 1], normals[3 * w + 2]);
}

// ---- simplifying M_l into M_{l−1} -----------------------------------------------------------

struct Block {
    CubeKey key;
    std::vector<uint32_t> cubes;  // indices into Level::cubes, in key order
};

// n×n×n cubes per block, the block grid offset so that the origin is a block centre (000 §3.2.4,
// "second method"): block b spans cubes [b·n − n/2, b·n + n/2) on each axis.
std::vector<Block> make_blocks(const Level& level, uint32_t n) {
    std::vector<std::pair<CubeKey, uint32_t>> keyed;
    for (uint32_t c = 0; c < level.cubes.size(); ++c) {
        CubeKey k = level.cubes[c].key;
        keyed.emplace_back(make_key((key_i(k) + n / 2) / n, (key_j(k) + n / 2) / n, (key_k(k) + n / 2) / n), c);
    }
    std::sort(keyed.begin(), keyed.end());
    std::vector<Block> blocks;
    for (size_t i = 0; i < keyed.size(); ++i) {
        if (i == 0 || keyed[i].first != keyed[i - 1].first) blocks.push_back(Block{keyed[i].first, {}});
        blocks.back().cubes.push_back(keyed[i].second);
    }
    return blocks;
}

// Points used by triangles of two or more blocks: never removed, so blocks simplify independently.
std::vector<uint8_t> border_points(const Level& level, const std::vector<Block>& blocks) {
    std::vector<uint32_t> owner(level.point_count, ~0u);
    std::vector<uint8_t> border(level.point_count, 0);
    for (uint32_t b = 0; b < blocks.size(); ++b)
        for (uint32_t c : blocks[b].cubes) {
            const Cube& cube = level.cubes[c];
            for (size_t i = 3 * size_t(cube.first); i < 3 * size_t(cube.first + cube.count); ++i) {
                uint32_t p = level.wedge_point[level.triangles[i]];
                if (owner[p] == ~0u) owner[p] = b;
                else if (owner[p] != b) border[p] = 1;
            }
        }
    return border;
}

// What one block hands back: per cube (in Block::cubes order) its surviving triangles, already mapped.
struct BlockOutput {
    std::vector<uint32_t> triangles;      // level-l wedge ids
    std::vector<uint32_t> cube_counts;
    std::vector<float> cube_step_error;   // model units
};

struct Scratch {
    IndexMap wedges{0}, points{0};
    std::vector<uint32_t> local_to_wedge, local_to_point;
    BlockMesh mesh;
};

BlockOutput simplify_one_block(const Level& level, const Block& block, const std::vector<uint8_t>& border,
                               const Frame& f, const BuildSettings& s, std::vector<uint32_t>& remap, Scratch& scratch) {
    const uint32_t l = level.level;
    const double size = f.cube_size(l), n = f.block;
    double center[3] = {f.origin[0] + double(key_i(block.key)) * n * size, f.origin[1] + double(key_j(block.key)) * n * size,
                        f.origin[2] + double(key_k(block.key)) * n * size};
    uint32_t block_triangles = 0;
    for (uint32_t c : block.cubes) block_triangles += level.cubes[c].count;

    // Scratch keeps its capacity from block to block: no allocation churn in the hot loop.
    BlockMesh& m = scratch.mesh;
    m.point_positions.clear(), m.point_locked.clear(), m.wedge_point.clear(), m.wedge_attributes.clear();
    m.triangles.clear();
    m.attribute_count = (level.colors.empty() ? 0 : 4) + (level.uvs.empty() ? 0 : 2) + (level.scanned_normals ? 3 : 0);
    scratch.wedges.reset(block_triangles / 2 + 64);  // a closed mesh has about half as many vertices
    scratch.points.reset(block_triangles / 2 + 64);
    scratch.local_to_wedge.clear();
    scratch.local_to_point.clear();
    m.triangles.reserve(3 * block_triangles);
    for (uint32_t c : block.cubes) {
        const Cube& cube = level.cubes[c];
        for (size_t i = 3 * size_t(cube.first); i < 3 * size_t(cube.first + cube.count); ++i) {
            uint32_t w = level.triangles[i];
            uint32_t local = scratch.wedges.find_or_insert(w, uint32_t(scratch.local_to_wedge.size()));
            if (local == scratch.local_to_wedge.size()) {
                scratch.local_to_wedge.push_back(w);
                uint32_t p = level.wedge_point[w];
                uint32_t lp = scratch.points.find_or_insert(p, uint32_t(scratch.local_to_point.size()));
                if (lp == scratch.local_to_point.size()) {
                    scratch.local_to_point.push_back(p);
                    for (int a = 0; a < 3; ++a)
                        m.point_positions.push_back(float((double(level.positions[3 * w + a]) - center[a]) / size));
                    m.point_locked.push_back(border[p]);
                }
                m.wedge_point.push_back(lp);
                for (int k = 0; k < 4 && !level.colors.empty(); ++k)
                    m.wedge_attributes.push_back(level.colors[4 * size_t(w) + k] * (kColorWeight / 255.0f));
                for (int k = 0; k < 2 && !level.uvs.empty(); ++k)
                    m.wedge_attributes.push_back(level.uvs[2 * size_t(w) + k] * kUvWeight);
                if (level.scanned_normals)
                    for (float x : decode_normal(level.normals[w][0], level.normals[w][1]))
                        m.wedge_attributes.push_back(x * kNormalWeight);
            }
            m.triangles.push_back(local);
        }
    }

    SimplifyLimits limits;
    limits.target_triangles = uint32_t(std::ceil(double(block_triangles) * s.ratio));
    limits.max_travel = f.sigma0 * 0.5f;                       // σ0·s_{l+1}, in cube sizes
    if (s.error > 0) limits.max_error = s.error * 2.0f;        // ε_q·s_{l−1}, in cube sizes
    SimplifyResult result = simplify_block(m, limits);

    for (uint32_t local = 0; local < result.wedge_remap.size(); ++local)
        if (result.wedge_remap[local] != local)
            remap[scratch.local_to_wedge[local]] = scratch.local_to_wedge[result.wedge_remap[local]];

    BlockOutput out;
    out.triangles.reserve(3 * size_t(result.triangles_left));
    size_t corner = 0;
    for (uint32_t c : block.cubes) {
        uint32_t kept = 0;
        float step = 0;
        for (uint32_t t = 0; t < level.cubes[c].count; ++t, corner += 3) {
            uint32_t a = result.wedge_remap[m.triangles[corner]], b = result.wedge_remap[m.triangles[corner + 1]],
                     d = result.wedge_remap[m.triangles[corner + 2]];
            uint32_t pa = m.wedge_point[a], pb = m.wedge_point[b], pd = m.wedge_point[d];
            if (pa == pb || pb == pd || pa == pd) continue;
            step = std::max({step, result.point_error[pa], result.point_error[pb], result.point_error[pd]});
            for (uint32_t x : {a, b, d}) out.triangles.push_back(scratch.local_to_wedge[x]);
            ++kept;
        }
        out.cube_counts.push_back(kept);
        out.cube_step_error.push_back(float(step * size));
    }
    return out;
}

struct Simplified {
    Level next;
    std::vector<uint32_t> parent;  // level-l wedge → its parent, a level-(l−1) wedge
};

Simplified simplify_level(const Level& level, const Frame& f, const BuildSettings& s, const Progress& progress) {
    const uint32_t l = level.level;
    std::vector<Block> blocks = make_blocks(level, f.block);
    std::vector<uint8_t> border = border_points(level, blocks);
    std::vector<uint32_t> remap(level.wedge_count());
    std::iota(remap.begin(), remap.end(), 0u);

    const unsigned threads = resolve_thread_count(s.threads);
    std::vector<Scratch> scratch(threads);
    std::vector<BlockOutput> outputs(blocks.size());
    std::atomic<uint64_t> done{0};
    const std::string stage = "simplify level " + std::to_string(l);
    const double total = double(level.triangles.size() / 3);
    parallel_for(blocks.size(), threads, [&](size_t b, unsigned worker) {
        progress.check();
        outputs[b] = simplify_one_block(level, blocks[b], border, f, s, remap, scratch[worker]);
        uint64_t finished = done += [&] {
            uint64_t t = 0;
            for (uint32_t c : blocks[b].cubes) t += level.cubes[c].count;
            return t;
        }();
        if (worker == 0) progress(stage, double(finished), total, "tri");
    });
    progress(stage, total, total, "tri");

    // Survivors keep their order; ranks give their level-(l−1) ids, independent of thread count.
    Simplified out;
    Level& next = out.next;
    next.level = l - 1;
    std::vector<uint32_t> new_wedge(level.wedge_count(), ~0u), new_point(level.point_count, ~0u);
    for (uint32_t w = 0; w < level.wedge_count(); ++w) {
        if (remap[w] != w) continue;
        new_wedge[w] = next.wedge_count();
        uint32_t p = level.wedge_point[w];
        if (new_point[p] == ~0u) new_point[p] = next.point_count++;
        next.wedge_point.push_back(new_point[p]);
        next.positions.insert(next.positions.end(), &level.positions[3 * size_t(w)], &level.positions[3 * size_t(w) + 3]);
        if (!level.colors.empty())
            next.colors.insert(next.colors.end(), &level.colors[4 * size_t(w)], &level.colors[4 * size_t(w) + 4]);
        if (!level.uvs.empty()) next.uvs.insert(next.uvs.end(), &level.uvs[2 * size_t(w)], &level.uvs[2 * size_t(w) + 2]);
    }
    out.parent.resize(level.wedge_count());
    for (uint32_t w = 0; w < level.wedge_count(); ++w) out.parent[w] = new_wedge[remap[w]];

    // Each surviving triangle goes to its own cube's parent, grouped by the child it came from
    // (BuildNewCube: simplified triangles are never re-bucketed by barycenter).
    struct Child {
        CubeKey parent;
        uint32_t octant, block, slot, first;
    };
    std::vector<Child> children;
    for (uint32_t b = 0; b < blocks.size(); ++b) {
        uint32_t first = 0;
        for (uint32_t slot = 0; slot < blocks[b].cubes.size(); ++slot) {
            CubeKey key = level.cubes[blocks[b].cubes[slot]].key;
            children.push_back(Child{parent_key(key), octant(key), b, slot, first});
            first += outputs[b].cube_counts[slot];
        }
    }
    std::sort(children.begin(), children.end(), [](const Child& a, const Child& b) {
        return a.parent < b.parent || (a.parent == b.parent && a.octant < b.octant);
    });
    for (const Child& child : children) {
        if (next.cubes.empty() || next.cubes.back().key != child.parent)
            next.cubes.push_back(Cube{child.parent, uint32_t(next.triangles.size() / 3), 0, {}, 0});
        Cube& parent = next.cubes.back();
        const BlockOutput& o = outputs[child.block];
        uint32_t count = o.cube_counts[child.slot];
        for (size_t i = 3 * size_t(child.first); i < 3 * size_t(child.first + count); ++i)
            next.triangles.push_back(new_wedge[o.triangles[i]]);
        parent.count += count;
        parent.child_counts[child.octant] += count;
        const Cube& from = level.cubes[blocks[child.block].cubes[child.slot]];
        parent.error = std::max(parent.error, from.error + o.cube_step_error[child.slot]);
    }
    return out;
}

// ---- writing cubes --------------------------------------------------------------------------

struct Extra {
    CubeKey cube;
    uint32_t wedge;
    bool operator<(const Extra& o) const { return cube < o.cube || (cube == o.cube && wedge < o.wedge); }
    bool operator==(const Extra& o) const { return cube == o.cube && wedge == o.wedge; }
};

// q = round((x − O)/h_l), as a multiplication by 1/h_l (a power of two over L_c): the same code
// quantizes a vertex in its cube and as a parent copy, so the two always agree.
uint16_t lattice(const Frame& f, float x, int axis, uint32_t level, uint32_t cell) {
    const double inverse_step = double(uint64_t(1) << (level + kLatticeBits)) / f.root_size;
    int64_t q = std::llround((double(x) - f.origin[axis]) * inverse_step);
    int64_t stored = q - (int64_t(cell) << kLatticeBits) + kLatticeBias;
    if (stored < 0 || stored > 0xFFFF)
        throw std::runtime_error("internal error: a level-" + std::to_string(level) +
                                 " vertex lies outside its cell's σ0 overhang");
    return uint16_t(stored);
}

// Appends wedge w of `level` to a cube's vertex arrays, on that level's lattice relative to `cell`.
void append_vertex(VertexArrays& out, const Level& level, uint32_t w, const uint32_t cell[3], const Frame& f,
                   uint32_t flags) {
    for (int a = 0; a < 3; ++a) out.positions.push_back(lattice(f, level.positions[3 * size_t(w) + a], a, level.level, cell[a]));
    out.normals.insert(out.normals.end(), level.normals[w].begin(), level.normals[w].end());
    if (flags & kHasColors) out.colors.insert(out.colors.end(), &level.colors[4 * size_t(w)], &level.colors[4 * size_t(w) + 4]);
    if (flags & kHasUvs) out.uvs.insert(out.uvs.end(), &level.uvs[2 * size_t(w)], &level.uvs[2 * size_t(w) + 2]);
}

struct EncodedCube {
    HlodNode node;
    std::vector<uint8_t> payload;
    std::vector<Extra> extras;  // parents this cube needs that the parent cube's triangles do not use
};

// One cube of level l, with its vertices' parents taken from `parent_level` through `parent`.
EncodedCube encode_level_cube(const Level& level, const Cube& cube, const Level& parent_level,
                              const std::vector<uint32_t>& parent, std::span<const Extra> extras, const Frame& f,
                              uint32_t flags) {
    const uint32_t l = level.level;
    const bool root = l == 0;
    const CubeKey parent_cube = root ? cube.key : parent_key(cube.key);

    // Index order for the codec: vertex-cache order within each child group keeps the groups whole.
    std::vector<uint32_t> global(level.triangles.begin() + 3 * size_t(cube.first),
                                 level.triangles.begin() + 3 * size_t(cube.first + cube.count));
    IndexMap local_of(global.size() / 4 + extras.size() + 16);  // about half as many vertices as triangles
    std::vector<uint32_t> vertices;
    std::vector<uint32_t> indices(global.size());
    for (size_t i = 0; i < global.size(); ++i) {
        uint32_t local = local_of.find_or_insert(global[i], uint32_t(vertices.size()));
        if (local == vertices.size()) vertices.push_back(global[i]);
        indices[i] = local;
    }
    size_t group_first = 0;
    for (uint32_t count : cube.child_counts) {
        if (count) meshopt_optimizeVertexCacheFifo(&indices[group_first], &indices[group_first], 3 * size_t(count), vertices.size(), 16);
        group_first += 3 * size_t(count);
    }
    std::vector<uint32_t> fetch_remap(vertices.size());
    size_t used = meshopt_optimizeVertexFetchRemap(fetch_remap.data(), indices.data(), indices.size(), vertices.size());
    std::vector<uint32_t> ordered(used);
    for (size_t v = 0; v < vertices.size(); ++v) ordered[fetch_remap[v]] = vertices[v];
    for (uint32_t& i : indices) i = fetch_remap[i];
    for (const Extra& e : extras)
        if (local_of.find(e.wedge) == IndexMap::kMissing) ordered.push_back(e.wedge);

    CubeData data;
    data.indices = std::move(indices);
    data.child_triangle_counts = cube.child_counts;
    const uint32_t cell[3] = {key_i(cube.key), key_j(cube.key), key_k(cube.key)};
    const uint32_t parent_cell[3] = {key_i(parent_cube), key_j(parent_cube), key_k(parent_cube)};
    IndexMap parent_slot(ordered.size() / 2 + 16);
    for (VertexArrays* a : {&data.vertices, &data.parents}) {
        a->positions.reserve(3 * ordered.size()), a->normals.reserve(2 * ordered.size());
        if (flags & kHasColors) a->colors.reserve(4 * ordered.size());
        if (flags & kHasUvs) a->uvs.reserve(2 * ordered.size());
    }
    data.parent_of.reserve(ordered.size());
    for (uint32_t w : ordered) {
        append_vertex(data.vertices, level, w, cell, f, flags);
        uint32_t slot = parent_slot.find_or_insert(parent[w], data.parents.size());
        if (slot == data.parents.size()) append_vertex(data.parents, parent_level, parent[w], parent_cell, f, flags);
        data.parent_of.push_back(slot);
    }

    EncodedCube out;
    // A vertex all of whose triangles here collapse away may have a parent the parent cube's own
    // triangles never use; that parent is stored there anyway, so P always lands in the parent cube.
    if (!root) {
        std::vector<uint8_t> kept(ordered.size(), 0);
        for (size_t t = 0; t < data.indices.size(); t += 3) {
            uint32_t p[3];
            for (int c = 0; c < 3; ++c) p[c] = parent_level.wedge_point[parent[ordered[data.indices[t + c]]]];
            if (p[0] != p[1] && p[1] != p[2] && p[0] != p[2])
                for (int c = 0; c < 3; ++c) kept[data.indices[t + c]] = 1;
        }
        for (size_t v = 0; v < ordered.size(); ++v)
            if (!kept[v]) out.extras.push_back(Extra{parent_cube, parent[ordered[v]]});
    }
    out.node.level = l;
    out.node.i = cell[0], out.node.j = cell[1], out.node.k = cell[2];
    out.node.error = cube.error;
    out.node.vertex_count = data.vertex_count();
    out.node.triangle_count = data.triangle_count();
    out.payload = encode_cube(data, flags);
    return out;
}

// Writes every cube of `level`; returns the extras its children-to-be (level l−1) must hold.
std::vector<Extra> write_level(const Level& level, const Level& parent_level, const std::vector<uint32_t>& parent,
                               const std::vector<Extra>& extras, const Frame& f, uint32_t flags, unsigned threads,
                               HlodWriter& writer, LevelStats& stats, const Progress& progress) {
    const std::string stage = "write level " + std::to_string(level.level);
    std::vector<Extra> needed;
    const size_t batch = size_t(threads) * 128;
    std::vector<EncodedCube> encoded;
    for (size_t first = 0; first < level.cubes.size(); first += batch) {
        progress.check();
        size_t count = std::min(batch, level.cubes.size() - first);
        encoded.assign(count, EncodedCube{});
        parallel_for(count, threads, [&](size_t i, unsigned) {
            const Cube& cube = level.cubes[first + i];
            auto lo = std::lower_bound(extras.begin(), extras.end(), Extra{cube.key, 0});
            auto hi = std::lower_bound(extras.begin(), extras.end(), Extra{cube.key + 1, 0});
            encoded[i] = encode_level_cube(level, cube, parent_level, parent, std::span(lo, hi), f, flags);
        });
        for (EncodedCube& e : encoded) {
            writer.add_cube(e.node, e.payload);
            stats.cubes++, stats.vertices += e.node.vertex_count, stats.triangles += e.node.triangle_count;
            stats.bytes += e.payload.size();
            needed.insert(needed.end(), e.extras.begin(), e.extras.end());
        }
        progress(stage, double(first + count), double(level.cubes.size()), "cube");
    }
    std::sort(needed.begin(), needed.end());
    needed.erase(std::unique(needed.begin(), needed.end()), needed.end());
    return needed;
}

}  // namespace

void check_settings(const BuildSettings& s) {
    auto fail = [](const std::string& what) { throw InputError("build settings: " + what); };
    if (s.levels < -1 || s.levels > kMaxLevels) fail("--levels must be auto or 0.." + std::to_string(kMaxLevels));
    if (s.block < 4 || s.block % 4 != 0 || s.block > 64) fail("--block must be a multiple of 4 from 4 to 64");
    if (!(s.ratio > 0 && s.ratio < 1)) fail("--ratio must lie strictly between 0 and 1");
    if (!(s.sigma0 >= 0.1f && s.sigma0 <= kMaxSigma0)) fail("--sigma0 must lie in [0.1, 0.45]");
    if (!(s.error == -1 || s.error > 0)) fail("--error must be positive");
    if (s.threads < 0) fail("--threads must be 0 (all cores) or more");
    if (s.leaf_triangles < 16) fail("leaf size must be at least 16 triangles");
}

BuildReport build_hlod(Mesh&& mesh, const std::filesystem::path& output, const BuildSettings& settings,
                       const std::string& source_name, const Progress& progress) {
    check_settings(settings);
    if (mesh.triangle_count() == 0) throw InputError(source_name + ": the mesh has no triangles");
    if (mesh.vertex_count() >= 0xFFFFFFFFu) throw InputError(source_name + ": more than 2^32 vertices");
    BuildReport report;
    Frame f = make_frame(mesh, source_name);
    f.block = uint32_t(settings.block);

    // σ0 and L together (DESIGN.md §2): pick L, then the σ0 the data needs; never break constraint 1.
    const bool automatic = settings.levels < 0;
    uint32_t L = automatic ? choose_levels(mesh, f, settings.leaf_triangles) : uint32_t(settings.levels);
    // At L = 0 every vertex lies in the root cell and nothing morphs: no edge bound applies there,
    // so capping L always ends in a model.
    const double edge = longest_edge(mesh);
    auto needed_sigma0 = [&](uint32_t levels) { return levels == 0 ? 0.0 : edge / f.cube_size(levels); };
    while (needed_sigma0(L) > kMaxSigma0) {
        if (!automatic || L == 0)
            throw InputError(source_name + ": edges up to " + std::to_string(edge) + " long need σ0 = " +
                             std::to_string(needed_sigma0(L)) + " > " + std::to_string(kMaxSigma0) +
                             " at " + std::to_string(L) + " levels; use fewer --levels");
        --L;
        report.notes.push_back("levels capped at " + std::to_string(L) + ": the input has edges of " +
                               std::to_string(edge) + " (max norm)");
    }
    f.max_level = L;
    f.sigma0 = std::max(settings.sigma0, float(needed_sigma0(L)));
    if (f.sigma0 > settings.sigma0)
        report.notes.push_back("σ0 raised to " + std::to_string(f.sigma0) + " by the input's longest edge");

    HlodHeader header;
    header.flags = (mesh.has_colors() ? kHasColors : 0u) | (mesh.has_uvs() ? kHasUvs : 0u);
    for (int a = 0; a < 3; ++a) header.origin[a] = mesh.origin[size_t(a)] + f.origin[a];  // in double: survey coordinates
    header.root_size = f.root_size;
    header.max_level = L;
    header.block_size = f.block;
    header.sigma0 = f.sigma0;
    header.ratio = settings.ratio;
    header.error_limit = settings.error;
    header.input_vertices = mesh.vertex_count();
    header.input_triangles = mesh.triangle_count();
    header.source = source_name;
    header.texture = mesh.texture;

    HlodWriter writer(output);
    const unsigned threads = resolve_thread_count(settings.threads);
    progress("partition", 0, 1, "");
    std::vector<float> input_normals = std::move(mesh.normals);
    Level level;
    {
        StageTimer timer(report.partition_seconds);
        level = partition(mesh, f, !input_normals.empty() || mesh.has_colors() || mesh.has_uvs(), threads);
    }
    {
        StageTimer timer(report.normals_seconds);
        if (!input_normals.empty()) take_input_normals(level, input_normals);
        else compute_normals(level);
        std::vector<float>().swap(input_normals);
    }
    progress.check();

    std::vector<Extra> extras;
    float error_q = 0;
    auto note_errors = [&](const Level& l) {
        for (const Cube& c : l.cubes) error_q = std::max(error_q, float(c.error / f.cube_size(l.level)));
    };
    while (level.level > 0) {
        Simplified s;
        {
            StageTimer timer(report.simplify_seconds);
            s = simplify_level(level, f, settings, progress);
        }
        {
            StageTimer timer(report.normals_seconds);
            compute_normals(s.next);
        }
        report.levels.push_back(LevelStats{level.level});
        {
            StageTimer timer(report.write_seconds);
            extras = write_level(level, s.next, s.parent, extras, f, header.flags, threads, writer,
                                 report.levels.back(), progress);
        }
        note_errors(level);
        level = std::move(s.next);
    }
    std::vector<uint32_t> identity(level.wedge_count());
    std::iota(identity.begin(), identity.end(), 0u);
    report.levels.push_back(LevelStats{0});
    {
        StageTimer timer(report.write_seconds);
        write_level(level, level, identity, extras, f, header.flags, threads, writer, report.levels.back(), progress);
    }
    note_errors(level);

    header.error_q = error_q;
    writer.finish(header);
    report.max_level = L;
    report.sigma0 = f.sigma0;
    report.error_q = error_q;
    std::error_code ec;
    report.output_bytes = std::filesystem::file_size(output, ec);
    return report;
}

}  // namespace strata

#include "preprocess/terrain_build.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <functional>
#include <mutex>
#include <numeric>
#include <optional>
#include <unordered_map>

#include <unistd.h>

#include "preprocess/byte_size.h"
#include "preprocess/elevation_raster.h"
#include "preprocess/error_bound.h"
#include "preprocess/hlod_format.h"
#include "preprocess/mesh.h"
#include "preprocess/parallel.h"
#include "preprocess/terrain_bounds.h"
#include "preprocess/terrain_cubes.h"
#include "preprocess/terrain_frame.h"
#include "preprocess/terrain_heights.h"
#include "preprocess/terrain_pyramid.h"

namespace strata {
namespace {

using build::CubeKey;
using terrain::Cube;
using terrain::kNoTriangle;
using terrain::TerrainLevel;

constexpr float kLeastSigma0 = 0.1f, kMostSigma0 = 0.45f;
// What a sample of a tile's window costs while its levels are built: positions, flags, cube keys,
// normals and numbering over all its levels, and its share of the cubes.
constexpr double kTileBytesPerSample = 170;
// What a level-T sample costs for the whole raster: the same, kept until the coarse levels are built.
constexpr double kCoarseBytesPerSample = 170;
// Level-T cells a tile reads beyond the samples it owns on each side: what its levels need to come out
// as they would from the whole raster, with room to spare: a vertex of level l depends on the level
// below within one of its cells (two level-T cells over all the tile's levels), and the bounds search
// two cells around a dropped fragment (terrain_bounds.cpp).
constexpr uint64_t kMarginCells = 5;

// Heights lie on a lattice 2^shift times as coarse as the level's position lattice (2^-15 of a cube),
// so that a payload codes them in fewer bits (FORMAT.md §6): the same shift on every level, so a
// level's heights are within half its quantum of the finer level's.
double height_quantum(const build::Frame& f, uint32_t level, uint32_t shift) {
    return std::ldexp(f.cube_size(level), int(shift) - kLatticeBits);
}

// The shift whose level-L quantum moves no height by more than `tolerance` metres (at most 14: the
// lattice's stored values keep their 16 bits). Default: 1/128 of the sample spacing, a slope error
// under half a degree.
uint32_t height_shift(const build::Frame& f, std::optional<double> tolerance, double spacing) {
    const double allowed = 2 * tolerance.value_or(spacing / 128);
    uint32_t shift = 0;
    while (shift < 14 && height_quantum(f, f.max_level, shift + 1) <= allowed) ++shift;
    return shift;
}

// Metres per unit of the band's elevations: the unit the raster states, else the one given.
double vertical_unit(const RasterInfo& info, const std::string& given) {
    std::string unit = info.unit.empty() ? given : info.unit;
    std::transform(unit.begin(), unit.end(), unit.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (unit.empty() || unit == "m" || unit == "metre" || unit == "meter" || unit == "metres" || unit == "meters") return 1;
    if (unit == "ft" || unit == "foot" || unit == "feet" || unit == "international foot") return 0.3048;
    if (unit == "us-ft" || unit == "us survey foot" || unit == "ftus") return 1200.0 / 3937.0;
    throw InputError((info.unit.empty() ? "--elevation-unit" : info.name + ": elevations in") + " '" + unit + "', a unit Strata cannot convert to metres");
}

// The raster and where its samples go in the model's frame.
struct Grid {
    const ElevationRaster* raster = nullptr;
    RasterInfo info;
    TerrainFrame frame;
    double unit = 1;             // metres per elevation unit
    std::optional<float> fill;   // the height of nodata samples, if filled
    float low = 0, high = 0;     // valid heights' range
    std::array<double, 3> lo{}, hi{};  // the valid samples' box in the model
    uint64_t nodata = 0;         // samples left without a height

    // The raster stores its southern row first.
    bool rows_run_north() const { return info.geotransform[5] > 0; }
    // A window's heights in metres, NaN where nodata stays a hole.
    void read(uint64_t column, uint64_t row, uint64_t columns, uint64_t rows, std::vector<float>& out) const {
        raster->read(column, row, columns, rows, out);
        for (float& h : out) h = std::isnan(h) ? (fill ? *fill : h) : float(h * unit);
    }
};

// The lattice heights keep: an integer raster's own step, so that its heights come back exactly (unless
// a fill height lies off it); 1 mm for floating-point samples.
HeightStep height_step(const Grid& grid) {
    static const std::vector<std::string> integers = {"Byte", "Int8", "UInt16", "Int16", "UInt32", "Int32"};
    const RasterInfo& info = grid.info;
    if (std::find(integers.begin(), integers.end(), info.sample_type) == integers.end() || info.scale == 0) return {};
    const HeightStep step{std::abs(info.scale) * grid.unit, info.offset * grid.unit};
    if (grid.fill && std::abs(std::remainder(double(*grid.fill) - step.base, step.step)) > 1e-6 * step.step) return {};
    return step;
}

// Checks the raster can be a terrain and reads it once through: its height range, box and nodata; and
// keeps its heights in the model (section HGHT).
Grid scan_grid(const ElevationRaster& raster, const TerrainSettings& settings, HlodWriter& writer, unsigned threads, const Progress& progress) {
    Grid grid;
    grid.raster = &raster;
    grid.info = raster.info();
    const RasterInfo& info = grid.info;
    grid.frame = TerrainFrame::for_raster(info, settings.frame, settings.frame_crs);
    grid.unit = vertical_unit(info, settings.elevation_unit);
    grid.fill = settings.fill;
    grid.low = INFINITY, grid.high = -INFINITY;
    grid.lo.fill(INFINITY), grid.hi.fill(-INFINITY);
    HeightSectionWriter heights(writer, info.width, info.height, height_step(grid), info.name);
    std::vector<float> band;
    for (uint64_t row = 0; row < info.height; row += kHeightBlock) {
        progress.check();
        const uint64_t rows = std::min<uint64_t>(kHeightBlock, info.height - row);
        grid.read(0, row, info.width, rows, band);
        heights.add_band(band, rows, threads);
        for (size_t s = 0; s < band.size(); ++s) {
            const float h = band[s];
            if (std::isnan(h)) {
                ++grid.nodata;
                continue;
            }
            grid.low = std::min(grid.low, h), grid.high = std::max(grid.high, h);
            const std::array<double, 3> p = grid.frame.position(s % info.width, row + s / info.width, h);
            for (size_t a = 0; a < 3; ++a) grid.lo[a] = std::min(grid.lo[a], p[a]), grid.hi[a] = std::max(grid.hi[a], p[a]);
        }
        progress("read", double(row + rows), double(info.height), "rows");
    }
    if (!(grid.low <= grid.high)) throw InputError(info.name + ": nodata everywhere, no elevation to build a terrain from");
    heights.finish();
    return grid;
}

// The octree over the grid: level-L cubes of cube_cells samples (at the centre), as many levels as
// cover the grid and its height range. In a projected CRS the origin is the south-west sample at the
// lowest height, so that cubes fall on whole samples; otherwise the box's lowest corner.
build::Frame octree_frame(const Grid& grid, uint32_t cube_cells) {
    build::Frame f{};
    const bool projected = grid.frame.kind() == TerrainFrameKind::projected;
    std::array<double, 3> low = grid.lo, high = grid.hi;
    if (projected) {
        const std::array<double, 3> corner = grid.frame.position(grid.info.width - 1, grid.rows_run_north() ? grid.info.height - 1 : 0, 0);
        low = {0, 0, grid.low}, high = {corner[0], corner[1], grid.high};
    }
    for (int a = 0; a < 3; ++a) f.origin[a] = low[size_t(a)];
    const double step = std::max(grid.frame.spacing()[0], grid.frame.spacing()[1]);
    const double extent = std::max({high[0] - low[0], high[1] - low[1], high[2] - low[2]});
    f.max_level = 0;
    while (cube_cells * step * double(uint64_t(1) << f.max_level) < extent) ++f.max_level;
    if (f.max_level > 15) throw InputError(grid.info.name + ": too many samples for one model's 16 levels");
    f.root_size = cube_cells * step * double(uint64_t(1) << f.max_level);
    f.block = 4;
    f.sigma0 = kMostSigma0;
    return f;
}

// How the raster is cut (issue 17: out of core): tiles of tile_cubes × tile_cubes level-T cube columns,
// each read with a margin and built from level L to level T alone; then levels T … 0 from level T's
// grid, which every tile contributes its part of. One tile of the whole raster when it fits.
struct TilePlan {
    uint32_t level = 0;       // T
    uint32_t tile_cubes = 1;  // level-T cubes per tile side
    uint64_t margin = 0;      // level-L samples read beyond a tile's own on each side
    unsigned at_once = 1;     // tiles built side by side, sharing the tiles' half of the memory
};

// The plan for `at_once` tiles side by side, if their share of the memory holds a tile.
std::optional<TilePlan> plan_for(const Grid& grid, const build::Frame& f, uint32_t cube_cells, uint64_t memory, unsigned at_once) {
    const double samples = double(grid.info.width) * double(grid.info.height);
    if (samples <= double(memory) / 2 / kTileBytesPerSample) return TilePlan{0, 1, 0, at_once};
    const double tile_budget = double(memory) / 2 / kTileBytesPerSample / at_once;
    for (uint32_t depth = 1; depth <= f.max_level; ++depth) {
        const double scale = double(uint64_t(1) << depth);
        if (samples / (scale * scale) * kCoarseBytesPerSample > double(memory) / 4) continue;
        const double side = std::sqrt(tile_budget) / scale;  // level-T samples along a tile's side
        const double cubes = std::floor((side - 2.0 * kMarginCells) / cube_cells);
        if (cubes < 1) break;
        const uint32_t level = f.max_level - depth;
        return TilePlan{level, uint32_t(std::min(cubes, double(uint64_t(1) << level))), kMarginCells << depth, at_once};
    }
    return std::nullopt;
}

// As many tiles side by side as there are threads, or as fit.
TilePlan plan_tiles(const Grid& grid, const build::Frame& f, uint32_t cube_cells, uint64_t memory, unsigned threads) {
    for (unsigned at_once = threads;; at_once /= 2) {
        if (const std::optional<TilePlan> plan = plan_for(grid, f, cube_cells, memory, at_once)) return *plan;
        if (at_once == 1)
            throw InputError(grid.info.name + ": " + describe_bytes(memory) +
                             " of memory cannot hold a tile of this raster's terrain; give more (--memory)");
    }
}

// Which tile owns each level-T sample: the one whose cubes its position (at height 0) falls in. A tile
// reads the samples around its own; level T's grid takes each sample from its owner.
struct TileOwners {
    uint64_t tiles = 0;               // per side
    std::vector<uint32_t> tile_of;    // per level-T vertex: tj · tiles + ti
    std::vector<std::array<uint64_t, 4>> box;  // per tile: its samples' first and last column, first and last row

    TileOwners(const Grid& grid, const TerrainLevel& level, const build::Frame& f, uint32_t tile_cubes) {
        const uint32_t T = level.level;
        tiles = (uint64_t(1) << T) / tile_cubes + ((uint64_t(1) << T) % tile_cubes != 0);
        tile_of.resize(level.width() * level.height());
        box.assign(tiles * tiles, {~uint64_t(0), 0, ~uint64_t(0), 0});
        const double size = f.cube_size(T);
        for (size_t r = 0; r < level.height(); ++r)
            for (size_t c = 0; c < level.width(); ++c) {
                const std::array<double, 3> p = grid.frame.position(level.columns[c], level.rows[r], 0);
                auto index = [&](int a) {
                    const double cube = std::floor((p[size_t(a)] - f.origin[a]) / size);
                    return std::min(tiles - 1, uint64_t(std::max(0.0, cube)) / tile_cubes);
                };
                const uint32_t t = uint32_t(index(1) * tiles + index(0));
                tile_of[level.vertex(c, r)] = t;
                std::array<uint64_t, 4>& b = box[t];
                b = {std::min(b[0], level.columns[c]), std::max(b[1], level.columns[c]), std::min(b[2], level.rows[r]), std::max(b[3], level.rows[r])};
            }
    }
    bool owns_samples(uint32_t tile) const { return box[tile][0] <= box[tile][1]; }
};

// A window of the raster's samples (what a tile reads), on samples that level T keeps.
struct Window {
    uint64_t column, row, columns, rows;
};

Window tile_window(const std::array<uint64_t, 4>& box, const TilePlan& plan, const Grid& grid, uint32_t max_level) {
    const uint64_t step = uint64_t(1) << (max_level - plan.level);
    auto low = [&](uint64_t first) { return (first > plan.margin ? first - plan.margin : 0) / step * step; };
    const uint64_t column = low(box[0]), row = low(box[2]);
    const uint64_t column_end = std::min(grid.info.width, box[1] + 1 + plan.margin), row_end = std::min(grid.info.height, box[3] + 1 + plan.margin);
    return {column, row, column_end - column, row_end - row};
}

TerrainLevel finest_level(const Grid& grid, const Window& w, const build::Frame& f, uint32_t shift) {
    TerrainLevel level;
    level.level = f.max_level;
    level.rows_run_north = grid.rows_run_north();
    level.columns.index.resize(w.columns), level.rows.index.resize(w.rows);
    std::iota(level.columns.index.begin(), level.columns.index.end(), w.column);
    std::iota(level.rows.index.begin(), level.rows.index.end(), w.row);
    level.columns.ends_raster = w.column + w.columns == grid.info.width;
    level.rows.ends_raster = w.row + w.rows == grid.info.height;
    std::vector<float> heights;
    grid.read(w.column, w.row, w.columns, w.rows, heights);
    const size_t width = level.width(), height = level.height();
    level.position.resize(3 * width * height);
    level.flags.assign(width * height, 0);
    for (size_t r = 0; r < height; ++r)
        for (size_t c = 0; c < width; ++c) {
            const uint64_t v = level.vertex(c, r);
            if (std::isnan(heights[v])) continue;
            level.flags[v] = terrain::kSampleValid;
            const std::array<double, 3> p = grid.frame.position(level.columns[c], level.rows[r], heights[v]);
            std::copy(p.begin(), p.end(), &level.position[3 * v]);
        }
    terrain::snap_heights(level, f.origin[2], height_quantum(f, f.max_level, shift));
    level.cube.assign(2 * (width - 1) * (height - 1), kNoTriangle);
    for (size_t r = 0; r + 1 < height; ++r)
        for (size_t c = 0; c + 1 < width; ++c)
            for (int t = 0; t < 2; ++t) {
                const std::array<uint64_t, 3> v = level.corners(c, r, t);
                if (!(level.flags[v[0]] & level.flags[v[1]] & level.flags[v[2]] & terrain::kSampleValid)) continue;
                std::array<double, 3> center{};
                for (uint64_t corner : v)
                    for (int a = 0; a < 3; ++a) center[size_t(a)] += level.at(corner)[a] / 3;
                level.cube[2 * level.cell(c, r) + t] = build::cell_of(f, center, f.max_level);
            }
    terrain::mark_used(level);
    return level;
}

// Level T over the whole raster, with nothing in it yet: the tiles fill it in.
TerrainLevel empty_level(const Grid& grid, uint32_t max_level, uint32_t level) {
    TerrainLevel out;
    out.level = level;
    out.rows_run_north = grid.rows_run_north();
    out.columns.index.resize(grid.info.width), out.rows.index.resize(grid.info.height);
    std::iota(out.columns.index.begin(), out.columns.index.end(), 0);
    std::iota(out.rows.index.begin(), out.rows.index.end(), 0);
    for (uint32_t l = max_level; l > level; --l) out.columns = out.columns.coarser(), out.rows = out.rows.coarser();
    out.position.assign(3 * out.width() * out.height(), 0.0);
    out.flags.assign(out.width() * out.height(), 0);
    out.cube.assign(2 * (out.width() - 1) * (out.height() - 1), kNoTriangle);
    return out;
}

// Where a level's axis keeps raster sample `index` (it must keep it).
size_t position_of(const terrain::Axis& axis, uint64_t index) {
    return size_t(std::lower_bound(axis.index.begin(), axis.index.end(), index) - axis.index.begin());
}

// What every tile and the coarse levels add to; tiles run on several threads, so `lock` guards it all
// but level T's grid, whose samples and cells each tile writes only where it owns them.
struct Assembly {
    const build::Frame& f;
    const std::string name;
    HlodWriter& writer;
    std::vector<build::CubeErrors> errors;
    std::vector<LevelStats> levels;  // by level
    std::mutex lock;
    TerrainLevel coarse;  // level T over the whole raster
    std::vector<Cube> coarse_cubes;  // level T's cubes, vertices by level-T ids
    terrain::CubeDistances coarse_forward;  // F of level T's cubes
    uint64_t input_triangles = 0;
    double sigma0_needed = 0;
    double texture_margin = 0;  // CubeEncoder::texture_margin_needed over every cube
    const uint32_t height_shift;  // the heights' lattice (height_quantum)

    Assembly(const build::Frame& frame, HlodWriter& output, std::string raster_name, uint32_t shift)
        : f(frame), name(std::move(raster_name)), writer(output), levels(frame.max_level + 1), height_shift(shift) {}
    terrain::CubeEncoder encoder(unsigned threads) { return terrain::CubeEncoder(f, name, writer, errors, levels, lock, threads, height_shift); }
};

// Levels from a finest one down to level `last`, and the bounds between consecutive ones.
struct Pyramid {
    std::vector<TerrainLevel> levels;                    // finest first
    std::vector<terrain::StepBound> steps;               // steps[l − last]: from level l + 1 to level l
    const terrain::CubeDistances* finest_forward = nullptr;  // F of the finest level's cubes

    uint32_t top() const { return levels.front().level; }
    uint32_t last() const { return levels.back().level; }
    const TerrainLevel& level(uint32_t l) const { return levels[top() - l]; }
    // F and D of level l's cubes (D: null at the pyramid's last level, whose parents it does not hold).
    const terrain::CubeDistances& forward(uint32_t l) const { return l == top() ? *finest_forward : steps[l - last()].forward; }
    const terrain::CubeDistances* coverage(uint32_t l) const { return l > last() ? &steps[l - 1 - last()].finer_coverage : nullptr; }
};

// `shift`: the heights' lattice (height_quantum); the finest level's are on it already.
Pyramid make_pyramid(TerrainLevel finest, uint32_t last, const terrain::CubeDistances& finest_forward, const build::Frame& f,
                     uint32_t shift) {
    Pyramid p;
    p.finest_forward = &finest_forward;
    p.levels.push_back(std::move(finest));
    while (p.levels.back().level > last) {
        p.levels.push_back(terrain::coarser_level(p.levels.back()));
        terrain::snap_heights(p.levels.back(), f.origin[2], height_quantum(f, p.levels.back().level, shift));
    }
    p.steps.resize(p.top() - last);
    const double far = std::sqrt(3.0) * f.root_size;  // the model's diagonal
    for (uint32_t l = p.top(); l-- > last;) p.steps[l - last] = terrain::bound_step(p.level(l + 1), p.level(l), p.forward(l + 1), far);
    return p;
}

// Which cubes of a level a step keeps.
using Owned = std::function<bool(CubeKey, uint32_t level)>;

// Encodes the pyramid's levels from the top down to last + 1, starting from the top level's cubes,
// parent by parent; returns level last's cubes, which the step does not encode. `number`: as for
// terrain::level_cubes, over the top level.
std::vector<Cube> encode_levels(const Pyramid& p, std::vector<Cube> cubes, const Owned& owned, std::vector<uint32_t>& number,
                                terrain::CubeEncoder& encoder, const Progress& progress) {
    for (uint32_t l = p.top(); l > p.last(); --l) {
        progress.check();
        std::vector<Cube> parents =
            terrain::level_cubes(p.level(l - 1), &p.level(l), cubes, number, [&](CubeKey key) { return owned(key, l - 1); });
        encoder.start_level(p.level(l), &p.forward(l), p.coverage(l));
        terrain::encode_children(parents, cubes, p.level(l), p.level(l - 1), number, encoder);
        cubes.swap(parents);
    }
    return cubes;
}

// One tile: levels L … T of its window, its own cubes of levels L … T + 1 encoded, its level-T cubes
// and its part of level T's grid handed to the coarse levels.
void build_tile(const Grid& grid, const Window& window, const std::array<uint32_t, 4>& owned_cubes, const TilePlan& plan,
                const TileOwners& owners, uint32_t tile, unsigned threads, Assembly& out, const Progress& progress) {
    const build::Frame& f = out.f;
    const uint32_t L = f.max_level, T = plan.level;
    // A cube of level l is the tile's when its level-T ancestor is one of the tile's cubes.
    const Owned owned = [&](CubeKey key, uint32_t l) {
        const uint32_t i = build::key_i(key) >> (l - T), j = build::key_j(key) >> (l - T);
        return i >= owned_cubes[0] && i < owned_cubes[1] && j >= owned_cubes[2] && j < owned_cubes[3];
    };
    TerrainLevel finest = finest_level(grid, window, f, out.height_shift);
    // F at level L: the heights' rounding to their lattice, half a quantum.
    terrain::CubeDistances rounding;
    for (CubeKey key : finest.cube)
        if (key != kNoTriangle) rounding.emplace(key, height_quantum(f, L, out.height_shift) / 2);
    const Pyramid p = make_pyramid(std::move(finest), T, rounding, f, out.height_shift);

    terrain::CubeEncoder encoder = out.encoder(threads);
    std::vector<uint32_t> number(p.level(L).flags.size(), terrain::kUnnumbered);
    std::vector<Cube> cubes = terrain::level_cubes(p.level(L), nullptr, {}, number, [&](CubeKey key) { return owned(key, L); });
    uint64_t triangles = 0;
    for (const Cube& cube : cubes) triangles += cube.triangles.size() / 3;
    cubes = encode_levels(p, std::move(cubes), owned, number, encoder, progress);

    // Level T: the tile's cubes (their F), and its samples and cells of the level's grid, whose axes
    // continue the window's from its first sample.
    const TerrainLevel& mine = p.level(T);
    TerrainLevel& whole = out.coarse;
    const size_t column0 = position_of(whole.columns, mine.columns[0]), row0 = position_of(whole.rows, mine.rows[0]);
    for (Cube& cube : cubes)
        for (uint64_t& v : cube.vertices) v = whole.vertex(column0 + v % mine.width(), row0 + v / mine.width());
    {
        std::lock_guard lock(out.lock);
        const terrain::CubeDistances& forward = p.forward(T);
        for (Cube& cube : cubes) {
            if (auto it = forward.find(cube.key); it != forward.end()) out.coarse_forward[cube.key] = it->second;
            out.coarse_cubes.push_back(std::move(cube));
        }
        out.input_triangles += triangles;
        out.sigma0_needed = std::max(out.sigma0_needed, encoder.sigma0_needed());
        out.texture_margin = std::max(out.texture_margin, encoder.texture_margin_needed());
    }
    for (size_t r = 0; r < mine.height(); ++r)
        for (size_t c = 0; c < mine.width(); ++c) {
            const uint64_t from = mine.vertex(c, r), to = whole.vertex(column0 + c, row0 + r);
            if (owners.tile_of[to] != tile) continue;
            whole.flags[to] = mine.flags[from];
            for (int a = 0; a < 3; ++a) whole.position[3 * to + a] = mine.position[3 * from + a];
            if (c + 1 == mine.width() || r + 1 == mine.height()) continue;
            const uint64_t cell = whole.cell(column0 + c, row0 + r);
            for (int t = 0; t < 2; ++t) whole.cube[2 * cell + t] = mine.cube[2 * mine.cell(c, r) + t];
        }
}

// Levels T … 0 from level T's grid and cubes; encodes level T's cubes and every coarser one.
void build_coarse_levels(const build::Frame& f, unsigned threads, Assembly& out, const Progress& progress) {
    terrain::CubeEncoder encoder = out.encoder(threads);
    const Pyramid p = make_pyramid(std::move(out.coarse), 0, out.coarse_forward, f, out.height_shift);
    std::vector<uint32_t> number(p.levels.front().flags.size(), terrain::kUnnumbered);
    std::vector<Cube> cubes = std::move(out.coarse_cubes);
    std::sort(cubes.begin(), cubes.end(), [](const Cube& a, const Cube& b) { return a.key < b.key; });
    cubes = encode_levels(p, std::move(cubes), [](CubeKey, uint32_t) { return true; }, number, encoder, progress);
    encoder.start_level(p.level(0), &p.forward(0), nullptr);
    std::vector<terrain::CubeContent> root{encoder.cube_data(cubes.front(), p.level(0), nullptr, nullptr)};
    encoder.write({&cubes.front()}, root, 0);
    out.sigma0_needed = std::max(out.sigma0_needed, encoder.sigma0_needed());
    out.texture_margin = std::max(out.texture_margin, encoder.texture_margin_needed());
}

HlodHeader terrain_header(const Grid& grid, const build::Frame& f, uint32_t cube_cells, const std::string& source_name) {
    const RasterInfo& info = grid.info;
    HlodHeader header;
    header.flags = kErrorsAreBounds;
    header.payload_codec = kGridPayloadCodec;
    for (int a = 0; a < 3; ++a) header.origin[a] = f.origin[a];
    header.root_size = f.root_size;
    header.max_level = f.max_level;
    header.block_size = f.block;
    header.sigma0 = f.sigma0;
    header.ratio = 0.25f;
    header.source = source_name;
    const std::array<double, 3>& geo = grid.frame.geo_origin();
    std::copy(geo.begin(), geo.end(), header.geo_origin);
    const std::string raster_crs = info.epsg ? "EPSG:" + std::to_string(*info.epsg) : info.crs_wkt;
    const bool reprojected = grid.frame.kind() == TerrainFrameKind::reprojected;
    header.crs = reprojected ? grid.frame.crs() : raster_crs;
    header.has_bounds = true;
    std::copy(grid.lo.begin(), grid.lo.end(), header.bounds_lo);
    std::copy(grid.hi.begin(), grid.hi.end(), header.bounds_hi);
    const std::array<double, 2> first = info.sample_position(0, 0);
    header.terrain = TerrainGrid{.columns = info.width,
                                 .rows = info.height,
                                 .spacing = {std::abs(info.geotransform[1]), std::abs(info.geotransform[5])},
                                 .nodata_samples = grid.nodata,
                                 .cube_cells = cube_cells,
                                 .rows_run_north = grid.rows_run_north(),
                                 .frame = uint32_t(grid.frame.kind()),
                                 .raster_geographic = info.geographic,
                                 .raster_crs = reprojected ? raster_crs : std::string(),
                                 .first_sample = {first[0], first[1]},
                                 .semi_major = info.semi_major,
                                 .inverse_flattening = info.inverse_flattening};
    return header;
}

}  // namespace

void set_frame(TerrainSettings& settings, const std::string& frame) {
    settings.frame = frame == "ecef" ? TerrainFrameKind::ecef : TerrainFrameKind::enu;
    settings.frame_crs.clear();
    if (frame == "enu" || frame == "ecef") return;
    TerrainFrame::check_crs(frame);
    settings.frame_crs = frame;
}

bool is_elevation_raster(const std::filesystem::path& file) {
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext != ".ply" && ext != ".obj" && ext != ".off" && ext != ".stl";
}

BuildReport build_terrain(const std::vector<std::filesystem::path>& files, const std::filesystem::path& output,
                          const TerrainSettings& settings, const std::string& source_name, const Progress& progress) {
    if (settings.cube_cells < 8 || settings.cube_cells > 256 || settings.cube_cells % 2)
        throw InputError("cube_cells must be even, 8 to 256, not " + std::to_string(settings.cube_cells));
    using Clock = std::chrono::steady_clock;
    auto since = [](Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); };
    auto start = Clock::now();
    const uint64_t memory = settings.memory ? settings.memory : default_memory_limit();
    limit_raster_cache(memory / 16);
    const ElevationRaster raster = ElevationRaster::open(files, settings.crs);
    if (settings.texture) check_texture_image(*settings.texture);
    const unsigned threads = resolve_thread_count(settings.threads);
    HlodWriter writer(output);
    const Grid grid = scan_grid(raster, settings, writer, threads, progress);
    const build::Frame f = octree_frame(grid, settings.cube_cells);
    if (settings.tiles && ((*settings.tiles)[0] > f.max_level || (*settings.tiles)[1] == 0))
        throw std::invalid_argument("build_terrain: tiles outside the model's levels");
    const TilePlan plan = settings.tiles ? TilePlan{(*settings.tiles)[0], (*settings.tiles)[1], kMarginCells << (f.max_level - (*settings.tiles)[0]), threads}
                                         : plan_tiles(grid, f, settings.cube_cells, memory - memory / 16, threads);
    BuildReport report;
    report.max_level = f.max_level;
    report.read_seconds = since(start);
    start = Clock::now();

    const std::array<double, 2> spacing = grid.frame.spacing();
    Assembly out(f, writer, grid.info.name, height_shift(f, settings.height_tolerance, std::min(spacing[0], spacing[1])));
    report.height_quantum = height_quantum(f, f.max_level, out.height_shift);
    out.coarse = empty_level(grid, f.max_level, plan.level);
    const TileOwners owners(grid, out.coarse, f, plan.tile_cubes);
    // Tiles side by side, each compressing its cubes on its share of the threads.
    const uint32_t tiles = uint32_t(owners.tiles * owners.tiles);
    const unsigned concurrent = std::min<unsigned>(plan.at_once, tiles), inner = std::max(1u, threads / concurrent);
    uint32_t done = 0;
    parallel_for(tiles, concurrent, [&](size_t tile, unsigned) {
        progress.check();
        if (owners.owns_samples(uint32_t(tile))) {
            const uint32_t ti = uint32_t(tile % owners.tiles), tj = uint32_t(tile / owners.tiles), b = plan.tile_cubes;
            build_tile(grid, tile_window(owners.box[tile], plan, grid, f.max_level), {ti * b, (ti + 1) * b, tj * b, (tj + 1) * b}, plan,
                       owners, uint32_t(tile), inner, out, progress);
        }
        std::lock_guard lock(out.lock);
        progress("tiles", double(++done), double(tiles), "tiles");
    });
    report.input_triangles = out.input_triangles;
    if (report.input_triangles == 0) throw InputError(grid.info.name + ": no cell has three valid corners: no ground to build");
    report.partition_seconds = since(start);
    start = Clock::now();
    build_coarse_levels(f, threads, out, progress);
    report.simplify_seconds = since(start);
    start = Clock::now();

    const double sigma0 = std::max(double(kLeastSigma0), out.sigma0_needed * 1.001);
    if (sigma0 > kMostSigma0)
        throw InputError(grid.info.name + ": ground too steep for cubes of " + std::to_string(settings.cube_cells) +
                         " cells (σ0 would be " + std::to_string(sigma0) + "); build with larger cubes (--cube-cells)");
    build::Frame bounded = f;
    bounded.sigma0 = float(sigma0);
    const std::vector<float> bounds = build::final_bounds(out.errors, bounded);
    for (size_t c = 0; c < bounds.size(); ++c) {
        out.writer.set_error(c, bounds[c]);
        report.error_q = std::max(report.error_q, build::round_up(bounds[c] / f.cube_size(out.errors[c].level)));
    }
    HlodHeader header = terrain_header(grid, bounded, settings.cube_cells, source_name);
    header.error_q = report.error_q;
    header.input_vertices = out.levels[f.max_level].vertices;
    header.input_triangles = report.input_triangles;
    if (settings.texture) {
        // The vertices' overhang, and the lattice's rounding of them (half a step, 2^-16·s_l) to spare.
        const float margin = float(out.texture_margin + std::ldexp(1.0, -14));
        const std::filesystem::path scratch = output.string() + std::string(HlodWriter::kTempMarker) + std::to_string(::getpid()) + ".image.vrt";
        const GroundHeight ground = [&grid](double column, double row) -> std::optional<double> {
            const RasterInfo& info = grid.info;
            if (!(column >= 0 && row >= 0 && column <= double(info.width - 1) && row <= double(info.height - 1))) return std::nullopt;
            const uint64_t c0 = std::min(uint64_t(column), info.width - 2), r0 = std::min(uint64_t(row), info.height - 2);
            std::vector<float> h;
            grid.read(c0, r0, 2, 2, h);
            const double u = column - double(c0), v = row - double(r0);
            const double value = (h[0] * (1 - u) + h[1] * u) * (1 - v) + (h[2] * (1 - u) + h[3] * u) * v;
            return std::isnan(value) ? std::nullopt : std::optional<double>(value);
        };
        const TextureReport textures = build_terrain_textures(*settings.texture, header, margin, out.writer, scratch, ground, threads, progress);
        report.texture_size = textures.layout.size;
        report.texture_bytes = textures.stored_bytes;
        report.texture_seconds = textures.seconds;
        char note[200];
        std::snprintf(note, sizeof note, "textures: %u × %u texels a cube (%.3g m a texel at level %u; the image's pixels: %.3g m)",
                      textures.layout.size, textures.layout.size, (1 + 2 * margin) * f.cube_size(f.max_level) / textures.layout.size,
                      f.max_level, textures.image_metres);
        report.notes.push_back(note);
    }
    out.writer.finish(header);
    for (uint32_t l = f.max_level + 1; l-- > 0;) report.levels.push_back(out.levels[l]);
    report.sigma0 = bounded.sigma0;
    report.write_seconds = since(start);
    std::error_code ec;
    report.output_bytes = std::filesystem::file_size(output, ec);
    return report;
}

}  // namespace strata

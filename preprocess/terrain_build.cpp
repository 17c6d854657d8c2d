#include "preprocess/terrain_build.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "preprocess/elevation_raster.h"
#include "preprocess/error_bound.h"
#include "preprocess/hlod_format.h"
#include "preprocess/mesh.h"
#include "preprocess/terrain_bounds.h"
#include "preprocess/terrain_pyramid.h"

namespace strata {
namespace {

using build::CubeKey;
using terrain::kNoTriangle;
using terrain::TerrainLevel;

constexpr float kLeastSigma0 = 0.1f, kMostSigma0 = 0.45f;

// Metres per unit of the band's elevations.
double vertical_unit(const RasterInfo& info) {
    std::string unit = info.unit;
    std::transform(unit.begin(), unit.end(), unit.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (unit.empty() || unit == "m" || unit == "metre" || unit == "meter" || unit == "metres" || unit == "meters") return 1;
    if (unit == "ft" || unit == "foot" || unit == "feet" || unit == "international foot") return 0.3048;
    if (unit == "us-ft" || unit == "us survey foot" || unit == "ftus") return 1200.0 / 3937.0;
    throw InputError(info.name + ": elevations in '" + info.unit + "', a unit Strata cannot convert to metres");
}

// The raster and where its samples go in the model's frame.
struct Grid {
    RasterInfo info;
    std::vector<float> heights;  // metres, row-major, NaN for nodata
    double spacing[2] = {0, 0};  // metres between columns, between rows
    bool rows_run_north = false;
    float low = 0, high = 0;     // valid heights' range
    uint64_t nodata = 0;         // samples left without a height

    double x(uint64_t column) const { return double(column) * spacing[0]; }
    double y(uint64_t row) const { return double(rows_run_north ? row : info.height - 1 - row) * spacing[1]; }
};

Grid read_grid(const ElevationRaster& raster, const TerrainSettings& settings, const Progress& progress) {
    Grid grid;
    grid.info = raster.info();
    const RasterInfo& info = grid.info;
    if (info.geographic)
        throw InputError(info.name + ": a geographic CRS (" + info.describe_crs() +
                         "): a terrain in degrees needs a metric frame, which Strata cannot make yet; reproject it "
                         "first (gdalwarp -t_srs with a projected CRS, e.g. its UTM zone)");
    if (std::abs(info.linear_unit - 1) > 1e-12)
        throw InputError(info.name + ": a projected CRS in units of " + std::to_string(info.linear_unit) +
                         " m; Strata builds terrains in metre-based CRSs (reproject it with gdalwarp)");
    const double unit = vertical_unit(info);
    grid.spacing[0] = info.geotransform[1], grid.spacing[1] = std::abs(info.geotransform[5]);
    grid.rows_run_north = info.geotransform[5] > 0;
    grid.heights.reserve(info.width * info.height);
    std::vector<float> band;
    constexpr uint64_t kBandRows = 256;
    for (uint64_t row = 0; row < info.height; row += kBandRows) {
        progress.check();
        raster.read(0, row, info.width, std::min(kBandRows, info.height - row), band);
        for (float& h : band) h = std::isnan(h) ? (settings.fill ? *settings.fill : h) : float(h * unit);
        grid.heights.insert(grid.heights.end(), band.begin(), band.end());
        progress("read", double(std::min(row + kBandRows, info.height)), double(info.height), "rows");
    }
    grid.low = INFINITY, grid.high = -INFINITY;
    for (float h : grid.heights) {
        if (std::isnan(h)) ++grid.nodata;
        else grid.low = std::min(grid.low, h), grid.high = std::max(grid.high, h);
    }
    if (!(grid.low <= grid.high)) throw InputError(info.name + ": nodata everywhere, no elevation to build a terrain from");
    return grid;
}

// The octree over the grid: the origin at the south-west sample and the lowest height, level-L
// cubes of cube_cells samples, as many levels as cover the grid and its height range.
build::Frame octree_frame(const Grid& grid, uint32_t cube_cells) {
    build::Frame f{};
    f.origin[0] = 0, f.origin[1] = 0, f.origin[2] = grid.low;
    const double step = std::max(grid.spacing[0], grid.spacing[1]);
    const double extent = std::max({grid.x(grid.info.width - 1), double(grid.info.height - 1) * grid.spacing[1], double(grid.high - grid.low)});
    f.max_level = 0;
    while (cube_cells * step * double(uint64_t(1) << f.max_level) < extent) ++f.max_level;
    if (f.max_level > 15) throw InputError(grid.info.name + ": too many samples for one model's 16 levels");
    f.root_size = cube_cells * step * double(uint64_t(1) << f.max_level);
    f.block = 4;
    f.sigma0 = kMostSigma0;
    return f;
}

TerrainLevel finest_level(const Grid& grid, const build::Frame& f) {
    TerrainLevel level;
    level.level = f.max_level;
    level.rows_run_north = grid.rows_run_north;
    level.columns.resize(grid.info.width), level.rows.resize(grid.info.height);
    std::iota(level.columns.begin(), level.columns.end(), 0);
    std::iota(level.rows.begin(), level.rows.end(), 0);
    const size_t w = level.width(), h = level.height();
    level.position.resize(3 * w * h);
    level.flags.assign(w * h, 0);
    for (size_t r = 0; r < h; ++r)
        for (size_t c = 0; c < w; ++c) {
            const uint64_t v = level.vertex(c, r);
            const float z = grid.heights[v];
            if (std::isnan(z)) continue;
            level.flags[v] = terrain::kSampleValid;
            double* p = &level.position[3 * v];
            p[0] = grid.x(c), p[1] = grid.y(r), p[2] = z;
        }
    level.cube.assign(2 * (w - 1) * (h - 1), kNoTriangle);
    for (size_t r = 0; r + 1 < h; ++r)
        for (size_t c = 0; c + 1 < w; ++c)
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

// One cube of one level while the model is assembled: its vertices (the level's ids) in payload
// order, the parents its children need last.
struct Cube {
    CubeKey key = 0;
    std::vector<uint64_t> vertices;
    std::vector<uint32_t> triangles;
    std::array<uint32_t, 8> child_counts{};
};

constexpr uint32_t kUnnumbered = ~0u;

uint64_t parent_vertex(const TerrainLevel& finer, const TerrainLevel& coarse, uint64_t v) {
    return coarse.vertex(terrain::parent_position(v % finer.width(), finer.width()),
                         terrain::parent_position(v / finer.width(), finer.height()));
}

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

// One cube from its triangles (2·cell + t, row order): grouped by the child they came from, in
// vertex-cache order, the vertices in first-use order. `number`: kUnnumbered per level vertex, and
// left so.
Cube make_cube(CubeKey key, const std::vector<uint64_t>& triangles, const TerrainLevel& level, const TerrainLevel* finer,
               std::vector<uint32_t>& number) {
    Cube cube;
    cube.key = key;
    const size_t cells_per_row = level.width() - 1;
    std::vector<uint8_t> octant(triangles.size(), 0);
    if (finer)
        for (size_t t = 0; t < triangles.size(); ++t) {
            const uint64_t cell = triangles[t] / 2;
            const size_t fc = terrain::finer_position(cell % cells_per_row + 1, level.width(), finer->width()) - 1;
            const size_t fr = terrain::finer_position(cell / cells_per_row + 1, level.height(), finer->height()) - 1;
            octant[t] = uint8_t(build::octant(finer->cube[2 * finer->cell(fc, fr) + triangles[t] % 2]));
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
    std::vector<uint32_t> order(cube.vertices.size());
    std::iota(order.begin(), order.end(), 0u);
    build::order_for_payload(cube.triangles, cube.child_counts, order);
    std::vector<uint64_t> ordered(order.size());
    for (size_t v = 0; v < order.size(); ++v) ordered[v] = cube.vertices[order[v]];
    cube.vertices.swap(ordered);
    return cube;
}

// The level's cubes in key order, with a cube (empty) for every parent of `children` that has no
// triangle of its own.
std::vector<Cube> level_cubes(const TerrainLevel& level, const TerrainLevel* finer, const std::vector<Cube>& children,
                              std::vector<uint32_t>& number) {
    std::unordered_map<CubeKey, std::vector<uint64_t>> by_cube = triangles_by_cube(level);
    for (const Cube& child : children) by_cube[build::parent_key(child.key)];
    std::vector<CubeKey> keys;
    for (const auto& entry : by_cube) keys.push_back(entry.first);
    std::sort(keys.begin(), keys.end());
    std::vector<Cube> cubes;
    for (CubeKey key : keys) cubes.push_back(make_cube(key, by_cube[key], level, finer, number));
    return cubes;
}

// Encodes cubes, each vertex naming its parent in the parent cube (itself at level 0).
class CubeEncoder {
public:
    CubeEncoder(const build::Frame& f, std::string name, HlodWriter& writer, std::vector<build::CubeErrors>& errors, BuildReport& report)
        : f_(f), name_(std::move(name)), writer_(writer), errors_(errors), report_(report) {}

    // Sets the level whose cubes come next: its normals, and its cubes' F and D.
    void start_level(const TerrainLevel& level, const terrain::CubeDistances* forward, const terrain::CubeDistances* coverage) {
        normals_ = terrain::vertex_normals(level);
        forward_ = forward, coverage_ = coverage;
        report_.levels.push_back(LevelStats{level.level});
    }

    // `parent_number`: each vertex of the parent cube's its place there (null at level 0).
    void encode(const Cube& cube, const TerrainLevel& level, const TerrainLevel* coarse, const std::vector<uint32_t>* parent_number) {
        const CubeData data = cube_data(cube, level, coarse, parent_number);
        HlodNode node;
        node.level = level.level;
        node.i = build::key_i(cube.key), node.j = build::key_j(cube.key), node.k = build::key_k(cube.key);
        node.vertex_count = data.vertex_count(), node.triangle_count = data.triangle_count();
        const std::vector<uint8_t> payload = encode_cube(data, kErrorsAreBounds);
        writer_.add_cube(node, payload);
        errors_.push_back({node.level, node.i, node.j, node.k, float(lookup(forward_, cube.key)), float(lookup(coverage_, cube.key))});
        LevelStats& stats = report_.levels.back();
        stats.cubes++, stats.vertices += node.vertex_count, stats.triangles += node.triangle_count, stats.bytes += payload.size();
    }

    // The σ0 the vertices need: their distance to their cube's cell (÷ s_l) and to their parent (÷ s_{l+1}).
    double sigma0_needed() const { return needed_; }

private:
    static double lookup(const terrain::CubeDistances* distances, CubeKey key) {
        if (!distances) return 0;
        auto it = distances->find(key);
        return it == distances->end() ? 0.0 : it->second;
    }

    CubeData cube_data(const Cube& cube, const TerrainLevel& level, const TerrainLevel* coarse, const std::vector<uint32_t>* parent_number) {
        const uint32_t l = level.level, cell[3] = {build::key_i(cube.key), build::key_j(cube.key), build::key_k(cube.key)};
        const double size = f_.cube_size(l), inverse_step = double(uint64_t(1) << (l + kLatticeBits)) / f_.root_size;
        CubeData data;
        const size_t n = cube.vertices.size();
        data.vertices.positions.resize(3 * n);
        data.vertices.normals.resize(2 * n);
        data.parent_vertex.resize(n);
        for (size_t v = 0; v < n; ++v) {
            const uint64_t id = cube.vertices[v];
            const double* p = level.at(id);
            for (int a = 0; a < 3; ++a) {
                const double low = f_.origin[a] + cell[a] * size;
                needed_ = std::max(needed_, std::max({0.0, low - p[a], p[a] - low - size}) / size);
                const int64_t stored = std::llround((p[a] - f_.origin[a]) * inverse_step) - (int64_t(cell[a]) << kLatticeBits) + kLatticeBias;
                if (stored < 0 || stored > 0xFFFF)
                    throw InputError(name_ + ": ground too steep for its cubes (a vertex of level " + std::to_string(l) +
                                     " lies half a cube outside its cell); build with larger cubes");
                data.vertices.positions[3 * v + size_t(a)] = uint16_t(stored);
            }
            const std::array<int16_t, 2> normal = encode_normal(normals_[3 * id], normals_[3 * id + 1], normals_[3 * id + 2]);
            data.vertices.normals[2 * v] = normal[0], data.vertices.normals[2 * v + 1] = normal[1];
            if (!coarse) {
                data.parent_vertex[v] = uint32_t(v);
                continue;
            }
            const uint64_t parent = parent_vertex(level, *coarse, id);
            data.parent_vertex[v] = (*parent_number)[parent];
            const double* q = coarse->at(parent);
            for (int a = 0; a < 3; ++a) needed_ = std::max(needed_, std::abs(p[a] - q[a]) / f_.cube_size(l + 1));
        }
        data.indices = cube.triangles;
        data.child_triangle_counts = cube.child_counts;
        return data;
    }

    const build::Frame& f_;
    const std::string name_;
    HlodWriter& writer_;
    std::vector<build::CubeErrors>& errors_;
    BuildReport& report_;
    std::vector<float> normals_;
    const terrain::CubeDistances *forward_ = nullptr, *coverage_ = nullptr;
    double needed_ = 0;
};

// Gives each parent the vertices its children need and it lacks, then encodes the children, parent by
// parent: a parent's vertex order is final once its children's are. `number`: as for make_cube.
void encode_children(std::vector<Cube>& parents, const std::vector<Cube>& children, const TerrainLevel& finer,
                     const TerrainLevel& coarse, std::vector<uint32_t>& number, CubeEncoder& encoder) {
    std::unordered_map<CubeKey, std::vector<uint32_t>> children_of;
    for (uint32_t c = 0; c < children.size(); ++c) children_of[build::parent_key(children[c].key)].push_back(c);
    for (Cube& parent : parents) {
        for (uint32_t v = 0; v < parent.vertices.size(); ++v) number[parent.vertices[v]] = v;
        const std::vector<uint32_t>& mine = children_of[parent.key];
        for (uint32_t c : mine)
            for (uint64_t v : children[c].vertices) {
                const uint64_t p = parent_vertex(finer, coarse, v);
                if (number[p] == kUnnumbered) number[p] = uint32_t(parent.vertices.size()), parent.vertices.push_back(p);
            }
        for (uint32_t c : mine) encoder.encode(children[c], finer, &coarse, &number);
        for (uint64_t v : parent.vertices) number[v] = kUnnumbered;
    }
}

HlodHeader terrain_header(const Grid& grid, const build::Frame& f, uint32_t cube_cells, const std::string& source_name) {
    const RasterInfo& info = grid.info;
    HlodHeader header;
    header.flags = kErrorsAreBounds;
    for (int a = 0; a < 3; ++a) header.origin[a] = f.origin[a];
    header.root_size = f.root_size;
    header.max_level = f.max_level;
    header.block_size = f.block;
    header.ratio = 0.25f;
    header.source = source_name;
    const double south_row = grid.rows_run_north ? 0.5 : double(info.height) - 0.5;
    header.geo_origin[0] = info.geotransform[0] + 0.5 * info.geotransform[1];
    header.geo_origin[1] = info.geotransform[3] + south_row * info.geotransform[5];
    header.crs = info.epsg ? "EPSG:" + std::to_string(*info.epsg) : info.crs_wkt;
    header.has_bounds = true;
    header.bounds_lo[0] = header.bounds_lo[1] = 0, header.bounds_lo[2] = grid.low;
    header.bounds_hi[0] = grid.x(info.width - 1), header.bounds_hi[1] = double(info.height - 1) * grid.spacing[1];
    header.bounds_hi[2] = grid.high;
    header.terrain = TerrainGrid{.columns = info.width,
                                 .rows = info.height,
                                 .spacing = {grid.spacing[0], grid.spacing[1]},
                                 .nodata_samples = grid.nodata,
                                 .cube_cells = cube_cells,
                                 .rows_run_north = grid.rows_run_north};
    return header;
}

}  // namespace

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
    const ElevationRaster raster = ElevationRaster::open(files, settings.crs);
    const Grid grid = read_grid(raster, settings, progress);
    const build::Frame f = octree_frame(grid, settings.cube_cells);
    BuildReport report;
    report.read_seconds = since(start);
    start = Clock::now();
    report.max_level = f.max_level;

    // The pyramid, finest first, and the bounds between consecutive levels.
    std::vector<TerrainLevel> levels;
    levels.push_back(finest_level(grid, f));
    report.input_triangles = levels.back().triangle_count();
    if (report.input_triangles == 0) throw InputError(grid.info.name + ": no cell has three valid corners: no ground to build");
    while (levels.back().level > 0) {
        progress.check();
        levels.push_back(terrain::coarser_level(levels.back()));
        progress("levels", double(levels.size()), double(f.max_level + 1), "levels");
    }
    report.partition_seconds = since(start);
    start = Clock::now();
    const double far = std::sqrt(3.0) * f.root_size;
    std::vector<terrain::StepBound> steps(f.max_level);  // steps[l]: level l+1 to level l
    for (uint32_t l = f.max_level; l-- > 0;) {
        progress.check();
        const terrain::CubeDistances none;
        steps[l] = terrain::bound_step(levels[f.max_level - l - 1], levels[f.max_level - l], l + 1 < f.max_level ? steps[l + 1].forward : none, far);
        progress("bounds", double(f.max_level - l), double(f.max_level), "levels");
    }

    report.simplify_seconds = since(start);
    start = Clock::now();

    // Cubes, finest first: a level's cubes are encoded once their parents' vertex order is fixed.
    HlodWriter writer(output);
    std::vector<build::CubeErrors> errors;
    CubeEncoder encoder(f, grid.info.name, writer, errors, report);
    std::vector<uint32_t> number(levels[0].flags.size(), kUnnumbered);
    std::vector<Cube> cubes = level_cubes(levels[0], nullptr, {}, number);
    for (uint32_t l = f.max_level; l > 0; --l) {
        progress.check();
        const TerrainLevel &level = levels[f.max_level - l], &coarse = levels[f.max_level - l + 1];
        std::vector<Cube> parents = level_cubes(coarse, &level, cubes, number);
        encoder.start_level(level, l < f.max_level ? &steps[l].forward : nullptr, &steps[l - 1].finer_coverage);
        encode_children(parents, cubes, level, coarse, number, encoder);
        cubes.swap(parents);
        progress("encode", double(f.max_level - l + 1), double(f.max_level + 1), "levels");
    }
    encoder.start_level(levels.back(), f.max_level > 0 ? &steps[0].forward : nullptr, nullptr);
    encoder.encode(cubes.front(), levels.back(), nullptr, nullptr);

    const double sigma0 = std::max(double(kLeastSigma0), encoder.sigma0_needed() * 1.001);
    if (sigma0 > kMostSigma0)
        throw InputError(grid.info.name + ": ground too steep for cubes of " + std::to_string(settings.cube_cells) +
                         " cells (σ0 would be " + std::to_string(sigma0) + "); build with larger cubes");
    build::Frame bounded = f;
    bounded.sigma0 = float(sigma0);
    const std::vector<float> bounds = build::final_bounds(errors, bounded);
    for (size_t c = 0; c < bounds.size(); ++c) {
        writer.set_error(c, bounds[c]);
        report.error_q = std::max(report.error_q, build::round_up(bounds[c] / f.cube_size(errors[c].level)));
    }
    HlodHeader header = terrain_header(grid, bounded, settings.cube_cells, source_name);
    header.sigma0 = bounded.sigma0;
    header.error_q = report.error_q;
    header.input_vertices = report.levels.front().vertices;
    header.input_triangles = report.input_triangles;
    writer.finish(header);
    report.sigma0 = bounded.sigma0;
    report.write_seconds = since(start);
    std::error_code ec;
    report.output_bytes = std::filesystem::file_size(output, ec);
    return report;
}

}  // namespace strata

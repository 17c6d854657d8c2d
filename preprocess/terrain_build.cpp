#include "preprocess/terrain_build.h"

#include <algorithm>
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
    for (float h : grid.heights)
        if (!std::isnan(h)) grid.low = std::min(grid.low, h), grid.high = std::max(grid.high, h);
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
    std::unordered_map<uint64_t, uint32_t> index;  // vertex id → place in `vertices`
};

uint64_t parent_vertex(const TerrainLevel& finer, const TerrainLevel& coarse, uint64_t v) {
    return coarse.vertex(terrain::parent_position(v % finer.width(), finer.width()),
                         terrain::parent_position(v / finer.width(), finer.height()));
}

// The level's cubes in key order: each triangle in its cube, grouped by the child it came from.
std::vector<Cube> level_cubes(const TerrainLevel& level, const TerrainLevel* finer) {
    struct Entry {
        CubeKey key;
        uint32_t octant;
        uint64_t triangle;  // 2·cell + t
    };
    std::vector<Entry> entries;
    for (size_t r = 0; r + 1 < level.height(); ++r)
        for (size_t c = 0; c + 1 < level.width(); ++c)
            for (int t = 0; t < 2; ++t) {
                const uint64_t triangle = 2 * level.cell(c, r) + uint64_t(t);
                if (level.cube[triangle] == kNoTriangle) continue;
                uint32_t octant = 0;
                if (finer) {
                    const size_t fc = terrain::finer_position(c + 1, level.width(), finer->width()) - 1;
                    const size_t fr = terrain::finer_position(r + 1, level.height(), finer->height()) - 1;
                    octant = build::octant(finer->cube[2 * finer->cell(fc, fr) + uint64_t(t)]);
                }
                entries.push_back({level.cube[triangle], octant, triangle});
            }
    std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
        return a.key != b.key ? a.key < b.key : a.octant != b.octant ? a.octant < b.octant : a.triangle < b.triangle;
    });
    std::vector<Cube> cubes;
    for (size_t first = 0; first < entries.size();) {
        size_t end = first;
        while (end < entries.size() && entries[end].key == entries[first].key) ++end;
        Cube cube;
        cube.key = entries[first].key;
        std::unordered_map<uint64_t, uint32_t> local;
        for (size_t e = first; e < end; ++e) {
            const uint64_t cell = entries[e].triangle / 2;
            const size_t width = level.width() - 1;
            for (uint64_t v : level.corners(size_t(cell % width), size_t(cell / width), int(entries[e].triangle % 2))) {
                auto [it, added] = local.emplace(v, uint32_t(cube.vertices.size()));
                if (added) cube.vertices.push_back(v);
                cube.triangles.push_back(it->second);
            }
            cube.child_counts[entries[e].octant]++;
        }
        std::vector<uint32_t> order(cube.vertices.size());
        std::iota(order.begin(), order.end(), 0u);
        build::order_for_payload(cube.triangles, cube.child_counts, order);
        std::vector<uint64_t> ordered(order.size());
        for (size_t v = 0; v < order.size(); ++v) ordered[v] = cube.vertices[order[v]];
        cube.vertices.swap(ordered);
        cubes.push_back(std::move(cube));
        first = end;
    }
    return cubes;
}

// Adds to each cube the parents its children's vertices need and it lacks (creating cubes that only
// hold such parents), and indexes every cube's vertices for its children's encoding.
void add_parents(std::vector<Cube>& cubes, const std::vector<Cube>& children, const TerrainLevel& finer, const TerrainLevel& coarse) {
    for (Cube& cube : cubes)
        for (uint32_t v = 0; v < cube.vertices.size(); ++v) cube.index.emplace(cube.vertices[v], v);
    std::unordered_map<CubeKey, size_t> place;
    for (size_t c = 0; c < cubes.size(); ++c) place.emplace(cubes[c].key, c);
    for (const Cube& child : children) {
        auto [it, added] = place.emplace(build::parent_key(child.key), cubes.size());
        if (added) {
            cubes.emplace_back();
            cubes.back().key = it->first;
        }
        Cube& parent = cubes[it->second];
        for (uint64_t v : child.vertices) {
            const uint64_t p = parent_vertex(finer, coarse, v);
            if (parent.index.emplace(p, uint32_t(parent.vertices.size())).second) parent.vertices.push_back(p);
        }
    }
    std::sort(cubes.begin(), cubes.end(), [](const Cube& a, const Cube& b) { return a.key < b.key; });
}

// Encodes a level's cubes, each vertex naming its parent in the parent level's cubes (itself at level 0).
class CubeEncoder {
public:
    CubeEncoder(const build::Frame& f, std::string name, HlodWriter& writer, std::vector<build::CubeErrors>& errors, BuildReport& report)
        : f_(f), name_(std::move(name)), writer_(writer), errors_(errors), report_(report) {}

    void encode_level(const std::vector<Cube>& cubes, const TerrainLevel& level, const TerrainLevel* coarse,
                      const std::vector<Cube>* parents, const terrain::StepBound* below, const terrain::CubeDistances* forward) {
        const std::vector<float> normals = terrain::vertex_normals(level);
        LevelStats stats{level.level};
        for (const Cube& cube : cubes) {
            const Cube* parent = parents ? &find(*parents, build::parent_key(cube.key)) : &cube;
            CubeData data = cube_data(cube, level, normals, coarse, *parent);
            HlodNode node;
            node.level = level.level;
            node.i = build::key_i(cube.key), node.j = build::key_j(cube.key), node.k = build::key_k(cube.key);
            node.vertex_count = data.vertex_count(), node.triangle_count = data.triangle_count();
            const std::vector<uint8_t> payload = encode_cube(data, kErrorsAreBounds);
            writer_.add_cube(node, payload);
            errors_.push_back({node.level, node.i, node.j, node.k, float(lookup(forward, cube.key)),
                               float(below ? lookup(&below->finer_coverage, cube.key) : 0.0)});
            stats.cubes++, stats.vertices += node.vertex_count, stats.triangles += node.triangle_count, stats.bytes += payload.size();
        }
        report_.levels.push_back(stats);
    }

    // The σ0 the vertices need: their distance to their cube's cell (÷ s_l) and to their parent (÷ s_{l+1}).
    double sigma0_needed() const { return needed_; }

private:
    static const Cube& find(const std::vector<Cube>& cubes, CubeKey key) {
        auto it = std::lower_bound(cubes.begin(), cubes.end(), key, [](const Cube& c, CubeKey k) { return c.key < k; });
        if (it == cubes.end() || it->key != key) throw std::logic_error("terrain build: a cube without its parent");
        return *it;
    }
    static double lookup(const terrain::CubeDistances* distances, CubeKey key) {
        if (!distances) return 0;
        auto it = distances->find(key);
        return it == distances->end() ? 0.0 : it->second;
    }

    CubeData cube_data(const Cube& cube, const TerrainLevel& level, const std::vector<float>& normals,
                       const TerrainLevel* coarse, const Cube& parent) {
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
            const std::array<int16_t, 2> normal = encode_normal(normals[3 * id], normals[3 * id + 1], normals[3 * id + 2]);
            data.vertices.normals[2 * v] = normal[0], data.vertices.normals[2 * v + 1] = normal[1];
            if (!coarse) {
                data.parent_vertex[v] = uint32_t(v);
                continue;
            }
            const uint64_t pid = parent_vertex(level, *coarse, id);
            data.parent_vertex[v] = parent.index.at(pid);
            const double* q = coarse->at(pid);
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
    double needed_ = 0;
};

HlodHeader terrain_header(const Grid& grid, const build::Frame& f, const std::string& source_name) {
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
    const ElevationRaster raster = ElevationRaster::open(files, settings.crs);
    const Grid grid = read_grid(raster, settings, progress);
    const build::Frame f = octree_frame(grid, settings.cube_cells);
    BuildReport report;
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
    const double far = std::sqrt(3.0) * f.root_size;
    std::vector<terrain::StepBound> steps(f.max_level);  // steps[l]: level l+1 to level l
    for (uint32_t l = f.max_level; l-- > 0;) {
        progress.check();
        const terrain::CubeDistances none;
        steps[l] = terrain::bound_step(levels[f.max_level - l - 1], levels[f.max_level - l], l + 1 < f.max_level ? steps[l + 1].forward : none, far);
        progress("bounds", double(f.max_level - l), double(f.max_level), "levels");
    }

    // Cubes, finest first: a level's cubes are encoded once their parents' vertex order is fixed.
    HlodWriter writer(output);
    std::vector<build::CubeErrors> errors;
    CubeEncoder encoder(f, grid.info.name, writer, errors, report);
    std::vector<Cube> cubes = level_cubes(levels[0], nullptr);
    for (uint32_t l = f.max_level; l > 0; --l) {
        progress.check();
        const TerrainLevel &level = levels[f.max_level - l], &coarse = levels[f.max_level - l + 1];
        std::vector<Cube> parents = level_cubes(coarse, &level);
        add_parents(parents, cubes, level, coarse);
        encoder.encode_level(cubes, level, &coarse, &parents, &steps[l - 1], l < f.max_level ? &steps[l].forward : nullptr);
        cubes.swap(parents);
        progress("encode", double(f.max_level - l + 1), double(f.max_level + 1), "levels");
    }
    encoder.encode_level(cubes, levels.back(), nullptr, nullptr, nullptr, f.max_level > 0 ? &steps[0].forward : nullptr);

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
    HlodHeader header = terrain_header(grid, bounded, source_name);
    header.sigma0 = bounded.sigma0;
    header.error_q = report.error_q;
    header.input_vertices = report.levels.front().vertices;
    header.input_triangles = report.input_triangles;
    writer.finish(header);
    report.sigma0 = bounded.sigma0;
    std::error_code ec;
    report.output_bytes = std::filesystem::file_size(output, ec);
    return report;
}

}  // namespace strata

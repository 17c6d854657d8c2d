#include "preprocess/embedding.h"

#include <algorithm>
#include <cmath>

#include "preprocess/georeference.h"
#include "preprocess/terrain_heights.h"

namespace strata {

TerrainSite TerrainSite::open(const std::filesystem::path& path) {
    TerrainSite site;
    auto file = std::make_shared<HlodFile>(path);
    const HlodHeader& header = file->header();
    const HlodSection* heights = file->find_section(kHeightsTag);
    if (!header.terrain || !heights || header.crs.empty())
        throw std::runtime_error(path.string() + ": not a terrain built from an elevation raster (it has no raster grid, heights or CRS)");
    site.georeference = std::make_shared<Georeference>(header, path.string());
    site.heights = std::make_shared<TerrainHeights>(file, *heights);
    site.file = std::move(file);
    return site;
}

bool raster_turns_over(const Georeference& geo) {
    const auto p00 = geo.sample_position(0, 0, 0), p10 = geo.sample_position(1, 0, 0), p01 = geo.sample_position(0, 1, 0);
    return ((*p10)[0] - (*p00)[0]) * ((*p01)[1] - (*p00)[1]) - ((*p10)[1] - (*p00)[1]) * ((*p01)[0] - (*p00)[0]) < 0;
}

uint32_t zone_level(const HlodHeader& terrain, double height_difference, double extent_cells, bool& capped) {
    const uint32_t L = terrain.max_level;
    // The finest m with ΔH ≤ 2·ε_q·s_(m−1).
    uint32_t m = L;
    while (m > 0 && height_difference > 2.0 * double(terrain.error_q) * terrain.cube_size(m - 1)) --m;
    // Zone cells (level m − 1's) of at most about twice the footprint's extent: 2^(L−m+1) ≤ 2·extent.
    uint32_t coarsest = L;
    while (coarsest > 1 && double(uint64_t(1) << (L - coarsest + 2)) <= 2.0 * std::max(extent_cells, 1.0)) --coarsest;
    capped = m < coarsest;
    // At least 1: the zone's cells are level m − 1's.
    return std::max({m, coarsest, 1u});
}

namespace {

glm::dvec3 placed_vertex(const Mesh& mesh, const glm::dmat4& mesh_to_terrain, size_t v) {
    const float* p = &mesh.positions[3 * v];
    return glm::dvec3(mesh_to_terrain * glm::dvec4(mesh.origin[0] + double(p[0]), mesh.origin[1] + double(p[1]), mesh.origin[2] + double(p[2]), 1.0));
}

glm::dvec2 raster_at(const Georeference& geo, const glm::dvec3& at) {
    const auto position = geo.raster_position(at.x, at.y, at.z);
    if (!position) throw std::runtime_error("a point the terrain's CRS cannot map");
    return glm::dvec2((*position)[0], (*position)[1]);
}

}  // namespace

double height_difference(const TerrainSite& terrain, const Mesh& mesh, const glm::dmat4& mesh_to_terrain) {
    double most = 0;
    for (size_t v = 0; v < mesh.vertex_count(); ++v) {
        const glm::dvec3 at = placed_vertex(mesh, mesh_to_terrain, v);
        const glm::dvec2 cell = raster_at(*terrain.georeference, at);
        if (const std::optional<double> ground = terrain.heights->at(cell.x, cell.y)) most = std::max(most, std::abs(at.z - *ground));
    }
    return most;
}

EmbeddingPlan plan_embedding(const TerrainSite& terrain, const Mesh& mesh, const glm::dmat4& mesh_to_terrain, const std::string& what) {
    // A closed mesh stands: ΔH is not needed (nor measured, as before).
    if (boundary_loops(mesh, what).empty()) return plan_embedding(terrain, mesh, mesh_to_terrain, 0.0, what);
    return plan_embedding(terrain, mesh, mesh_to_terrain, height_difference(terrain, mesh, mesh_to_terrain), what);
}

EmbeddingPlan plan_embedding(const TerrainSite& terrain, const Mesh& mesh, const glm::dmat4& mesh_to_terrain, double height_difference,
                             const std::string& what) {
    const TerrainGrid& grid = terrain.grid();
    const Georeference& geo = *terrain.georeference;
    const int64_t columns = int64_t(grid.columns), rows = int64_t(grid.rows);
    auto placed = [&](size_t v) { return placed_vertex(mesh, mesh_to_terrain, v); };

    EmbeddingPlan plan;
    if (boundary_loops(mesh, what).empty()) {
        plan.standing = true;
        return plan;
    }
    plan.footprint = make_footprint(
        mesh,
        [&](const glm::dvec3& at) { return raster_at(geo, glm::dvec3(mesh_to_terrain * glm::dvec4(at, 1.0))); }, columns, rows, what);
    plan.height_difference = height_difference;
    const auto [lo, hi] = bounds(plan.footprint.points);
    const double extent = double(std::max(hi.x - lo.x, hi.y - lo.y)) / double(kGridPointOne);
    plan.zone_level = zone_level(terrain.header(), plan.height_difference, extent, plan.zone_capped);
    if (terrain.header().max_level == 0) throw InputError(what + ": the terrain has a single level, too coarse to embed a mesh in");
    plan.zone = classify_cells(plan.footprint.points, int64_t(1) << (terrain.header().max_level - plan.zone_level + 1), columns, rows);
    plan.skirt = build_skirt(plan.footprint, plan.zone, columns, rows, what);

    // The skirt's vertices in the terrain's frame, relative to the first one (floats near zero).
    std::vector<glm::dvec3> positions;
    positions.reserve(plan.skirt.vertices.size());
    for (const SkirtVertex& v : plan.skirt.vertices) {
        switch (v.kind) {
        case SkirtVertex::Kind::sample: {
            const std::optional<double> h = terrain.heights->sample(uint64_t(v.a), uint64_t(v.b));
            if (!h)
                throw InputError(what + ": the embedding's zone covers a raster sample without an elevation (column " + std::to_string(v.a) +
                                 ", row " + std::to_string(v.b) + "): fill the raster's holes (--fill-nodata) or place the mesh elsewhere");
            const auto at = geo.sample_position(double(v.a), double(v.b), *h);
            positions.emplace_back((*at)[0], (*at)[1], (*at)[2]);
            break;
        }
        case SkirtVertex::Kind::boundary:
            positions.push_back(placed(plan.footprint.ring[size_t(v.a)]));
            break;
        case SkirtVertex::Kind::crossing: {
            const size_t n = plan.footprint.ring.size();
            const glm::dvec3 a = placed(plan.footprint.ring[size_t(v.a)]), b = placed(plan.footprint.ring[(size_t(v.a) + 1) % n]);
            positions.push_back(a + (b - a) * (double(v.num) / double(v.den)));
            break;
        }
        }
    }
    Mesh& skirt = plan.skirt_mesh;
    const glm::dvec3 origin = positions.empty() ? glm::dvec3(0) : positions.front();
    skirt.origin = {origin.x, origin.y, origin.z};
    skirt.positions.reserve(3 * positions.size());
    for (const glm::dvec3& p : positions)
        skirt.positions.insert(skirt.positions.end(), {float(p.x - origin.x), float(p.y - origin.y), float(p.z - origin.z)});
    skirt.indices = plan.skirt.triangles;
    if (raster_turns_over(geo))
        for (size_t t = 0; t < skirt.indices.size(); t += 3) std::swap(skirt.indices[t + 1], skirt.indices[t + 2]);
    return plan;
}

}  // namespace strata

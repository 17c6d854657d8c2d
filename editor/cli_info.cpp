// strata info FILE.hlod: what a model holds, from its header and node table alone: no payload byte is
// read, so a model of any size is described in the time it takes to read kilobytes (`strata verify`
// checks the payloads).
#include "editor/commands.h"
#include "preprocess/elevation_raster.h"
#include "preprocess/embedding_file.h"
#include "preprocess/cube_textures.h"
#include "preprocess/hlod_format.h"
#include "preprocess/terrain_heights.h"

#include <cmath>
#include <cstdio>
#include <memory>

namespace strata::cli {
namespace {

// A terrain's raster: its grid, holes and the ground it covers (FORMAT.md §4.7), and its heights (§4.8).
void print_terrain(const std::shared_ptr<const HlodFile>& file) {
    const HlodHeader& h = file->header();
    const TerrainGrid& t = *h.terrain;
    const double samples = double(t.columns) * double(t.rows);
    const char* unit = t.raster_geographic ? "°" : " m";
    std::printf("terrain     %llu × %llu samples, %g × %g%s apart, %llu nodata (%.2g %%), cubes of %u cells\n",
                (unsigned long long)t.columns, (unsigned long long)t.rows, t.spacing[0], t.spacing[1], unit,
                (unsigned long long)t.nodata_samples, 100.0 * double(t.nodata_samples) / samples, t.cube_cells);
    if (t.frame == 0)
        std::printf("frame       x east, y north, z up, metres: the CRS's plane from its model origin\n");
    else if (t.frame == 3)
        std::printf("frame       x east, y north, z up, metres: reprojected from %s into the CRS's plane, from its model origin\n",
                    describe_crs(t.raster_crs).c_str());
    else
        std::printf("frame       x east, y north, z up, metres: %s at longitude %.9g°, latitude %.9g°\n",
                    t.frame == 1 ? "enu, the flat tangent plane" : "ecef, the Earth's curvature kept, seen", h.geo_origin[0],
                    h.geo_origin[1]);
    if (h.has_bounds)
        std::printf("extent      %.10g × %.10g m, heights %.10g to %.10g m\n", h.bounds_hi[0] - h.bounds_lo[0],
                    h.bounds_hi[1] - h.bounds_lo[1], h.bounds_lo[2], h.bounds_hi[2]);
    const HlodSection* section = file->find_section(kHeightsTag);
    if (!section) {
        std::printf("heights     not kept (rebuild from the raster for model:height_at)\n");
        return;
    }
    const HeightStep step = TerrainHeights(file, *section).step();
    std::printf("heights     to %.6g m%s, %.2f MB, %.3g bytes a sample\n", step.step, step.step == 0.001 ? "" : " (the raster's own step: exact)",
                double(section->size) / 1e6, double(section->size) / samples);
}

// An embedding file's section EMBD (FORMAT.md §4.10): which terrain and site, where, and the zone.
void print_embedding(const HlodFile& file) {
    const EmbeddingRecord r = read_embedding(file);
    std::printf("embedding   %s on terrain %s (fingerprints %08x, %08x)\n", r.site_file.c_str(), r.terrain_file.c_str(),
                r.site_fingerprint, r.terrain_fingerprint);
    if (r.standing) {
        std::printf("            standing: a closed mesh on the ground, nothing cut\n");
    } else {
        std::printf("zone        level %u of 0 … %u, cells of %lld samples, %lld × %lld from cell (%lld, %lld): %zu partly, %zu wholly covered%s\n",
                    r.zone_level, r.terrain_levels, (long long)r.zone.size, (long long)r.zone.width, (long long)r.zone.height,
                    (long long)r.zone.first_x, (long long)r.zone.first_y, r.cells(CellCover::partly), r.cells(CellCover::whole),
                    r.zone_capped ? " (capped)" : "");
        std::printf("            ΔH %.3f m, %llu boundary vertices, raster %llu × %llu\n", r.height_difference,
                    (unsigned long long)r.boundary_vertices, (unsigned long long)r.columns, (unsigned long long)r.rows);
    }
    const glm::dmat4& m = r.placement;
    std::printf("placement   site → terrain: translation (%.10g, %.10g, %.10g), scale %.6g, heading %.4g°\n", m[3][0], m[3][1], m[3][2],
                std::cbrt(glm::determinant(glm::dmat3(m))), std::atan2(-m[0][1], m[0][0]) * 180.0 / M_PI);
}

int run_info(const std::string& path) {
    const auto shared_file = std::make_shared<const HlodFile>(path);
    const HlodFile& file = *shared_file;
    const HlodHeader& h = file.header();
    std::printf("file        %s (%.2f MB)\n", path.c_str(), file.file_size() / 1e6);
    std::printf("source      %s: %llu vertices, %llu triangles\n", h.source.c_str(),
                (unsigned long long)h.input_vertices, (unsigned long long)h.input_triangles);
    std::printf("attributes  normals%s%s%s%s\n", h.has_colors() ? ", colours" : "", h.has_uvs() ? ", UVs" : "",
                h.texture.empty() ? "" : ", texture ", h.texture.c_str());
    std::printf("bounds      origin (%g, %g, %g), root cube %g\n", h.origin[0], h.origin[1], h.origin[2], h.root_size);
    if (!h.crs.empty())
        std::printf("georef      %s, %s (%.17g, %.17g, %.17g)\n", describe_crs(h.crs).c_str(),
                    h.terrain && h.terrain->tangent_frame() ? "tangent point" : "model origin at", h.geo_origin[0], h.geo_origin[1], h.geo_origin[2]);
    if (h.terrain) print_terrain(shared_file);
    if (file.find_section(kEmbeddingTag)) print_embedding(file);
    if (const HlodSection* section = file.find_section(kTexturesTag)) {  // FORMAT.md §4.9
        const CubeTextures textures(shared_file, *section, file.nodes().size());
        const uint32_t size = textures.layout().size;
        std::printf("textures    %u × %u texels a cube, BC1 sRGB with mips, %.2f MB (%.3g bits a texel)\n", size, size,
                    double(section->size) / 1e6, 8.0 * double(textures.stored_bytes()) / (double(file.nodes().size()) * size * size));
    }
    std::printf("levels      %u (0 … %u), block %u³, σ0 %.4g, ε_q %.4g\n", h.max_level + 1, h.max_level, h.block_size,
                h.sigma0, h.error_q);
    std::printf("errors      %s\n", h.flags & kErrorsAreBounds ? "bounds (FORMAT.md §13)"
                                                               : "estimates (built before 2026-12: rebuild for bounds)");
    std::printf("settings    ratio %.3g, error limit %s%s\n", h.ratio,
                h.error_limit > 0 ? std::to_string(h.error_limit).c_str() : "none",
                h.flags & kLockedBoundary ? ", boundary locked" : "");
    std::printf("\n%5s %8s %12s %12s %12s %10s %12s\n", "level", "cubes", "vertices", "triangles", "bytes", "cube size",
                "max error");
    uint64_t total_v = 0, total_t = 0, total_b = 0;
    for (uint32_t l = 0; l <= h.max_level; ++l) {
        uint64_t cubes = 0, v = 0, t = 0, b = 0;
        float error = 0;
        for (const HlodNode& n : file.nodes())
            if (n.level == l) cubes++, v += n.vertex_count, t += n.triangle_count, b += n.size, error = std::max(error, n.error);
        total_v += v, total_t += t, total_b += b;
        std::printf("%5u %8llu %12llu %12llu %12llu %10.4g %12.4g\n", l, (unsigned long long)cubes,
                    (unsigned long long)v, (unsigned long long)t, (unsigned long long)b, h.cube_size(l), error);
    }
    std::printf("%5s %8llu %12llu %12llu %12llu\n", "all", (unsigned long long)file.nodes().size(),
                (unsigned long long)total_v, (unsigned long long)total_t, (unsigned long long)total_b);
    return kOk;
}

}  // namespace

Command add_info(CLI::App& app) {
    auto path = std::make_shared<std::string>();
    CLI::App* sub = app.add_subcommand("info", "Describe a .hlod model: levels, cubes, vertices and triangles per level, bytes, bounds, settings.");
    sub->add_option("file", *path, "The .hlod file")->required();
    return {sub, [path] { return run_info(*path); }};
}

}  // namespace strata::cli

// strata embed TERRAIN.hlod SITE -o OUT.hlod: embed a site (a .hlod built with --lock-boundary, or a
// mesh file, built so first) in a terrain once, keeping the skirt and the zone in an embedding file (preprocess/embedding_file.h) that
// a scene reloads without recomputing.
#include "editor/commands.h"
#include "editor/progress_bar.h"
#include "preprocess/byte_size.h"
#include "preprocess/embedding_file.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace strata::cli {
namespace {

struct EmbedOptions {
    std::string terrain, site, output, at, matrix, memory;
    EmbedSettings settings;
    bool quiet = false;
};

// LON,LAT in degrees.
bool parse_point(const std::string& text, std::array<double, 2>& point) {
    const size_t comma = text.find(',');
    if (comma == std::string::npos) return false;
    for (int i = 0; i < 2; ++i) {
        const std::string part = i == 0 ? text.substr(0, comma) : text.substr(comma + 1);
        char* end = nullptr;
        point[size_t(i)] = std::strtod(part.c_str(), &end);
        if (part.empty() || *end || !std::isfinite(point[size_t(i)])) return false;
    }
    return std::abs(point[0]) <= 360 && std::abs(point[1]) <= 90;
}

// 16 numbers, comma-separated, column-major; "" or why not.
std::string parse_matrix(const std::string& text, glm::dmat4& matrix) {
    std::vector<std::string> parts(1);
    for (char c : text) {
        if (c == ',')
            parts.emplace_back();
        else
            parts.back().push_back(c);
    }
    if (parts.size() != 16) return "it takes 16 comma-separated numbers, column-major, not " + std::to_string(parts.size());
    for (int i = 0; i < 16; ++i) {
        char* end = nullptr;
        matrix[i / 4][i % 4] = std::strtod(parts[size_t(i)].c_str(), &end);
        if (parts[size_t(i)].empty() || *end) return "'" + parts[size_t(i)] + "' is not a number";
    }
    return placement_matrix_problem(matrix);
}

int run_embed(const EmbedOptions& o) {
    EmbedSettings settings = o.settings;
    if (o.output.empty()) {
        std::fprintf(stderr, "strata embed: --output is required\n");
        return kUsage;
    }
    if (!o.at.empty()) {
        std::array<double, 2> point{};
        if (!parse_point(o.at, point)) {
            std::fprintf(stderr, "strata embed: --at takes a longitude and a latitude in degrees, LON,LAT, not '%s'\n", o.at.c_str());
            return kUsage;
        }
        settings.placement.at = point;
    }
    if (!o.matrix.empty()) {
        glm::dmat4 matrix(1.0);
        if (const std::string problem = parse_matrix(o.matrix, matrix); !problem.empty()) {
            std::fprintf(stderr, "strata embed: --matrix: %s\n", problem.c_str());
            return kUsage;
        }
        settings.placement.matrix = matrix;
    }
    if (!o.memory.empty()) {
        try {
            settings.memory = parse_byte_size(o.memory);
        } catch (const std::invalid_argument& e) {
            std::fprintf(stderr, "strata embed: --memory: %s\n", e.what());
            return kUsage;
        }
    }
    // Without --at or --matrix the site must say where it lies (opening reads kilobytes); a mesh cannot.
    const bool placed = settings.placement.at || settings.placement.matrix;
    if (!placed && std::filesystem::exists(o.site) && (!is_hlod_file(o.site) || HlodFile(o.site).header().crs.empty())) {
        std::fprintf(stderr, "strata embed: %s has no georeference (CRS): place it with --at LON,LAT or --matrix\n", o.site.c_str());
        return kUsage;
    }
    const std::atomic<bool>* cancel = install_interrupt_flag();
    ProgressBar bar(!o.quiet);
    try {
        const EmbedReport report = build_embedding(o.terrain, o.site, o.output, settings, bar.progress(cancel));
        bar.finish();
        for (const std::string& warning : report.warnings) std::fprintf(stderr, "strata embed: warning: %s\n", warning.c_str());
        if (o.quiet) return kOk;
        if (report.site_model != o.site)
            std::printf("%s: the site model, %s built with its boundary locked\n", report.site_model.c_str(), o.site.c_str());
        const EmbeddingRecord& r = report.record;
        if (r.standing) {
            std::printf("%s: %s stands on %s (a closed mesh: nothing cut), %.2f s\n", o.output.c_str(), o.site.c_str(), o.terrain.c_str(),
                        report.seconds);
            std::printf("  bytes       EMBD %llu, file %llu\n", (unsigned long long)report.embd_bytes, (unsigned long long)report.file_bytes);
            return kOk;
        }
        std::printf("%s: %s embedded in %s, %.2f s\n", o.output.c_str(), o.site.c_str(), o.terrain.c_str(), report.seconds);
        std::printf("  zone        level %u of 0 … %u (cells of %lld samples): %zu partly, %zu wholly covered%s\n", r.zone_level,
                    r.terrain_levels, (long long)r.zone.size, r.cells(CellCover::partly), r.cells(CellCover::whole),
                    r.zone_capped ? "; m capped: ΔH asks for a coarser level, the site appears from this one" : "; m as ΔH asks, not capped");
        std::printf("  ΔH          %.3f m\n", r.height_difference);
        std::printf("  skirt       %llu triangles, %llu boundary vertices\n", (unsigned long long)report.skirt_triangles,
                    (unsigned long long)r.boundary_vertices);
        const double per_vertex = double(std::max<uint64_t>(r.boundary_vertices, 1));
        std::printf("  bytes       EMBD %llu (%.2f a boundary vertex), file %llu (%.1f a boundary vertex)", (unsigned long long)report.embd_bytes,
                    double(report.embd_bytes) / per_vertex, (unsigned long long)report.file_bytes, double(report.file_bytes) / per_vertex);
        if (report.texture_bytes) std::printf(", of which the skirt's imagery %llu", (unsigned long long)report.texture_bytes);
        std::printf("\n");
        return kOk;
    } catch (const Cancelled&) {
        bar.finish();
        std::fprintf(stderr, "strata embed: interrupted; %s was not written\n", o.output.c_str());
        return kInterrupted;
    }
}

}  // namespace

Command add_embed(CLI::App& app) {
    auto o = std::make_shared<EmbedOptions>();
    CLI::App* sub = app.add_subcommand(
        "embed",
        "Embed a site (a .hlod built with --lock-boundary, or a mesh file, built so beside the output) in a terrain: write its skirt and "
        "zone to an embedding file (.hlod).");
    sub->add_option("terrain", o->terrain, "The terrain .hlod (built from an elevation raster)")->required();
    sub->add_option("site", o->site,
                    "The site: a .hlod built with strata build --lock-boundary, or a mesh (OBJ, PLY, OFF, STL: a building, a road, a "
                    "quarry floor), built so into OUT_site.hlod (kept, and reused while the mesh is older); a closed mesh stands on the ground")
        ->required();
    sub->add_option("-o,--output", o->output, "The embedding file to write (.hlod)");
    CLI::Option* at = sub->add_option("--at", o->at,
                    "Put the centroid of the site's boundary at this longitude and latitude (degrees), lifted so its boundary "
                    "meets the ground best (mean ground − site height 0 over its vertices); default: where the site's own "
                    "georeference puts it")
        ->type_name("LON,LAT");
    CLI::Option* matrix =
        sub->add_option("--matrix", o->matrix,
                        "Place the site by this matrix from its model coordinates to the terrain's (16 numbers, column-major, as "
                        "Lua's; an affine map that does not mirror), as given: nothing lifted")
            ->type_name("M0,...,M15")
            ->excludes(at);
    sub->add_option("--scale", o->settings.placement.scale, "Scale the site about its boundary's centroid")
        ->check(positive_number())
        ->capture_default_str()
        ->excludes(matrix);
    sub->add_option("--heading", o->settings.placement.heading, "Turn the site clockwise seen from above (degrees) about its boundary's centroid")
        ->capture_default_str()
        ->excludes(matrix);
    sub->add_option("--threads", o->settings.threads, "Worker threads (0: every core)")->capture_default_str();
    sub->add_option("--memory", o->memory,
                    "Memory for the builds' buffers (the skirt's, and a mesh site's), in bytes or with a binary suffix K, M, "
                    "G, T; default a quarter of physical memory. A .hlod site is read a cube at a time whatever its size");
    sub->add_flag("-q,--quiet", o->quiet, "No progress bar and no summary");
    return {sub, [o] { return run_embed(*o); }};
}

}  // namespace strata::cli

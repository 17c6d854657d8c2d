// The hybrid terrain benchmark (issue 18 §4): a real scan embedded in a real DEM and drawn with real
// OpenGL. The scan is the bundled bunny (data/bunny.off, 75 000 triangles) opened at its base, stood
// up, scaled to SITE metres and set on the ground at the centre of data/olinda_dem.tif (111 × 111
// samples, 90 m); the terrain, the site and the skirt are built as .hlod (the site and the skirt with
// locked boundaries). Views circle the site at distances from a site's width to ten, at 1280×720 and
// 1 px. Per view: triangles drawn and the frame's time, the seams' share of both (their cost: the
// frame's time less that of the same frame without them, the median of 7 interleaved pairs, which takes
// out the CPU's choice of the seam vertices and the GPU's morph pass and draw; and that choice timed
// alone), and the same views drawn at full
// resolution (every cube of the terrain's finest level, the site's finest level; nothing embedded: the
// scan drawn over the full grid). Medians over the views; each time the median of 3 renders. Asserts
// nothing.
//
//   bench_hybrid_terrain [VIEWS [SITE [trinidad | patch]]]      (defaults 24 600)
//
// `trinidad` embeds the site in data/trinidad.nc instead (2401 × 1201 samples at 3″, 5.8 M triangles at
// full resolution), at its centre. `patch` is thesis 003's own setup (ch. 5; the note's §7): the grid is
// trinidad.nc downsampled 4 × (gdal_translate, averaged), the embedded mesh a patch of the
// full-resolution DEM SITE metres wide (a disc of rings of its samples' spacing, heights bilinear from
// the raster: a TIN as dense as the DEM), and full resolution is the whole DEM at its finest.
//
// A frame's time is the renderer's, from the start of culling to glFinish() returning (llvmpipe
// rasterizes on the CPU: its threads share this machine's cores).
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <glm/gtc/constants.hpp>

#include "engine/gl/context.h"
#include "engine/gl/framebuffer.h"
#include "engine/render/renderer.h"
#include "engine/scene/light.h"
#include "nodes/terrain.h"
#include "preprocess/embedding.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/mesh_io.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/bench/bench_stats.h"
#include "tests/support/test_meshes.h"

namespace {

using namespace strata;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// The bunny opened at its base (the faces of its lowest 6 %), turned from y up to z up, `width` metres
// wide, its base's mean height on the ground's at (x, y).
Mesh site_on_ground(const TerrainSite& terrain, const std::filesystem::path& scan, double x, double y, double width) {
    const Mesh bunny = read_mesh(scan);
    glm::dvec3 lo(1e300), hi(-1e300);
    for (size_t v = 0; v < bunny.vertex_count(); ++v) {
        const glm::dvec3 p(bunny.positions[3 * v], bunny.positions[3 * v + 1], bunny.positions[3 * v + 2]);
        lo = glm::min(lo, p), hi = glm::max(hi, p);
    }
    const double cut = lo.y + 0.06 * (hi.y - lo.y), scale = width / std::max(hi.x - lo.x, hi.z - lo.z);
    Mesh site;
    site.origin = {x, y, 0};
    for (size_t v = 0; v < bunny.vertex_count(); ++v) {
        const float* p = &bunny.positions[3 * v];
        site.positions.insert(site.positions.end(), {float((p[0] - 0.5 * (lo.x + hi.x)) * scale), float(-(p[2] - 0.5 * (lo.z + hi.z)) * scale),
                                                     float((p[1] - cut) * scale)});
    }
    for (size_t t = 0; t < bunny.indices.size(); t += 3) {
        const uint32_t* f = &bunny.indices[t];
        if (bunny.positions[3 * f[0] + 1] < cut && bunny.positions[3 * f[1] + 1] < cut && bunny.positions[3 * f[2] + 1] < cut) continue;
        site.indices.insert(site.indices.end(), {f[0], f[1], f[2]});
    }
    // Set on the ground: its base (the cut) at the ground's mean height under it.
    const Georeference& geo = *terrain.georeference;
    double ground = 0;
    int samples = 0;
    for (size_t v = 0; v < site.vertex_count(); ++v) {
        if (site.positions[3 * v + 2] > 0.02 * width) continue;
        const auto cell = geo.raster_position(x + site.positions[3 * v], y + site.positions[3 * v + 1], 0);
        if (const auto h = cell ? terrain.heights->at((*cell)[0], (*cell)[1]) : std::nullopt) ground += *h, ++samples;
    }
    site.origin[2] = samples ? ground / samples : 0;
    return site;
}

// A disc `width` wide around (x, y) of `full`'s ground at its own sample spacing, in `grid`'s model frame
// (both from one raster, `grid` downsampled): rings one spacing apart, each cut into pieces of about that
// length, heights bilinear from `full`'s raster.
Mesh dem_patch(const TerrainSite& full, const TerrainSite& grid, double x, double y, double width) {
    const Georeference& from = *full.georeference;
    const Georeference& to = *grid.georeference;
    const std::array<double, 3> centre_geo = to.to_geo({x, y, 0});
    const std::array<double, 3> centre_full = from.to_local(centre_geo);
    const auto a = from.sample_position(0, 0, 0), b = from.sample_position(1, 0, 0);
    const double spacing = std::hypot((*b)[0] - (*a)[0], (*b)[1] - (*a)[1]);
    Mesh mesh;
    mesh.origin = {x, y, 0};
    std::vector<std::vector<uint32_t>> rings;
    auto add = [&](double dx, double dy) {  // a point of the full raster's frame, by its offset from the centre
        const glm::dvec3 at(centre_full[0] + dx, centre_full[1] + dy, 0);
        const auto cell = from.raster_position(at.x, at.y, 0);
        const double h = cell ? full.heights->at((*cell)[0], (*cell)[1]).value_or(0) : 0;
        const std::array<double, 3> p = to.to_local(from.to_geo({at.x, at.y, h}));
        mesh.positions.insert(mesh.positions.end(), {float(p[0] - x), float(p[1] - y), float(p[2])});
        return uint32_t(mesh.vertex_count() - 1);
    };
    const int count = std::max(2, int(0.5 * width / spacing));
    rings.push_back({add(0, 0)});
    for (int k = 1; k <= count; ++k) {
        const double r = 0.5 * width * k / count;
        const int pieces = std::max(6, int(2 * M_PI * r / spacing));
        rings.emplace_back();
        for (int i = 0; i < pieces; ++i) rings.back().push_back(add(r * std::cos(2 * M_PI * i / pieces), r * std::sin(2 * M_PI * i / pieces)));
    }
    // Between two rings: walk both, always advancing the one whose next point comes first by angle.
    for (size_t k = 1; k < rings.size(); ++k) {
        const auto& in = rings[k - 1];
        const auto& out = rings[k];
        if (in.size() == 1) {
            for (size_t i = 0; i < out.size(); ++i) mesh.indices.insert(mesh.indices.end(), {in[0], out[i], out[(i + 1) % out.size()]});
            continue;
        }
        size_t i = 0, o = 0;
        while (i < in.size() || o < out.size()) {
            const bool step_out = i == in.size() || (o < out.size() && double(o + 1) / out.size() <= double(i + 1) / in.size());
            if (step_out) {
                mesh.indices.insert(mesh.indices.end(), {in[i % in.size()], out[o], out[(o + 1) % out.size()]});
                ++o;
            } else {
                mesh.indices.insert(mesh.indices.end(), {in[i], out[o % out.size()], in[(i + 1) % in.size()]});
                ++i;
            }
        }
    }
    return mesh;
}

// Builds with the most levels (up to 5) that the mesh's longest edges allow.
void build_locked(Mesh mesh, const std::filesystem::path& out, const char* what) {
    for (int levels = 5;; --levels) {
        try {
            BuildSettings settings;
            settings.lock_boundary = true;
            settings.levels = levels;
            build_hlod(Mesh(mesh), out, settings, what);
            return;
        } catch (const std::exception&) {
            if (levels == 0) throw;
        }
    }
}

struct Frame {
    double seconds = 0;
    uint64_t triangles = 0;
};

Frame render(Renderer& renderer, Node& scene, const Camera& camera, gl::Framebuffer& target) {
    std::vector<double> times;
    uint64_t triangles = 0;
    for (int run = 0; run < 3; ++run) {
        const auto start = Clock::now();
        triangles = renderer.render(scene, camera, target).triangles;
        times.push_back(seconds_since(start));
    }
    return {bench::median(times), triangles};
}

}  // namespace

int main(int argc, char** argv) try {
    const int views = argc > 1 ? std::atoi(argv[1]) : 24;
    const double width = argc > 2 ? std::atof(argv[2]) : 600;
    const std::string mode = argc > 3 ? argv[3] : "";
    const bool patch = mode == "patch", trinidad = mode == "trinidad" || patch;
    const auto data = std::filesystem::path(STRATA_SOURCE_DIR) / "data";
    if (views < 1 || !(width > 0)) {
        std::fprintf(stderr, "usage: bench_hybrid_terrain [VIEWS >= 1 [SITE > 0 metres [trinidad | patch]]]\n");
        return 2;
    }
    const std::filesystem::path dem = data / (trinidad ? "trinidad.nc" : "olinda_dem.tif");
    if (!std::filesystem::exists(dem) || !std::filesystem::exists(data / "bunny.off")) {
        std::fprintf(stderr, "bench_hybrid_terrain: %s or data/bunny.off missing: run scripts/setup.sh\n", dem.c_str());
        return 1;
    }
    const test::TempDir dir;
    auto start = Clock::now();
    TerrainSettings terrain_settings;
    terrain_settings.cube_cells = trinidad ? 64 : 16;
    if (trinidad) terrain_settings.crs = "EPSG:4326", terrain_settings.elevation_unit = "ft";
    // The grid; in patch mode the DEM downsampled, and the DEM itself as full resolution.
    std::filesystem::path grid_dem = dem;
    if (patch) {
        grid_dem = dir / "grid.tif";
        const std::string command = "gdal_translate -q -r average -outsize 25% 25% '" + dem.string() + "' '" + grid_dem.string() + "'";
        if (std::system(command.c_str()) != 0) throw std::runtime_error("gdal_translate failed: " + command);
        build_terrain({dem}, dir / "full.hlod", terrain_settings, dem.filename().string());
        terrain_settings.cube_cells = 16;
    }
    build_terrain({grid_dem}, dir / "terrain.hlod", terrain_settings, grid_dem.filename().string());
    const double terrain_seconds = seconds_since(start);
    const TerrainSite terrain = TerrainSite::open(dir / "terrain.hlod");
    const auto centre = terrain.georeference->sample_position(double(terrain.grid().columns / 2), double(terrain.grid().rows / 2), 0);
    const double cx = (*centre)[0], cy = (*centre)[1];
    Mesh site = patch ? dem_patch(TerrainSite::open(dir / "full.hlod"), terrain, cx, cy, width) : site_on_ground(terrain, data / "bunny.off", cx, cy, width);
    const size_t site_triangles = site.triangle_count();
    start = Clock::now();
    const EmbeddingPlan plan = plan_embedding(terrain, site, glm::dmat4(1.0), "bunny.off");
    const double plan_seconds = seconds_since(start);
    start = Clock::now();
    build_locked(Mesh(plan.skirt_mesh), dir / "skirt.hlod", "skirt");
    const double skirt_seconds = seconds_since(start);
    build_locked(std::move(site), dir / "site.hlod", "bunny.off");

    const auto context = gl::create_headless_context();
    auto ground = HlodModel::load(dir / "terrain.hlod");
    auto hybrid = std::make_shared<Terrain>(ground);
    const auto embedding = hybrid->embed(HlodModel::load(dir / "skirt.hlod"), HlodModel::load(dir / "site.hlod"), glm::dmat4(1.0),
                                         plan.zone_level, plan.zone, "bunny.off");
    auto scene = std::make_shared<Group>();
    scene->add(std::make_shared<DirectionalLight>());
    scene->add(hybrid);
    // Full resolution: the grid's finest level everywhere and the scan's finest level, no embedding (in
    // patch mode the whole DEM at its finest, which holds the patch).
    auto full_ground = HlodModel::load(dir / (patch ? "full.hlod" : "terrain.hlod"));
    auto full = std::make_shared<Group>();
    full->add(std::make_shared<DirectionalLight>());
    full->add(full_ground);
    full_ground->set_kappa0(1e9);
    if (!patch) {
        auto full_site = HlodModel::load(dir / "site.hlod");
        full->add(full_site);
        full_site->set_kappa0(1e9);
    }
    for (const auto& m : {ground, embedding->skirt(), embedding->site()}) m->set_pixel_error(1.0);

    Camera camera;
    camera.width = 1280, camera.height = 720, camera.fov_y_degrees = 50;
    gl::Framebuffer target({.width = 1280, .height = 720, .samples = 1});
    Renderer renderer;
    std::vector<double> hybrid_triangles, full_triangles, full_frame_ms;
    std::vector<double> frame, stitch_time_share, stitch_triangle_share, fewer, faster, stitch_ms, stitch_cpu_ms;
    size_t drawn = 0;
    constexpr int kDistances = 6;  // a site's width × 10^(k/5), k = 0 … 5
    std::array<std::vector<double>, kDistances> fewer_at, faster_at;
    for (int i = 0; i < views; ++i) {
        const double distance = width * std::pow(10.0, double(i % kDistances) / 5.0), angle = 2 * glm::pi<double>() * i / views;
        const glm::dvec3 at{cx, cy, plan.skirt_mesh.origin[2] + 0.2 * width};
        const glm::dvec3 eye = at + glm::dvec3(distance * std::cos(angle), distance * std::sin(angle), 0.35 * distance);
        camera.look_at(eye, at, {0, 0, 1});
        const Frame hybrid_frame = render(renderer, *scene, camera, target);
        const Frame full_frame = render(renderer, *full, camera, target);
        frame.push_back(hybrid_frame.seconds * 1e3);
        full_frame_ms.push_back(full_frame.seconds * 1e3);
        hybrid_triangles.push_back(double(hybrid_frame.triangles)), full_triangles.push_back(double(full_frame.triangles));
        fewer.push_back(double(full_frame.triangles) / double(hybrid_frame.triangles));
        faster.push_back(full_frame.seconds / hybrid_frame.seconds);
        fewer_at[size_t(i % kDistances)].push_back(fewer.back()), faster_at[size_t(i % kDistances)].push_back(faster.back());
        if (!embedding->drawn()) continue;
        ++drawn;
        // The seams' cost: the frame less the same frame without them, in interleaved pairs (their cost is
        // near the frames' run-to-run spread); and the CPU's part, which vertices they join, alone.
        std::vector<double> differences;
        for (int pair = 0; pair < 7; ++pair) {
            for (const bool shown : {true, false}) {
                embedding->seams().set_visible(shown);
                const auto start = Clock::now();
                renderer.render(*scene, camera, target);
                differences.push_back((shown ? 1 : -1) * seconds_since(start));
            }
            differences[differences.size() - 2] += differences.back();
            differences.pop_back();
        }
        embedding->seams().set_visible(true);
        const double seam_seconds = bench::median(differences);
        const auto& s = embedding->selections();
        std::vector<StitchRefTriangle> seams;
        std::vector<double> times;
        for (int run = 0; run < 3; ++run) {
            seams.clear();
            const auto t0 = Clock::now();
            embedding->stitch().seam_vertices(s.terrain.cubes, s.skirt.cubes, s.site.cubes, seams);
            times.push_back(seconds_since(t0));
        }
        stitch_cpu_ms.push_back(bench::median(times) * 1e3);
        stitch_ms.push_back(seam_seconds * 1e3);
        stitch_time_share.push_back(seam_seconds / hybrid_frame.seconds);
        stitch_triangle_share.push_back(double(seams.size()) / double(hybrid_frame.triangles));
    }
    std::printf("terrain %s: %llu × %llu samples, built in %.2f s; site %s %.0f m wide, %zu triangles, %zu boundary vertices; zone level %u%s, ΔH %.1f m\n",
                grid_dem.filename().c_str(), (unsigned long long)terrain.grid().columns, (unsigned long long)terrain.grid().rows, terrain_seconds, patch ? "(a patch of the full DEM)" : "(the bunny)", width, site_triangles,
                embedding->stitch().boundary_vertices(),
                plan.zone_level, plan.zone_capped ? " (capped)" : "", plan.height_difference);
    std::printf("embedding: plan %.3f s, skirt build %.3f s, skirt %zu triangles, %zu border steps\n", plan_seconds, skirt_seconds,
                plan.skirt_mesh.triangle_count(), embedding->stitch().border_steps());
    std::printf("%d views at 1280×720, 1 px (embedding drawn in %zu), medians:\n", views, drawn);
    std::printf("  frame %.1f ms; stitch %.3f ms = %.2f %% of the frame (of which the CPU's choice of vertices %.3f ms); seam triangles %.2f %% of those drawn\n",
                bench::median(frame), bench::median(stitch_ms), 100 * bench::median(stitch_time_share), bench::median(stitch_cpu_ms),
                100 * bench::median(stitch_triangle_share));
    std::printf("  triangles drawn %.0f (full resolution %.0f); full-resolution frame %.1f ms\n", bench::median(hybrid_triangles),
                bench::median(full_triangles), bench::median(full_frame_ms));
    std::printf("  against full resolution: %.1f× fewer triangles, %.2f× faster\n", bench::median(fewer), bench::median(faster));
    std::printf("  by distance (site widths): ");
    for (int k = 0; k < kDistances && k < views; ++k)
        std::printf("%s%.1f: %.1f×, %.2f×", k ? "; " : "", std::pow(10.0, double(k) / 5.0), bench::median(fewer_at[size_t(k)]), bench::median(faster_at[size_t(k)]));
    std::printf("\n");
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "bench_hybrid_terrain: %s\n", e.what());
    return 1;
}

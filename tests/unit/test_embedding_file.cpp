// The embedding file (preprocess/embedding_file.h, FORMAT.md §4.10): a site .hlod embedded in a terrain
// .hlod gives a skirt model whose two locked boundaries decode to the same floats at every level and a
// section EMBD that reads back field for field; the site is placed where --at says (or its own CRS), ΔH
// counts the finest level's vertices, and a different terrain, an unlocked site, a corrupt or unknown
// section are refused by name. A closed site stands, in a file without cubes.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <set>

#include "preprocess/cube_textures.h"
#include "preprocess/embedding.h"
#include "preprocess/embedding_file.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/hlod_verify.h"
#include "preprocess/terrain_build.h"
#include "preprocess/terrain_heights.h"
#include "tests/support/geotiff.h"
#include "tests/support/test_meshes.h"

namespace strata {
namespace {

namespace fs = std::filesystem;

constexpr int kSize = 97;        // samples per side
constexpr double kSpacing = 30;  // metres

double dem_height(int c, int r, double lift) { return 400 + lift + 25 * std::sin(c * 0.11) * std::cos(r * 0.07) + 0.8 * c; }

fs::path terrain(const test::TempDir& dir, const std::string& name, double lift = 0) {
    test::TiffSpec spec;
    spec.width = spec.height = kSize;
    spec.type = GDT_Float32;
    for (int r = 0; r < kSize; ++r)
        for (int c = 0; c < kSize; ++c) spec.values.push_back(float(dem_height(c, r, lift)));
    const fs::path dem = dir.path() / (name + ".tif"), out = dir.path() / (name + ".hlod");
    test::write_tiff(dem, spec);
    TerrainSettings settings;
    settings.cube_cells = 8;
    build_terrain({dem}, out, settings, name + ".tif");
    return out;
}

// A bumpy square patch `side` metres wide of n × n quads around its own origin, with a narrow spike of
// `spike` metres at its middle (which coarse levels simplify away).
Mesh patch(int n, double side, double spike) {
    Mesh mesh;
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            const double u = side * (double(x) / n - 0.5), v = side * (double(y) / n - 0.5);
            double z = 1.5 * std::sin(u * 0.05) * std::cos(v * 0.04);
            if (x == n / 2 && y == n / 2) z += spike;
            mesh.positions.insert(mesh.positions.end(), {float(u), float(v), float(z)});
        }
    for (uint32_t y = 0; y < uint32_t(n); ++y)
        for (uint32_t x = 0; x < uint32_t(n); ++x) {
            const uint32_t a = y * uint32_t(n + 1) + x, b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
        }
    return mesh;
}

fs::path build_site(const test::TempDir& dir, const std::string& name, Mesh mesh, bool lock) {
    BuildSettings settings;
    settings.lock_boundary = lock;
    settings.leaf_triangles = 512;
    const fs::path out = dir.path() / (name + ".hlod");
    build_hlod(std::move(mesh), out, settings, name + ".ply");
    return out;
}

// The longitude and latitude of terrain model point (x, y).
std::array<double, 2> lon_lat(const fs::path& terrain_path, double x, double y) {
    const TerrainSite t = TerrainSite::open(terrain_path);
    const std::array<double, 3> geo = t.georeference->to_geo({x, y, 0});
    return {geo[0], geo[1]};
}

EmbedSettings at(const std::array<double, 2>& point) {
    EmbedSettings settings;
    settings.placement.at = point;
    settings.leaf_triangles = 256;  // a skirt of several levels
    return settings;
}

std::string message_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "(nothing thrown)";
}

TEST(EmbeddingFile, EveryFieldOfTheSectionReadsBack) {
    EmbeddingRecord r;
    r.terrain_file = "../dem/olinda.hlod";
    r.site_file = "/data/sites/fort.hlod";
    r.terrain_fingerprint = 0xdeadbeef, r.site_fingerprint = 0x01234567;
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) r.placement[c][row] = 0.1 * c - 0.37 * row + (c == 3 ? 1e6 : 0);
    r.terrain_levels = 5, r.zone_level = 4;  // cells of level 3: 4 raster steps
    r.height_difference = 12.625;
    r.zone_capped = true;
    r.columns = 97, r.rows = 81;
    r.boundary_vertices = 321;
    r.zone.size = 4, r.zone.first_x = 3, r.zone.first_y = 2, r.zone.width = 3, r.zone.height = 3;  // 9 cells: not a whole byte
    r.zone.cover = {CellCover::partly, CellCover::partly, CellCover::none, CellCover::partly, CellCover::whole,
                    CellCover::partly, CellCover::none, CellCover::partly, CellCover::partly};
    const std::vector<uint8_t> bytes = encode_embedding(r);
    const EmbeddingRecord back = decode_embedding(bytes, "test");
    EXPECT_EQ(back.version, kEmbeddingVersion);
    EXPECT_EQ(back.terrain_file, r.terrain_file);
    EXPECT_EQ(back.site_file, r.site_file);
    EXPECT_EQ(back.terrain_fingerprint, r.terrain_fingerprint);
    EXPECT_EQ(back.site_fingerprint, r.site_fingerprint);
    EXPECT_EQ(back.placement, r.placement);
    EXPECT_EQ(back.terrain_levels, 5u);
    EXPECT_EQ(back.zone_level, 4u);
    EXPECT_EQ(back.height_difference, 12.625);
    EXPECT_TRUE(back.zone_capped);
    EXPECT_FALSE(back.standing);
    EXPECT_EQ(back.columns, 97u);
    EXPECT_EQ(back.rows, 81u);
    EXPECT_EQ(back.boundary_vertices, 321u);
    EXPECT_EQ(back.zone.size, 4);
    EXPECT_EQ(back.zone.first_x, 3);
    EXPECT_EQ(back.zone.first_y, 2);
    EXPECT_EQ(back.zone.width, 3);
    EXPECT_EQ(back.zone.height, 3);
    EXPECT_EQ(back.zone.cover, r.zone.cover);
    EXPECT_EQ(back.cells(CellCover::partly), 6u);
    EXPECT_EQ(back.cells(CellCover::whole), 1u);

    // What a reader refuses, by name: another version, a cell size that is not level m − 1's, a zone off the
    // raster, a short section, bytes past the end.
    EmbeddingRecord other = r;
    other.version = 2;
    EXPECT_NE(message_of([&] { decode_embedding(encode_embedding(other), "x.hlod: section 'EMBD'"); }).find("x.hlod: section 'EMBD': version 2"), std::string::npos);
    other = r, other.zone.size = 8;
    EXPECT_NE(message_of([&] { decode_embedding(encode_embedding(other), "x"); }).find("not level 3's 4"), std::string::npos);
    other = r, other.zone.first_x = 22;  // cells up to 24·4 = 96 = the last sample's column
    EXPECT_NE(message_of([&] { decode_embedding(encode_embedding(other), "x"); }).find("outside the raster"), std::string::npos);
    EXPECT_NE(message_of([&] { decode_embedding(std::span(bytes).first(bytes.size() - 1), "x"); }).find("ends early"), std::string::npos);
    std::vector<uint8_t> longer = bytes;
    longer.push_back(0);
    EXPECT_NE(message_of([&] { decode_embedding(longer, "x"); }).find("past its end"), std::string::npos);
}

// Builds the embedding of the bumpy patch on a terrain at its model point (1400, 1500).
struct Embedded {
    test::TempDir dir;
    fs::path dem, site, out;
    EmbedReport report;
    explicit Embedded(double spike = 0, EmbedSettings settings = {}) {
        dem = terrain(dir, "dem");
        site = build_site(dir, "site", patch(40, 300, spike), true);
        out = dir.path() / "embedded" / "site_on_dem.hlod";
        fs::create_directories(out.parent_path());
        const EmbedSettings placed = at(lon_lat(dem, 1400, 1500));
        settings.placement.at = placed.placement.at;
        settings.leaf_triangles = placed.leaf_triangles;
        report = build_embedding(dem, site, out, settings);
    }
};

TEST(EmbeddingFile, TheFileKeepsThePlanAndNamesItsTerrainAndSite) {
    const Embedded e;
    const HlodFile file(e.out);
    const EmbeddingRecord r = read_embedding(file);
    EXPECT_EQ(r.terrain_file, "../dem.hlod");  // relative to the embedding file's folder
    EXPECT_EQ(r.site_file, "../site.hlod");
    EXPECT_EQ(embedded_path(e.out, r.terrain_file).lexically_normal(), e.dem.lexically_normal());
    EXPECT_EQ(r.terrain_fingerprint, model_fingerprint(HlodFile(e.dem)));
    EXPECT_EQ(r.site_fingerprint, model_fingerprint(HlodFile(e.site)));
    EXPECT_FALSE(r.standing);
    EXPECT_EQ(r.columns, uint64_t(kSize));
    EXPECT_EQ(r.rows, uint64_t(kSize));
    // The same plan as planning it here from the site's coarsest level and the record's placement.
    const TerrainSite t = TerrainSite::open(e.dem);
    const SiteModel site = open_site(e.site);
    const EmbeddingPlan plan = plan_embedding(t, site.coarsest, r.placement, r.height_difference, "site");
    EXPECT_EQ(r.zone_level, plan.zone_level);
    EXPECT_EQ(r.terrain_levels, t.header().max_level);
    EXPECT_EQ(r.zone.size, plan.zone.size);
    EXPECT_EQ(r.zone.first_x, plan.zone.first_x);
    EXPECT_EQ(r.zone.first_y, plan.zone.first_y);
    EXPECT_EQ(r.zone.cover, plan.zone.cover);
    EXPECT_GT(r.cells(CellCover::partly), 0u);
    EXPECT_EQ(r.boundary_vertices, plan.footprint.ring.size());
    EXPECT_EQ(r.boundary_vertices, 160u);  // the patch's 4 × 40 boundary edges
    EXPECT_EQ(e.report.skirt_triangles, plan.skirt_mesh.triangle_count());
    EXPECT_EQ(e.report.embd_bytes, file.find_section(kEmbeddingTag)->size);
    // The skirt lies in the terrain's model frame, its GEOR the terrain's.
    const HlodFile dem(e.dem);
    EXPECT_EQ(file.header().crs, dem.header().crs);
    for (int a = 0; a < 3; ++a) EXPECT_EQ(file.header().geo_origin[a], dem.header().geo_origin[a]);
    EXPECT_NEAR(file.header().bounds_lo[0], 1400, 1500);
    EXPECT_NEAR(file.header().bounds_hi[1], 1500, 1500);
    EXPECT_NEAR(file.header().bounds_lo[2], 450, 100);  // the ground's heights
    const VerifyReport verified = verify_hlod(file);
    EXPECT_TRUE(verified.embedding);
    EXPECT_TRUE(verified.boundary_locked);
    EXPECT_EQ(verified.triangles > 0, true);
    // An untextured terrain's skirt has no textures either.
    EXPECT_EQ(file.find_section(kTexturesTag), nullptr);
    EXPECT_EQ(e.report.texture_bytes, 0u);
}

// --at puts the boundary's centroid on the point and its mean height on the ground; scale and heading
// turn it about that centroid, clockwise.
TEST(EmbeddingFile, AtScaleAndHeadingPlaceTheSite) {
    const test::TempDir dir;
    const fs::path dem = terrain(dir, "dem");
    const fs::path site_path = build_site(dir, "site", patch(40, 300, 0), true);
    const TerrainSite t = TerrainSite::open(dem);
    const SiteModel site = open_site(site_path);
    SitePlacement placement;
    placement.at = lon_lat(dem, 1400, 1500);
    placement.scale = 2;
    placement.heading = 90;
    const glm::dmat4 m = place_site(t, site, placement, "site");
    // The patch's boundary centroid is its origin, (0, 0); its corner (150, −150) goes to (−300, −300)
    // from the centroid under a clockwise quarter turn and a scale of 2.
    const glm::dvec3 centre(m * glm::dvec4(0, 0, 0, 1));
    EXPECT_NEAR(centre.x, 1400, 1e-6);
    EXPECT_NEAR(centre.y, 1500, 1e-6);
    const glm::dvec3 corner(m * glm::dvec4(150, -150, 0, 1));
    EXPECT_NEAR(corner.x - centre.x, -300, 1e-6);
    EXPECT_NEAR(corner.y - centre.y, -300, 1e-6);
    // Mean (ground − site) over the boundary vertices is 0.
    double sum = 0;
    size_t count = 0;
    for (const std::vector<uint32_t>& loop : boundary_loops(site.coarsest, "site"))
        for (uint32_t v : loop) {
            const glm::dvec3 p(m * glm::dvec4(site.coarsest.origin[0] + site.coarsest.positions[3 * v],
                                              site.coarsest.origin[1] + site.coarsest.positions[3 * v + 1],
                                              site.coarsest.origin[2] + site.coarsest.positions[3 * v + 2], 1));
            const auto cell = t.georeference->raster_position(p.x, p.y, p.z);
            sum += *t.heights->at((*cell)[0], (*cell)[1]) - p.z, ++count;
        }
    EXPECT_EQ(count, 160u);
    EXPECT_NEAR(sum / double(count), 0, 1e-6);
}

// ΔH counts every vertex of the finest level, not only the coarsest level's.
TEST(EmbeddingFile, HeightDifferenceComesFromTheFinestLevel) {
    const Embedded spiked(60);
    const HlodFile site(spiked.site);
    ASSERT_GT(site.header().max_level, 0u);
    const EmbeddingRecord r = read_embedding(HlodFile(spiked.out));
    EXPECT_GT(r.height_difference, 55);
    // Exactly the input's, up to the finest lattice's rounding.
    const TerrainSite t = TerrainSite::open(spiked.dem);
    EXPECT_NEAR(r.height_difference, height_difference(t, patch(40, 300, 60), r.placement), 1e-3);
    const Embedded flat(0);
    EXPECT_LT(read_embedding(HlodFile(flat.out)).height_difference, 30);
    EXPECT_LT(r.zone_level, read_embedding(HlodFile(flat.out)).zone_level);  // a coarser zone for the taller site
}

// The skirt's two boundaries (along the zone's border and along the site's) are locked: level 0 and
// the finest level have the same boundary edges, decoded to the same floats. (The spike makes the zone
// coarse, so that the skirt has samples off its boundaries to simplify.)
TEST(EmbeddingFile, TheSkirtsBoundariesDecodeIdenticallyAtEveryLevel) {
    const Embedded e(60);
    const HlodFile file(e.out);
    const HlodHeader& h = file.header();
    ASSERT_GE(h.max_level, 1u) << "the skirt has one level: nothing to compare";
    EXPECT_TRUE(h.flags & kLockedBoundary);
    using Point = std::array<uint32_t, 3>;
    using Edge = std::pair<Point, Point>;
    std::vector<std::map<Edge, int>> uses(h.max_level + 1);
    for (const HlodNode& n : file.nodes()) {
        const CubeData cube = file.read_cube(n);
        const uint32_t cell[3] = {n.i, n.j, n.k};
        std::vector<Point> point(cube.vertex_count());
        for (uint32_t v = 0; v < cube.vertex_count(); ++v)
            for (int a = 0; a < 3; ++a) {
                const float x = decode_coordinate(h, a, n.level, cell[a], cube.vertices.positions[3 * v + size_t(a)]) + 0.0f;
                std::memcpy(&point[v][size_t(a)], &x, 4);
            }
        for (size_t t = 0; t < cube.indices.size(); t += 3)
            for (int c = 0; c < 3; ++c) {
                const Point &a = point[cube.indices[t + size_t(c)]], &b = point[cube.indices[t + size_t(c + 1) % 3]];
                if (a != b) ++uses[n.level][a < b ? Edge{a, b} : Edge{b, a}];
            }
    }
    auto boundary = [&](uint32_t level) {
        std::set<Edge> edges;
        for (const auto& [edge, count] : uses[level])
            if (count % 2) edges.insert(edge);
        return edges;
    };
    const std::set<Edge> coarsest = boundary(0), finest = boundary(h.max_level);
    // The site's ring (160 edges, cut where it crosses grid lines) and the zone's border.
    EXPECT_GT(finest.size(), 160u + 8u);
    EXPECT_EQ(coarsest, finest);
    EXPECT_LT(uses[0].size(), uses[h.max_level].size());  // level 0 is simpler inside
}

TEST(EmbeddingFile, ADifferentTerrainIsRefusedNamingBoth) {
    const Embedded e;
    const fs::path other = terrain(e.dir, "other", 3.0);
    const EmbeddingRecord r = read_embedding(HlodFile(e.out));
    EXPECT_NO_THROW(check_embedded_terrain(r, e.out, HlodFile(e.dem)));
    EXPECT_NO_THROW(check_embedded_site(r, e.out, HlodFile(e.site)));
    const std::string message = message_of([&] { check_embedded_terrain(r, e.out, HlodFile(other)); });
    EXPECT_NE(message.find(e.out.string() + ": made for the terrain ../dem.hlod"), std::string::npos) << message;
    EXPECT_NE(message.find(other.string() + " is another model"), std::string::npos) << message;
    EXPECT_NE(message_of([&] { check_embedded_site(r, e.out, HlodFile(e.dem)); }).find("made for the site ../site.hlod"), std::string::npos);
}

TEST(EmbeddingFile, AnOpenSiteWhoseBoundaryIsNotLockedIsRefused) {
    const test::TempDir dir;
    const fs::path dem = terrain(dir, "dem");
    const fs::path site = build_site(dir, "loose", patch(20, 200, 0), false);
    const fs::path out = dir.path() / "out.hlod";
    try {
        build_embedding(dem, site, out, at(lon_lat(dem, 1400, 1500)));
        FAIL() << "an unlocked open site was embedded";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()), site.string() + ": its open boundary is not locked; rebuild it with strata build --lock-boundary");
    }
    for (const fs::directory_entry& entry : fs::directory_iterator(dir.path()))
        EXPECT_NE(entry.path().filename().string().rfind("out.hlod", 0), 0u) << entry.path() << " was left behind";
}

// Cancelled (Ctrl-C), an embedding leaves nothing behind: no output, no intermediate skirt, no work folder.
TEST(EmbeddingFile, ACancelledEmbeddingLeavesNothing) {
    const test::TempDir dir;
    const fs::path dem = terrain(dir, "dem");
    const fs::path site = build_site(dir, "site", patch(40, 300, 0), true);
    const fs::path out = dir.path() / "out" / "embedded.hlod";
    fs::create_directories(out.parent_path());
    for (const size_t after : {size_t(1), size_t(3), size_t(8)}) {  // at several points of the work
        std::atomic<bool> cancel{false};
        size_t calls = 0;
        Progress progress;
        progress.cancel = &cancel;
        progress.report = [&](std::string_view, double, double, std::string_view) {
            if (++calls >= after) cancel = true;
        };
        EXPECT_THROW(build_embedding(dem, site, out, at(lon_lat(dem, 1400, 1500)), progress), Cancelled) << after;
        EXPECT_TRUE(fs::is_empty(out.parent_path())) << fs::directory_iterator(out.parent_path())->path();
    }
}

TEST(EmbeddingFile, ACorruptSectionIsRefusedNamingTheFile) {
    const Embedded e;
    const HlodSection section = *HlodFile(e.out).find_section(kEmbeddingTag);
    {
        std::fstream f(e.out, std::ios::in | std::ios::out | std::ios::binary);
        f.seekg(std::streamoff(section.offset + 20));
        char byte = 0;
        f.read(&byte, 1);
        byte = char(byte ^ 0x10);
        f.seekp(std::streamoff(section.offset + 20));
        f.write(&byte, 1);
    }
    const HlodFile file(e.out);  // opening does not read an optional section
    EXPECT_EQ(message_of([&] { read_embedding(file); }), e.out.string() + ": section 'EMBD' checksum mismatch (the file is corrupt)");
    EXPECT_THROW(verify_hlod(file), std::runtime_error);
    // A model that is no embedding says so.
    EXPECT_NE(message_of([&] { read_embedding(HlodFile(e.site)); }).find(e.site.string() + ": not an embedding"), std::string::npos);
}

TEST(EmbeddingFile, AClosedSiteStandsInAFileWithoutCubes) {
    const test::TempDir dir;
    const fs::path dem = terrain(dir, "dem");
    const fs::path site = build_site(dir, "statue", test::icosphere(3, 20.0f), true);
    const fs::path out = dir.path() / "statue_on_dem.hlod";
    const EmbedReport report = build_embedding(dem, site, out, at(lon_lat(dem, 1400, 1500)));
    EXPECT_TRUE(report.record.standing);
    EXPECT_EQ(report.skirt_triangles, 0u);
    const HlodFile file(out);
    EXPECT_TRUE(file.nodes().empty());
    EXPECT_EQ(file.file_size(), fs::file_size(out));
    const EmbeddingRecord r = read_embedding(file);
    EXPECT_TRUE(r.standing);
    EXPECT_EQ(r.zone.width * r.zone.height, 0);
    EXPECT_EQ(r.site_fingerprint, model_fingerprint(HlodFile(site)));
    // Placed at the point, its lowest vertex on the ground.
    const glm::dvec3 centre(r.placement * glm::dvec4(0, 0, 0, 1));
    EXPECT_NEAR(centre.x, 1400, 1.0);
    EXPECT_NEAR(centre.y, 1500, 1.0);
    const TerrainSite t = TerrainSite::open(dem);
    const Mesh& coarsest = open_site(site).coarsest;
    double lowest = 1e9;
    for (uint32_t v = 0; v < coarsest.vertex_count(); ++v) {
        const glm::dvec3 p(r.placement * glm::dvec4(coarsest.origin[0] + coarsest.positions[3 * v], coarsest.origin[1] + coarsest.positions[3 * v + 1],
                                                    coarsest.origin[2] + coarsest.positions[3 * v + 2], 1));
        const auto cell = t.georeference->raster_position(p.x, p.y, p.z);
        lowest = std::min(lowest, p.z - *t.heights->at((*cell)[0], (*cell)[1]));
    }
    EXPECT_NEAR(lowest, 0, 1e-6);
    EXPECT_TRUE(verify_hlod(file).embedding);
}

// A copy of the model at `in` with a georeference.
fs::path with_georeference(const fs::path& in_path, const fs::path& out, const std::string& crs, const std::array<double, 3>& origin) {
    const HlodFile in(in_path);
    HlodWriter writer(out);
    for (const HlodNode& n : in.nodes()) writer.add_cube(n, in.read_payload(n));
    HlodHeader header = in.header();
    header.crs = crs;
    for (int a = 0; a < 3; ++a) header.geo_origin[a] = origin[size_t(a)];
    writer.finish(header);
    return out;
}

// Without --at, a site in the terrain's CRS is moved by the difference of their origins; one without a
// CRS is refused naming it.
TEST(EmbeddingFile, ASiteInTheTerrainsCrsIsPlacedByItsOrigin) {
    const test::TempDir dir;
    const fs::path dem = terrain(dir, "dem");
    const fs::path plain = build_site(dir, "site", patch(20, 200, 0), true);
    // The same model with a georeference: its origin at the terrain's model point (1400, 1500, 420).
    const HlodFile terrain_file(dem);
    const double* o = terrain_file.header().geo_origin;
    const fs::path georeferenced =
        with_georeference(plain, dir.path() / "geo_site.hlod", terrain_file.header().crs, {o[0] + 1400, o[1] + 1500, o[2] + 420});
    const TerrainSite t = TerrainSite::open(dem);
    const glm::dmat4 m = place_site(t, open_site(georeferenced), SitePlacement{}, "geo_site.hlod");
    EXPECT_EQ(m[3][0], 1400);
    EXPECT_EQ(m[3][1], 1500);
    EXPECT_EQ(m[3][2], 420);
    EXPECT_EQ(glm::dmat3(m), glm::dmat3(1.0));
    const std::string message = message_of([&] { place_site(t, open_site(plain), SitePlacement{}, "site.hlod"); });
    EXPECT_EQ(message, "site.hlod: the site has no georeference (CRS); place it with --at LON,LAT");
}

// In another CRS, through PROJ: the site's centre lands where PROJ puts it, its axes turned by the
// grid's convergence between the two zones; another vertical datum is refused naming both CRSs.
TEST(EmbeddingFile, ASiteInAnotherCrsIsPlacedThroughProj) {
    const test::TempDir dir;
    const fs::path dem = terrain(dir, "dem");
    const fs::path plain = build_site(dir, "site", patch(20, 200, 0), true);
    const TerrainSite t = TerrainSite::open(dem);
    const std::array<double, 3> there = t.georeference->to_geo({1400, 1500, 420}, "EPSG:32633");  // the next UTM zone east
    const fs::path other = with_georeference(plain, dir.path() / "utm33.hlod", "EPSG:32633", there);
    const glm::dmat4 m = place_site(t, open_site(other), SitePlacement{}, "utm33.hlod");
    const glm::dvec3 centre(m * glm::dvec4(0, 0, 0, 1));
    EXPECT_NEAR(centre.x, 1400, 1e-3);
    EXPECT_NEAR(centre.y, 1500, 1e-3);
    EXPECT_NEAR(centre.z, 420, 1e-3);
    // A 6° zone away, north turns by a few degrees; lengths stay within the zones' scale factors.
    const double turn = std::atan2(m[0][1], m[0][0]) * 180 / M_PI;
    EXPECT_GT(std::abs(turn), 1.0);
    EXPECT_LT(std::abs(turn), 10.0);
    EXPECT_NEAR(glm::length(glm::dvec3(m[0])), 1.0, 5e-3);
    const fs::path geoid = with_georeference(plain, dir.path() / "geoid.hlod", "EPSG:32632+5773", there);
    const std::string message = message_of([&] { place_site(t, open_site(geoid), SitePlacement{}, "geoid.hlod"); });
    EXPECT_NE(message.find("geoid.hlod: its CRS (EPSG:32632+5773) and the terrain's (EPSG:32632) have different vertical datums"), std::string::npos)
        << message;
}

}  // namespace
}  // namespace strata

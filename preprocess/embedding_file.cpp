#include "preprocess/embedding_file.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "preprocess/build_inputs.h"
#include "preprocess/byte_packing.h"
#include "preprocess/byte_size.h"
#include "preprocess/cube_textures.h"
#include "preprocess/embedding.h"
#include "preprocess/georeference.h"
#include "preprocess/hlod_builder.h"
#include "preprocess/imagery_sampler.h"
#include "preprocess/parallel.h"
#include "preprocess/terrain_heights.h"

namespace strata {

namespace fs = std::filesystem;

namespace {

constexpr uint32_t kStanding = 1u << 0, kCapped = 1u << 1;
constexpr uint32_t kMaxPathBytes = 4096;
constexpr uint64_t kMaxZoneCells = uint64_t(1) << 32;

std::string hex(uint32_t value) {
    char text[16];
    std::snprintf(text, sizeof text, "%08x", value);
    return text;
}

}  // namespace

size_t EmbeddingRecord::cells(CellCover cover) const { return size_t(std::count(zone.cover.begin(), zone.cover.end(), cover)); }

// ---- EMBD's bytes (FORMAT.md §4.10) ---------------------------------------------------------------

std::vector<uint8_t> encode_embedding(const EmbeddingRecord& r) {
    ByteWriter w;
    w.put(r.version);
    w.put(uint32_t((r.standing ? kStanding : 0u) | (r.zone_capped ? kCapped : 0u)));
    w.put(r.terrain_levels);
    w.put(r.zone_level);
    w.put(r.height_difference);
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) w.put(r.placement[c][row]);
    w.put(r.columns), w.put(r.rows);
    w.put(r.boundary_vertices);
    w.put(r.terrain_fingerprint), w.put(r.site_fingerprint);
    w.put(r.zone.size);
    w.put(r.zone.first_x), w.put(r.zone.first_y), w.put(r.zone.width), w.put(r.zone.height);
    w.put_string(r.terrain_file);
    w.put_string(r.site_file);
    std::vector<uint8_t> covers((r.zone.cover.size() + 3) / 4, 0);
    for (size_t c = 0; c < r.zone.cover.size(); ++c) covers[c / 4] |= uint8_t(uint8_t(r.zone.cover[c]) << (2 * (c % 4)));
    w.put_bytes(covers.data(), covers.size());
    return std::move(w.bytes);
}

EmbeddingRecord decode_embedding(std::span<const uint8_t> bytes, const std::string& what) {
    ByteReader in(bytes, what);
    EmbeddingRecord r;
    r.version = in.get<uint32_t>();
    if (r.version != kEmbeddingVersion)
        throw std::runtime_error(what + ": version " + std::to_string(r.version) + ", which this Strata does not read (it reads " +
                                 std::to_string(kEmbeddingVersion) + "); embed the site again with strata embed");
    const uint32_t flags = in.get<uint32_t>();
    r.standing = flags & kStanding, r.zone_capped = flags & kCapped;
    r.terrain_levels = in.get<uint32_t>();
    r.zone_level = in.get<uint32_t>();
    r.height_difference = in.get<double>();
    bool finite = std::isfinite(r.height_difference) && r.height_difference >= 0;
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) finite &= std::isfinite(r.placement[c][row] = in.get<double>());
    r.columns = in.get<uint64_t>(), r.rows = in.get<uint64_t>();
    r.boundary_vertices = in.get<uint64_t>();
    r.terrain_fingerprint = in.get<uint32_t>(), r.site_fingerprint = in.get<uint32_t>();
    r.zone.size = in.get<int64_t>();
    r.zone.first_x = in.get<int64_t>(), r.zone.first_y = in.get<int64_t>();
    r.zone.width = in.get<int64_t>(), r.zone.height = in.get<int64_t>();
    r.terrain_file = in.get_string(kMaxPathBytes);
    r.site_file = in.get_string(kMaxPathBytes);
    if ((flags & ~(kStanding | kCapped)) != 0) throw std::runtime_error(what + ": unknown flags " + std::to_string(flags));
    if (!finite) throw std::runtime_error(what + ": the placement or ΔH is not finite");
    if (r.columns < 2 || r.rows < 2 || r.columns > (uint64_t(1) << 32) || r.rows > (uint64_t(1) << 32))
        throw std::runtime_error(what + ": a raster of " + std::to_string(r.columns) + " × " + std::to_string(r.rows) + " samples");
    if (r.terrain_levels > 31 || r.zone_level > r.terrain_levels)
        throw std::runtime_error(what + ": zone level " + std::to_string(r.zone_level) + " of a terrain with levels 0 … " +
                                 std::to_string(r.terrain_levels));
    const CellCovers& z = r.zone;
    if (r.standing) {
        if (z.width != 0 || z.height != 0) throw std::runtime_error(what + ": a standing site with a zone");
    } else {
        // The zone's cells are level m − 1's (embedding.h), m ≥ 1.
        if (r.zone_level == 0) throw std::runtime_error(what + ": zone level 0 (an embedding is drawn from level 1 at the coarsest)");
        if (z.size != int64_t(1) << (r.terrain_levels - r.zone_level + 1))
            throw std::runtime_error(what + ": zone cells of " + std::to_string(z.size) + " raster steps, not level " +
                                     std::to_string(r.zone_level - 1) + "'s " + std::to_string(int64_t(1) << (r.terrain_levels - r.zone_level + 1)));
        // Every cell of the box starts before the raster's last sample.
        const auto inside = [&](int64_t first, int64_t count, uint64_t samples) {
            return first >= 0 && count > 0 && count <= int64_t(samples) && first <= int64_t(samples) &&
                   WideInt(first + count - 1) * z.size < WideInt(samples) - 1;  // 128 bits: no overflow
        };
        if (!inside(z.first_x, z.width, r.columns) || !inside(z.first_y, z.height, r.rows))
            throw std::runtime_error(what + ": the zone (cells " + std::to_string(z.first_x) + " … " + std::to_string(z.first_x + z.width - 1) +
                                     " × " + std::to_string(z.first_y) + " … " + std::to_string(z.first_y + z.height - 1) + " of " +
                                     std::to_string(z.size) + " steps) lies outside the raster");
    }
    const uint64_t cells = uint64_t(z.width) * uint64_t(z.height);
    if (cells > kMaxZoneCells) throw std::runtime_error(what + ": a zone of " + std::to_string(cells) + " cells");
    const std::span<const uint8_t> covers = in.get_bytes(size_t((cells + 3) / 4));
    if (!in.at_end()) throw std::runtime_error(what + ": " + std::to_string(bytes.size() - in.position()) + " bytes past its end");
    r.zone.cover.resize(size_t(cells));
    for (size_t c = 0; c < cells; ++c) {
        const uint8_t value = (covers[c / 4] >> (2 * (c % 4))) & 3u;
        if (value > uint8_t(CellCover::whole)) throw std::runtime_error(what + ": cell " + std::to_string(c) + " has cover 3");
        r.zone.cover[c] = CellCover(value);
    }
    if (cells % 4 && (covers.back() >> (2 * (cells % 4))) != 0) throw std::runtime_error(what + ": bits set past the zone's last cell");
    return r;
}

EmbeddingRecord read_embedding(const HlodFile& file) {
    const std::string name = file.path().string();
    const HlodSection* section = file.find_section(kEmbeddingTag);
    if (!section) throw std::runtime_error(name + ": not an embedding (it has no section 'EMBD'; strata embed makes one)");
    const std::vector<uint8_t> bytes = file.read_section_part(*section, 0, section->size, "bytes");
    if (crc32c(bytes.data(), bytes.size()) != section->checksum)
        throw std::runtime_error(name + ": section 'EMBD' checksum mismatch (the file is corrupt)");
    return decode_embedding(bytes, name + ": section 'EMBD'");
}

uint32_t model_fingerprint(const HlodFile& file) {
    ByteWriter sums;
    for (const char* tag : {"MODL", "NODE", "GEOR", "TERR"})
        for (const HlodSection& s : file.sections())
            if (std::memcmp(s.tag.data(), tag, 4) == 0) sums.put(s.checksum);
    return crc32c(sums.bytes.data(), sums.bytes.size());
}

fs::path embedded_path(const fs::path& embedding_file, const std::string& stored) {
    const fs::path p(stored);
    return p.is_absolute() || !embedding_file.has_parent_path() ? p : embedding_file.parent_path() / p;
}

namespace {

void check_embedded(const std::string& kind, const std::string& stored, uint32_t fingerprint, const fs::path& embedding_file,
                    const HlodFile& model) {
    const uint32_t found = model_fingerprint(model);
    if (found != fingerprint)
        throw std::runtime_error(embedding_file.string() + ": made for the " + kind + " " + stored + " (fingerprint " + hex(fingerprint) +
                                 "), but " + model.path().string() + " is another model (fingerprint " + hex(found) +
                                 "); embed the site again on it with strata embed");
}

// How the embedding file names `file`: from its own folder where it can, else in full.
std::string stored_path(const fs::path& file, const fs::path& output) {
    std::error_code ec;
    fs::path whole = fs::weakly_canonical(fs::absolute(file), ec);
    if (ec) whole = fs::absolute(file);
    fs::path folder = fs::weakly_canonical(fs::absolute(output).parent_path(), ec);
    if (ec) folder = fs::absolute(output).parent_path();
    const fs::path relative = whole.lexically_relative(folder);
    return relative.empty() ? whole.string() : relative.generic_string();
}

}  // namespace

void check_embedded_terrain(const EmbeddingRecord& record, const fs::path& embedding_file, const HlodFile& terrain) {
    check_embedded("terrain", record.terrain_file, record.terrain_fingerprint, embedding_file, terrain);
}

void check_embedded_site(const EmbeddingRecord& record, const fs::path& embedding_file, const HlodFile& site) {
    check_embedded("site", record.site_file, record.site_fingerprint, embedding_file, site);
}

// ---- the site ------------------------------------------------------------------------------------

Mesh cube_mesh(const HlodHeader& h, const HlodNode& node, const CubeData& cube) {
    Mesh mesh;
    mesh.origin = {h.origin[0], h.origin[1], h.origin[2]};
    const uint32_t cell[3] = {node.i, node.j, node.k};
    const float step = h.lattice_step(node.level);
    mesh.positions.resize(cube.vertices.positions.size());
    for (size_t v = 0; v < cube.vertex_count(); ++v)
        for (int a = 0; a < 3; ++a) {
            // decode_coordinate's product (the shader's), added to the origin in double.
            const int32_t q = int32_t(cube.vertices.positions[3 * v + size_t(a)]) + int32_t(cell[a] << kLatticeBits) - kLatticeBias;
            const float product = float(q) * step;
            mesh.positions[3 * v + size_t(a)] = product;
        }
    mesh.indices = cube.indices;
    return mesh;
}

SiteModel open_site(const fs::path& path) {
    SiteModel site;
    site.file = std::make_shared<const HlodFile>(path);
    const HlodFile& file = *site.file;
    const std::string name = path.string();
    const auto root = std::find_if(file.nodes().begin(), file.nodes().end(), [](const HlodNode& n) { return n.level == 0; });
    if (root == file.nodes().end()) throw InputError(name + ": the model has no cubes (no level 0)");
    if (file.header().terrain) throw InputError(name + ": a terrain, not a site (a mesh built with strata build --lock-boundary)");
    site.coarsest = cube_mesh(file.header(), *root, file.read_cube(*root));
    site.open = !boundary_loops(site.coarsest, name).empty();
    if (site.open && !(file.header().flags & kLockedBoundary))
        throw InputError(name + ": its open boundary is not locked; rebuild it with strata build --lock-boundary");
    return site;
}

double site_height_difference(const TerrainSite& terrain, const HlodFile& site, const glm::dmat4& site_to_terrain, int threads,
                              const Progress& progress) {
    std::vector<const HlodNode*> finest;
    for (const HlodNode& n : site.nodes())
        if (n.level == site.header().max_level) finest.push_back(&n);
    std::vector<double> most(finest.size(), 0.0);
    std::atomic<size_t> done{0};
    parallel_for(finest.size(), resolve_thread_count(threads), [&](size_t c, unsigned worker) {
        progress.check();
        const HlodNode& node = *finest[c];
        most[c] = height_difference(terrain, cube_mesh(site.header(), node, site.read_cube(node)), site_to_terrain);
        const size_t finished = ++done;
        if (worker == 0) progress("height difference", double(finished), double(finest.size()), "cubes");
    });
    progress("height difference", double(finest.size()), double(finest.size()), "cubes");
    return most.empty() ? 0.0 : *std::max_element(most.begin(), most.end());
}

// ---- placing the site ----------------------------------------------------------------------------

namespace {

glm::dvec3 vertex_of(const Mesh& mesh, uint32_t v) {
    return {mesh.origin[0] + double(mesh.positions[3 * size_t(v)]), mesh.origin[1] + double(mesh.positions[3 * size_t(v) + 1]),
            mesh.origin[2] + double(mesh.positions[3 * size_t(v) + 2])};
}

// The outer boundary loop (the one enclosing the largest area seen from above), as make_footprint takes it.
std::vector<glm::dvec3> outer_ring(const Mesh& mesh, const std::string& what) {
    std::vector<glm::dvec3> best;
    double best_area = -1;
    for (const std::vector<uint32_t>& loop : boundary_loops(mesh, what)) {
        std::vector<glm::dvec3> ring;
        for (uint32_t v : loop) ring.push_back(vertex_of(mesh, v));
        double area = 0;
        for (size_t i = 0; i < ring.size(); ++i) {
            const glm::dvec3 a = ring[i] - ring.front(), b = ring[(i + 1) % ring.size()] - ring.front();
            area += a.x * b.y - b.x * a.y;
        }
        if (std::abs(area) > best_area) best_area = std::abs(area), best = std::move(ring);
    }
    return best;
}


// What a placement places: the boundary's vertices (every vertex, for a standing site).
std::vector<glm::dvec3> placed_points(const SiteModel& site, const std::string& what) {
    std::vector<glm::dvec3> ring = site.open ? outer_ring(site.coarsest, what) : std::vector<glm::dvec3>();
    if (ring.empty())
        for (uint32_t v = 0; v < site.coarsest.vertex_count(); ++v) ring.push_back(vertex_of(site.coarsest, v));
    return ring;
}

// (ground − site height) over the points placed by `m` that lie over the raster's data: its sum, its
// largest value and how many points.
struct GroundBelow {
    double sum = 0, most = -std::numeric_limits<double>::infinity();
    size_t grounded = 0;
};
GroundBelow ground_below(const TerrainSite& terrain, std::span<const glm::dvec3> points, const glm::dmat4& m) {
    GroundBelow below;
    for (const glm::dvec3& p : points) {
        const glm::dvec3 at(m * glm::dvec4(p, 1.0));
        const auto cell = terrain.georeference->raster_position(at.x, at.y, at.z);
        if (const std::optional<double> ground = cell ? terrain.heights->at((*cell)[0], (*cell)[1]) : std::nullopt)
            below.sum += *ground - at.z, below.most = std::max(below.most, *ground - at.z), ++below.grounded;
    }
    return below;
}

glm::dvec3 centroid_of(std::span<const glm::dvec3> points) {
    glm::dvec3 centroid(0);
    for (const glm::dvec3& p : points) centroid += p / double(points.size());
    return centroid;
}

}  // namespace

std::string placement_matrix_problem(const glm::dmat4& m) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(m[c][r])) return "a placement matrix must hold 16 finite numbers";
    if (m[0][3] != 0 || m[1][3] != 0 || m[2][3] != 0 || m[3][3] != 1) return "a placement matrix must be affine (its last row 0, 0, 0, 1)";
    if (!(glm::determinant(glm::dmat3(m)) > 0))
        return "a placement matrix must not mirror the site or flatten it (the determinant of its 3 × 3 part must be above 0)";
    return "";
}

glm::dmat4 place_site(const TerrainSite& terrain, const SiteModel& site, const SitePlacement& placement, const std::string& what) {
    const std::vector<glm::dvec3> ring = placed_points(site, what);
    if (placement.matrix) {
        if (const std::string problem = placement_matrix_problem(*placement.matrix); !problem.empty()) throw InputError(what + ": " + problem);
        if (ground_below(terrain, ring, *placement.matrix).grounded == 0)
            throw InputError(what + ": placed by its matrix it lies wholly off the terrain's raster (or over nodata)");
        return *placement.matrix;
    }
    if (!(placement.scale > 0) || !std::isfinite(placement.scale) || !std::isfinite(placement.heading))
        throw InputError(what + ": a scale above 0 and a finite heading are needed");
    const glm::dvec3 centroid = centroid_of(ring);
    const double turn = -placement.heading * M_PI / 180.0;  // clockwise seen from above
    glm::dmat4 about(1.0);
    about[0][0] = placement.scale * std::cos(turn), about[0][1] = placement.scale * std::sin(turn);
    about[1][0] = -placement.scale * std::sin(turn), about[1][1] = placement.scale * std::cos(turn);
    about[2][2] = placement.scale;
    const glm::dvec3 moved = centroid - glm::dvec3(about * glm::dvec4(centroid, 1.0));
    about[3] = glm::dvec4(moved, 1.0);  // about the centroid

    const Georeference& geo = *terrain.georeference;
    if (placement.at) {
        const auto [lon, lat] = *placement.at;
        const std::array<double, 3> target = geo.to_local({lon, lat, 0.0});
        glm::dmat4 m = about;
        m[3] += glm::dvec4(target[0] - centroid.x, target[1] - centroid.y, 0.0, 0.0);
        // Lift it so that its boundary meets the ground best: the mean of (ground − site) is 0. A standing
        // site is lifted until its lowest point (against the ground) touches it.
        const GroundBelow below = ground_below(terrain, ring, m);
        if (below.grounded == 0)
            throw InputError(what + ": placed at " + std::to_string(lon) + ", " + std::to_string(lat) +
                             " it lies wholly off the terrain's raster (or over nodata)");
        m[3].z += site.open ? below.sum / double(below.grounded) : below.most;
        return m;
    }

    const HlodHeader& h = site.file->header();
    if (h.crs.empty()) throw InputError(what + ": the site has no georeference (CRS); place it with --at LON,LAT");
    const Georeference mine(h, what);
    const std::string& theirs = terrain.header().crs;
    try {
        if (h.crs == theirs && !terrain.grid().tangent_frame()) {
            // The same CRS, the terrain in its plane: a translation between the origins.
            const std::array<double, 3> shift = geo.crs_to_model(mine.model_to_crs({0, 0, 0}));
            glm::dmat4 m = about;
            m[3] += glm::dvec4(shift[0], shift[1], shift[2], 0.0);
            return m;
        }
        // Through PROJ: an affine map fitted at the centroid over the boundary's extent. PROJ passes heights
        // through, so two vertical datums cannot be mapped.
        if (const std::string a = vertical_datum(h.crs), b = vertical_datum(theirs); a != b)
            throw InputError(what + ": its CRS (" + h.crs + ") and the terrain's (" + theirs + ") have different vertical datums (" +
                             (a.empty() ? "ellipsoidal heights" : a) + ", " + (b.empty() ? "ellipsoidal heights" : b) +
                             "); convert its heights, or place it with --at LON,LAT");
        double extent = 1;
        for (const glm::dvec3& p : ring) extent = std::max({extent, std::abs(p.x - centroid.x), std::abs(p.y - centroid.y)});
        auto map = [&](const glm::dvec3& p) {
            const std::array<double, 3> local = geo.to_local(mine.model_to_crs({p.x, p.y, p.z}), h.crs);
            return glm::dvec3(local[0], local[1], local[2]);
        };
        const glm::dvec3 centre = map(centroid);
        glm::dmat4 fit(1.0);
        for (int a = 0; a < 3; ++a) {
            glm::dvec3 step(0);
            step[a] = extent;
            fit[a] = glm::dvec4((map(centroid + step) - centre) / extent, 0.0);
        }
        fit[3] = glm::dvec4(centre - glm::dvec3(fit * glm::dvec4(centroid, 0.0)), 1.0);
        return fit * about;
    } catch (const InputError&) {
        throw;
    } catch (const std::runtime_error& e) {
        throw InputError(what + ": its CRS (" + h.crs + ") cannot be mapped to the terrain's (" + theirs + "): " + e.what());
    }
}

SitePlacement placement_of(const TerrainSite& terrain, const SiteModel& site, const glm::dmat4& site_to_terrain, const std::string& what) {
    SitePlacement placement;
    placement.scale = glm::length(glm::dvec3(site_to_terrain[2]));
    placement.heading = -std::atan2(site_to_terrain[0][1], site_to_terrain[0][0]) * 180.0 / M_PI;
    const glm::dvec3 at(site_to_terrain * glm::dvec4(centroid_of(placed_points(site, what)), 1.0));
    const std::array<double, 3> geo = terrain.georeference->to_geo({at.x, at.y, at.z});
    placement.at = {geo[0], geo[1]};
    placement.matrix = site_to_terrain;
    return placement;
}

// ---- the embedding file --------------------------------------------------------------------------

namespace {

// Removes a file when it goes out of scope (the skirt's intermediate build).
struct RemovedOnExit {
    fs::path path;
    ~RemovedOnExit() {
        std::error_code ec;
        fs::remove(path, ec);
    }
};

// The skirt's textures (section TXTR) from the terrain's, so that the skirt shows the ground's imagery:
// each skirt cube's texture resampled (imagery_sampler.h) from the terrain level whose texels are the
// ground's density at the skirt cube's own. The planar mapping and the codec are the terrain's; the
// margin is the skirt's σ0 (a mesh's vertices lie within σ0·s_l of their cubes, not a grid's few
// lattice steps), and the size the power of two that makes the skirt's finest texels at least as dense
// as the terrain's finest (its leaf cubes are not the terrain's size). Returns the section's bytes.
uint64_t write_skirt_textures(const TerrainSite& terrain, const CubeTextures& ground, const HlodFile& skirt, HlodWriter& writer, int threads,
                              const Progress& progress) {
    const HlodHeader& h = skirt.header();
    const double reach[2] = {h.origin[0] - h.sigma0 * h.root_size, h.origin[1] - h.sigma0 * h.root_size};
    const double reach_hi[2] = {h.origin[0] + (1 + h.sigma0) * h.root_size, h.origin[1] + (1 + h.sigma0) * h.root_size};
    const std::vector<HlodNode>& nodes = terrain.file->nodes();
    auto sampler = [&] { return ImagerySampler(terrain.header(), ground, nodes.size(), [&](uint64_t n) -> const HlodNode& { return nodes[n]; }, reach, reach_hi); };
    TextureLayout layout;
    layout.margin = h.sigma0;
    const double finest = sampler().texel_spacing(terrain.header().max_level);
    layout.size = std::bit_ceil(uint32_t(std::clamp(std::ceil((1 + 2 * double(h.sigma0)) * h.cube_size(h.max_level) / finest), 8.0, 4096.0)));
    TextureSectionWriter section(writer, layout);
    const unsigned workers = resolve_thread_count(threads);
    std::vector<std::optional<ImagerySampler>> samplers(workers);  // each worker's own decoded textures
    std::atomic<size_t> done{0};
    parallel_for(skirt.nodes().size(), workers, [&](size_t c, unsigned worker) {
        progress.check();
        if (!samplers[worker]) samplers[worker].emplace(sampler());
        ImagerySampler& imagery = *samplers[worker];
        const HlodNode& n = skirt.nodes()[c];
        const double s = h.cube_size(n.level), spacing = (1 + 2 * double(layout.margin)) * s / layout.size;
        const TexelGrid grid{h.origin[0] + (n.i - double(layout.margin)) * s + spacing / 2, h.origin[1] + (n.j - double(layout.margin)) * s + spacing / 2,
                             spacing, layout.size, layout.size};
        section.add(n.level, n.i, n.j, n.k, encode_bc1_chain(imagery.sample(imagery.level_for(spacing), grid), layout.size));
        const size_t finished = ++done;
        if (worker == 0) progress("skirt textures", double(finished), double(skirt.nodes().size()), "cubes");
    });
    section.finish();
    return section.bytes();
}

}  // namespace

namespace {

// build_embedding for the .hlod `site_path`; `given` is the site as the user named it (the .hlod itself,
// or the mesh it was built from), which messages and the models' sources name.
EmbedReport embed_model(const fs::path& terrain_path, const fs::path& site_path, const fs::path& given, const fs::path& output,
                        const EmbedSettings& settings, const Progress& progress) {
    const auto start = std::chrono::steady_clock::now();
    check_output_folder(output);
    const TerrainSite terrain = TerrainSite::open(terrain_path);
    const SiteModel site = open_site(site_path);
    const std::string what = given.string();
    const glm::dmat4 placement = place_site(terrain, site, settings.placement, what);
    progress.check();

    EmbedReport report;
    EmbeddingRecord& r = report.record;
    r.terrain_file = stored_path(terrain_path, output);
    r.site_file = stored_path(site_path, output);
    r.terrain_fingerprint = model_fingerprint(*terrain.file);
    r.site_fingerprint = model_fingerprint(*site.file);
    r.placement = placement;
    r.terrain_levels = terrain.header().max_level;
    r.columns = terrain.grid().columns, r.rows = terrain.grid().rows;

    HlodHeader header;
    const HlodFile* skirt = nullptr;
    std::unique_ptr<HlodFile> built;
    RemovedOnExit intermediate{output.string() + std::string(HlodWriter::kTempMarker) + std::to_string(::getpid()) + ".skirt"};
    if (!site.open) {
        // A closed site stands on the ground: nothing is cut, and the model holds no cube.
        r.standing = true;
        r.zone_level = r.terrain_levels;
        r.zone.size = 1;
        header.root_size = 1;
        header.sigma0 = 0.25f;
        header.flags = kErrorsAreBounds;
    } else {
        const double dh = site_height_difference(terrain, *site.file, placement, settings.threads, progress);
        EmbeddingPlan plan = plan_embedding(terrain, site.coarsest, placement, dh, what);
        r.zone_level = plan.zone_level;
        r.height_difference = plan.height_difference;
        r.zone_capped = plan.zone_capped;
        r.boundary_vertices = plan.footprint.ring.size();
        r.zone = std::move(plan.zone);
        report.skirt_triangles = plan.skirt_mesh.triangle_count();
        BuildSettings build;
        build.lock_boundary = true;
        build.threads = settings.threads;
        build.memory = settings.memory;
        if (settings.leaf_triangles > 0) build.leaf_triangles = settings.leaf_triangles;
        build_hlod(std::move(plan.skirt_mesh), intermediate.path, build, given.filename().string() + " skirt", progress);
        built = std::make_unique<HlodFile>(intermediate.path);
        skirt = built.get();
        header = skirt->header();
    }
    header.source = given.filename().string() + " embedded in " + terrain_path.filename().string();
    // GEOR: the terrain's, where its origin is an offset in its CRS (not a tangent point, which needs TERR).
    if (!terrain.grid().tangent_frame()) {
        header.crs = terrain.header().crs;
        std::copy(std::begin(terrain.header().geo_origin), std::end(terrain.header().geo_origin), header.geo_origin);
    }
    std::vector<uint8_t> section = encode_embedding(r);
    report.embd_bytes = section.size();
    HlodWriter writer(output);
    if (skirt)
        for (const HlodNode& n : skirt->nodes()) {
            progress.check();
            writer.add_cube(n, skirt->read_payload(n));
        }
    if (const HlodSection* textures = terrain.file->find_section(kTexturesTag); textures && skirt) {
        const CubeTextures ground(terrain.file, *textures, terrain.file->nodes().size());
        report.texture_bytes = write_skirt_textures(terrain, ground, *skirt, writer, settings.threads, progress);
    }
    writer.set_section_head(kEmbeddingTag, std::move(section));
    progress.check();
    writer.finish(header);
    std::error_code ec;
    report.file_bytes = fs::file_size(output, ec);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
}

}  // namespace

fs::path site_model_file(const fs::path& embedding_file) {
    return embedding_file.parent_path() / (embedding_file.stem().string() + "_site.hlod");
}

namespace {

// A model built from `mesh` as the mesh is now: stamped with the mesh's own time when it was built (an
// edit since, or another mesh of that name, has another), from a file of that name, its boundary locked.
bool built_from(const fs::path& model, const fs::path& mesh) {
    std::error_code ec;
    const auto built = fs::last_write_time(model, ec);
    if (ec || built != fs::last_write_time(mesh)) return false;
    try {
        const HlodFile file(model);
        const HlodHeader& h = file.header();
        return h.source == mesh.filename().string() && (h.flags & kLockedBoundary);
    } catch (const std::exception&) {
        return false;
    }
}

// The .hlod an embedding reads for `site` (current_site_model), built first when it is a mesh without a
// current model; `built` when this call built it.
struct SiteModelFile {
    fs::path path;
    bool built = false;
};
SiteModelFile site_model_for(const fs::path& site, const fs::path& embedding_file, const EmbedSettings& settings, std::vector<std::string>& warnings,
                             const Progress& progress) {
    if (const std::optional<fs::path> current = current_site_model(site, embedding_file)) return {*current, false};
    const fs::path model = site_model_file(embedding_file);
    const auto stamp = fs::last_write_time(site);  // before it is read: an edit meanwhile makes it stale
    BuildSettings build;
    build.lock_boundary = true;
    build.threads = settings.threads;
    build.memory = settings.memory ? settings.memory : default_memory_limit();
    const std::vector<fs::path> files{site};
    build_hlod(input_from_files(files, build.memory, progress, warnings), files, model, build, site.filename().string(), progress);
    fs::last_write_time(model, stamp);
    return {model, true};
}

}  // namespace

std::optional<fs::path> current_site_model(const fs::path& site, const fs::path& embedding_file) {
    if (!fs::exists(site)) throw InputError(site.string() + ": no such file");
    if (is_hlod_file(site)) return site;
    const fs::path model = site_model_file(embedding_file);
    return built_from(model, site) ? std::optional<fs::path>(model) : std::nullopt;
}

EmbedReport build_embedding(const fs::path& terrain, const fs::path& site, const fs::path& output, const EmbedSettings& settings,
                            const Progress& progress) {
    std::vector<std::string> warnings;
    const SiteModelFile model = site_model_for(site, output, settings, warnings, progress);
    EmbedReport report;
    try {
        report = embed_model(terrain, model.path, site, output, settings, progress);
    } catch (...) {
        std::error_code ignored;
        if (model.built) fs::remove(model.path, ignored);  // built for this embedding alone
        throw;
    }
    report.site_model = model.path;
    report.warnings = std::move(warnings);
    return report;
}

fs::path default_embedding_file(const fs::path& terrain, const fs::path& site, int number) {
    return site.parent_path() / (site.stem().string() + "_on_" + terrain.stem().string() + (number > 1 ? "_" + std::to_string(number) : "") + ".hlod");
}

fs::path embedding_file_for(const fs::path& terrain, const fs::path& given_site, const SitePlacement& placement, fs::path output,
                            const Progress& progress, std::vector<std::string>* warnings) {
    if (output.empty()) output = default_embedding_file(terrain, given_site);
    const std::optional<fs::path> site = current_site_model(given_site, output);  // none: nothing made for it yet
    if (site && fs::exists(output)) {
        try {
            const HlodFile file(output);
            const EmbeddingRecord record = read_embedding(file);
            check_embedded_terrain(record, output, HlodFile(terrain));
            check_embedded_site(record, output, HlodFile(*site));
            const glm::dmat4 wanted = place_site(TerrainSite::open(terrain), open_site(*site), placement, site->string());
            if (record.placement == wanted) return output;
        } catch (const std::exception&) {
            // not a match: made again below
        }
    }
    EmbedSettings settings;
    settings.placement = placement;
    EmbedReport report = build_embedding(terrain, given_site, output, settings, progress);
    if (warnings) warnings->insert(warnings->end(), report.warnings.begin(), report.warnings.end());
    return output;
}

}  // namespace strata

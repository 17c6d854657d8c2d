// The file that keeps an embedding (HYBRID.md §2, FORMAT.md §4.10): what `strata embed` computes once
// per site and terrain, so that a scene reloads it without recomputing. It is the skirt as a .hlod of its
// own (built with its open boundaries locked, in the terrain's model frame) plus a section EMBD that says
// which terrain and which site it joins, where the site stands on the terrain, and the zone of grid cells
// it replaces.
//
// The skirt's frame: its model coordinates are the terrain's (the skirt was built from the embedding plan's
// skirt mesh, whose origin + positions are terrain model coordinates), so a node drawing it with the
// terrain's node matrix puts it in place; its GEOR, where it has one, is the terrain's.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "preprocess/footprint.h"
#include "preprocess/hlod_format.h"
#include "preprocess/mesh.h"
#include "preprocess/progress.h"

namespace strata {

struct TerrainSite;

inline constexpr char kEmbeddingTag[5] = "EMBD";
inline constexpr uint32_t kEmbeddingVersion = 1;

// Section EMBD, decoded (FORMAT.md §4.10 gives its bytes).
struct EmbeddingRecord {
    uint32_t version = kEmbeddingVersion;
    // The terrain and the site as the file names them: relative to the embedding file's folder where
    // they can be (embedded_path resolves them), else absolute; and their fingerprints (model_fingerprint).
    std::string terrain_file, site_file;
    uint32_t terrain_fingerprint = 0, site_fingerprint = 0;
    glm::dmat4 placement{1.0};   // the site's node frame (its model coordinates) → the terrain's
    uint32_t terrain_levels = 0;  // the terrain's L (max_level)
    uint32_t zone_level = 0;      // m
    double height_difference = 0;  // ΔH, metres
    bool zone_capped = false;
    bool standing = false;         // a closed site: no zone, no skirt (the model has no cubes)
    uint64_t columns = 0, rows = 0;  // the terrain's raster
    uint64_t boundary_vertices = 0;  // the site's boundary ring (the footprint's points)
    CellCovers zone;                 // level-(m−1) cells (size 2^(L−m+1) raster steps); empty when standing

    size_t cells(CellCover cover) const;  // how many of the zone's cells have this cover
};

std::vector<uint8_t> encode_embedding(const EmbeddingRecord& record);
// Throws std::runtime_error "<what>: ..." naming the problem (a short section, an unknown version, values
// out of range: a zone off the raster, a cell size that is not level m − 1's).
EmbeddingRecord decode_embedding(std::span<const uint8_t> bytes, const std::string& what);
// The file's EMBD (its CRC checked). Throws std::runtime_error naming the file when it has none, or it
// is corrupt or of an unknown version.
EmbeddingRecord read_embedding(const HlodFile& file);

// What identifies a model's content, cheaply: CRC-32C of the checksums of its sections MODL, NODE and,
// where it has them, GEOR and TERR (the node table holds every cube's checksum).
uint32_t model_fingerprint(const HlodFile& file);

// A file an embedding names, found from the embedding file's own path.
std::filesystem::path embedded_path(const std::filesystem::path& embedding_file, const std::string& stored);
// Throws std::runtime_error naming both files when `terrain` (or `site`) is not the one the embedding
// was made for (its fingerprint differs).
void check_embedded_terrain(const EmbeddingRecord& record, const std::filesystem::path& embedding_file, const HlodFile& terrain);
void check_embedded_site(const EmbeddingRecord& record, const std::filesystem::path& embedding_file, const HlodFile& site);

// ---- the site ------------------------------------------------------------------------------------

// What the embedding reads of a site .hlod: its coarsest level as a mesh (its open boundary is the
// finest level's when the model's boundary is locked), in the site's model coordinates: origin + the
// decoded lattice offsets, in double.
struct SiteModel {
    std::shared_ptr<const HlodFile> file;
    Mesh coarsest;
    bool open = false;  // it has an open boundary (else it stands)
};
// Throws std::runtime_error naming the file when it cannot be read, and InputError when its open boundary
// is not locked ("rebuild it with strata build --lock-boundary").
SiteModel open_site(const std::filesystem::path& path);

// A cube's vertices in its model's coordinates (origin + lattice offsets, in double), as a mesh.
Mesh cube_mesh(const HlodHeader& header, const HlodNode& node, const CubeData& cube);

// ΔH over every vertex of the site's finest level, placed by `site_to_terrain`: a cube at a time, on
// `threads` threads (0: every core).
double site_height_difference(const TerrainSite& terrain, const HlodFile& site, const glm::dmat4& site_to_terrain, int threads,
                              const Progress& progress = {});

// ---- placing the site ----------------------------------------------------------------------------

struct SitePlacement {
    // --at: longitude and latitude (degrees, on the terrain CRS's datum) of the centroid of the boundary's
    // vertices; the site is then lifted so that the mean of (ground − site) over them is 0. A standing site
    // (no boundary): the centroid of its coarsest level's vertices, lifted until the lowest of them, against
    // the ground, touches it.
    std::optional<std::array<double, 2>> at;
    double scale = 1;    // about the boundary's centroid, before the rest
    double heading = 0;  // degrees, clockwise seen from above (a compass turn), about the centroid
    // --matrix: the site's model coordinates → the terrain's, as given (what a transform node over the
    // site would hold under the terrain: a tilt, a shear, any affine map that is not a mirror); at, scale
    // and heading are then not used, and nothing is lifted.
    std::optional<glm::dmat4> matrix;
};

// Why `matrix` cannot place a site ("" when it can): not finite, not affine (its last row 0, 0, 0, 1),
// or a mirror or flat (its 3 × 3 part's determinant not above 0), which would turn the footprint inside out.
std::string placement_matrix_problem(const glm::dmat4& matrix);

// The site's node frame → the terrain's. With `matrix`: that matrix (InputError when
// placement_matrix_problem names a problem, or the site then lies wholly off the raster). With `at`: as
// SitePlacement says. Without either: from the site's
// own georeference (a translation in the terrain's CRS; through PROJ, fitted at the site's centre, in
// another); InputError naming the file when it has none, and naming both CRSs when one cannot be mapped to
// the other. Scale and heading apply about the centroid with `at` or the georeference.
glm::dmat4 place_site(const TerrainSite& terrain, const SiteModel& site, const SitePlacement& placement, const std::string& what);
// The placement that place_site turns into `site_to_terrain`, where an editor that moves an embedding
// starts: `matrix` is `site_to_terrain` itself; scale and heading come from it and `at` is where the
// boundary's centroid lands, so that a move that gives any of these three (and clears `matrix`) keeps the
// others. For a matrix place_site made with `at`, at/scale/heading give the same matrix again up to
// rounding; for a site placed by its own georeference or a tilted matrix, they place it by `at` (the lift
// is then the ground's, and a tilt is lost).
SitePlacement placement_of(const TerrainSite& terrain, const SiteModel& site, const glm::dmat4& site_to_terrain, const std::string& what);

// ---- the embedding file --------------------------------------------------------------------------

struct EmbedSettings {
    SitePlacement placement;
    int threads = 0;      // 0: every core
    uint64_t memory = 0;  // the skirt's build (BuildSettings::memory); 0: its default
    int leaf_triangles = 0;  // the skirt's build (BuildSettings::leaf_triangles); 0: its default
};

struct EmbedReport {
    EmbeddingRecord record;
    std::filesystem::path site_model;   // the .hlod read for the site: itself, or the mesh's (site_model_file)
    std::vector<std::string> warnings;  // what a mesh site's reader read past rather than refused
    uint64_t skirt_triangles = 0;
    uint64_t embd_bytes = 0, file_bytes = 0;
    uint64_t texture_bytes = 0;  // the skirt's textures (section TXTR), when the terrain has some
    double seconds = 0;
};

// A plain mesh as a site (a TIN: a building, a road, a quarry floor; OBJ, PLY, OFF or STL): an
// embedding reads a .hlod with its open boundary locked, so build_embedding builds the mesh into one
// beside the embedding file, site_model_file(embedding_file) = "<its stem>_site.hlod", and keeps it
// (the embedding file names it).
std::filesystem::path site_model_file(const std::filesystem::path& embedding_file);
// The .hlod an embedding reads for `site` as things are: `site` itself when it is a .hlod model (by its
// first bytes); for a mesh, site_model_file(embedding_file) when one was built from this mesh as it is
// now, else none. InputError when `site` does not exist.
std::optional<std::filesystem::path> current_site_model(const std::filesystem::path& site, const std::filesystem::path& embedding_file);

// strata embed TERRAIN SITE -o OUT: plans the embedding of `site` (a .hlod, or a mesh: built first into
// site_model_file(output) unless current_site_model has one, streamed, within settings.memory or a
// quarter of physical memory) on `terrain` (a terrain .hlod), builds its skirt and writes the embedding
// file; a textured terrain's skirt gets its imagery (section TXTR, resampled from the terrain's
// textures). Throws InputError for input that cannot be embedded (naming the file), Cancelled, and
// std::runtime_error for read or write failures; in every case no output is left behind (a complete
// earlier file at `output` stays as it was, and a mesh's model built by this call is removed).
EmbedReport build_embedding(const std::filesystem::path& terrain, const std::filesystem::path& site, const std::filesystem::path& output,
                            const EmbedSettings& settings, const Progress& progress = {});

// Where an embedding of `site` on `terrain` goes by default: beside the site, "<site>_on_<terrain>.hlod",
// and for `number` > 1 "<site>_on_<terrain>_<number>.hlod" (more embeddings of one site in one terrain).
std::filesystem::path default_embedding_file(const std::filesystem::path& terrain, const std::filesystem::path& site, int number = 1);

// The embedding file for `site` (a .hlod, or a mesh: build_embedding) on `terrain` placed as
// `placement`: `output`, or when empty default_embedding_file. Made (build_embedding) unless the file
// there was made for these models and this placement already, so that a scene that reloads, or asks
// again, does not recompute it. What a mesh's reader read past goes to `warnings` where given.
std::filesystem::path embedding_file_for(const std::filesystem::path& terrain, const std::filesystem::path& site, const SitePlacement& placement,
                                         std::filesystem::path output = {}, const Progress& progress = {}, std::vector<std::string>* warnings = nullptr);

}  // namespace strata

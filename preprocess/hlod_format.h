// The .hlod file, version 2 (preprocess/FORMAT.md describes it byte by byte): a small header, a table
// of tagged sections (the model's fields, the node table, the cube payloads coarse levels first, an
// optional georeference), each with its own CRC. Everything here is plain data plus the code that turns
// it into bytes and back; the builder, `strata info` and `strata verify` all go through it.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace strata {

inline constexpr char kHlodMagic[8] = {'S', 'T', 'R', 'A', 'T', 'A', 'H', 'L'};
inline constexpr uint32_t kHlodVersion = 2;
// MODL's payload codec id: 2 is the seven-stream cube payload (triangles; positions, normals and parents
// as residuals against what the triangles predict, with their low bits in a shared bit stream; colours;
// UVs), each stream stored or zstd-packed (FORMAT.md §5). Codec 1 (before 2026-12) is refused with how to
// rebuild; a later layout gets a new id, which older readers refuse by name instead of misreading.
inline constexpr uint32_t kCubePayloadCodec = 2;
// Codec 3, for terrains built from a raster (FORMAT.md §5.1): the same payload, but the triangles are
// a grid's cells (a few bytes of runs instead of an index stream), the walk goes row by row, and heights
// may lie on a coarser lattice. Decodes to the same CubeData, so everything after the reader is shared.
inline constexpr uint32_t kGridPayloadCodec = 3;

// Vertex positions live on one lattice per level anchored at the model origin (DESIGN.md §2):
// q = round((x − O)/h_l) with h_l = 2^-15·s_l, stored as the 16-bit q − 2^15·cell + 2^14.
inline constexpr int kLatticeBits = 15;
inline constexpr int32_t kLatticeBias = 1 << 14;

enum HlodFlags : uint32_t {
    kHasColors = 1u << 0,
    kHasUvs = 1u << 1,
    // Node errors are conservative bounds (FORMAT.md §4.2); models built before 2026-12 stored an
    // estimate instead.
    kErrorsAreBounds = 1u << 2,
    // The model's open boundary is locked (BuildSettings::lock_boundary): every level has the finest
    // level's boundary, each of its vertices on level 0's lattice, so it decodes to the same floats at
    // every level (FORMAT.md §6). Readers that do not know the bit decode the model all the same.
    kLockedBoundary = 1u << 3,
};

// A terrain built straight from an elevation raster (section TERR): the raster's grid as the model
// holds it (FORMAT.md §4.7). Level L's vertices are its valid samples.
struct TerrainGrid {
    uint64_t columns = 0, rows = 0;   // samples of the raster
    double spacing[2] = {0, 0};       // between columns, between rows, in the CRS's units (metres or degrees)
    uint64_t nodata_samples = 0;      // samples without an elevation: holes, unless the build filled them
    uint32_t cube_cells = 0;          // cells along a cube's side, at every level
    bool rows_run_north = false;      // the raster stores its southern row first: y = spacing[1]·r
    // How samples go into the model (preprocess/terrain_frame.h): 0 the projected CRS's plane (GEOR's
    // origin + (x, y) is the CRS position), 1 enu and 2 ecef at GEOR's origin (longitude, latitude,
    // height), 3 reprojected into GEOR's CRS (a plane in metres, origin + (x, y) as in 0).
    uint32_t frame = 0;
    bool raster_geographic = false;  // the raster's CRS is in degrees (always in frames 1 and 2)
    std::string raster_crs;          // frame 3: the raster's own CRS (EPSG:N or WKT), which its grid is in
    // Frames 1 and 2: GEOR's origin is a tangent point, not an offset in the CRS.
    bool tangent_frame() const { return frame == 1 || frame == 2; }
    // The CRS position of the sample at column 0, row 0 (degrees of longitude and latitude in frames 1
    // and 2), and the CRS's ellipsoid (semi-major axis in metres, inverse flattening, 0 for a sphere):
    // what turns model coordinates back into the raster's grid and the CRS without GDAL.
    double first_sample[2] = {0, 0};
    double semi_major = 0, inverse_flattening = 0;
};

struct HlodHeader {
    uint32_t version = kHlodVersion;
    uint32_t payload_codec = kCubePayloadCodec;
    uint32_t flags = 0;
    double origin[3] = {0, 0, 0};  // O: the input's bounding-box minimum
    double root_size = 0;          // L_c: its longest side; s_l = 2^-l·L_c
    uint32_t max_level = 0;        // L: levels are 0 (coarsest) … L (full resolution)
    uint32_t block_size = 0;       // n
    float sigma0 = 0;              // the σ0 the model guarantees
    float error_q = 0;             // ε_q = max over cubes of error / s_l
    float ratio = 0;               // build setting: target triangles per level
    float error_limit = -1;        // build setting: --error, or −1 for none
    uint64_t input_vertices = 0;
    uint64_t input_triangles = 0;
    uint64_t node_count = 0;
    std::string source;            // the input file's name (no directories)
    std::string texture;           // texture image the source named, or empty
    // Georeference (section GEOR, written only when crs is not empty): model coordinates x are
    // geo_origin + x in the coordinate reference system crs ("EPSG:32633", or WKT).
    double geo_origin[3] = {0, 0, 0};
    std::string crs;
    // The input's bounding box in model coordinates (section BNDS), when the file has it: what a
    // streamed model frames and clips with before any cube is read.
    bool has_bounds = false;
    double bounds_lo[3] = {0, 0, 0}, bounds_hi[3] = {0, 0, 0};
    std::optional<TerrainGrid> terrain;  // section TERR: a terrain built from an elevation raster

    bool has_colors() const { return flags & kHasColors; }
    bool has_uvs() const { return flags & kHasUvs; }
    double cube_size(uint32_t level) const { return root_size / double(uint64_t(1) << level); }
    // h_l in the float the decoder uses, so CPU and GPU decode bit-identically.
    float lattice_step(uint32_t level) const { return float(cube_size(level) / double(1 << kLatticeBits)); }
};

struct HlodNode {
    uint32_t level = 0;
    uint32_t i = 0, j = 0, k = 0;
    float error = 0;           // geometric error against M_L, model units
    uint32_t vertex_count = 0;
    uint32_t triangle_count = 0;
    uint64_t offset = 0;       // payload position in the file
    uint64_t size = 0;         // payload bytes
    uint32_t checksum = 0;     // CRC-32C of the payload bytes
};

// One entry of the section table (FORMAT.md §3).
struct HlodSection {
    std::array<char, 4> tag{};
    uint32_t flags = 0;  // bit 0: required (a reader that does not know the tag refuses the file)
    uint64_t offset = 0, size = 0;
    uint32_t checksum = 0;  // CRC-32C of the section's bytes

    std::string name() const { return std::string(tag.data(), tag.size()); }
};

// Vertices in struct-of-arrays form: a cube's own vertices, or its table of parents.
struct VertexArrays {
    std::vector<uint16_t> positions;  // 3 per vertex: lattice ints relative to a cell (see kLatticeBits)
    std::vector<int16_t> normals;     // 2 per vertex: octahedral
    std::vector<uint8_t> colors;      // 4 per vertex, if the model has colours
    std::vector<float> uvs;           // 2 per vertex, if the model has UVs

    uint32_t size() const { return uint32_t(positions.size() / 3); }
};

// One cube, decoded. Each vertex names its parent P(v) by its index among the parent cube's
// vertices (the renderer keeps a cube's ancestors resident with it, DESIGN.md §2); about four
// vertices share a parent.
struct CubeData {
    VertexArrays vertices;                // level-l lattice, relative to the cube's cell
    std::vector<uint32_t> parent_vertex;  // per vertex: P(v) among the parent cube's vertices (level 0: v)
    std::vector<uint32_t> indices;        // 3 per triangle
    // Triangles are grouped by the child cube (octant i&1 | j&1<<1 | k&1<<2) they were simplified from;
    // at level L, whose triangles have no children, all are counted in [0].
    std::array<uint32_t, 8> child_triangle_counts{};
    // Filled by resolve_parents, so that the cube draws and morphs on its own: the distinct parents,
    // copied from the parent cube's vertices (level-(l−1) lattice, relative to the parent's cell), and
    // per vertex its entry among them.
    VertexArrays parents;
    std::vector<uint32_t> parent_of;
    // The cube's texture (section TXTR, preprocess/cube_textures.h): its BC1 mip chain; empty without.
    std::vector<uint8_t> texture;

    uint32_t vertex_count() const { return vertices.size(); }
    uint32_t triangle_count() const { return uint32_t(indices.size() / 3); }
};

// Copies each vertex's parent out of the parent cube's vertices (at level 0, pass the cube's own).
// Throws std::runtime_error naming the cube when a parent index lies past the parent's vertices.
void resolve_parents(CubeData& cube, const VertexArrays& parent_vertices, const std::string& what);

uint32_t crc32c(const void* data, size_t size);
// CRC-32C of A followed by B, from CRC-32C(A), CRC-32C(B) and B's length: the writer checksums the
// payload section from the payloads' own checksums, without reading the bytes it copies.
uint32_t crc32c_combine(uint32_t first, uint32_t second, uint64_t second_size);

std::vector<uint8_t> encode_cube(const CubeData& cube, uint32_t flags);
// Throws std::runtime_error("...") describing what is wrong with the bytes.
CubeData decode_cube(std::span<const uint8_t> bytes, const HlodNode& node, uint32_t flags, uint32_t codec = kCubePayloadCodec);

// Where a grid payload's vertices stand in their level's grid (codec 3): a column and row per vertex,
// in row-major order; the heights' shift (every stored z a multiple of 2^shift, shift ≤ 14); the
// raster's row order, which fixes the triangles' winding.
struct GridPlacement {
    std::vector<std::array<uint32_t, 2>> samples;
    uint32_t height_shift = 0;
    bool rows_run_north = false;
};
// A terrain cube as a grid payload: its triangles must be its grid's cells' (TerrainLevel::corners),
// grouped by child, in row-major cell order within a group, triangle 0 before 1 (std::logic_error
// otherwise: a builder's mistake). No colours or UVs.
std::vector<uint8_t> encode_grid_cube(const CubeData& cube, const GridPlacement& grid);

// Octahedral normal encoding: 12-bit snorm per component (±2047; worst error about 0.04°), kept
// in an int16 whose small range the vertex codec packs tighter than full 16-bit values.
inline constexpr int kNormalBits = 12;
std::array<int16_t, 2> encode_normal(float x, float y, float z);
std::array<float, 3> decode_normal(int16_t u, int16_t v);
// The octahedral normal of a sum of triangle normals (b − a) × (c − a) in lattice integers, each
// component wrapped to 64 bits: what a payload predicts for a vertex from its cube's triangles (FORMAT.md
// §7). A builder that gives a vertex the normal of this sum over the same triangles stores no residual.
std::array<int16_t, 2> lattice_normal(const std::array<uint64_t, 3>& sum);

// A file descriptor that closes itself, so that a constructor throwing after open() leaks nothing.
class FileHandle {
public:
    FileHandle() = default;
    explicit FileHandle(int fd) : fd_(fd) {}
    ~FileHandle();
    FileHandle(const FileHandle&) = delete;
    FileHandle& operator=(const FileHandle&) = delete;
    int get() const { return fd_; }
    int release();  // closes and reports close()'s result (0 or -1 with errno), so writes can be checked

private:
    int fd_ = -1;
};

// Reads exactly `size` bytes at `offset`; false if the file ends first (errno 0) or a read fails (errno
// says why).
bool read_fully(int fd, uint64_t offset, void* data, size_t size);

// The builder adds payloads finest level first; the file stores them coarsest first. So add_cube
// spools payloads to "<path>.tmp-<pid>.payloads", and finish() writes "<path>.tmp-<pid>" (header,
// sections, then the payloads copied level by level from the spool), fsyncs it and renames it over
// `path`. A writer destroyed before finish() removes both temporaries, so a failed or cancelled build
// leaves nothing behind. Memory: the node entries only.
class HlodWriter {
public:
    // While it runs, the writer of OUT keeps OUT<kTempMarker>PID (the file being assembled) and
    // OUT<kTempMarker>PID<kSpoolSuffix> (its payloads): what remove_build_leftovers looks for.
    static constexpr std::string_view kTempMarker = ".tmp-", kSpoolSuffix = ".payloads";

    explicit HlodWriter(std::filesystem::path path);
    ~HlodWriter();
    HlodWriter(const HlodWriter&) = delete;
    HlodWriter& operator=(const HlodWriter&) = delete;

    // Spools a payload, in any order; fills node.size and node.checksum.
    void add_cube(HlodNode node, std::span<const uint8_t> payload);
    // Before finish(): sets the error of the index-th cube added (errors are chained once all are in).
    void set_error(size_t index, float error) { nodes_.at(index).error = error; }
    // An optional section too large to hold in memory (a terrain's heights): its chunks spool with the
    // payloads, in call order; finish() writes the section before PAYL, its head first (set last, when
    // what it indexes is known). The tag must not be one the writer writes itself.
    void append_to_section(const char (&tag)[5], std::span<const uint8_t> bytes);
    void set_section_head(const char (&tag)[5], std::vector<uint8_t> head);
    // Before finish(): the cubes added so far, in the order NODE will list them (a section indexed by
    // cube, such as a terrain's textures, writes its index in that order).
    std::vector<HlodNode> nodes_in_file_order() const;
    // Writes the file; header.node_count is set from the cubes added. Throws std::runtime_error naming
    // the path when a write fails.
    void finish(HlodHeader header);
    // After finish(): the node table as written, in file order, with the payloads' final offsets.
    const std::vector<HlodNode>& nodes() const { return nodes_; }

private:
    struct SpooledSection {
        std::array<char, 4> tag{};
        std::vector<uint8_t> head;
        std::vector<std::pair<uint64_t, uint64_t>> chunks;  // spool offset and size
        uint64_t chunk_bytes = 0;
        uint32_t chunk_checksum = 0;  // CRC-32C of the chunks, back to back
    };
    SpooledSection& spooled_section(const char (&tag)[5]);
    uint64_t spool(std::span<const uint8_t> bytes);  // appends to the spool; returns where
    void remove_temporaries();
    std::vector<SpooledSection> sections_;
    std::filesystem::path path_, temp_path_, spool_path_;
    std::FILE* spool_ = nullptr;
    uint64_t spooled_ = 0;
    std::vector<HlodNode> nodes_;  // until finish(), offsets are spool offsets
};

// Whether the file at `path` begins as a .hlod does (kHlodMagic), as opposed to a mesh or a raster;
// false when it cannot be read. Says nothing of the rest of it: HlodFile checks that.
bool is_hlod_file(const std::filesystem::path& path);

// An opened .hlod: header, section table, model fields and node table read and checked (kilobytes,
// whatever the model's size: no payload byte is read); payloads are read on demand.
class HlodFile {
public:
    // Throws std::runtime_error naming the file and the problem (not a .hlod, a version 1 model,
    // truncated, a section out of range or corrupt, a section or payload codec this Strata does not know…).
    explicit HlodFile(const std::filesystem::path& path);

    const HlodHeader& header() const { return header_; }
    const std::vector<HlodNode>& nodes() const { return nodes_; }
    // Hands the node table over to an owner that keeps it with its own per-cube state (a streamed
    // model's tree), so that it is held once; nodes() is empty after. read_cube takes the node itself.
    std::vector<HlodNode> take_nodes() { return std::move(nodes_); }
    const std::vector<HlodSection>& sections() const { return sections_; }
    uint64_t file_size() const { return file_size_; }
    const std::filesystem::path& path() const { return path_; }
    // Which file this is, whatever path it was opened by: two HlodFiles with equal identities read the
    // same bytes (a file rewritten in place since gets a new modification time).
    struct Identity {
        uint64_t device = 0, inode = 0, size = 0;
        int64_t modified_ns = 0;
        bool operator==(const Identity&) const = default;
    };
    const Identity& identity() const { return identity_; }

    // Reads node's payload and checks its checksum; throws naming the cube on mismatch. Safe to call
    // from several threads at once (positioned reads).
    std::vector<uint8_t> read_payload(const HlodNode& node) const;
    CubeData read_cube(const HlodNode& node) const;
    // Reads a whole section in chunks of a few MB and checks its CRC (for PAYL, which opening does not read).
    void check_section(const HlodSection& section) const;
    // The section with this tag, or null.
    const HlodSection* find_section(const char (&tag)[5]) const;
    // `size` bytes from `offset` within `section` (a section too large to read whole, which checks its
    // parts itself); throws std::runtime_error naming the file and `what` when they lie outside it or
    // cannot be read.
    std::vector<uint8_t> read_section_part(const HlodSection& section, uint64_t offset, uint64_t size, const std::string& what) const;

private:
    void read_section_table(std::span<const uint8_t> fixed_header);
    std::vector<uint8_t> read_section(const HlodSection& section, uint64_t max_size) const;
    void read_model_section(const HlodSection& section);
    void read_node_section(const HlodSection& section, const HlodSection& payloads);
    void read_georeference_section(const HlodSection& section);
    void read_bounds_section(const HlodSection& section);
    void read_terrain_section(const HlodSection& section);
    void read_at(uint64_t offset, void* data, size_t size, const std::string& what) const;

    std::filesystem::path path_;
    FileHandle file_;
    uint64_t file_size_ = 0;
    Identity identity_;
    HlodHeader header_;
    std::vector<HlodSection> sections_;
    std::vector<HlodNode> nodes_;
};

std::string describe_cube(const HlodNode& node);  // "cube (level 3, 1 2 0)"

// A stored coordinate back to model units: O + q·h_l with q = stored + 2^15·cell − 2^14, in exactly
// the float operations the renderer's shader uses, so a vertex shared by two cubes (or a parent copy
// and the parent's own vertex) decodes to the same float everywhere.
inline float decode_coordinate(const HlodHeader& h, int axis, uint32_t level, uint32_t cell, uint16_t stored) {
    int32_t q = int32_t(stored) + int32_t(cell << kLatticeBits) - kLatticeBias;
    float product = float(q) * h.lattice_step(level);  // two statements: no fused multiply-add
    return float(h.origin[axis]) + product;
}

}  // namespace strata

// The .hlod file, version 1 (preprocess/FORMAT.md describes it byte by byte): a header, compressed
// per-cube payloads, and a node table at the end. Everything here is plain data plus the code that
// turns it into bytes and back; the builder, `strata info` and `strata verify` all go through it.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace strata {

inline constexpr char kHlodMagic[8] = {'S', 'T', 'R', 'A', 'T', 'A', 'H', 'L'};
inline constexpr uint32_t kHlodVersion = 1;

// Vertex positions live on one lattice per level anchored at the model origin (DESIGN.md §2):
// q = round((x − O)/h_l) with h_l = 2^-15·s_l, stored as the 16-bit q − 2^15·cell + 2^14.
inline constexpr int kLatticeBits = 15;
inline constexpr int32_t kLatticeBias = 1 << 14;

enum HlodFlags : uint32_t {
    kHasColors = 1u << 0,
    kHasUvs = 1u << 1,
};

struct HlodHeader {
    uint32_t version = kHlodVersion;
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
    uint64_t node_table_offset = 0;
    std::string source;            // the input file's name (no directories)
    std::string texture;           // texture image the source named, or empty

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

    uint32_t vertex_count() const { return vertices.size(); }
    uint32_t triangle_count() const { return uint32_t(indices.size() / 3); }
};

// Copies each vertex's parent out of the parent cube's vertices (at level 0, pass the cube's own).
// Throws std::runtime_error naming the cube when a parent index lies past the parent's vertices.
void resolve_parents(CubeData& cube, const VertexArrays& parent_vertices, const std::string& what);

uint32_t crc32c(const void* data, size_t size);

std::vector<uint8_t> encode_cube(const CubeData& cube, uint32_t flags);
// Throws std::runtime_error("...") describing what is wrong with the bytes.
CubeData decode_cube(std::span<const uint8_t> bytes, const HlodNode& node, uint32_t flags);

// Octahedral normal encoding: 12-bit snorm per component (±2047; worst error about 0.04°), kept
// in an int16 whose small range the vertex codec packs tighter than full 16-bit values.
inline constexpr int kNormalBits = 12;
std::array<int16_t, 2> encode_normal(float x, float y, float z);
std::array<float, 3> decode_normal(int16_t u, int16_t v);

// Writes to "<path>.tmp-<pid>" and renames over `path` in finish(); a writer destroyed before finish()
// removes its temporary file, so a failed or cancelled build leaves nothing behind.
class HlodWriter {
public:
    explicit HlodWriter(std::filesystem::path path);
    ~HlodWriter();
    HlodWriter(const HlodWriter&) = delete;
    HlodWriter& operator=(const HlodWriter&) = delete;

    // Appends a payload; fills node.offset, node.size and node.checksum.
    void add_cube(HlodNode node, std::span<const uint8_t> payload);
    void finish(HlodHeader header);
    const std::vector<HlodNode>& nodes() const { return nodes_; }

private:
    void write(const void* data, size_t size);
    std::filesystem::path path_, temp_path_;
    std::FILE* file_ = nullptr;
    uint64_t offset_ = 0;
    std::vector<HlodNode> nodes_;
};

// An opened .hlod: header and node table read and checked; payloads read on demand.
class HlodFile {
public:
    // Throws std::runtime_error naming the file and the problem (not a .hlod, wrong version, truncated,
    // node table out of range, ...).
    explicit HlodFile(const std::filesystem::path& path);
    ~HlodFile();
    HlodFile(const HlodFile&) = delete;
    HlodFile& operator=(const HlodFile&) = delete;

    const HlodHeader& header() const { return header_; }
    const std::vector<HlodNode>& nodes() const { return nodes_; }
    uint64_t file_size() const { return file_size_; }
    const std::filesystem::path& path() const { return path_; }

    // Reads node's payload and checks its checksum; throws naming the cube on mismatch.
    std::vector<uint8_t> read_payload(const HlodNode& node) const;
    CubeData read_cube(const HlodNode& node) const;

private:
    struct Closer {
        void operator()(std::FILE* file) const { std::fclose(file); }
    };
    std::filesystem::path path_;
    // Owned, so a constructor that throws after opening still closes the file.
    std::unique_ptr<std::FILE, Closer> file_;
    uint64_t file_size_ = 0;
    HlodHeader header_;
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

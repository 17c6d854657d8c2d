#include "preprocess/hlod_format.h"
#include "preprocess/byte_packing.h"

#include <fcntl.h>
#include <meshoptimizer.h>
#include <zstd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <tuple>

namespace strata {
namespace {

// FORMAT.md §3–§4.
constexpr size_t kFixedHeaderBytes = 32;
constexpr size_t kHeaderCrcAt = 28;
constexpr size_t kSectionEntryBytes = 32;
constexpr uint32_t kMaxSections = 256;
constexpr uint32_t kRequiredSection = 1u << 0;
constexpr size_t kNodeBytes = 48;
constexpr size_t kMaxNameBytes = 4096;
constexpr size_t kMaxCrsBytes = 65536;
constexpr size_t kModelFixedBytes = 88;        // MODL before its two names
constexpr size_t kGeoreferenceFixedBytes = 24;  // GEOR before its CRS string
constexpr uint64_t kSectionAlignment = 8;
constexpr uint64_t kPayloadAlignment = 4096;
constexpr size_t kChunkBytes = size_t(8) << 20;  // copies and streamed checksums go this many bytes at a time

constexpr uint32_t kCrc32cPolynomial = 0x82F63B78u;  // reflected

constexpr char kModelTag[5] = "MODL", kNodeTag[5] = "NODE", kPayloadTag[5] = "PAYL", kGeoreferenceTag[5] = "GEOR",
               kBoundsTag[5] = "BNDS", kTerrainTag[5] = "TERR";
constexpr size_t kBoundsBytes = 48;   // BNDS: six f64
constexpr size_t kTerrainBytes = 88;  // TERR: two u64, two f64, a u64, four u32, four f64

// ---- CRC-32C (Castagnoli): hardware instruction where there is one, table otherwise ------------

uint32_t crc32c_table(uint32_t crc, const uint8_t* p, size_t n) {
    static const auto table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; ++i) {
            uint32_t c = i;
            for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (kCrc32cPolynomial & (0u - (c & 1u)));
            t[i] = c;
        }
        return t;
    }();
    for (size_t i = 0; i < n; ++i) crc = table[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
    return crc;
}

#if defined(__x86_64__)
__attribute__((target("sse4.2"))) uint32_t crc32c_hardware(uint32_t crc, const uint8_t* p, size_t n) {
    uint64_t c = crc;
    for (; n >= 8; n -= 8, p += 8) {
        uint64_t word;
        std::memcpy(&word, p, 8);
        c = __builtin_ia32_crc32di(c, word);
    }
    uint32_t c32 = uint32_t(c);
    for (; n > 0; --n, ++p) c32 = __builtin_ia32_crc32qi(c32, *p);
    return c32;
}
#endif

// ---- streams -------------------------------------------------------------------------------

template <class T>
std::vector<uint8_t> as_bytes(const std::vector<T>& v) {
    std::vector<uint8_t> out(v.size() * sizeof(T));
    if (!v.empty()) std::memcpy(out.data(), v.data(), out.size());
    return out;
}

template <class T>
void from_bytes(const std::vector<uint8_t>& bytes, std::vector<T>& v) {
    v.resize(bytes.size() / sizeof(T));
    if (!v.empty()) std::memcpy(v.data(), bytes.data(), bytes.size());
}


// ---- sections ------------------------------------------------------------------------------

// a·b modulo the CRC-32C polynomial, in the reflected bit order the CRC uses (x^0 is the top bit).
uint32_t multiply_modulo_polynomial(uint32_t a, uint32_t b) {
    uint32_t product = 0;
    for (uint32_t bit = 1u << 31; bit != 0; bit >>= 1) {
        if (a & bit) product ^= b;
        b = (b & 1) ? (b >> 1) ^ kCrc32cPolynomial : b >> 1;
    }
    return product;
}

// x^(8·n) modulo the polynomial: what running n more bytes through the CRC register multiplies it by.
uint32_t shift_by_bytes(uint64_t n) {
    uint32_t result = 1u << 31;  // x^0
    uint32_t power = 1u << 23;   // x^8, squared for each bit of n
    for (; n != 0; n >>= 1) {
        if (n & 1) result = multiply_modulo_polynomial(result, power);
        power = multiply_modulo_polynomial(power, power);
    }
    return result;
}

uint64_t align_up(uint64_t x, uint64_t alignment) { return (x + alignment - 1) / alignment * alignment; }

bool is_tag(const HlodSection& s, const char (&tag)[5]) { return std::memcmp(s.tag.data(), tag, 4) == 0; }

std::string quoted(const HlodSection& s) { return "section '" + s.name() + "'"; }

// Payloads in the file: coarse levels first, each level in (k, j, i) order.
bool in_file_order(const HlodNode& a, const HlodNode& b) {
    return std::tie(a.level, a.k, a.j, a.i) < std::tie(b.level, b.k, b.j, b.i);
}

void write_model(ByteWriter& w, const HlodHeader& h) {
    w.put(h.payload_codec);
    w.put(h.flags);
    for (double o : h.origin) w.put(o);
    w.put(h.root_size);
    w.put(h.max_level);
    w.put(h.block_size);
    w.put(h.sigma0);
    w.put(h.error_q);
    w.put(h.ratio);
    w.put(h.error_limit);
    w.put(h.input_vertices);
    w.put(h.input_triangles);
    w.put(h.node_count);
    w.put_string(h.source);
    w.put_string(h.texture);
}

void write_georeference(ByteWriter& w, const HlodHeader& h) {
    for (double o : h.geo_origin) w.put(o);
    w.put_string(h.crs);
}

void write_terrain(ByteWriter& w, const TerrainGrid& t) {
    w.put(t.columns), w.put(t.rows), w.put(t.spacing[0]), w.put(t.spacing[1]), w.put(t.nodata_samples);
    w.put(t.cube_cells), w.put(uint32_t((t.rows_run_north ? 1 : 0) | (t.raster_geographic ? 2 : 0))), w.put(t.frame), w.put(uint32_t(0));
    w.put(t.first_sample[0]), w.put(t.first_sample[1]), w.put(t.semi_major), w.put(t.inverse_flattening);
    if (t.frame == 3) w.put_string(t.raster_crs);
}

void write_bounds(ByteWriter& w, const HlodHeader& h) {
    for (double v : h.bounds_lo) w.put(v);
    for (double v : h.bounds_hi) w.put(v);
}

void write_node(ByteWriter& w, const HlodNode& n) {
    w.put(n.offset), w.put(n.size);
    w.put(n.level), w.put(n.i), w.put(n.j), w.put(n.k);
    w.put(n.error);
    w.put(n.vertex_count), w.put(n.triangle_count);
    w.put(n.checksum);
}

HlodNode read_node(ByteReader& r) {
    HlodNode n;
    n.offset = r.get<uint64_t>(), n.size = r.get<uint64_t>();
    n.level = r.get<uint32_t>(), n.i = r.get<uint32_t>(), n.j = r.get<uint32_t>(), n.k = r.get<uint32_t>();
    n.error = r.get<float>();
    n.vertex_count = r.get<uint32_t>(), n.triangle_count = r.get<uint32_t>();
    n.checksum = r.get<uint32_t>();
    return n;
}

std::string io_error(const std::filesystem::path& path, const std::string& what) {
    return path.string() + ": " + what + (errno ? std::string(" (") + std::strerror(errno) + ")" : "");
}

void write_all(int fd, const uint8_t* data, size_t size, const std::filesystem::path& path) {
    while (size > 0) {
        errno = 0;
        const ssize_t n = ::write(fd, data, std::min(size, kChunkBytes));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw std::runtime_error(io_error(path, "write failed"));
        data += n, size -= size_t(n);
    }
}

// Appends `size` bytes of `from`, starting at `offset`, to `to` at its file position: inside the kernel
// with copy_file_range (nothing passes through memory; some filesystems share the blocks), else, where
// the kernel or filesystem cannot, through a buffer of a few MB.
void copy_bytes(int from, uint64_t offset, int to, uint64_t size, const std::filesystem::path& path) {
    while (size > 0) {
        off_t in = off_t(offset);
        errno = 0;
        const ssize_t n = ::copy_file_range(from, &in, to, nullptr, std::min<uint64_t>(size, kChunkBytes), 0);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EXDEV || errno == ENOSYS || errno == EOPNOTSUPP || errno == EINVAL)) break;
        if (n == 0) errno = 0;  // the spool ended early
        if (n <= 0) throw std::runtime_error(io_error(path, "write failed"));
        offset += uint64_t(n), size -= uint64_t(n);
    }
    std::vector<uint8_t> buffer(std::min<uint64_t>(size, kChunkBytes));
    while (size > 0) {
        const size_t chunk = std::min<uint64_t>(size, buffer.size());
        if (!read_fully(from, offset, buffer.data(), chunk))
            throw std::runtime_error(io_error(path, "cannot read back the spooled payloads"));
        write_all(to, buffer.data(), chunk, path);
        offset += chunk, size -= chunk;
    }
}

}  // namespace

uint32_t crc32c(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
#if defined(__x86_64__)
    static const bool hardware = __builtin_cpu_supports("sse4.2");
    if (hardware) return ~crc32c_hardware(~0u, p, size);
#endif
    return ~crc32c_table(~0u, p, size);
}

uint32_t crc32c_combine(uint32_t first, uint32_t second, uint64_t second_size) {
    return multiply_modulo_polynomial(shift_by_bytes(second_size), first) ^ second;
}

FileHandle::~FileHandle() {
    if (fd_ >= 0) ::close(fd_);
}

int FileHandle::release() {
    const int fd = fd_;
    fd_ = -1;
    return fd >= 0 ? ::close(fd) : 0;
}

bool read_fully(int fd, uint64_t offset, void* data, size_t size) {
    auto* bytes = static_cast<uint8_t*>(data);
    while (size > 0) {
        errno = 0;
        const ssize_t n = ::pread(fd, bytes, size, off_t(offset));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        bytes += n, size -= size_t(n), offset += uint64_t(n);
    }
    return true;
}

std::string describe_cube(const HlodNode& node) {
    return "cube (level " + std::to_string(node.level) + ", " + std::to_string(node.i) + " " +
           std::to_string(node.j) + " " + std::to_string(node.k) + ")";
}

std::array<int16_t, 2> encode_normal(float x, float y, float z) {
    float l1 = std::fabs(x) + std::fabs(y) + std::fabs(z);
    if (!(l1 > 0)) return {0, 0};
    x /= l1, y /= l1, z /= l1;
    if (z < 0) {
        float ox = (1 - std::fabs(y)) * (x >= 0 ? 1.0f : -1.0f);
        float oy = (1 - std::fabs(x)) * (y >= 0 ? 1.0f : -1.0f);
        x = ox, y = oy;
    }
    constexpr float steps = float((1 << (kNormalBits - 1)) - 1);
    auto snorm = [](float v) { return int16_t(std::lround(std::clamp(v, -1.0f, 1.0f) * steps)); };
    return {snorm(x), snorm(y)};
}

std::array<float, 3> decode_normal(int16_t u, int16_t v) {
    constexpr float scale = float((1 << (kNormalBits - 1)) - 1);
    float x = std::max(u / scale, -1.0f), y = std::max(v / scale, -1.0f);
    float z = 1 - std::fabs(x) - std::fabs(y);
    if (z < 0) {
        float ox = (1 - std::fabs(y)) * (x >= 0 ? 1.0f : -1.0f);
        float oy = (1 - std::fabs(x)) * (y >= 0 ? 1.0f : -1.0f);
        x = ox, y = oy;
    }
    float len = std::sqrt(x * x + y * y + z * z);
    return {x / len, y / len, z / len};
}

namespace {

// A payload's streams (FORMAT.md §5), each stored as it is or as its own zstd frame: one Huffman table
// per stream fits its symbols far better than one table over all of them.
enum Stream { kIndices, kPositions, kNormals, kParents, kColors, kUvs, kBits, kStreams };
// zstd level 9. On the 19.3 M-triangle bunny (2 threads, quiet machine) level 19 is 2.8 % smaller
// (4.80 against 4.93 bytes a triangle) but takes the whole build from 21.7 s to 32.2 s, zstd then
// being 39 % of the build's CPU; level 3 is 1.3 % larger for 20.0 s. Decoding speed does not depend
// on it.
constexpr int kZstdLevel = 9;
// A stream may be at most this many times its zstd frame, so that a small payload cannot make a reader
// allocate gigabytes; a writer stores a stream as it is when it would compress further.
constexpr uint64_t kMaxZstdRatio = 64;
constexpr uint32_t kNone = ~0u;
// The position prediction where a cube's walk starts (FORMAT.md §6): the centre of the cell.
constexpr uint16_t kCellCentre = uint16_t(kLatticeBias + (1 << (kLatticeBits - 1)));

struct ZstdContexts {
    ZSTD_CCtx* compress = ZSTD_createCCtx();
    ZSTD_DCtx* decompress = ZSTD_createDCtx();
    ~ZstdContexts() { ZSTD_freeCCtx(compress), ZSTD_freeDCtx(decompress); }
};
thread_local ZstdContexts zstd;  // reused: creating a context costs more than decoding a small cube

// ---- residuals: a size class per value, its low bits in a shared bit stream ----------------

// The size class of a zigzagged value: its bit length (0 for 0).
uint32_t size_class(uint32_t z) { return z ? uint32_t(32 - __builtin_clz(z)) : 0; }

// Bits packed from the lowest bit of the first byte up.
class BitWriter {
public:
    void put(uint64_t value, uint32_t count) {  // count ≤ 32
        pending_ |= value << filled_;
        filled_ += count;
        while (filled_ >= 8) bytes_.push_back(uint8_t(pending_)), pending_ >>= 8, filled_ -= 8;
    }
    // A value of class `n` has its top bit implied: the other n − 1 go to the stream.
    void put_low_bits(uint32_t z, uint32_t n) {
        if (n > 1) put(z & ((uint64_t(1) << (n - 1)) - 1), n - 1);
    }
    std::vector<uint8_t> finish() {
        if (filled_ > 0) bytes_.push_back(uint8_t(pending_));
        pending_ = 0, filled_ = 0;
        return std::move(bytes_);
    }

private:
    std::vector<uint8_t> bytes_;
    uint64_t pending_ = 0;
    uint32_t filled_ = 0;
};

class BitReader {
public:
    BitReader(std::span<const uint8_t> bytes, const std::string& what) : bytes_(bytes), what_(what) {}
    uint32_t get(uint32_t count) {  // count ≤ 32
        if (filled_ < count) refill(count);
        const uint32_t value = uint32_t(pending_ & ((uint64_t(1) << count) - 1));
        pending_ >>= count, filled_ -= count;
        return value;
    }
    // The zigzagged value of class n (≤ 32).
    uint32_t value_of_class(uint32_t n) {  // without a branch on n, which the data makes unpredictable
        return uint32_t((uint64_t(1) << n) >> 1) | get(n - (n != 0));
    }
    // No whole byte left unread: the writer ends the stream with the last value's bits.
    bool at_end() const { return at_ == bytes_.size() && filled_ < 8; }

private:
    void refill(uint32_t count) {
        if (bytes_.size() - at_ >= 8) {  // a whole word: take as many of its bytes as fit
            uint64_t word;
            std::memcpy(&word, bytes_.data() + at_, 8);
            pending_ |= word << filled_;
            at_ += (63 - filled_) >> 3;
            filled_ |= 56;
            return;
        }
        while (filled_ <= 56 && at_ < bytes_.size()) pending_ |= uint64_t(bytes_[at_++]) << filled_, filled_ += 8;
        if (filled_ < count) throw std::runtime_error(what_ + ": bit stream ends early");
    }
    std::span<const uint8_t> bytes_;
    const std::string& what_;
    size_t at_ = 0;
    uint64_t pending_ = 0;
    uint32_t filled_ = 0;
};

// ---- the first-use walk (FORMAT.md §5) -----------------------------------------------------

// Each vertex in the order the triangles first use it, with what the decoder knows of its surroundings
// then: `a` and `b`, the two other corners of that first triangle (next and previous, keeping the
// winding) if they came earlier, and `d`, the far corner of a recent earlier triangle across the edge
// b→a (the neighbour that shares the edge with matching winding), found in a small hash table of recent
// edges. Vertices no triangle uses follow, in index order, with nothing known.
struct FirstUse {
    uint32_t v, a, b, d;
};

// The recent edges (FORMAT.md §5): entry h(x, y) holds the last triangle's edge x→y that hashed there,
// with its third corner. 4096 entries find the neighbour of 99 % of the vertices an exact search over
// all earlier triangles finds, at a fraction of its cost (no per-vertex lists to build).
class RecentEdges {
public:
    RecentEdges() : entries_(kEntries, Entry{kNone, kNone, kNone}) {}
    void add(uint32_t x, uint32_t y, uint32_t third) { entries_[slot(x, y)] = {x, y, third}; }
    uint32_t third(uint32_t x, uint32_t y) const {
        const Entry& e = entries_[slot(x, y)];
        return e.x == x && e.y == y ? e.third : kNone;
    }

private:
    static constexpr uint32_t kEntryBits = 12, kEntries = 1u << kEntryBits;
    static uint32_t slot(uint32_t x, uint32_t y) { return ((x * 2654435761u + y) * 2246822519u) >> (32 - kEntryBits); }
    struct Entry {
        uint32_t x, y, third;
    };
    std::vector<Entry> entries_;
};

std::vector<FirstUse> first_use_walk(const std::vector<uint32_t>& indices, uint32_t vertex_count) {
    std::vector<uint8_t> seen(vertex_count, 0);
    std::vector<FirstUse> walk;
    walk.reserve(vertex_count);
    RecentEdges edges;
    for (size_t t = 0; t < indices.size(); t += 3) {
        const uint32_t* corner = &indices[t];
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = corner[k];
            if (seen[v]) continue;
            const uint32_t a = corner[(k + 1) % 3], b = corner[(k + 2) % 3];
            const bool a_known = seen[a], b_known = seen[b];
            walk.push_back({v, a_known ? a : kNone, b_known ? b : kNone, a_known && b_known ? edges.third(b, a) : kNone});
            seen[v] = 1;
        }
        edges.add(corner[0], corner[1], corner[2]);
        edges.add(corner[1], corner[2], corner[0]);
        edges.add(corner[2], corner[0], corner[1]);
    }
    for (uint32_t v = 0; v < vertex_count; ++v)
        if (!seen[v]) walk.push_back({v, kNone, kNone, kNone});
    return walk;
}

// The position the decoder expects for a vertex of the walk, from positions it already has: across the
// edge a→b from the neighbour d (parallelogram a + b − d), else the middle of a and b, else a or b, else
// the previous vertex of the walk. Arithmetic modulo 2^16, as the residuals.
inline std::array<uint16_t, 3> predicted_position(const FirstUse& f, const uint16_t* positions, const uint16_t* previous) {
    const uint16_t* a = f.a != kNone ? positions + 3 * size_t(f.a) : nullptr;
    const uint16_t* b = f.b != kNone ? positions + 3 * size_t(f.b) : nullptr;
    if (a && b && f.d != kNone) {
        const uint16_t* d = positions + 3 * size_t(f.d);
        return {uint16_t(a[0] + b[0] - d[0]), uint16_t(a[1] + b[1] - d[1]), uint16_t(a[2] + b[2] - d[2])};
    }
    if (a && b)
        return {uint16_t((uint32_t(a[0]) + b[0]) >> 1), uint16_t((uint32_t(a[1]) + b[1]) >> 1),
                uint16_t((uint32_t(a[2]) + b[2]) >> 1)};
    const uint16_t* known = a ? a : b ? b : previous;
    return {known[0], known[1], known[2]};
}

// Parent symbols (FORMAT.md §9): the parent repeats the previous vertex's, or a's or b's, or is one past
// the largest so far; else it is coded as a difference from the previous vertex's.
enum ParentSymbol : uint8_t { kSameAsPrevious, kSameAsA, kSameAsB, kNextNew, kExplicit };
constexpr uint32_t kLastParentSymbol = kExplicit + 32;

// ---- stream containers ---------------------------------------------------------------------

std::vector<uint8_t> encode_vertices(const std::vector<uint8_t>& records, size_t count, size_t record_size) {
    if (count == 0) return {};
    std::vector<uint8_t> out(meshopt_encodeVertexBufferBound(count, record_size));
    out.resize(meshopt_encodeVertexBuffer(out.data(), out.size(), records.data(), count, record_size));
    return out;
}

std::vector<uint8_t> decode_vertices(std::span<const uint8_t> encoded, size_t count, size_t record_size,
                                     const std::string& what) {
    std::vector<uint8_t> out(count * record_size);
    if (count == 0) return out;
    if (meshopt_decodeVertexBuffer(out.data(), count, record_size, encoded.data(), encoded.size()) != 0)
        throw std::runtime_error(what + ": vertex stream does not decode");
    return out;
}

std::vector<uint8_t> encode_indices(const std::vector<uint32_t>& indices, size_t vertex_count) {
    if (indices.empty()) return {};
    std::vector<uint8_t> out(meshopt_encodeIndexBufferBound(indices.size(), vertex_count));
    out.resize(meshopt_encodeIndexBuffer(out.data(), out.size(), indices.data(), indices.size()));
    return out;
}

// The triangles as the decoder gets them back: every prediction uses the decoded buffer, whose corners
// the index codec may have rotated.
std::vector<uint32_t> decode_indices(std::span<const uint8_t> stream, uint32_t triangles, uint32_t vertex_count,
                                     const std::string& what) {
    std::vector<uint32_t> indices(size_t(triangles) * 3);
    if (triangles && meshopt_decodeIndexBuffer(indices.data(), indices.size(), 4, stream.data(), stream.size()) != 0)
        throw std::runtime_error(what + ": index stream does not decode");
    // The largest index first (a loop the compiler vectorizes), the offending one only when there is one.
    uint32_t largest = 0;
    for (uint32_t index : indices) largest = std::max(largest, index);
    if (!indices.empty() && largest >= vertex_count) {
        const uint32_t index = *std::find_if(indices.begin(), indices.end(), [&](uint32_t i) { return i >= vertex_count; });
        throw std::runtime_error(what + ": index " + std::to_string(index) + " past its " + std::to_string(vertex_count) +
                                 " vertices");
    }
    return indices;
}

// A stream in the payload: as a zstd frame when that is smaller and within the ratio a reader accepts,
// else as it is. Returns the bytes to store.
// `floor`: a size any stream may unpack to whatever its ratio (grid payloads; 0 for meshes).
std::vector<uint8_t> packed(const std::vector<uint8_t>& stream, uint64_t floor) {
    if (stream.empty()) return {};
    std::vector<uint8_t> frame(ZSTD_compressBound(stream.size()));
    const size_t size = ZSTD_compressCCtx(zstd.compress, frame.data(), frame.size(), stream.data(), stream.size(), kZstdLevel);
    if (ZSTD_isError(size)) throw std::runtime_error(std::string("zstd: ") + ZSTD_getErrorName(size));
    if (size < stream.size() && stream.size() <= std::max(kMaxZstdRatio * size, floor)) {
        frame.resize(size);
        return frame;
    }
    return stream;
}

// A stream back from its stored bytes: `size` is its unpacked length, checked against the stored bytes
// before anything is allocated for it.
std::vector<uint8_t> unpacked(std::span<const uint8_t> stored, uint32_t size, uint64_t floor, const std::string& what) {
    if (stored.size() == size) return {stored.begin(), stored.end()};
    if (stored.size() > size) throw std::runtime_error(what + ": stream stored in more bytes than it holds");
    if (size > std::max(kMaxZstdRatio * stored.size(), floor)) throw std::runtime_error(what + ": counts larger than the payload could hold");
    if (ZSTD_getFrameContentSize(stored.data(), stored.size()) != size)
        throw std::runtime_error(what + ": zstd frame does not hold the stream's size");
    std::vector<uint8_t> stream(size);
    const size_t got = ZSTD_decompressDCtx(zstd.decompress, stream.data(), stream.size(), stored.data(), stored.size());
    if (ZSTD_isError(got) || got != size) throw std::runtime_error(what + ": zstd frame does not decode");
    return stream;
}

// The octahedral normal of vertex v that the triangles predict (FORMAT.md §7): the sum over its
// triangles of (b − a) × (c − a) in lattice integers, in wrapping 64-bit arithmetic so that every
// reader gets the same bits, mapped in f64. Where the builder computed a vertex's normal from the same
// triangles (inside a cube, without seams), the prediction is the stored normal or next to it.
// std::lround for |t| ≤ 2047 without its library call (decoding calls it twice per vertex): the
// truncation is exact, and so is t minus it.
int16_t round_half_away(double t) {
    int32_t whole = int32_t(t);
    const double fraction = t - double(whole);
    whole += (fraction >= 0.5) - (fraction <= -0.5);
    return int16_t(whole);
}

std::vector<int16_t> predicted_normals(const std::vector<uint16_t>& positions, const std::vector<uint32_t>& indices) {
    const size_t n = positions.size() / 3;
    std::vector<std::array<uint64_t, 3>> sums(n, {0, 0, 0});
    for (size_t t = 0; t < indices.size(); t += 3) {
        // A corner past the vertices makes the decoder refuse the payload; the encoder just skips it.
        if (indices[t] >= n || indices[t + 1] >= n || indices[t + 2] >= n) continue;
        const uint16_t* p[3];
        for (int k = 0; k < 3; ++k) p[k] = &positions[3 * size_t(indices[t + k])];
        int64_t e1[3], e2[3];
        for (int a = 0; a < 3; ++a) e1[a] = int64_t(p[1][a]) - p[0][a], e2[a] = int64_t(p[2][a]) - p[0][a];
        const uint64_t normal[3] = {uint64_t(e1[1] * e2[2] - e1[2] * e2[1]), uint64_t(e1[2] * e2[0] - e1[0] * e2[2]),
                                    uint64_t(e1[0] * e2[1] - e1[1] * e2[0])};
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) sums[indices[t + k]][a] += normal[a];
    }
    std::vector<int16_t> out(2 * sums.size());
    for (size_t v = 0; v < sums.size(); ++v) {
        const std::array<int16_t, 2> normal = lattice_normal(sums[v]);
        out[2 * v] = normal[0], out[2 * v + 1] = normal[1];
    }
    return out;
}

}  // namespace

std::array<int16_t, 2> lattice_normal(const std::array<uint64_t, 3>& sum) {
    constexpr double steps = double((1 << (kNormalBits - 1)) - 1);
    double x = double(int64_t(sum[0])), y = double(int64_t(sum[1])), z = double(int64_t(sum[2]));
    const double l1 = std::fabs(x) + std::fabs(y) + std::fabs(z);
    if (!(l1 > 0)) return {0, 0};  // no triangle
    x /= l1, y /= l1, z /= l1;
    if (z < 0) {
        const double ox = (1 - std::fabs(y)) * (x >= 0 ? 1.0 : -1.0);
        const double oy = (1 - std::fabs(x)) * (y >= 0 ? 1.0 : -1.0);
        x = ox, y = oy;
    }
    return {round_half_away(std::clamp(x, -1.0, 1.0) * steps), round_half_away(std::clamp(y, -1.0, 1.0) * steps)};
}

namespace {

// ---- the streams, one function each way ----------------------------------------------------

// Heights may lie on a lattice 2^shift times coarser (grid payloads, FORMAT.md §6): their residuals
// count its steps, modulo 2^(16 − shift). `shift` 0: every axis as it is.
int32_t height_residual(uint16_t value, uint16_t predicted, uint32_t shift) {
    const uint32_t bits = 16 - shift;
    const uint32_t difference = uint32_t((value >> shift) - (predicted >> shift)) & ((1u << bits) - 1);
    return int32_t(difference << (32 - bits)) >> (32 - bits);  // sign-extended from its bits
}

// Where the class of axis x of the i-th vertex of the walk lies in stream 1: x, y, z together, or
// (grid payloads) every x, then every y, then every z, so that the grid's x and y classes, nearly all
// 0, make long runs.
struct ClassOrder {
    bool planar = false;
    size_t vertices = 0;
    size_t at(size_t i, int x) const { return planar ? size_t(x) * vertices + i : 3 * i + size_t(x); }
};

std::vector<uint8_t> encode_positions(const std::vector<FirstUse>& walk, const std::vector<uint16_t>& positions, uint32_t shift,
                                      ClassOrder order, BitWriter& bits) {
    std::vector<uint8_t> classes(positions.size());
    uint16_t previous[3] = {kCellCentre, kCellCentre, kCellCentre};
    for (size_t i = 0; i < walk.size(); ++i) {
        const FirstUse& f = walk[i];
        const std::array<uint16_t, 3> p = predicted_position(f, positions.data(), previous);
        for (int x = 0; x < 3; ++x) {
            const uint16_t value = positions[3 * size_t(f.v) + x];
            const uint32_t z = zigzag(x == 2 ? height_residual(value, p[x], shift) : int16_t(uint16_t(value - p[x])));
            const uint8_t n = uint8_t(size_class(z));
            classes[order.at(i, x)] = n;
            bits.put_low_bits(z, n);
            previous[x] = value;
        }
    }
    return classes;
}

void decode_positions(const std::vector<FirstUse>& walk, std::span<const uint8_t> classes, uint32_t shift, ClassOrder order,
                      BitReader& bits, std::vector<uint16_t>& positions, const std::string& what) {
    positions.resize(3 * walk.size());
    uint16_t previous[3] = {kCellCentre, kCellCentre, kCellCentre};
    for (size_t i = 0; i < walk.size(); ++i) {
        const FirstUse& f = walk[i];
        const std::array<uint16_t, 3> p = predicted_position(f, positions.data(), previous);
        for (int x = 0; x < 3; ++x) {
            const uint8_t* c = &classes[order.at(i, x)];
            if (*c > 16) throw std::runtime_error(what + ": position residual class " + std::to_string(*c) + " past 16");
            const int32_t r = unzigzag(bits.value_of_class(*c));
            const uint16_t value = x == 2 && shift ? uint16_t((uint32_t(p[x] >> shift) + uint32_t(r)) << shift)
                                                   : uint16_t(p[x] + uint16_t(r));
            positions[3 * size_t(f.v) + x] = previous[x] = value;
        }
    }
}

// Normal residuals: one byte per vertex, the classes of du (high four bits) and dv (low four).
std::vector<uint8_t> encode_normals(const std::vector<FirstUse>& walk, const std::vector<int16_t>& normals,
                                    const std::vector<int16_t>& predicted, BitWriter& bits) {
    std::vector<uint8_t> classes;
    classes.reserve(walk.size());
    for (const FirstUse& f : walk) {
        uint32_t z[2], n[2];
        for (int k = 0; k < 2; ++k) {
            const size_t at = 2 * size_t(f.v) + k;
            z[k] = zigzag(int32_t(normals[at]) - predicted[at]), n[k] = size_class(z[k]);
        }
        classes.push_back(uint8_t(n[0] << 4 | n[1]));
        bits.put_low_bits(z[0], n[0]), bits.put_low_bits(z[1], n[1]);
    }
    return classes;
}

void decode_normals(const std::vector<FirstUse>& walk, std::span<const uint8_t> classes, BitReader& bits,
                    const std::vector<int16_t>& predicted, std::vector<int16_t>& normals, const std::string& what) {
    constexpr int kNormalLimit = (1 << (kNormalBits - 1)) - 1;
    normals.resize(2 * walk.size());
    for (size_t i = 0; i < walk.size(); ++i) {
        const uint32_t n[2] = {uint32_t(classes[i] >> 4), uint32_t(classes[i] & 15)};
        for (int k = 0; k < 2; ++k) {
            const size_t at = 2 * size_t(walk[i].v) + k;
            const int32_t value = predicted[at] + unzigzag(bits.value_of_class(n[k]));
            if (value < -kNormalLimit || value > kNormalLimit)
                throw std::runtime_error(what + ": normal of vertex " + std::to_string(walk[i].v) + " out of range");
            normals[at] = int16_t(value);
        }
    }
}

// What the decoder already knows when it reaches a vertex's parent (FORMAT.md §9).
struct ParentContext {
    uint32_t previous = 0;  // the previous vertex's parent in walk order
    uint32_t largest = 0;
    bool any = false;
    void add(uint32_t parent) {
        previous = parent;
        if (!any || parent > largest) largest = parent;
        any = true;
    }
    uint32_t next_new() const { return any ? largest + 1 : 0; }  // wraps like every u32 here
};

std::vector<uint8_t> encode_parents(const std::vector<FirstUse>& walk, const std::vector<uint32_t>& parents,
                                    BitWriter& bits) {
    std::vector<uint8_t> symbols;
    symbols.reserve(walk.size());
    ParentContext known;
    for (const FirstUse& f : walk) {
        const uint32_t parent = parents[f.v];
        if (parent == known.previous) symbols.push_back(kSameAsPrevious);
        else if (f.a != kNone && parent == parents[f.a]) symbols.push_back(kSameAsA);
        else if (f.b != kNone && parent == parents[f.b]) symbols.push_back(kSameAsB);
        else if (parent == known.next_new()) symbols.push_back(kNextNew);
        else {
            const uint32_t z = zigzag(int32_t(parent - known.previous));
            symbols.push_back(uint8_t(kExplicit + size_class(z)));
            bits.put_low_bits(z, size_class(z));
        }
        known.add(parent);
    }
    return symbols;
}

void decode_parents(const std::vector<FirstUse>& walk, std::span<const uint8_t> symbols, BitReader& bits,
                    std::vector<uint32_t>& parents, const std::string& what) {
    parents.resize(walk.size());
    ParentContext known;
    for (size_t i = 0; i < walk.size(); ++i) {
        const FirstUse& f = walk[i];
        const uint8_t s = symbols[i];
        uint32_t parent;
        if (s == kSameAsPrevious) parent = known.previous;
        else if (s == kSameAsA || s == kSameAsB) {
            const uint32_t corner = s == kSameAsA ? f.a : f.b;
            if (corner == kNone)
                throw std::runtime_error(what + ": parent of vertex " + std::to_string(f.v) + " names a corner not yet decoded");
            parent = parents[corner];
        } else if (s == kNextNew) parent = known.next_new();
        else if (s <= kLastParentSymbol) parent = known.previous + uint32_t(unzigzag(bits.value_of_class(s - kExplicit)));
        else throw std::runtime_error(what + ": parent symbol " + std::to_string(s) + " past " + std::to_string(kLastParentSymbol));
        parents[f.v] = parent;
        known.add(parent);
    }
}

// ---- grid payloads (codec 3, FORMAT.md §5.1) ------------------------------------------------

constexpr uint32_t kMaxGridSide = 4096;
constexpr uint32_t kMaxHeightShift = 14;
constexpr uint8_t kGridRowsRunNorth = 1;
// A grid payload's streams are far more regular than a mesh's (most normals and most x, y residuals
// are 0): each may unpack to this many bytes whatever its frame's ratio, which still bounds what a
// reader allocates.
constexpr uint64_t kGridStreamFloor = uint64_t(1) << 20;

void put_varint(std::vector<uint8_t>& out, uint64_t value) {
    for (; value >= 0x80; value >>= 7) out.push_back(uint8_t(value | 0x80));
    out.push_back(uint8_t(value));
}

uint32_t get_varint(ByteReader& r, const std::string& what) {
    uint64_t value = 0;
    for (int shift = 0;; shift += 7) {
        const uint8_t byte = r.get<uint8_t>();
        value |= uint64_t(byte & 0x7F) << shift;
        if (value > 0xFFFFFFFFu) throw std::runtime_error(what + ": grid run past 2^32");
        if (!(byte & 0x80)) return uint32_t(value);
        if (shift == 28) throw std::runtime_error(what + ": grid run past 2^32");
    }
}

// Run lengths of a grid stream: the samples' alternate between absent and present, absent first; the
// cells' repeat a value.
class SampleRuns {
public:
    SampleRuns(ByteReader& r, const std::string& what) : r_(r), what_(what) {}
    bool next() {
        while (left_ == 0) left_ = get_varint(r_, what_), present_ = !present_;
        --left_;
        return present_;
    }
    bool ended() const { return left_ == 0; }

private:
    ByteReader& r_;
    const std::string& what_;
    uint32_t left_ = 0;
    bool present_ = true;  // the first run is absent
};

class CellRuns {
public:
    CellRuns(ByteReader& r, const std::string& what) : r_(r), what_(what) {}
    uint8_t next() {
        if (left_ == 0) {
            value_ = r_.get<uint8_t>(), left_ = get_varint(r_, what_);
            if (left_ == 0) throw std::runtime_error(what_ + ": a cell run of length 0");
            if ((value_ & 15) > 8 || (value_ >> 4) > 8) throw std::runtime_error(what_ + ": cell value " + std::to_string(value_) + " names no child group");
        }
        --left_;
        return value_;
    }
    bool ended() const { return left_ == 0; }

private:
    ByteReader& r_;
    const std::string& what_;
    uint32_t left_ = 0;
    uint8_t value_ = 0;
};

// What a grid stream gives: the triangles, grouped by child, the walk, and the heights' shift.
struct GridTopology {
    std::vector<uint32_t> indices;
    std::vector<FirstUse> walk;
    uint32_t height_shift = 0;
};

// Decodes a grid stream (FORMAT.md §5.1) for a cube of `vertices` vertices and `child_counts`
// triangles per child group (the caller has checked their sum is at most 2·vertices).
GridTopology decode_grid(std::span<const uint8_t> stream, uint32_t vertices, const std::array<uint32_t, 8>& child_counts,
                         const std::string& what) {
    ByteReader r(stream, what + " grid stream");
    const uint32_t width = r.get<uint16_t>(), height = r.get<uint16_t>();
    GridTopology out;
    out.height_shift = r.get<uint8_t>();
    const uint8_t flags = r.get<uint8_t>();
    if (width < 1 || height < 1 || width > kMaxGridSide || height > kMaxGridSide)
        throw std::runtime_error(what + ": a grid of " + std::to_string(width) + " × " + std::to_string(height) + " samples");
    if (out.height_shift > kMaxHeightShift) throw std::runtime_error(what + ": height shift " + std::to_string(out.height_shift) + " past 14");
    if (flags & ~kGridRowsRunNorth) throw std::runtime_error(what + ": unknown grid flags");
    std::array<uint32_t, 8> next{}, end{};
    for (uint32_t o = 0, sum = 0; o < 8; ++o) next[o] = sum, sum += child_counts[o], end[o] = sum;
    // The sample runs, then the cell runs: find where the first end.
    const std::span<const uint8_t> runs = stream.subspan(r.position());
    ByteReader scan(runs, what + " grid stream");
    for (uint64_t covered = 0; covered < uint64_t(width) * height;) covered += get_varint(scan, what);
    ByteReader sample_bytes(runs.first(scan.position()), what + " grid stream"), cell_bytes(runs.subspan(scan.position()), what + " grid stream");
    SampleRuns samples(sample_bytes, what);
    CellRuns cells(cell_bytes, what);
    out.indices.resize(3 * size_t(end[7]));
    out.walk.reserve(vertices);
    std::vector<uint32_t> two_above(width, kNone), above(width, kNone), here(width, kNone);
    auto next_row = [&] { std::swap(two_above, above), std::swap(above, here); };
    uint32_t count = 0;
    for (uint32_t row = 0; row < height; ++row) {
        for (uint32_t c = 0; c < width; ++c) {
            here[c] = kNone;
            if (!samples.next()) continue;
            if (count == vertices) throw std::runtime_error(what + ": grid has more vertices than its count");
            FirstUse f{count, c > 0 ? here[c - 1] : kNone, above[c], kNone};
            if (f.a != kNone && f.b != kNone) f.d = above[c - 1];
            else if (f.a != kNone) f.b = f.a, f.d = c > 1 ? here[c - 2] : kNone;  // along the row: 2a − (a's own a)
            else if (f.b != kNone) f.a = f.b, f.d = two_above[c];               // down the column
            out.walk.push_back(f);
            here[c] = count++;
        }
        if (row == 0) {
            next_row();
            continue;
        }
        for (uint32_t c = 0; c + 1 < width; ++c) {
            const uint8_t value = cells.next();
            for (int t = 0; t < 2; ++t) {
                const uint32_t group = (value >> (4 * t)) & 15;
                if (group == 0) continue;
                const uint32_t o = group - 1;
                // Triangle t of the cell (FORMAT.md §4.7): min, (min column, max row) or (max column, min
                // row), max; counter-clockwise seen from above.
                const uint32_t min = above[c], max = here[c + 1], side = t == 0 ? here[c] : above[c + 1];
                if (min == kNone || max == kNone || side == kNone)
                    throw std::runtime_error(what + ": a triangle of grid cell (" + std::to_string(c) + ", " + std::to_string(row - 1) + ") lacks a corner");
                if (next[o] == end[o]) throw std::runtime_error(what + ": child group " + std::to_string(o) + " has more triangles than its count");
                const bool turn = (t == 0) != bool(flags & kGridRowsRunNorth);
                uint32_t* corner = &out.indices[3 * size_t(next[o]++)];
                corner[0] = min, corner[1] = turn ? side : max, corner[2] = turn ? max : side;
            }
        }
        next_row();
    }
    if (!samples.ended() || !sample_bytes.at_end()) throw std::runtime_error(what + ": grid stream's sample runs overrun its grid");
    if (!cells.ended() || !cell_bytes.at_end()) throw std::runtime_error(what + ": grid stream longer than its grid");
    if (count != vertices) throw std::runtime_error(what + ": grid has fewer vertices than its count");
    for (uint32_t o = 0; o < 8; ++o)
        if (next[o] != end[o]) throw std::runtime_error(what + ": child group " + std::to_string(o) + " has fewer triangles than its count");
    return out;
}

// The grid stream of a cube whose vertices (at least one) stand at `grid.samples` (row-major, in vertex
// order) and whose triangles are the grid's, grouped by child.
std::vector<uint8_t> encode_grid(const CubeData& cube, const GridPlacement& grid) {
    const uint32_t n = cube.vertex_count();
    if (grid.samples.size() != n) throw std::logic_error("encode_grid_cube: a sample per vertex");
    uint32_t c0 = ~0u, r0 = ~0u, c1 = 0, r1 = 0;
    for (const auto& [c, r] : grid.samples) c0 = std::min(c0, c), c1 = std::max(c1, c), r0 = std::min(r0, r), r1 = std::max(r1, r);
    const uint32_t width = c1 - c0 + 1, height = r1 - r0 + 1;
    if (width > kMaxGridSide || height > kMaxGridSide || grid.height_shift > kMaxHeightShift)
        throw std::logic_error("encode_grid_cube: a grid of " + std::to_string(width) + " × " + std::to_string(height) + " samples");
    std::vector<uint32_t> at(size_t(width) * height, kNone);
    for (size_t v = 0, previous = 0; v < n; ++v) {
        const size_t sample = size_t(grid.samples[v][1] - r0) * width + (grid.samples[v][0] - c0);
        if (v > 0 && sample <= previous) throw std::logic_error("encode_grid_cube: vertices not in row-major order");
        at[sample] = uint32_t(v), previous = sample;
    }
    std::vector<uint8_t> out;
    out.push_back(uint8_t(width)), out.push_back(uint8_t(width >> 8)), out.push_back(uint8_t(height)), out.push_back(uint8_t(height >> 8));
    out.push_back(uint8_t(grid.height_shift)), out.push_back(grid.rows_run_north ? kGridRowsRunNorth : 0);
    bool present = false;
    uint64_t run = 0;
    for (uint32_t v : at) {
        if ((v != kNone) != present) put_varint(out, run), run = 0, present = !present;
        ++run;
    }
    put_varint(out, run);
    std::vector<uint8_t> cell(size_t(width - 1) * (height - 1), 0);
    for (uint32_t o = 0, t = 0; o < 8; ++o)
        for (uint32_t end = t + cube.child_triangle_counts[o]; t < end; ++t) {
            uint32_t cmin = ~0u, rmin = ~0u;
            for (int k = 0; k < 3; ++k) {
                const auto& s = grid.samples[cube.indices[3 * size_t(t) + k]];
                cmin = std::min(cmin, s[0]), rmin = std::min(rmin, s[1]);
            }
            bool low_side = false;  // a corner at (min column, max row): triangle 0
            for (int k = 0; k < 3; ++k) {
                const auto& s = grid.samples[cube.indices[3 * size_t(t) + k]];
                low_side |= s[0] == cmin && s[1] == rmin + 1;
            }
            if (cmin + 1 > c1 || rmin + 1 > r1) throw std::logic_error("encode_grid_cube: a triangle that is not a grid cell's");
            uint8_t& value = cell[size_t(rmin - r0) * (width - 1) + (cmin - c0)];
            const int shift = low_side ? 0 : 4;
            if ((value >> shift) & 15) throw std::logic_error("encode_grid_cube: two triangles in one place of a cell");
            value |= uint8_t((o + 1) << shift);
        }
    for (size_t i = 0; i < cell.size();) {
        size_t j = i;
        while (j < cell.size() && cell[j] == cell[i]) ++j;
        out.push_back(cell[i]), put_varint(out, j - i), i = j;
    }
    return out;
}

// The streams every payload codes the same way once its triangles and walk are known: positions,
// normals and parents as residual classes, colours, UVs, the low bits. Returns the whole payload.
// `grid`: a grid payload (FORMAT.md §5.1), with the heights' shift.
std::vector<uint8_t> payload_from(const CubeData& cube, uint32_t flags, std::vector<uint8_t> triangles,
                                  const std::vector<uint32_t>& indices, const std::vector<FirstUse>& walk, bool grid,
                                  uint32_t height_shift) {
    const uint32_t n = cube.vertex_count();
    std::vector<uint8_t> streams[kStreams];
    streams[kIndices] = std::move(triangles);
    BitWriter bits;
    streams[kPositions] = encode_positions(walk, cube.vertices.positions, height_shift, ClassOrder{grid, n}, bits);
    streams[kNormals] = encode_normals(walk, cube.vertices.normals, predicted_normals(cube.vertices.positions, indices), bits);
    streams[kParents] = encode_parents(walk, cube.parent_vertex, bits);
    if (flags & kHasColors) streams[kColors] = encode_vertices(cube.vertices.colors, n, 4);
    if (flags & kHasUvs) streams[kUvs] = encode_vertices(as_bytes(cube.vertices.uvs), n, 8);
    streams[kBits] = bits.finish();
    ByteWriter w;
    w.put(n);
    w.put(cube.triangle_count());
    for (uint32_t c : cube.child_triangle_counts) w.put(c);
    std::vector<uint8_t> body;
    for (const auto& s : streams) {
        const std::vector<uint8_t> stored = packed(s, grid ? kGridStreamFloor : 0);
        w.put(uint32_t(s.size())), w.put(uint32_t(stored.size()));
        body.insert(body.end(), stored.begin(), stored.end());
    }
    w.put_bytes(body.data(), body.size());
    return std::move(w.bytes);
}

}  // namespace

// Payload (FORMAT.md §5): counts, child triangle counts, each stream's size and stored size, then the
// streams: the triangles (meshoptimizer's index codec), then positions, normals and parents as residual
// classes against what the triangles predict, walking the vertices in first-use order, colours and UVs
// (its vertex codec), and the residuals' low bits.
std::vector<uint8_t> encode_cube(const CubeData& cube, uint32_t flags) {
    const uint32_t n = cube.vertex_count();
    std::vector<uint8_t> triangles = encode_indices(cube.indices, n);
    const std::vector<uint32_t> indices = decode_indices(triangles, cube.triangle_count(), n, "encode_cube");
    return payload_from(cube, flags, std::move(triangles), indices, first_use_walk(indices, n), false, 0);
}

std::vector<uint8_t> encode_grid_cube(const CubeData& cube, const GridPlacement& grid) {
    std::vector<uint8_t> stream = cube.vertex_count() ? encode_grid(cube, grid) : std::vector<uint8_t>();
    GridTopology topology;
    if (!stream.empty()) topology = decode_grid(stream, cube.vertex_count(), cube.child_triangle_counts, "encode_grid_cube");
    if (topology.indices != cube.indices) throw std::logic_error("encode_grid_cube: the cube's triangles are not its grid's, in the grid's order");
    const uint32_t shift = grid.height_shift;
    for (size_t v = 0; v < cube.vertex_count(); ++v)
        if (cube.vertices.positions[3 * v + 2] & ((1u << shift) - 1)) throw std::logic_error("encode_grid_cube: a height off its lattice");
    return payload_from(cube, 0, std::move(stream), topology.indices, topology.walk, true, shift);
}

CubeData decode_cube(std::span<const uint8_t> bytes, const HlodNode& node, uint32_t flags, uint32_t codec) {
    const std::string what = describe_cube(node);
    const bool grid = codec == kGridPayloadCodec;
    ByteReader r(bytes, what + " payload");
    CubeData cube;
    const uint32_t n = r.get<uint32_t>(), triangles = r.get<uint32_t>();
    if (n != node.vertex_count || triangles != node.triangle_count)
        throw std::runtime_error(what + ": payload counts disagree with the node table");
    uint64_t grouped = 0;
    for (uint32_t& c : cube.child_triangle_counts) grouped += c = r.get<uint32_t>();
    if (grouped != triangles) throw std::runtime_error(what + ": child triangle counts do not add up");
    uint32_t sizes[kStreams], stored[kStreams];
    for (int s = 0; s < kStreams; ++s) sizes[s] = r.get<uint32_t>(), stored[s] = r.get<uint32_t>();
    // Every count is bounded by the stream that holds it before anything is allocated for it: one byte
    // per position coordinate and one per normal and parent; at least a byte per triangle in the index
    // codec, at most two triangles a vertex in a grid.
    const bool colours = (flags & kHasColors) && n > 0, uvs = (flags & kHasUvs) && n > 0;
    if (sizes[kPositions] != 3 * uint64_t(n) || sizes[kNormals] != n || sizes[kParents] != n ||
        colours != (sizes[kColors] != 0) || uvs != (sizes[kUvs] != 0))
        throw std::runtime_error(what + ": stream sizes disagree with the counts");
    if (grid ? triangles > 2 * uint64_t(n) || (n == 0) != (sizes[kIndices] == 0)
             : triangles > sizes[kIndices] || (triangles == 0) != (sizes[kIndices] == 0))
        throw std::runtime_error(what + ": counts larger than the payload could hold");
    std::vector<uint8_t> streams[kStreams];
    for (int s = 0; s < kStreams; ++s) streams[s] = unpacked(r.get_bytes(stored[s]), sizes[s], grid ? kGridStreamFloor : 0, what);
    if (!r.at_end()) throw std::runtime_error(what + ": payload longer than its streams");

    std::vector<FirstUse> walk;
    uint32_t height_shift = 0;
    if (grid) {
        GridTopology topology;
        if (n > 0) topology = decode_grid(streams[kIndices], n, cube.child_triangle_counts, what);
        cube.indices = std::move(topology.indices), walk = std::move(topology.walk), height_shift = topology.height_shift;
    } else {
        cube.indices = decode_indices(streams[kIndices], triangles, n, what);
        walk = first_use_walk(cube.indices, n);
    }
    BitReader bits(streams[kBits], what);
    decode_positions(walk, streams[kPositions], height_shift, ClassOrder{grid, n}, bits, cube.vertices.positions, what);
    decode_normals(walk, streams[kNormals], bits, predicted_normals(cube.vertices.positions, cube.indices),
                   cube.vertices.normals, what);
    decode_parents(walk, streams[kParents], bits, cube.parent_vertex, what);
    if (!bits.at_end()) throw std::runtime_error(what + ": bit stream longer than its residuals");
    if (flags & kHasColors) cube.vertices.colors = decode_vertices(streams[kColors], n, 4, what);
    if (flags & kHasUvs) from_bytes(decode_vertices(streams[kUvs], n, 8, what), cube.vertices.uvs);
    return cube;
}

void resolve_parents(CubeData& cube, const VertexArrays& from, const std::string& what) {
    const uint32_t available = from.size();
    VertexArrays& to = cube.parents;
    to = VertexArrays{};
    cube.parent_of.resize(cube.vertex_count());
    std::vector<uint32_t> slot(available, ~0u);
    for (uint32_t v = 0; v < cube.vertex_count(); ++v) {
        const uint32_t p = cube.parent_vertex[v];
        if (p >= available)
            throw std::runtime_error(what + ": vertex " + std::to_string(v) + "'s parent " + std::to_string(p) +
                                     " lies past the parent cube's " + std::to_string(available) + " vertices");
        if (slot[p] == ~0u) {
            slot[p] = to.size();
            to.positions.insert(to.positions.end(), &from.positions[3 * size_t(p)], &from.positions[3 * size_t(p)] + 3);
            to.normals.insert(to.normals.end(), &from.normals[2 * size_t(p)], &from.normals[2 * size_t(p)] + 2);
            if (!from.colors.empty()) to.colors.insert(to.colors.end(), &from.colors[4 * size_t(p)], &from.colors[4 * size_t(p)] + 4);
            if (!from.uvs.empty()) to.uvs.insert(to.uvs.end(), &from.uvs[2 * size_t(p)], &from.uvs[2 * size_t(p)] + 2);
        }
        cube.parent_of[v] = slot[p];
    }
}

// ---- writer --------------------------------------------------------------------------------

HlodWriter::HlodWriter(std::filesystem::path path) : path_(std::move(path)) {
    temp_path_ = path_;
    temp_path_ += std::string(kTempMarker) + std::to_string(::getpid());
    spool_path_ = temp_path_;
    spool_path_ += kSpoolSuffix;
    errno = 0;
    spool_ = std::fopen(spool_path_.c_str(), "w+b");
    if (!spool_) throw std::runtime_error(io_error(path_, "cannot create the output file"));
}

HlodWriter::~HlodWriter() { remove_temporaries(); }

void HlodWriter::remove_temporaries() {
    if (spool_) std::fclose(spool_);
    spool_ = nullptr;
    std::error_code ignored;
    std::filesystem::remove(spool_path_, ignored);
    std::filesystem::remove(temp_path_, ignored);
}

uint64_t HlodWriter::spool(std::span<const uint8_t> bytes) {
    if (!spool_) throw std::logic_error("HlodWriter: a write after finish()");
    errno = 0;
    if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), spool_) != bytes.size())
        throw std::runtime_error(io_error(path_, "write failed"));
    spooled_ += bytes.size();
    return spooled_ - bytes.size();
}

void HlodWriter::add_cube(HlodNode node, std::span<const uint8_t> payload) {
    node.size = payload.size();
    node.checksum = crc32c(payload.data(), payload.size());
    node.offset = spool(payload);
    nodes_.push_back(node);
}

HlodWriter::SpooledSection& HlodWriter::spooled_section(const char (&tag)[5]) {
    for (SpooledSection& s : sections_)
        if (std::memcmp(s.tag.data(), tag, 4) == 0) return s;
    for (const char* own : {kModelTag, kNodeTag, kPayloadTag, kGeoreferenceTag, kBoundsTag, kTerrainTag})
        if (std::memcmp(own, tag, 4) == 0) throw std::logic_error(std::string("HlodWriter: section ") + tag + " is the writer's own");
    SpooledSection& s = sections_.emplace_back();
    std::memcpy(s.tag.data(), tag, 4);
    return s;
}

void HlodWriter::append_to_section(const char (&tag)[5], std::span<const uint8_t> bytes) {
    SpooledSection& s = spooled_section(tag);
    s.chunks.emplace_back(spool(bytes), bytes.size());
    s.chunk_checksum = crc32c_combine(s.chunk_checksum, crc32c(bytes.data(), bytes.size()), bytes.size());
    s.chunk_bytes += bytes.size();
}

void HlodWriter::set_section_head(const char (&tag)[5], std::vector<uint8_t> head) { spooled_section(tag).head = std::move(head); }

namespace {

// Where each payload goes: level by level from `start`, every level from a multiple of 4 KiB (so a
// reader fetches a level with aligned reads), the payloads of a level packed. Returns the region's end.
uint64_t place_payloads(std::vector<HlodNode>& nodes, uint64_t start) {
    uint64_t at = start;
    for (size_t n = 0; n < nodes.size(); ++n) {
        if (n > 0 && nodes[n].level != nodes[n - 1].level) at = align_up(at, kPayloadAlignment);
        nodes[n].offset = at;
        at += nodes[n].size;
    }
    return at;
}

// The CRC of the payload region from the payloads' own CRCs and the zero padding between levels.
uint32_t payload_region_checksum(const std::vector<HlodNode>& nodes, uint64_t start) {
    static const std::array<uint8_t, kPayloadAlignment> zeros{};
    uint32_t crc = 0;  // CRC-32C of nothing
    uint64_t at = start;
    for (const HlodNode& n : nodes) {
        const uint64_t gap = n.offset - at;
        if (gap) crc = crc32c_combine(crc, crc32c(zeros.data(), gap), gap);
        crc = crc32c_combine(crc, n.checksum, n.size);
        at = n.offset + n.size;
    }
    return crc;
}

// Makes a rename durable: the directory entry is on disk too, not only the file's bytes.
void sync_directory(const std::filesystem::path& file) {
    const std::filesystem::path dir = file.has_parent_path() ? file.parent_path() : ".";
    FileHandle handle(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (handle.get() >= 0) ::fsync(handle.get());
}

}  // namespace

std::vector<HlodNode> HlodWriter::nodes_in_file_order() const {
    std::vector<HlodNode> nodes = nodes_;
    std::stable_sort(nodes.begin(), nodes.end(), in_file_order);
    return nodes;
}

void HlodWriter::finish(HlodHeader header) {
    if (!spool_) throw std::logic_error("HlodWriter::finish twice");
    errno = 0;
    if (std::fflush(spool_) != 0) throw std::runtime_error(io_error(path_, "write failed"));
    header.version = kHlodVersion;
    header.node_count = nodes_.size();

    // Payloads arrive finest level first; sorting their entries is all the reordering costs in memory.
    std::vector<HlodNode> spooled = nodes_in_file_order();
    ByteWriter model, node_table, georeference, bounds, terrain;
    write_model(model, header);
    if (!header.crs.empty()) write_georeference(georeference, header);
    if (header.has_bounds) write_bounds(bounds, header);
    if (header.terrain) write_terrain(terrain, *header.terrain);

    // Layout (FORMAT.md §1): header, section table, the small sections on 8-byte boundaries, then the
    // payloads from a 4 KiB boundary. Sizes are known before contents: NODE is 48 bytes a cube.
    std::vector<HlodSection> table;
    std::vector<const std::vector<uint8_t>*> contents;  // per section: its bytes (a spooled one's head); null for PAYL
    std::vector<const SpooledSection*> spooled_sections;  // per section: its chunks, when it has some in the spool
    auto add = [&](const char(&tag)[5], uint32_t flags, const std::vector<uint8_t>* bytes, uint64_t size) {
        HlodSection s;
        std::memcpy(s.tag.data(), tag, 4);
        s.flags = flags;
        s.size = size;
        table.push_back(s);
        contents.push_back(bytes);
        spooled_sections.push_back(nullptr);
    };
    add(kModelTag, kRequiredSection, &model.bytes, model.bytes.size());
    add(kNodeTag, kRequiredSection, &node_table.bytes, kNodeBytes * spooled.size());
    if (!georeference.bytes.empty()) add(kGeoreferenceTag, 0, &georeference.bytes, georeference.bytes.size());
    if (!bounds.bytes.empty()) add(kBoundsTag, 0, &bounds.bytes, bounds.bytes.size());
    // A terrain in a frame other than its CRS's plane must not be read by a reader that would take GEOR
    // as an offset in the CRS: its TERR is required.
    if (!terrain.bytes.empty()) add(kTerrainTag, header.terrain->tangent_frame() ? kRequiredSection : 0, &terrain.bytes, terrain.bytes.size());
    for (const SpooledSection& spooled : sections_) {
        char tag[5] = {};
        std::memcpy(tag, spooled.tag.data(), 4);
        add(tag, 0, &spooled.head, spooled.head.size() + spooled.chunk_bytes);
        spooled_sections.back() = &spooled;
    }
    add(kPayloadTag, kRequiredSection, nullptr, 0);
    uint64_t at = kFixedHeaderBytes + kSectionEntryBytes * table.size();
    for (HlodSection& s : table) {
        s.offset = align_up(at, contents[&s - table.data()] ? kSectionAlignment : kPayloadAlignment);
        at = s.offset + s.size;
    }
    HlodSection& payloads = table.back();
    std::vector<HlodNode> placed = spooled;
    const uint64_t file_size = place_payloads(placed, payloads.offset);
    payloads.size = file_size - payloads.offset;
    payloads.checksum = payload_region_checksum(placed, payloads.offset);
    for (const HlodNode& n : placed) write_node(node_table, n);
    for (size_t s = 0; s < table.size(); ++s) {
        if (contents[s]) table[s].checksum = crc32c(contents[s]->data(), contents[s]->size());
        if (const SpooledSection* spooled = spooled_sections[s])
            table[s].checksum = crc32c_combine(table[s].checksum, spooled->chunk_checksum, spooled->chunk_bytes);
    }

    ByteWriter head, entries;
    head.put_bytes(kHlodMagic, sizeof(kHlodMagic));
    head.put(kHlodVersion);
    head.put(uint32_t(table.size()));
    head.put(file_size);
    head.put(uint32_t(0));
    for (const HlodSection& s : table) {
        entries.put_bytes(s.tag.data(), s.tag.size());
        entries.put(s.flags), entries.put(s.offset), entries.put(s.size), entries.put(s.checksum);
        entries.put(uint32_t(0));
    }
    head.put(crc32c_combine(crc32c(head.bytes.data(), kHeaderCrcAt), crc32c(entries.bytes.data(), entries.bytes.size()),
                            entries.bytes.size()));

    errno = 0;
    FileHandle out(::open(temp_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666));
    if (out.get() < 0) throw std::runtime_error(io_error(path_, "cannot create the output file"));
    uint64_t written = 0;
    auto append = [&](const std::vector<uint8_t>& bytes) {
        write_all(out.get(), bytes.data(), bytes.size(), path_);
        written += bytes.size();
    };
    auto pad_to = [&](uint64_t offset) {  // every gap of the layout is under 4 KiB
        static const std::array<uint8_t, kPayloadAlignment> zeros{};
        write_all(out.get(), zeros.data(), offset - written, path_);
        written = offset;
    };
    append(head.bytes);
    append(entries.bytes);
    const int spool = ::fileno(spool_);
    for (size_t s = 0; s < table.size(); ++s) {
        if (!contents[s]) continue;
        pad_to(table[s].offset), append(*contents[s]);
        if (const SpooledSection* spooled = spooled_sections[s])
            for (const auto& [offset, size] : spooled->chunks) copy_bytes(spool, offset, out.get(), size, path_), written += size;
    }
    for (size_t n = 0; n < placed.size();) {
        pad_to(placed[n].offset);
        // Payloads that lie back to back in both files go in one copy.
        size_t end = n + 1;
        uint64_t size = placed[n].size;
        while (end < placed.size() && placed[end].offset == placed[n].offset + size &&
               spooled[end].offset == spooled[n].offset + size)
            size += placed[end++].size;
        copy_bytes(spool, spooled[n].offset, out.get(), size, path_);
        written += size;
        n = end;
    }
    pad_to(file_size);  // a model without cubes (a standing site's embedding) ends at PAYL's empty start
    errno = 0;
    if (::fsync(out.get()) != 0 || out.release() != 0) throw std::runtime_error(io_error(path_, "write failed"));
    std::error_code ec;
    std::filesystem::rename(temp_path_, path_, ec);
    if (ec) {
        errno = ec.value();
        throw std::runtime_error(io_error(path_, "cannot finish the output file"));
    }
    sync_directory(path_);
    nodes_ = std::move(placed);
    remove_temporaries();  // the spool; the other temporary is now `path`
}

// ---- reader --------------------------------------------------------------------------------

bool is_hlod_file(const std::filesystem::path& path) {
    char magic[sizeof kHlodMagic] = {};
    std::ifstream in(path, std::ios::binary);
    return in.read(magic, sizeof magic) && std::equal(std::begin(magic), std::end(magic), std::begin(kHlodMagic));
}

HlodFile::HlodFile(const std::filesystem::path& path)
    : path_(path), file_(::open(path.c_str(), O_RDONLY | O_CLOEXEC)) {
    if (file_.get() < 0) throw std::runtime_error(io_error(path, "cannot open"));
    const std::string name = path.string();
    struct stat status;
    if (::fstat(file_.get(), &status) != 0) throw std::runtime_error(io_error(path, "cannot read its size"));
    if (!S_ISREG(status.st_mode)) throw std::runtime_error(name + ": not a regular file");
    file_size_ = uint64_t(status.st_size);
    identity_ = {uint64_t(status.st_dev), uint64_t(status.st_ino), file_size_,
                 int64_t(status.st_mtim.tv_sec) * 1'000'000'000 + status.st_mtim.tv_nsec};

    // Magic and version first: they sit where version 1 had them (its header was 128 bytes), so an old
    // file is named as one.
    std::array<uint8_t, kFixedHeaderBytes> fixed{};
    const size_t head = size_t(std::min<uint64_t>(file_size_, fixed.size()));
    read_at(0, fixed.data(), head, "the header");
    if (head < kFixedHeaderBytes) throw std::runtime_error(name + ": too short to be a .hlod file");
    if (std::memcmp(fixed.data(), kHlodMagic, sizeof(kHlodMagic)) != 0)
        throw std::runtime_error(name + ": not a .hlod file (bad magic)");
    uint32_t version;
    std::memcpy(&version, fixed.data() + sizeof(kHlodMagic), 4);
    if (version == 1)
        throw std::runtime_error(name + ": a version 1 model (from an older Strata); rebuild it from its scan: strata build SCAN -o " + name);
    if (version != kHlodVersion)
        throw std::runtime_error(name + ": .hlod version " + std::to_string(version) + ", but this Strata reads version " +
                                 std::to_string(kHlodVersion) + (version > kHlodVersion ? "; it was written by a newer version" : ""));
    read_section_table(fixed);

    const HlodSection* model = find_section(kModelTag);
    const HlodSection* nodes = find_section(kNodeTag);
    const HlodSection* payloads = find_section(kPayloadTag);
    for (auto [section, tag] : {std::pair{model, kModelTag}, std::pair{nodes, kNodeTag}, std::pair{payloads, kPayloadTag}})
        if (!section) throw std::runtime_error(name + ": has no section '" + tag + "' (the file is corrupt)");
    read_model_section(*model);
    read_node_section(*nodes, *payloads);
    if (const HlodSection* georeference = find_section(kGeoreferenceTag)) read_georeference_section(*georeference);
    if (const HlodSection* bounds = find_section(kBoundsTag)) read_bounds_section(*bounds);
    if (const HlodSection* terrain = find_section(kTerrainTag)) read_terrain_section(*terrain);
}

void HlodFile::read_at(uint64_t offset, void* data, size_t size, const std::string& what) const {
    if (!read_fully(file_.get(), offset, data, size))
        throw std::runtime_error(io_error(path_, "cannot read " + what));
}

std::vector<uint8_t> HlodFile::read_section_part(const HlodSection& section, uint64_t offset, uint64_t size, const std::string& what) const {
    if (offset > section.size || size > section.size - offset)
        throw std::runtime_error(path_.string() + ": " + quoted(section) + ": " + what + " lies outside the section (the file is corrupt)");
    std::vector<uint8_t> bytes(size);
    read_at(section.offset + offset, bytes.data(), bytes.size(), quoted(section) + " " + what);
    return bytes;
}

const HlodSection* HlodFile::find_section(const char (&tag)[5]) const {
    for (const HlodSection& s : sections_)
        if (is_tag(s, tag)) return &s;
    return nullptr;
}

// The table: every section inside the file, after the table, none overlapping another, no tag twice,
// and no required section this reader does not know.
void HlodFile::read_section_table(std::span<const uint8_t> fixed) {
    const std::string name = path_.string();
    ByteReader r(fixed, name + ": header");
    r.get_bytes(sizeof(kHlodMagic) + 4);  // magic and version, checked
    const uint32_t count = r.get<uint32_t>();
    const uint64_t declared_size = r.get<uint64_t>();
    r.get<uint32_t>();  // reserved
    const uint32_t stored_crc = r.get<uint32_t>();
    if (count == 0 || count > kMaxSections)
        throw std::runtime_error(name + ": " + std::to_string(count) + " sections (the file is corrupt)");
    const uint64_t table_end = kFixedHeaderBytes + uint64_t(kSectionEntryBytes) * count;
    if (table_end > file_size_)
        throw std::runtime_error(name + ": truncated inside its section table (" + std::to_string(file_size_) + " bytes)");
    std::vector<uint8_t> table(table_end - kFixedHeaderBytes);
    read_at(kFixedHeaderBytes, table.data(), table.size(), "the section table");
    if (crc32c_combine(crc32c(fixed.data(), kHeaderCrcAt), crc32c(table.data(), table.size()), table.size()) != stored_crc)
        throw std::runtime_error(name + ": header checksum mismatch (the file is corrupt)");
    if (file_size_ < declared_size)
        throw std::runtime_error(name + ": truncated: " + std::to_string(file_size_) + " of its " +
                                 std::to_string(declared_size) + " bytes");
    if (file_size_ > declared_size)
        throw std::runtime_error(name + ": " + std::to_string(file_size_ - declared_size) +
                                 " bytes past the end its header declares (the file is corrupt)");

    ByteReader t(table, name + ": section table");
    for (uint32_t e = 0; e < count; ++e) {
        HlodSection s;
        auto tag = t.get_bytes(4);
        if (!std::all_of(tag.begin(), tag.end(), [](uint8_t c) { return c >= 0x20 && c <= 0x7E; }))
            throw std::runtime_error(name + ": section table entry " + std::to_string(e) + " has a tag that is not ASCII");
        std::copy(tag.begin(), tag.end(), s.tag.begin());
        s.flags = t.get<uint32_t>();
        s.offset = t.get<uint64_t>();
        s.size = t.get<uint64_t>();
        s.checksum = t.get<uint32_t>();
        t.get<uint32_t>();  // reserved
        if (s.offset < table_end) throw std::runtime_error(name + ": " + quoted(s) + " overlaps the header");
        if (s.offset > file_size_ || s.size > file_size_ - s.offset)
            throw std::runtime_error(name + ": " + quoted(s) + " reaches past the end of the file");
        for (const HlodSection& other : sections_)
            if (other.tag == s.tag) throw std::runtime_error(name + ": " + quoted(s) + " appears twice");
        sections_.push_back(s);
    }
    std::vector<const HlodSection*> by_offset;
    for (const HlodSection& s : sections_) by_offset.push_back(&s);
    std::sort(by_offset.begin(), by_offset.end(), [](auto* a, auto* b) { return a->offset < b->offset; });
    for (size_t s = 1; s < by_offset.size(); ++s)
        if (by_offset[s - 1]->offset + by_offset[s - 1]->size > by_offset[s]->offset)
            throw std::runtime_error(name + ": sections '" + by_offset[s - 1]->name() + "' and '" + by_offset[s]->name() +
                                     "' overlap");
    for (const HlodSection& s : sections_) {
        const bool known = is_tag(s, kModelTag) || is_tag(s, kNodeTag) || is_tag(s, kPayloadTag) || is_tag(s, kGeoreferenceTag) ||
                           is_tag(s, kBoundsTag) || is_tag(s, kTerrainTag);
        if (!known && (s.flags & kRequiredSection))
            throw std::runtime_error(name + ": needs section '" + s.name() +
                                     "', which this Strata does not know; it was written by a newer version");
    }
}

// A small section, read whole and checked against its CRC; `max_size` bounds what is allocated.
std::vector<uint8_t> HlodFile::read_section(const HlodSection& section, uint64_t max_size) const {
    const std::string name = path_.string();
    if (section.size > max_size)
        throw std::runtime_error(name + ": " + quoted(section) + " is " + std::to_string(section.size) +
                                 " bytes, more than the " + std::to_string(max_size) + " it can need");
    std::vector<uint8_t> bytes(section.size);
    read_at(section.offset, bytes.data(), bytes.size(), quoted(section));
    if (crc32c(bytes.data(), bytes.size()) != section.checksum)
        throw std::runtime_error(name + ": " + quoted(section) + " checksum mismatch (the file is corrupt)");
    return bytes;
}

void HlodFile::check_section(const HlodSection& section) const {
    std::vector<uint8_t> chunk(std::min<uint64_t>(section.size, kChunkBytes));
    uint32_t crc = 0;
    for (uint64_t done = 0; done < section.size;) {
        const size_t size = size_t(std::min<uint64_t>(section.size - done, chunk.size()));
        read_at(section.offset + done, chunk.data(), size, quoted(section));
        crc = crc32c_combine(crc, crc32c(chunk.data(), size), size);
        done += size;
    }
    if (crc != section.checksum)
        throw std::runtime_error(path_.string() + ": " + quoted(section) + " checksum mismatch (the file is corrupt)");
}

void HlodFile::read_model_section(const HlodSection& section) {
    const std::string name = path_.string();
    const std::vector<uint8_t> bytes = read_section(section, kModelFixedBytes + 2 * (4 + kMaxNameBytes));
    ByteReader r(bytes, name + ": " + quoted(section));
    HlodHeader& h = header_;
    h.payload_codec = r.get<uint32_t>();
    if (h.payload_codec < kCubePayloadCodec)
        throw std::runtime_error(name + ": payload codec " + std::to_string(h.payload_codec) +
                                 " (from an older Strata), which this Strata no longer reads; rebuild it from its scan: "
                                 "strata build SCAN -o " + name);
    if (h.payload_codec != kCubePayloadCodec && h.payload_codec != kGridPayloadCodec)
        throw std::runtime_error(name + ": payload codec " + std::to_string(h.payload_codec) +
                                 ", which this Strata does not know; it was written by a newer version");
    h.flags = r.get<uint32_t>();
    if (h.payload_codec == kGridPayloadCodec && (h.flags & (kHasColors | kHasUvs)))
        throw std::runtime_error(name + ": a terrain's grid payloads carry no colours or UVs, but its flags say they do");
    for (double& o : h.origin) o = r.get<double>();
    h.root_size = r.get<double>();
    h.max_level = r.get<uint32_t>();
    h.block_size = r.get<uint32_t>();
    h.sigma0 = r.get<float>();
    h.error_q = r.get<float>();
    h.ratio = r.get<float>();
    h.error_limit = r.get<float>();
    h.input_vertices = r.get<uint64_t>();
    h.input_triangles = r.get<uint64_t>();
    h.node_count = r.get<uint64_t>();
    h.source = r.get_string(kMaxNameBytes);
    h.texture = r.get_string(kMaxNameBytes);
    if (!r.at_end()) throw std::runtime_error(name + ": " + quoted(section) + " is longer than its fields");
    bool finite = std::isfinite(h.root_size) && std::isfinite(h.error_q) && std::isfinite(h.ratio) &&
                  std::isfinite(h.error_limit) && h.error_q >= 0;
    for (double o : h.origin) finite &= std::isfinite(o);
    if (!finite || h.max_level > 15 || !(h.root_size > 0) || !(h.sigma0 > 0 && h.sigma0 < 0.5f))
        throw std::runtime_error(name + ": model values out of range (" + quoted(section) + ")");
}

void HlodFile::read_node_section(const HlodSection& section, const HlodSection& payloads) {
    const std::string name = path_.string();
    const uint64_t count = header_.node_count;
    // The size is checked against the count before anything is allocated for the count.
    if (count > section.size / kNodeBytes || section.size != kNodeBytes * count)
        throw std::runtime_error(name + ": " + quoted(section) + " holds " + std::to_string(section.size) +
                                 " bytes, not 48 for each of the model's " + std::to_string(count) + " cubes");
    const std::vector<uint8_t> bytes = read_section(section, section.size);
    ByteReader r(bytes, name + ": " + quoted(section));
    nodes_.reserve(count);
    const uint64_t payloads_end = payloads.offset + payloads.size;
    for (uint64_t i = 0; i < count; ++i) {
        const HlodNode n = read_node(r);
        // The level first: shifting by a level past 63 would be undefined.
        if (n.level > header_.max_level || n.i >= (1u << n.level) || n.j >= (1u << n.level) || n.k >= (1u << n.level))
            throw std::runtime_error(name + ": " + describe_cube(n) + " outside the octree");
        if (n.offset < payloads.offset || n.offset > payloads_end || n.size > payloads_end - n.offset)
            throw std::runtime_error(name + ": " + describe_cube(n) + " payload out of range (outside section 'PAYL')");
        nodes_.push_back(n);
    }
}

void HlodFile::read_georeference_section(const HlodSection& section) {
    const std::string name = path_.string();
    const std::vector<uint8_t> bytes = read_section(section, kGeoreferenceFixedBytes + 4 + kMaxCrsBytes);
    ByteReader r(bytes, name + ": " + quoted(section));
    for (double& o : header_.geo_origin) {
        o = r.get<double>();
        if (!std::isfinite(o)) throw std::runtime_error(name + ": " + quoted(section) + ": origin not finite");
    }
    header_.crs = r.get_string(kMaxCrsBytes);
    if (!r.at_end()) throw std::runtime_error(name + ": " + quoted(section) + " is longer than its fields");
}

void HlodFile::read_bounds_section(const HlodSection& section) {
    const std::string name = path_.string();
    const std::vector<uint8_t> bytes = read_section(section, kBoundsBytes);
    ByteReader r(bytes, name + ": " + quoted(section));
    for (double& v : header_.bounds_lo) v = r.get<double>();
    for (double& v : header_.bounds_hi) v = r.get<double>();
    if (!r.at_end()) throw std::runtime_error(name + ": " + quoted(section) + " is longer than its fields");
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(header_.bounds_lo[a]) || !std::isfinite(header_.bounds_hi[a]) || header_.bounds_lo[a] > header_.bounds_hi[a])
            throw std::runtime_error(name + ": " + quoted(section) + ": the box is not finite, or its corners are swapped");
    header_.has_bounds = true;
}

void HlodFile::read_terrain_section(const HlodSection& section) {
    const std::string what = path_.string() + ": " + quoted(section);
    if (section.size == 56)
        throw std::runtime_error(what + ": a terrain section of 56 bytes, from a development build of 2026-12-06 that kept "
                                 "too little to find heights; rebuild the model from its raster (strata build DEM -o " + path_.string() + ")");
    const std::vector<uint8_t> bytes = read_section(section, kTerrainBytes + 4 + kMaxCrsBytes);
    ByteReader r(bytes, what);
    TerrainGrid t;
    t.columns = r.get<uint64_t>(), t.rows = r.get<uint64_t>();
    t.spacing[0] = r.get<double>(), t.spacing[1] = r.get<double>();
    t.nodata_samples = r.get<uint64_t>();
    t.cube_cells = r.get<uint32_t>();
    const uint32_t flags = r.get<uint32_t>();
    t.frame = r.get<uint32_t>();
    r.get<uint32_t>();  // reserved
    t.first_sample[0] = r.get<double>(), t.first_sample[1] = r.get<double>();
    t.semi_major = r.get<double>(), t.inverse_flattening = r.get<double>();
    if (t.frame == 3) t.raster_crs = r.get_string(kMaxCrsBytes);
    if (!r.at_end()) throw std::runtime_error(what + " is longer than its fields");
    if (t.frame == 3 && t.raster_crs.empty()) throw std::runtime_error(what + ": a reprojected terrain without its raster's CRS");
    if (t.columns < 2 || t.rows < 2 || t.columns > (uint64_t(1) << 32) || t.rows > (uint64_t(1) << 32))
        throw std::runtime_error(what + ": a grid of " + std::to_string(t.columns) + " × " + std::to_string(t.rows) + " samples");
    if (!(t.spacing[0] > 0) || !(t.spacing[1] > 0) || !std::isfinite(t.spacing[0]) || !std::isfinite(t.spacing[1]))
        throw std::runtime_error(what + ": sample spacing not a positive number");
    if (t.nodata_samples > t.columns * t.rows) throw std::runtime_error(what + ": more nodata samples than samples");
    if (t.cube_cells < 8 || t.cube_cells > 256 || t.cube_cells % 2) throw std::runtime_error(what + ": cubes of " + std::to_string(t.cube_cells) + " cells");
    if (flags > 3) throw std::runtime_error(what + ": unknown flags " + std::to_string(flags));
    if (t.frame > 3) throw std::runtime_error(what + ": frame " + std::to_string(t.frame) + ", which this Strata does not know");
    if (!std::isfinite(t.first_sample[0]) || !std::isfinite(t.first_sample[1])) throw std::runtime_error(what + ": the first sample's position is not finite");
    if (!(t.semi_major >= 0) || !(t.inverse_flattening == 0 || t.inverse_flattening > 1) || !std::isfinite(t.semi_major) ||
        !std::isfinite(t.inverse_flattening) ||
        (t.tangent_frame() && !(t.semi_major > 0)))
        throw std::runtime_error(what + ": an ellipsoid of semi-major axis " + std::to_string(t.semi_major) + " m and inverse flattening " +
                                 std::to_string(t.inverse_flattening));
    t.rows_run_north = flags & 1;
    t.raster_geographic = (flags & 2) || t.tangent_frame();
    header_.terrain = t;
}

std::vector<uint8_t> HlodFile::read_payload(const HlodNode& node) const {
    std::vector<uint8_t> bytes(node.size);
    read_at(node.offset, bytes.data(), bytes.size(), describe_cube(node));
    if (crc32c(bytes.data(), bytes.size()) != node.checksum)
        throw std::runtime_error(path_.string() + ": " + describe_cube(node) +
                                 " checksum mismatch (the file is corrupt)");
    return bytes;
}

CubeData HlodFile::read_cube(const HlodNode& node) const {
    try {
        return decode_cube(read_payload(node), node, header_.flags, header_.payload_codec);
    } catch (const std::runtime_error& e) {
        std::string message = e.what();
        if (message.rfind(path_.string(), 0) == 0) throw;
        throw std::runtime_error(path_.string() + ": " + message);
    }
}

}  // namespace strata

#include "preprocess/hlod_format.h"

#include <meshoptimizer.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace strata {
namespace {

constexpr size_t kHeaderBytes = 128;
constexpr size_t kNodeBytes = 48;
constexpr size_t kMaxNameBytes = 4096;

// ---- little-endian byte packing -------------------------------------------------------------

class ByteWriter {
public:
    template <class T>
    void put(T value) {
        static_assert(std::is_trivially_copyable_v<T>);
        size_t at = bytes.size();
        bytes.resize(at + sizeof(T));
        std::memcpy(bytes.data() + at, &value, sizeof(T));  // x86-64 and aarch64 are little-endian
    }
    void put_bytes(const void* data, size_t size) {
        const auto* p = static_cast<const uint8_t*>(data);
        bytes.insert(bytes.end(), p, p + size);
    }
    void put_string(const std::string& s) {
        put(uint32_t(s.size()));
        put_bytes(s.data(), s.size());
    }
    std::vector<uint8_t> bytes;
};

class ByteReader {
public:
    ByteReader(std::span<const uint8_t> bytes, std::string what) : bytes_(bytes), what_(std::move(what)) {}
    template <class T>
    T get() {
        need(sizeof(T));
        T value;
        std::memcpy(&value, bytes_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return value;
    }
    std::span<const uint8_t> get_bytes(size_t size) {
        need(size);
        auto span = bytes_.subspan(at_, size);
        at_ += size;
        return span;
    }
    std::string get_string() {
        uint32_t size = get<uint32_t>();
        if (size > kMaxNameBytes) throw std::runtime_error(what_ + ": name of " + std::to_string(size) + " bytes");
        auto span = get_bytes(size);
        return std::string(span.begin(), span.end());
    }
    size_t position() const { return at_; }

private:
    void need(size_t size) const {
        if (size > bytes_.size() - at_) throw std::runtime_error(what_ + " ends early");
    }
    std::span<const uint8_t> bytes_;
    std::string what_;
    size_t at_ = 0;
};

// ---- CRC-32C (Castagnoli): hardware instruction where there is one, table otherwise ------------

uint32_t crc32c_table(uint32_t crc, const uint8_t* p, size_t n) {
    static const auto table = [] {
        std::array<uint32_t, 256> t{};
        for (uint32_t i = 0; i < 256; ++i) {
            uint32_t c = i;
            for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0x82F63B78u & (0u - (c & 1u)));
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

// Position and normal travel together as one 12-byte record (the last two bytes zero).
std::vector<uint8_t> position_normal_records(const VertexArrays& v) {
    std::vector<uint8_t> out(size_t(v.size()) * 12, 0);
    for (size_t i = 0; i < v.size(); ++i) {
        std::memcpy(&out[12 * i], &v.positions[3 * i], 6);
        std::memcpy(&out[12 * i + 6], &v.normals[2 * i], 4);
    }
    return out;
}

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

void write_header(ByteWriter& w, const HlodHeader& h) {
    w.put_bytes(kHlodMagic, sizeof(kHlodMagic));
    w.put(h.version);
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
    w.put(h.node_table_offset);
    w.put(crc32c(w.bytes.data(), w.bytes.size()));
    w.bytes.resize(kHeaderBytes, 0);
}

void write_node(ByteWriter& w, const HlodNode& n) {
    w.put(n.level), w.put(n.i), w.put(n.j), w.put(n.k);
    w.put(n.error);
    w.put(n.vertex_count), w.put(n.triangle_count);
    w.put(n.checksum);
    w.put(n.offset), w.put(n.size);
}

HlodNode read_node(ByteReader& r) {
    HlodNode n;
    n.level = r.get<uint32_t>(), n.i = r.get<uint32_t>(), n.j = r.get<uint32_t>(), n.k = r.get<uint32_t>();
    n.error = r.get<float>();
    n.vertex_count = r.get<uint32_t>(), n.triangle_count = r.get<uint32_t>();
    n.checksum = r.get<uint32_t>();
    n.offset = r.get<uint64_t>(), n.size = r.get<uint64_t>();
    return n;
}

std::string io_error(const std::filesystem::path& path, const std::string& what) {
    return path.string() + ": " + what + (errno ? std::string(" (") + std::strerror(errno) + ")" : "");
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

// Streams of a payload: position+normal records, colours, UVs, parent indices, triangles.
constexpr int kStreams = 5;

}  // namespace

// Payload: counts, child triangle counts, five stream sizes, then the streams: the vertices
// (position+normal, colours, UVs), each vertex's parent index in the parent cube, and the triangles,
// in meshoptimizer's vertex and index codecs.
std::vector<uint8_t> encode_cube(const CubeData& cube, uint32_t flags) {
    const size_t n = cube.vertex_count();
    std::vector<uint8_t> streams[kStreams];
    streams[0] = encode_vertices(position_normal_records(cube.vertices), n, 12);
    if (flags & kHasColors) streams[1] = encode_vertices(cube.vertices.colors, n, 4);
    if (flags & kHasUvs) streams[2] = encode_vertices(as_bytes(cube.vertices.uvs), n, 8);
    streams[3] = encode_vertices(as_bytes(cube.parent_vertex), n, 4);
    if (!cube.indices.empty()) {
        streams[4].resize(meshopt_encodeIndexBufferBound(cube.indices.size(), n));
        streams[4].resize(meshopt_encodeIndexBuffer(streams[4].data(), streams[4].size(), cube.indices.data(),
                                                    cube.indices.size()));
    }
    ByteWriter w;
    w.put(uint32_t(n));
    w.put(cube.triangle_count());
    for (uint32_t c : cube.child_triangle_counts) w.put(c);
    for (const auto& s : streams) w.put(uint32_t(s.size()));
    for (const auto& s : streams) w.put_bytes(s.data(), s.size());
    return std::move(w.bytes);
}

CubeData decode_cube(std::span<const uint8_t> bytes, const HlodNode& node, uint32_t flags) {
    const std::string what = describe_cube(node);
    ByteReader r(bytes, what + " payload");
    CubeData cube;
    const uint32_t n = r.get<uint32_t>(), triangles = r.get<uint32_t>();
    if (n != node.vertex_count || triangles != node.triangle_count)
        throw std::runtime_error(what + ": payload counts disagree with the node table");
    uint64_t grouped = 0;
    for (uint32_t& c : cube.child_triangle_counts) grouped += c = r.get<uint32_t>();
    if (grouped != triangles) throw std::runtime_error(what + ": child triangle counts do not add up");
    uint32_t sizes[kStreams];
    for (uint32_t& s : sizes) s = r.get<uint32_t>();
    // Bound every count by the stream that holds it before allocating for it: meshoptimizer's vertex
    // codec spends at least 2 bits per 16 records on each byte of a record (so a 12-byte record costs
    // ≥ 3/16 byte), its index codec at least a byte per triangle.
    uint64_t streamed = 0;
    for (uint32_t size : sizes) streamed += size;
    auto fits = [](uint64_t count, uint32_t stream) { return count <= 8 * uint64_t(stream) + 16; };
    if (streamed > bytes.size() || !fits(n, sizes[0]) || triangles > sizes[4])
        throw std::runtime_error(what + ": counts larger than the payload could hold");
    auto records = decode_vertices(r.get_bytes(sizes[0]), n, 12, what);
    cube.vertices.positions.resize(3 * size_t(n));
    cube.vertices.normals.resize(2 * size_t(n));
    for (size_t i = 0; i < n; ++i) {
        std::memcpy(&cube.vertices.positions[3 * i], &records[12 * i], 6);
        std::memcpy(&cube.vertices.normals[2 * i], &records[12 * i + 6], 4);
    }
    auto colors = r.get_bytes(sizes[1]);
    if (flags & kHasColors) cube.vertices.colors = decode_vertices(colors, n, 4, what);
    auto uvs = r.get_bytes(sizes[2]);
    if (flags & kHasUvs) from_bytes(decode_vertices(uvs, n, 8, what), cube.vertices.uvs);
    from_bytes(decode_vertices(r.get_bytes(sizes[3]), n, 4, what), cube.parent_vertex);
    cube.indices.resize(size_t(triangles) * 3);
    auto index_stream = r.get_bytes(sizes[4]);
    if (triangles && meshopt_decodeIndexBuffer(cube.indices.data(), cube.indices.size(), 4, index_stream.data(),
                                               index_stream.size()) != 0)
        throw std::runtime_error(what + ": index stream does not decode");
    for (uint32_t index : cube.indices)
        if (index >= n) throw std::runtime_error(what + ": index " + std::to_string(index) + " past its " +
                                                 std::to_string(n) + " vertices");
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
    temp_path_ += ".tmp-" + std::to_string(::getpid());
    errno = 0;
    file_ = std::fopen(temp_path_.c_str(), "wb");
    if (!file_) throw std::runtime_error(io_error(path_, "cannot create the output file"));
    std::vector<uint8_t> placeholder(kHeaderBytes, 0);
    write(placeholder.data(), placeholder.size());
}

HlodWriter::~HlodWriter() {
    if (file_) {
        std::fclose(file_);
        std::error_code ignored;
        std::filesystem::remove(temp_path_, ignored);
    }
}

void HlodWriter::write(const void* data, size_t size) {
    errno = 0;
    if (size && std::fwrite(data, 1, size, file_) != size) throw std::runtime_error(io_error(path_, "write failed"));
    offset_ += size;
}

void HlodWriter::add_cube(HlodNode node, std::span<const uint8_t> payload) {
    node.offset = offset_;
    node.size = payload.size();
    node.checksum = crc32c(payload.data(), payload.size());
    write(payload.data(), payload.size());
    nodes_.push_back(node);
}

void HlodWriter::finish(HlodHeader header) {
    header.node_count = nodes_.size();
    header.node_table_offset = offset_;
    ByteWriter table;
    table.put_string(header.source);
    table.put_string(header.texture);
    for (const HlodNode& n : nodes_) write_node(table, n);
    table.put(crc32c(table.bytes.data(), table.bytes.size()));
    write(table.bytes.data(), table.bytes.size());

    ByteWriter head;
    write_header(head, header);
    errno = 0;
    if (std::fseek(file_, 0, SEEK_SET) != 0) throw std::runtime_error(io_error(path_, "seek failed"));
    write(head.bytes.data(), head.bytes.size());
    if (std::fflush(file_) != 0 || ::fsync(::fileno(file_)) != 0)
        throw std::runtime_error(io_error(path_, "write failed"));
    int closed = std::fclose(file_);
    file_ = nullptr;
    std::error_code ec;
    if (closed == 0) std::filesystem::rename(temp_path_, path_, ec);
    if (closed != 0 || ec) {
        std::filesystem::remove(temp_path_, ec);
        throw std::runtime_error(io_error(path_, "cannot finish the output file"));
    }
}

// ---- reader --------------------------------------------------------------------------------

HlodFile::HlodFile(const std::filesystem::path& path) : path_(path) {
    errno = 0;
    file_.reset(std::fopen(path.c_str(), "rb"));
    if (!file_) throw std::runtime_error(io_error(path, "cannot open"));
    std::error_code ec;
    file_size_ = std::filesystem::file_size(path, ec);
    if (ec) throw std::runtime_error(path.string() + ": cannot read its size");
    const std::string name = path.string();

    std::vector<uint8_t> head(kHeaderBytes);
    if (file_size_ < kHeaderBytes || std::fread(head.data(), 1, head.size(), file_.get()) != head.size())
        throw std::runtime_error(name + ": too short to be a .hlod file");
    if (std::memcmp(head.data(), kHlodMagic, sizeof(kHlodMagic)) != 0)
        throw std::runtime_error(name + ": not a .hlod file (bad magic)");
    ByteReader r(head, name + ": header");
    r.get_bytes(sizeof(kHlodMagic));
    HlodHeader& h = header_;
    h.version = r.get<uint32_t>();
    if (h.version != kHlodVersion)
        throw std::runtime_error(name + ": .hlod version " + std::to_string(h.version) + ", this build reads " +
                                 std::to_string(kHlodVersion));
    h.flags = r.get<uint32_t>();
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
    h.node_table_offset = r.get<uint64_t>();
    size_t checked = r.position();
    if (r.get<uint32_t>() != crc32c(head.data(), checked))
        throw std::runtime_error(name + ": header checksum mismatch (the file is corrupt)");
    bool finite = std::isfinite(h.root_size) && std::isfinite(h.error_q) && std::isfinite(h.ratio) &&
                  std::isfinite(h.error_limit) && h.error_q >= 0;
    for (double o : h.origin) finite &= std::isfinite(o);
    if (!finite || h.max_level > 15 || !(h.root_size > 0) || !(h.sigma0 > 0 && h.sigma0 < 0.5f))
        throw std::runtime_error(name + ": header values out of range");

    uint64_t table_bytes = file_size_ - std::min(file_size_, h.node_table_offset);
    if (h.node_table_offset < kHeaderBytes || h.node_table_offset > file_size_ ||
        h.node_count > table_bytes / kNodeBytes)
        throw std::runtime_error(name + ": node table out of range (the file is truncated or corrupt)");
    std::vector<uint8_t> table(table_bytes);
    std::fseek(file_.get(), long(h.node_table_offset), SEEK_SET);
    if (std::fread(table.data(), 1, table.size(), file_.get()) != table.size())
        throw std::runtime_error(name + ": cannot read the node table");
    ByteReader t(table, name + ": node table");
    h.source = t.get_string();
    h.texture = t.get_string();
    nodes_.reserve(h.node_count);
    for (uint64_t i = 0; i < h.node_count; ++i) nodes_.push_back(read_node(t));
    size_t table_checked = t.position();
    if (t.get<uint32_t>() != crc32c(table.data(), table_checked))
        throw std::runtime_error(name + ": node table checksum mismatch (the file is corrupt)");
    for (const HlodNode& n : nodes_) {
        // The level first: shifting by a level past 63 would be undefined.
        if (n.level > h.max_level || n.i >= (1u << n.level) || n.j >= (1u << n.level) || n.k >= (1u << n.level))
            throw std::runtime_error(name + ": " + describe_cube(n) + " outside the octree");
        if (n.offset < kHeaderBytes || n.offset > h.node_table_offset || n.size > h.node_table_offset - n.offset)
            throw std::runtime_error(name + ": " + describe_cube(n) + " payload out of range");
    }
}

HlodFile::~HlodFile() = default;

std::vector<uint8_t> HlodFile::read_payload(const HlodNode& node) const {
    std::vector<uint8_t> bytes(node.size);
    if (std::fseek(file_.get(), long(node.offset), SEEK_SET) != 0 ||
        std::fread(bytes.data(), 1, bytes.size(), file_.get()) != bytes.size())
        throw std::runtime_error(path_.string() + ": cannot read " + describe_cube(node));
    if (crc32c(bytes.data(), bytes.size()) != node.checksum)
        throw std::runtime_error(path_.string() + ": " + describe_cube(node) +
                                 " checksum mismatch (the file is corrupt)");
    return bytes;
}

CubeData HlodFile::read_cube(const HlodNode& node) const {
    try {
        return decode_cube(read_payload(node), node, header_.flags);
    } catch (const std::runtime_error& e) {
        std::string message = e.what();
        if (message.rfind(path_.string(), 0) == 0) throw;
        throw std::runtime_error(path_.string() + ": " + message);
    }
}

}  // namespace strata

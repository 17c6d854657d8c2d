#include "preprocess/job_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <initializer_list>
#include <stdexcept>

#include "preprocess/atomic_file.h"
#include "preprocess/byte_packing.h"
#include "preprocess/hlod_format.h"

namespace strata::build {
namespace {

constexpr uint32_t kCubeFileMagic = 0x46434A53;     // "SJCF"
constexpr uint32_t kPayloadFileMagic = 0x46504A53;  // "SJPF"
constexpr uint32_t kJobFileVersion = 3;  // 3: boundary flags and odd edges (lock_boundary)
constexpr size_t kBlockEntryBytes = 44, kArrayEntryBytes = 28;  // a cube file's index entries
enum RecordFlags : uint8_t { kColors = 1, kUvs = 2, kNormals = 4, kBoundary = 8 };

[[noreturn]] void damaged(const std::filesystem::path& path, const std::string& what) {
    throw DamagedWork(path.string() + ": " + what +
                             "; this build's temporary files are damaged: remove them (strata build --clean) and build again");
}

template <class T>
void put_array(ByteWriter& out, const std::vector<T>& values) {
    out.put_bytes(values.data(), values.size() * sizeof(T));
}

template <class T>
void get_array(ByteReader& in, std::vector<T>& values, size_t count) {
    const std::span<const uint8_t> bytes = in.get_bytes(count * sizeof(T));
    values.resize(count);
    if (count) std::memcpy(values.data(), bytes.data(), bytes.size());  // an empty vector's data() may be null
}

// A cube's bytes: key, error, counts, flags, child counts, then the arrays as they are in memory.
void put_cube(ByteWriter& out, const CubeRecord& c) {
    out.put(c.key), out.put(c.error), out.put(c.vertex_count()), out.put(c.triangle_count());
    out.put(uint32_t((c.colors.empty() ? 0 : kColors) | (c.uvs.empty() ? 0 : kUvs) | (c.normals.empty() ? 0 : kNormals) |
                     (c.boundary.empty() ? 0 : kBoundary)));
    out.put(uint32_t(0));
    for (uint32_t n : c.child_counts) out.put(n);
    put_array(out, c.positions), put_array(out, c.colors), put_array(out, c.uvs), put_array(out, c.normals);
    put_array(out, c.boundary), put_array(out, c.triangles);
}

CubeRecord get_cube(ByteReader& in) {
    CubeRecord c;
    c.key = in.get<CubeKey>(), c.error = in.get<float>();
    const size_t vertices = in.get<uint32_t>(), triangles = in.get<uint32_t>();
    const uint32_t flags = in.get<uint32_t>();
    in.get<uint32_t>();
    for (uint32_t& n : c.child_counts) n = in.get<uint32_t>();
    get_array(in, c.positions, 3 * vertices);
    get_array(in, c.colors, flags & kColors ? 4 * vertices : 0);
    get_array(in, c.uvs, flags & kUvs ? 2 * vertices : 0);
    get_array(in, c.normals, flags & kNormals ? 3 * vertices : 0);
    get_array(in, c.boundary, flags & kBoundary ? vertices : 0);
    get_array(in, c.triangles, 3 * triangles);
    return c;
}

// A cube file's head: 16 fixed bytes, the blocks' entries, the listings' and the odd edges' entries, the
// head's CRC.
uint64_t index_bytes(uint64_t blocks) { return 16 + blocks * kBlockEntryBytes + 2 * kArrayEntryBytes + 4; }

// Writes the parts one after the other as one file; returns its size.
uint64_t commit(const std::filesystem::path& path, std::initializer_list<const std::vector<uint8_t>*> parts) {
    AtomicOutputFile file(path);
    uint64_t size = 0;
    for (const std::vector<uint8_t>* part : parts) file.write(part->data(), part->size()), size += part->size();
    file.commit(AtomicOutputFile::Sync::to_kernel);
    return size;
}

void read_exactly(int fd, const std::filesystem::path& path, uint64_t offset, void* data, size_t size) {
    if (read_fully(fd, offset, data, size)) return;
    if (errno) throw std::runtime_error(path.string() + ": cannot read (" + std::strerror(errno) + ")");
    damaged(path, "ends early");
}

int open_job_file(const std::filesystem::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw std::runtime_error(path.string() + ": cannot open (" + std::strerror(errno) + ")");
    return fd;
}

}  // namespace

// Layout: magic, version, level, block count; per block (key, offset, size, cubes, triangles, CRC);
// the listings' and the odd edges' (offset, size, count, CRC); the CRC of all that; then the sections.
uint64_t write_cube_file(const std::filesystem::path& path, std::vector<CubeRecord> cubes, uint32_t level,
                         const std::vector<BorderEntry>& border, const std::vector<OpenEdge>& odd_edges, const Frame& f) {
    std::sort(cubes.begin(), cubes.end(), [&](const CubeRecord& a, const CubeRecord& b) {
        return std::pair(f.block_of(a.key), a.key) < std::pair(f.block_of(b.key), b.key);
    });
    struct Entry {
        CubeKey block;
        uint64_t offset, size, count, triangles;
        uint32_t checksum;
    };
    std::vector<Entry> entries;
    ByteWriter body;
    for (size_t first = 0, last; first < cubes.size(); first = last) {
        const CubeKey block = f.block_of(cubes[first].key);
        Entry e{block, body.bytes.size(), 0, 0, 0, 0};
        for (last = first; last < cubes.size() && f.block_of(cubes[last].key) == block; ++last) {
            put_cube(body, cubes[last]);
            e.count++, e.triangles += cubes[last].triangle_count();
        }
        e.size = body.bytes.size() - e.offset;
        e.checksum = crc32c(body.bytes.data() + e.offset, e.size);
        entries.push_back(e);
    }
    const uint64_t listings_at = body.bytes.size();
    body.put_bytes(border.data(), border.size() * sizeof(BorderEntry));
    const uint64_t edges_at = body.bytes.size();
    body.put_bytes(odd_edges.data(), odd_edges.size() * sizeof(OpenEdge));

    ByteWriter head;
    head.put(kCubeFileMagic), head.put(kJobFileVersion), head.put(level), head.put(uint32_t(entries.size()));
    const uint64_t head_bytes = index_bytes(entries.size());
    for (const Entry& e : entries) {
        head.put(e.block), head.put(head_bytes + e.offset), head.put(e.size), head.put(e.count), head.put(e.triangles);
        head.put(e.checksum);
    }
    auto put_array_entry = [&](uint64_t at, uint64_t size, uint64_t count) {
        head.put(head_bytes + at), head.put(size), head.put(count), head.put(crc32c(body.bytes.data() + at, size));
    };
    put_array_entry(listings_at, border.size() * sizeof(BorderEntry), border.size());
    put_array_entry(edges_at, odd_edges.size() * sizeof(OpenEdge), odd_edges.size());
    head.put(crc32c(head.bytes.data(), head.bytes.size()));
    return commit(path, {&head.bytes, &body.bytes});
}

CubeFile::CubeFile(std::filesystem::path path) : path_(std::move(path)), file_(open_job_file(path_)) {
    uint32_t fixed[4];
    read_exactly(file_.get(), path_, 0, fixed, sizeof(fixed));
    if (fixed[0] != kCubeFileMagic || fixed[1] != kJobFileVersion) damaged(path_, "not a cube file of this Strata");
    level_ = fixed[2];
    const uint64_t blocks = fixed[3];
    std::error_code ec;
    if (index_bytes(blocks) > std::filesystem::file_size(path_, ec) || ec) damaged(path_, "ends early");
    std::vector<uint8_t> head(index_bytes(blocks));
    read_exactly(file_.get(), path_, 0, head.data(), head.size());
    uint32_t stored;
    std::memcpy(&stored, head.data() + head.size() - 4, 4);
    if (crc32c(head.data(), head.size() - 4) != stored) damaged(path_, "index checksum mismatch");
    ByteReader in{std::span<const uint8_t>(head).subspan(16), path_.string()};
    for (uint64_t b = 0; b < blocks; ++b) {
        BlockSection s;
        s.block = in.get<CubeKey>();
        s.section.offset = in.get<uint64_t>(), s.section.size = in.get<uint64_t>(), s.section.count = in.get<uint64_t>();
        s.section.triangles = in.get<uint64_t>(), s.section.checksum = in.get<uint32_t>();
        blocks_.push_back(s);
    }
    for (Section* s : {&listings_, &odd_edges_}) {
        s->offset = in.get<uint64_t>(), s->size = in.get<uint64_t>(), s->count = in.get<uint64_t>();
        s->checksum = in.get<uint32_t>();
    }
}

std::vector<uint8_t> CubeFile::read_section(const Section& s) const {
    std::vector<uint8_t> bytes(s.size);
    read_exactly(file_.get(), path_, s.offset, bytes.data(), bytes.size());
    if (crc32c(bytes.data(), bytes.size()) != s.checksum) damaged(path_, "section checksum mismatch");
    return bytes;
}

const CubeFile::Section* CubeFile::find(CubeKey block) const {
    const auto it = std::lower_bound(blocks_.begin(), blocks_.end(), block,
                                     [](const BlockSection& s, CubeKey key) { return s.block < key; });
    return it != blocks_.end() && it->block == block ? &it->section : nullptr;
}

std::vector<CubeRecord> CubeFile::cubes_of(CubeKey block) const {
    const Section* s = find(block);
    if (!s) return {};
    const std::vector<uint8_t> bytes = read_section(*s);
    ByteReader in(bytes, path_.string());
    std::vector<CubeRecord> cubes;
    for (uint64_t c = 0; c < s->count; ++c) cubes.push_back(get_cube(in));
    return cubes;
}

uint64_t CubeFile::triangles_of(CubeKey block) const {
    const Section* s = find(block);
    return s ? s->triangles : 0;
}

template <class T>
std::vector<T> CubeFile::read_array(const Section& s, const char* what) const {
    if (s.size != s.count * sizeof(T)) damaged(path_, std::string(what) + " count disagrees with its size");
    const std::vector<uint8_t> bytes = read_section(s);
    std::vector<T> entries(s.count);
    if (!bytes.empty()) std::memcpy(entries.data(), bytes.data(), bytes.size());
    return entries;
}

std::vector<BorderEntry> CubeFile::listings() const { return read_array<BorderEntry>(listings_, "listing"); }

std::vector<OpenEdge> CubeFile::odd_edges() const { return read_array<OpenEdge>(odd_edges_, "odd edge"); }

// Layout: magic, version, count; per cube its node's fields and payload size, then its payload; the
// CRC of everything before it.
uint64_t write_payload_file(const std::filesystem::path& path, const std::vector<EncodedCube>& cubes) {
    ByteWriter out;
    out.put(kPayloadFileMagic), out.put(kJobFileVersion), out.put(uint64_t(cubes.size()));
    for (const EncodedCube& e : cubes) {
        const HlodNode& n = e.node;
        out.put(n.level), out.put(n.i), out.put(n.j), out.put(n.k), out.put(n.error), out.put(e.coverage);
        out.put(n.vertex_count), out.put(n.triangle_count), out.put(uint64_t(e.payload.size()));
        out.put_bytes(e.payload.data(), e.payload.size());
    }
    out.put(crc32c(out.bytes.data(), out.bytes.size()));
    return commit(path, {&out.bytes});
}

std::vector<EncodedCube> read_payload_file(const std::filesystem::path& path) {
    const FileHandle file(open_job_file(path));
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec || size < 20) damaged(path, "too short for a payload file");
    std::vector<uint8_t> bytes(size);
    read_exactly(file.get(), path, 0, bytes.data(), bytes.size());
    uint32_t stored;
    std::memcpy(&stored, bytes.data() + size - 4, 4);
    if (crc32c(bytes.data(), size - 4) != stored) damaged(path, "checksum mismatch");
    ByteReader in{std::span<const uint8_t>(bytes).first(size - 4), path.string()};
    if (in.get<uint32_t>() != kPayloadFileMagic || in.get<uint32_t>() != kJobFileVersion)
        damaged(path, "not a payload file of this Strata");
    const uint64_t count = in.get<uint64_t>();
    std::vector<EncodedCube> cubes;
    for (uint64_t c = 0; c < count; ++c) {
        EncodedCube e;
        HlodNode& n = e.node;
        n.level = in.get<uint32_t>(), n.i = in.get<uint32_t>(), n.j = in.get<uint32_t>(), n.k = in.get<uint32_t>();
        n.error = in.get<float>(), e.coverage = in.get<float>(), n.vertex_count = in.get<uint32_t>(), n.triangle_count = in.get<uint32_t>();
        const std::span<const uint8_t> payload = in.get_bytes(in.get<uint64_t>());
        e.payload.assign(payload.begin(), payload.end());
        cubes.push_back(std::move(e));
    }
    if (!in.at_end()) damaged(path, "longer than its cubes");
    return cubes;
}

}  // namespace strata::build

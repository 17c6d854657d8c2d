#include "preprocess/mesh_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "preprocess/mesh_readers.h"

namespace strata {
namespace detail {

void advise_huge_pages(const void* data, size_t bytes) {
    constexpr uintptr_t kHuge = uintptr_t(2) << 20;
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
    const uintptr_t end = (reinterpret_cast<uintptr_t>(data) + bytes) & ~(kHuge - 1);
    if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // a hint only
}

size_t first_non_finite(const float* xyz, size_t count) {
    // Fixed-size blocks of branch-free checks, which GCC vectorizes at -O2, so the common all-finite
    // case costs one pass at memory speed; only a bad block (or the tail) is searched one by one.
    constexpr size_t kBlock = 256;
    const size_t floats = count * 3;
    size_t start = 0;
    for (; start + kBlock <= floats; start += kBlock) {
        uint32_t bad = 0;
        for (size_t k = 0; k < kBlock; ++k)
            bad |= uint32_t((std::bit_cast<uint32_t>(xyz[start + k]) & 0x7f800000u) == 0x7f800000u);
        if (bad) break;
    }
    for (size_t i = start; i < floats; ++i)
        if (!std::isfinite(xyz[i])) return i / 3;
    return count;
}

}  // namespace detail

namespace {

// ---- reading the file -----------------------------------------------------------------------------

// Large arrays straight from mmap (the file being read, weld's scratch): already zeroed (no fill pass)
// and on huge pages.
template <class T>
class PageArray {
public:
    explicit PageArray(size_t count) : count_(count), bytes_(count * sizeof(T) + kHuge) {
        void* mapped = ::mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (mapped == MAP_FAILED) throw std::bad_alloc();
        base_ = mapped;
        const uintptr_t aligned = (reinterpret_cast<uintptr_t>(mapped) + kHuge - 1) & ~(kHuge - 1);
        data_ = reinterpret_cast<T*>(aligned);
        detail::advise_huge_pages(data_, count * sizeof(T));
    }
    ~PageArray() { ::munmap(base_, bytes_); }
    PageArray(const PageArray&) = delete;
    PageArray& operator=(const PageArray&) = delete;

    T& operator[](size_t i) { return data_[i]; }
    T* data() { return data_; }
    size_t size() const { return count_; }

private:
    static constexpr size_t kHuge = size_t(2) << 20;
    size_t count_;
    size_t bytes_;
    void* base_ = nullptr;
    T* data_ = nullptr;
};

struct Descriptor {
    explicit Descriptor(int descriptor) : fd(descriptor) {}
    Descriptor(const Descriptor&) = delete;
    Descriptor& operator=(const Descriptor&) = delete;
    ~Descriptor() {
        if (fd >= 0) ::close(fd);
    }
    int fd;
};

[[noreturn]] void fail_file(const std::string& name, const std::string& what, int error) {
    std::string message = name + ": " + what;
    if (error) message += std::string(" (") + std::strerror(error) + ")";
    throw InputError(message);
}

Descriptor open_file(const std::filesystem::path& path, const std::string& name) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) fail_file(name, "cannot open", errno);
    return Descriptor(fd);
}

// The size of the regular, non-empty file open as `fd`; anything else is an InputError.
size_t regular_file_size(int fd, const std::string& name) {
    struct stat info {};
    if (::fstat(fd, &info) != 0) fail_file(name, "cannot stat", errno);
    if (S_ISDIR(info.st_mode)) fail_file(name, "is a directory, not a mesh file", 0);
    if (!S_ISREG(info.st_mode)) fail_file(name, "is not a regular file", 0);
    if (info.st_size == 0) fail_file(name, "empty file", 0);
    return size_t(info.st_size);
}

// The whole input, read into memory. Read rather than mapped: a mapped file that is truncated while it
// is parsed kills the process with SIGBUS, whereas read() returns fewer bytes than expected, which is an
// error naming the file; once read, the bytes cannot change under the parser. Copying from the page
// cache costs little next to parsing (bench_ply_read).
class FileBytes {
public:
    // Reports "load" progress in bytes after each chunk (a slow disk takes a while) and polls cancel.
    FileBytes(const std::filesystem::path& path, const std::string& name, const Progress& progress) : name_(name) {
        const Descriptor file = open_file(path, name);
        const size_t size = regular_file_size(file.fd, name);
        try {
            bytes_.emplace(size);
        } catch (const std::bad_alloc&) {
            fail("not enough memory to read its " + std::to_string(size) + " bytes", 0);
        }
        read_all(file.fd, progress);
    }

    const char* data() { return bytes_->data(); }
    size_t size() const { return bytes_->size(); }

private:
    static constexpr size_t kChunk = size_t(4) << 20;

    void read_all(int fd, const Progress& progress) {
        const size_t size = bytes_->size();
        ::posix_fadvise(fd, 0, 0, POSIX_FADV_SEQUENTIAL);  // a hint: read ahead
        for (size_t done = 0; done < size;) {
            const ssize_t got = ::pread(fd, bytes_->data() + done, std::min(kChunk, size - done), off_t(done));
            if (got < 0 && errno == EINTR) continue;
            if (got < 0) fail("cannot read", errno);
            if (got == 0) changed("it ends after " + std::to_string(done) + " of its " + std::to_string(size) + " bytes");
            done += size_t(got);
            progress("load", double(done), double(size), "B");
            progress.check();
        }
        // Grown meanwhile (or cut and grown again): what was read is no one version of the file.
        struct stat info {};
        if (::fstat(fd, &info) != 0) fail("cannot stat", errno);
        if (size_t(info.st_size) != size) changed("it is " + std::to_string(info.st_size) + " bytes now, not " +
                                                  std::to_string(size));
    }

    [[noreturn]] void changed(const std::string& what) const {
        fail("the file changed while it was being read: " + what, 0);
    }
    [[noreturn]] void fail(const std::string& what, int error) const { fail_file(name_, what, error); }

    std::string name_;
    std::optional<PageArray<char>> bytes_;
};

// ---- choosing the reader --------------------------------------------------------------------------

enum class Format { unknown, ply, obj, off, stl };

bool is_binary_stl(const char* data, size_t size) {
    if (size < 84) return false;
    uint32_t count;
    std::memcpy(&count, data + 80, 4);
    if constexpr (std::endian::native == std::endian::big) count = __builtin_bswap32(count);
    return 84 + 50 * uint64_t(count) == size;
}

// "OFF" with Geomview's optional prefixes: ST (uv), C (colour), N (normal), 4 (4D), n (dimension),
// perhaps with the vertex count glued on ("OFF1234 ...": ModelNet's files).
bool is_off_keyword(std::string_view token) {
    const size_t off = token.find("OFF");
    if (off == std::string_view::npos) return false;
    return token.substr(0, off).find_first_not_of("STCN4n") == std::string_view::npos &&
           token.substr(off + 3).find_first_not_of("0123456789") == std::string_view::npos;
}

bool is_obj_keyword(std::string_view token) {
    static constexpr std::array<std::string_view, 12> kKeywords = {
        "v", "vt", "vn", "vp", "f", "o", "g", "s", "l", "p", "mtllib", "usemtl"};
    return std::find(kKeywords.begin(), kKeywords.end(), token) != kKeywords.end();
}

// The first token of the first line that is neither blank nor a '#' comment (text formats only).
std::string_view first_keyword(const char* data, size_t size) {
    detail::Lines lines(data, data + std::min<size_t>(size, 1 << 16));
    std::string_view line;
    while (lines.next(line)) {
        detail::Tokens tokens(line);
        std::string_view token = tokens.next();
        if (!token.empty() && token[0] != '#') return token;
    }
    return {};
}

Format sniff_content(const char* data, size_t size) {
    if (size >= 3 && std::memcmp(data, "ply", 3) == 0 && (size == 3 || data[3] == '\n' || data[3] == '\r'))
        return Format::ply;
    // Binary STL first: its free-form 80-byte header may well start with "solid".
    if (is_binary_stl(data, size)) return Format::stl;
    std::string_view keyword = first_keyword(data, size);
    if (is_off_keyword(keyword)) return Format::off;
    if (detail::is_keyword(keyword, "solid")) return Format::stl;
    if (is_obj_keyword(keyword)) return Format::obj;
    return Format::unknown;
}

Format format_from_extension(const std::filesystem::path& path) {
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".ply") return Format::ply;
    if (ext == ".obj") return Format::obj;
    if (ext == ".off") return Format::off;
    if (ext == ".stl") return Format::stl;
    return Format::unknown;
}

// A UTF-8 byte order mark before a text format's first keyword, as Windows editors write it.
constexpr std::string_view kByteOrderMark = "\xEF\xBB\xBF";

Mesh read_format(Format format, const detail::ReadInput& input) {
    switch (format) {
        case Format::ply: return detail::read_ply(input);
        case Format::obj: return detail::read_obj(input);
        case Format::off: return detail::read_off(input);
        case Format::stl: return detail::read_stl(input);
        case Format::unknown: break;
    }
    input.fail("unknown mesh format (expected PLY, OBJ, OFF or STL)");
}

// ---- weld -----------------------------------------------------------------------------------------

constexpr uint32_t kNone = UINT32_MAX;

// The bytes of one vertex across the attribute arrays the mesh has.
struct VertexBytes {
    const float* positions;
    const float* normals;  // null when absent, like the others
    const uint8_t* colors;
    const float* uvs;

    static uint64_t mix(uint64_t h, uint64_t word) {
        h = (h ^ word) * 0x9E3779B97F4A7C15ull;
        return h ^ (h >> 31);
    }
    static uint64_t xyz_words(uint64_t h, const float* p) {
        uint64_t a;
        uint32_t b;
        std::memcpy(&a, p, 8);
        std::memcpy(&b, p + 2, 4);
        return mix(mix(h, a), b);
    }
    uint64_t hash(size_t i) const {
        uint64_t h = xyz_words(0x51ED270B27A4B8C1ull, positions + 3 * i);
        if (normals) h = xyz_words(h, normals + 3 * i);
        if (colors) {
            uint32_t rgba;
            std::memcpy(&rgba, colors + 4 * i, 4);
            h = mix(h, rgba);
        }
        if (uvs) {
            uint64_t uv;
            std::memcpy(&uv, uvs + 2 * i, 8);
            h = mix(h, uv);
        }
        // murmur3's finalizer: the table index takes the low bits, the tag the high ones.
        h ^= h >> 33;
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 33;
        h *= 0xc4ceb9fe1a85ec53ull;
        return h ^ (h >> 33);
    }
    bool same_position(size_t a, size_t b) const { return std::memcmp(positions + 3 * a, positions + 3 * b, 12) == 0; }
    bool equal(size_t a, size_t b) const {
        return same_position(a, b) && (!normals || std::memcmp(normals + 3 * a, normals + 3 * b, 12) == 0) &&
               (!colors || std::memcmp(colors + 4 * a, colors + 4 * b, 4) == 0) &&
               (!uvs || std::memcmp(uvs + 2 * a, uvs + 2 * b, 8) == 0);
    }
};


bool any_index_at_least(const std::vector<uint32_t>& indices, uint32_t n) {
    // Fixed-size blocks of branch-free compares, which GCC vectorizes at -O2.
    constexpr size_t kBlock = 64;
    const uint32_t* idx = indices.data();
    size_t i = 0;
    for (; i + kBlock <= indices.size(); i += kBlock) {
        uint32_t bad = 0;
        for (size_t k = 0; k < kBlock; ++k) bad |= uint32_t(idx[i + k] >= n);
        if (bad) return true;
    }
    for (; i < indices.size(); ++i)
        if (idx[i] >= n) return true;
    return false;
}

void check_weldable(const Mesh& mesh) {
    const size_t n = mesh.vertex_count();
    if (mesh.positions.size() % 3 != 0) throw std::invalid_argument("weld: positions are not xyz triples");
    if (n >= kNone) throw std::invalid_argument("weld: too many vertices for 32-bit indices");
    if (mesh.has_normals() && mesh.normals.size() != 3 * n) throw std::invalid_argument("weld: normals size");
    if (mesh.has_colors() && mesh.colors.size() != 4 * n) throw std::invalid_argument("weld: colors size");
    if (mesh.has_uvs() && mesh.uvs.size() != 2 * n) throw std::invalid_argument("weld: uvs size");
    if (mesh.indices.size() % 3 != 0) throw std::invalid_argument("weld: indices are not triangles");
    if (any_index_at_least(mesh.indices, uint32_t(n)))
        throw std::invalid_argument("weld: index past the vertex count");
}

// -0.0 + 0.0 == +0.0, so after this equal values have equal bits and byte hashing is exact. (The
// compiler may not drop the addition: without -ffast-math it is not an identity.) Fixed-size blocks
// let GCC vectorize it at -O2.
void canonicalize_zeros(std::vector<float>& values) {
    constexpr size_t kBlock = 16;
    float* v = values.data();
    size_t i = 0;
    for (; i + kBlock <= values.size(); i += kBlock)
        for (size_t k = 0; k < kBlock; ++k) v[i + k] += 0.0f;
    for (; i < values.size(); ++i) v[i] += 0.0f;
}

// representative[i]: the first vertex equal to i. An open-addressing table of (hash tag, vertex + 1),
// 0 meaning empty, with the slot of a vertex a few iterations ahead prefetched: every probe of a table
// this size is a cache miss, and prefetching overlaps them.
void find_representatives(const VertexBytes& bytes, PageArray<uint32_t>& representative) {
    const size_t n = representative.size();
    const size_t capacity = std::bit_ceil(std::max<size_t>(16, n + n / 2));
    const size_t mask = capacity - 1;
    PageArray<uint64_t> table(capacity);
    constexpr size_t kAhead = 16;
    std::array<uint64_t, kAhead> pending{};
    for (size_t i = 0; i < std::min(n, kAhead); ++i) {
        pending[i] = bytes.hash(i);
        __builtin_prefetch(&table[pending[i] & mask]);
    }
    for (size_t i = 0; i < n; ++i) {
        const uint64_t h = pending[i % kAhead];
        if (i + kAhead < n) {
            const uint64_t later = bytes.hash(i + kAhead);
            pending[i % kAhead] = later;
            __builtin_prefetch(&table[later & mask], 1);
        }
        const uint64_t tag = h >> 32;
        for (size_t slot = h & mask;; slot = (slot + 1) & mask) {
            const uint64_t entry = table[slot];
            if (entry == 0) {
                table[slot] = (tag << 32) | (i + 1);
                representative[i] = uint32_t(i);
                break;
            }
            const uint32_t other = uint32_t(entry) - 1;
            if ((entry >> 32) == tag && bytes.equal(other, i)) {
                representative[i] = other;
                break;
            }
        }
    }
}

// Rewrites triangles onto representatives and drops those with two corners at one position. Without
// attributes, representatives are unique per position, so comparing indices is enough.
void keep_proper_triangles(Mesh& mesh, const VertexBytes& bytes, PageArray<uint32_t>& representative) {
    const bool seams_possible = bytes.normals || bytes.colors || bytes.uvs;
    uint32_t* idx = mesh.indices.data();
    size_t kept = 0;
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const uint32_t a = representative[idx[t]], b = representative[idx[t + 1]], c = representative[idx[t + 2]];
        if (a == b || b == c || a == c) continue;
        if (seams_possible && (bytes.same_position(a, b) || bytes.same_position(b, c) || bytes.same_position(a, c)))
            continue;
        idx[kept] = a;
        idx[kept + 1] = b;
        idx[kept + 2] = c;
        kept += 3;
    }
    mesh.indices.resize(kept);
}

template <class T>
void move_vertex(std::vector<T>& values, size_t width, size_t from, size_t to) {
    if (values.empty()) return;
    std::copy_n(values.begin() + from * width, width, values.begin() + to * width);
}

// Drops vertices no triangle uses, keeping the order of the rest; `scratch` is reused as the new ids.
void compact_vertices(Mesh& mesh, PageArray<uint32_t>& scratch) {
    PageArray<uint32_t>& new_id = scratch;
    std::fill_n(new_id.data(), new_id.size(), kNone);
    for (uint32_t index : mesh.indices) new_id[index] = 0;
    uint32_t next = 0;
    for (size_t v = 0; v < new_id.size(); ++v) {
        if (new_id[v] == kNone) continue;
        new_id[v] = next;
        if (v != next) {
            move_vertex(mesh.positions, 3, v, next);
            move_vertex(mesh.normals, 3, v, next);
            move_vertex(mesh.colors, 4, v, next);
            move_vertex(mesh.uvs, 2, v, next);
        }
        ++next;
    }
    if (next == new_id.size()) return;  // nothing dropped: ids unchanged
    for (uint32_t& index : mesh.indices) index = new_id[index];
    mesh.positions.resize(size_t(next) * 3);
    if (mesh.has_normals()) mesh.normals.resize(size_t(next) * 3);
    if (mesh.has_colors()) mesh.colors.resize(size_t(next) * 4);
    if (mesh.has_uvs()) mesh.uvs.resize(size_t(next) * 2);
}

// ---- write_ply ------------------------------------------------------------------------------------

// A temporary file beside the target that is removed unless commit() renamed it into place.
class TempFile {
public:
    TempFile(const std::filesystem::path& target, std::string name) : target_(target), name_(std::move(name)) {
        static std::atomic<unsigned> counter{0};
        std::string leaf = "." + target.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                           std::to_string(counter.fetch_add(1));
        temp_ = target.parent_path() / leaf;
        file_ = std::fopen(temp_.c_str(), "wbx");
        if (!file_) fail("cannot create temporary file " + temp_.string(), errno);
        std::setvbuf(file_, nullptr, _IOFBF, size_t(1) << 20);
    }
    ~TempFile() {
        if (file_) std::fclose(file_);
        if (!committed_) {
            std::error_code ignored;
            std::filesystem::remove(temp_, ignored);
        }
    }
    TempFile(const TempFile&) = delete;
    TempFile& operator=(const TempFile&) = delete;

    void write(const void* data, size_t size) {
        if (size && std::fwrite(data, 1, size, file_) != size) fail("write failed", errno);
    }
    void write(std::string_view text) { write(text.data(), text.size()); }

    void commit() {
        if (std::fflush(file_) != 0 || ::fsync(::fileno(file_)) != 0) fail("write failed", errno);
        int closed = std::fclose(file_);
        file_ = nullptr;
        if (closed != 0) fail("write failed", errno);
        std::error_code ec;
        std::filesystem::rename(temp_, target_, ec);
        if (ec) throw std::runtime_error(name_ + ": cannot rename temporary file into place (" + ec.message() + ")");
        committed_ = true;
    }

private:
    [[noreturn]] void fail(const std::string& what, int error) {
        throw std::runtime_error(name_ + ": " + what + " (" + std::strerror(error) + ")");
    }
    std::filesystem::path target_;
    std::filesystem::path temp_;
    std::string name_;
    std::FILE* file_ = nullptr;
    bool committed_ = false;
};

void check_writable(const Mesh& mesh, const std::string& name) {
    try {
        check_weldable(mesh);  // the same consistency rules
    } catch (const std::invalid_argument& e) {
        throw std::runtime_error(name + ": cannot write an inconsistent mesh (" + e.what() + ")");
    }
}

bool has_origin(const Mesh& mesh) { return mesh.origin != std::array<double, 3>{}; }

// A vertex's true position, as written when the mesh has an origin.
std::array<double, 3> true_position(const Mesh& mesh, size_t v) {
    std::array<double, 3> p;
    for (int a = 0; a < 3; ++a) p[size_t(a)] = mesh.origin[size_t(a)] + double(mesh.positions[3 * v + size_t(a)]);
    return p;
}

std::string ply_header(const Mesh& mesh, PlyEncoding encoding) {
    static constexpr std::array<const char*, 3> kFormats = {"binary_little_endian", "binary_big_endian", "ascii"};
    std::string h = "ply\nformat " + std::string(kFormats[size_t(encoding)]) + " 1.0\ncomment written by strata\n";
    if (!mesh.texture.empty()) h += "comment TextureFile " + mesh.texture + "\n";
    h += "element vertex " + std::to_string(mesh.vertex_count()) + "\n";
    h += has_origin(mesh) ? "property double x\nproperty double y\nproperty double z\n"
                          : "property float x\nproperty float y\nproperty float z\n";
    if (mesh.has_normals()) h += "property float nx\nproperty float ny\nproperty float nz\n";
    if (mesh.has_colors())
        h += "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n";
    if (mesh.has_uvs()) h += "property float u\nproperty float v\n";
    h += "element face " + std::to_string(mesh.triangle_count()) + "\n";
    h += "property list uchar uint vertex_indices\nend_header\n";
    return h;
}

// Appends 4-byte words (or 8-byte ones, Word = uint64_t) in the file's byte order.
template <bool Swap, class Word = uint32_t>
void put_words(std::vector<char>& out, const void* words, size_t count) {
    constexpr size_t kSize = sizeof(Word);
    const size_t at = out.size();
    out.resize(at + kSize * count);
    char* dst = out.data() + at;
    for (size_t i = 0; i < count; ++i) {
        Word w;
        std::memcpy(&w, static_cast<const char*>(words) + kSize * i, kSize);
        if constexpr (Swap && kSize == 4) w = __builtin_bswap32(w);
        if constexpr (Swap && kSize == 8) w = __builtin_bswap64(w);
        std::memcpy(dst + kSize * i, &w, kSize);
    }
}

constexpr size_t kWriteChunk = size_t(1) << 20;

template <bool Swap>
void write_binary_body(TempFile& file, const Mesh& mesh) {
    std::vector<char> buffer;
    buffer.reserve(kWriteChunk + 64);
    const bool doubles = has_origin(mesh);
    for (size_t v = 0; v < mesh.vertex_count(); ++v) {
        if (doubles) put_words<Swap, uint64_t>(buffer, true_position(mesh, v).data(), 3);
        else put_words<Swap>(buffer, &mesh.positions[3 * v], 3);
        if (mesh.has_normals()) put_words<Swap>(buffer, &mesh.normals[3 * v], 3);
        if (mesh.has_colors()) buffer.insert(buffer.end(), &mesh.colors[4 * v], &mesh.colors[4 * v] + 4);
        if (mesh.has_uvs()) put_words<Swap>(buffer, &mesh.uvs[2 * v], 2);
        if (buffer.size() >= kWriteChunk) file.write(buffer.data(), buffer.size()), buffer.clear();
    }
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        buffer.push_back(3);
        put_words<Swap>(buffer, &mesh.indices[t], 3);
        if (buffer.size() >= kWriteChunk) file.write(buffer.data(), buffer.size()), buffer.clear();
    }
    file.write(buffer.data(), buffer.size());
}

// Shortest text that reads back as exactly the same value (std::to_chars round-trips).
template <class T>
void put_text(std::string& out, T value, char separator) {
    char digits[32];
    auto [end, ec] = std::to_chars(digits, digits + sizeof digits, value);
    out.append(digits, end);
    out += separator;
}

void write_ascii_body(TempFile& file, const Mesh& mesh) {
    std::string buffer;
    const bool doubles = has_origin(mesh);
    for (size_t v = 0; v < mesh.vertex_count(); ++v) {
        if (doubles)
            for (double x : true_position(mesh, v)) put_text(buffer, x, ' ');
        else
            for (int k = 0; k < 3; ++k) put_text(buffer, mesh.positions[3 * v + k], ' ');
        if (mesh.has_normals())
            for (int k = 0; k < 3; ++k) put_text(buffer, mesh.normals[3 * v + k], ' ');
        if (mesh.has_colors())
            for (int k = 0; k < 4; ++k) put_text(buffer, unsigned(mesh.colors[4 * v + k]), ' ');
        if (mesh.has_uvs())
            for (int k = 0; k < 2; ++k) put_text(buffer, mesh.uvs[2 * v + k], ' ');
        buffer.back() = '\n';
        if (buffer.size() >= kWriteChunk) file.write(buffer), buffer.clear();
    }
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        buffer += "3 ";
        for (int k = 0; k < 3; ++k) put_text(buffer, mesh.indices[t + k], k == 2 ? '\n' : ' ');
        if (buffer.size() >= kWriteChunk) file.write(buffer), buffer.clear();
    }
    file.write(buffer);
}

}  // namespace

namespace detail {

Mesh read_mesh_as_listed(const std::filesystem::path& path, const Progress& progress, std::vector<std::string>& warnings,
                         const std::array<double, 3>* origin) {
    const std::string name = path.string();
    // The file's bytes are freed on return, so they and weld's tables are never resident at once.
    FileBytes file(path, name, progress);
    std::string_view bytes(file.data(), file.size());
    if (bytes.starts_with(kByteOrderMark)) bytes.remove_prefix(kByteOrderMark.size());
    const detail::ReadInput input{path, name, bytes.data(), bytes.size(), progress, &warnings, origin};
    Format format = sniff_content(bytes.data(), bytes.size());
    if (format == Format::unknown) format = format_from_extension(path);
    progress("read", 0, double(bytes.size()), "B");
    progress.check();
    Mesh mesh = read_format(format, input);
    progress("read", double(bytes.size()), double(bytes.size()), "B");
    return mesh;
}

}  // namespace detail

namespace {

// ---- tiles ----------------------------------------------------------------------------------------

// "a.ply, b.ply and 3 more": a list of tiles for a message, however many there are.
std::string file_list(const std::vector<std::string>& names) {
    constexpr size_t kShown = 4;
    std::string out;
    for (size_t i = 0; i < std::min(names.size(), kShown); ++i) {
        if (i > 0) out += (i + 1 == names.size() ? " and " : ", ");
        out += names[i];
    }
    if (names.size() > kShown) out += " and " + std::to_string(names.size() - kShown) + " more";
    return out;
}

std::string texture_name(const std::string& texture) { return texture.empty() ? "no texture" : "texture '" + texture + "'"; }

}  // namespace

namespace detail {

ModelAttributes common_attributes(const std::vector<TileAttributes>& tiles, std::vector<std::string>& warnings) {
    for (size_t i = 1; i < tiles.size(); ++i)
        if (tiles[i].texture != tiles[0].texture)
            throw InputError(tiles[i].name + ": names " + texture_name(tiles[i].texture) + ", but " + tiles[0].name +
                             " names " + texture_name(tiles[0].texture) + ": the tiles of one model share one texture");
    ModelAttributes model;
    auto check = [&](bool AttributeSet::*has, const char* noun, const char* dropped) {
        std::vector<std::string> lacking;
        for (const TileAttributes& tile : tiles)
            if (!(tile.has.*has)) lacking.push_back(tile.name);
        model.kept.*has = lacking.empty();
        if (lacking.empty() || lacking.size() == tiles.size()) return;
        warnings.push_back(file_list(lacking) + ": no " + noun + ", which the other " +
                           std::to_string(tiles.size() - lacking.size()) + " of the " + std::to_string(tiles.size()) +
                           " files have: the model is built without " + dropped);
    };
    check(&AttributeSet::normals, "normals", "normals");
    check(&AttributeSet::colors, "colours", "colours");
    check(&AttributeSet::uvs, "UVs", "UVs and texture");
    if (model.kept.uvs && !tiles.empty()) model.texture = tiles.front().texture;
    return model;
}

}  // namespace detail

namespace {

template <class T>
void append(std::vector<T>& to, std::vector<T>& from, bool keep) {
    if (keep) to.insert(to.end(), from.begin(), from.end());
    std::vector<T>().swap(from);
}

// The tiles end to end, each freed once copied: the storage is reserved untouched, so memory holds
// about one copy of the model throughout rather than two.
Mesh join(const std::vector<std::filesystem::path>& paths, std::vector<Mesh>& tiles, std::vector<std::string>& warnings) {
    std::vector<detail::TileAttributes> attributes;
    for (size_t i = 0; i < tiles.size(); ++i)
        attributes.push_back({paths[i].string(), {tiles[i].has_normals(), tiles[i].has_colors(), tiles[i].has_uvs()}, tiles[i].texture});
    const AttributeSet kept = detail::common_attributes(attributes, warnings).kept;
    uint64_t vertices = 0, indices = 0;
    for (const Mesh& tile : tiles) vertices += tile.vertex_count(), indices += tile.indices.size();
    if (vertices >= kNone)
        throw InputError(paths.front().string() + " to " + paths.back().string() + " (" + std::to_string(paths.size()) +
                         " files): more than 2^32 vertices together (" + std::to_string(vertices) + ")");
    Mesh merged;
    merged.origin = tiles.front().origin;
    if (kept.uvs) merged.texture = tiles.front().texture;
    detail::reserve_huge(merged.positions, size_t(3 * vertices));
    if (kept.normals) detail::reserve_huge(merged.normals, size_t(3 * vertices));
    if (kept.colors) detail::reserve_huge(merged.colors, size_t(4 * vertices));
    if (kept.uvs) detail::reserve_huge(merged.uvs, size_t(2 * vertices));
    detail::reserve_huge(merged.indices, size_t(indices));
    for (Mesh& tile : tiles) {
        const uint32_t base = uint32_t(merged.vertex_count());
        for (uint32_t index : tile.indices) merged.indices.push_back(base + index);
        std::vector<uint32_t>().swap(tile.indices);
        append(merged.positions, tile.positions, true);
        append(merged.normals, tile.normals, kept.normals);
        append(merged.colors, tile.colors, kept.colors);
        append(merged.uvs, tile.uvs, kept.uvs);
    }
    weld(merged);
    return merged;
}

// ---- estimating a file's triangles ----------------------------------------------------------------

// Bytes per triangle of typical text files, for those whose header gives no count: an OBJ's
// "v x y z" lines (about half as many as triangles) and "f a b c" lines; an ASCII STL's seven-line facets.
constexpr uint64_t kObjBytesPerTriangle = 32;
constexpr uint64_t kAsciiStlBytesPerTriangle = 200;

// The count the header gives, if it gives one that can be read from the file's first bytes.
std::optional<uint64_t> header_triangles(Format format, const detail::ReadInput& input, size_t file_size) {
    try {
        if (format == Format::ply) return detail::ply_face_count(input);
        if (format == Format::off) return detail::off_face_count(input);
    } catch (const InputError&) {
        return std::nullopt;  // the real read will report what is wrong with it
    }
    if (format == Format::stl && input.size >= 84) {
        uint32_t count;
        std::memcpy(&count, input.data + 80, 4);
        if constexpr (std::endian::native == std::endian::big) count = __builtin_bswap32(count);
        if (84 + 50 * uint64_t(count) == file_size) return count;
    }
    return std::nullopt;
}

}  // namespace

Mesh read_mesh(const std::filesystem::path& path, const Progress& progress, std::vector<std::string>& warnings) {
    Mesh mesh = detail::read_mesh_as_listed(path, progress, warnings, nullptr);
    weld(mesh);
    return mesh;
}

Mesh read_tiles(const std::vector<std::filesystem::path>& paths, const Progress& progress,
                std::vector<std::string>& warnings) {
    if (paths.empty()) throw std::invalid_argument("read_tiles: no files");
    if (paths.size() == 1) return read_mesh(paths.front(), progress, warnings);
    double total = 0;
    std::vector<double> sizes;
    for (const std::filesystem::path& path : paths) {
        std::error_code unknown;  // a missing file is reported when it is read
        const auto size = std::filesystem::file_size(path, unknown);
        sizes.push_back(unknown ? 0.0 : double(size));
        total += sizes.back();
    }
    std::vector<Mesh> tiles;
    tiles.reserve(paths.size());
    double before = 0;
    for (size_t i = 0; i < paths.size(); ++i) {
        const Progress tile_progress{[&](std::string_view stage, double done, double, std::string_view unit) {
                                         progress(stage, before + done, total, unit);
                                     },
                                     progress.cancel};
        tiles.push_back(detail::read_mesh_as_listed(paths[i], tile_progress, warnings, i == 0 ? nullptr : &tiles.front().origin));
        weld(tiles.back());
        before += sizes[i];
    }
    return join(paths, tiles, warnings);
}

TriangleEstimate estimate_triangles(const std::filesystem::path& path) {
    const std::string name = path.string();
    const Descriptor file = open_file(path, name);
    const size_t size = regular_file_size(file.fd, name);
    std::string prefix(std::min<size_t>(size, size_t(64) << 10), '\0');
    const ssize_t got = ::pread(file.fd, prefix.data(), prefix.size(), 0);
    if (got < 0) fail_file(name, "cannot read", errno);
    prefix.resize(size_t(got));
    std::string_view bytes(prefix);
    if (bytes.starts_with(kByteOrderMark)) bytes.remove_prefix(kByteOrderMark.size());
    Format format = sniff_content(bytes.data(), bytes.size());
    if (format == Format::unknown) format = format_from_extension(path);
    const Progress quiet;
    const detail::ReadInput input{path, name, bytes.data(), bytes.size(), quiet};
    if (const std::optional<uint64_t> counted = header_triangles(format, input, size)) return {*counted, true};
    const uint64_t per_triangle = format == Format::stl ? kAsciiStlBytesPerTriangle : kObjBytesPerTriangle;
    return {std::max<uint64_t>(1, size / per_triangle), false};
}

Mesh read_mesh(const std::filesystem::path& path, const Progress& progress) {
    std::vector<std::string> ignored;
    return read_mesh(path, progress, ignored);
}

void weld(Mesh& mesh) {
    check_weldable(mesh);
    canonicalize_zeros(mesh.positions);
    canonicalize_zeros(mesh.normals);
    canonicalize_zeros(mesh.uvs);
    const VertexBytes bytes{mesh.positions.data(), mesh.has_normals() ? mesh.normals.data() : nullptr,
                            mesh.has_colors() ? mesh.colors.data() : nullptr,
                            mesh.has_uvs() ? mesh.uvs.data() : nullptr};
    PageArray<uint32_t> representative(mesh.vertex_count());
    find_representatives(bytes, representative);
    keep_proper_triangles(mesh, bytes, representative);
    compact_vertices(mesh, representative);
}

void write_ply(const std::filesystem::path& path, const Mesh& mesh, PlyEncoding encoding) {
    const std::string name = path.string();
    check_writable(mesh, name);
    TempFile file(path, name);
    file.write(ply_header(mesh, encoding));
    constexpr bool kLittleHost = std::endian::native == std::endian::little;
    switch (encoding) {
        case PlyEncoding::binary_little_endian: write_binary_body<!kLittleHost>(file, mesh); break;
        case PlyEncoding::binary_big_endian: write_binary_body<kLittleHost>(file, mesh); break;
        case PlyEncoding::ascii: write_ascii_body(file, mesh); break;
    }
    file.commit();
}

}  // namespace strata

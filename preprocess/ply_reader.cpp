// PLY reader: ascii, binary_little_endian and binary_big_endian. Scans are mostly binary PLY with the
// plain layout (float x y z [+ fixed-size extras], faces as uchar 3 + int indices), so that layout
// gets column loops over chunks of the mapped file and a 13-bytes-per-face loop; anything else goes
// through a slower per-property walk that handles lists and unknown elements. A binary PLY can also be
// streamed (open_ply_stream): the builder reads scans larger than memory that way.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "preprocess/mesh_readers.h"

namespace strata::detail {
namespace {

// ---- header ---------------------------------------------------------------------------------------

enum class PlyType : uint8_t { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

size_t type_size(PlyType type) {
    static constexpr std::array<size_t, 8> kSizes = {1, 1, 2, 2, 4, 4, 4, 8};
    return kSizes[size_t(type)];
}
bool is_integer(PlyType type) { return type < PlyType::float32; }

bool parse_type(std::string_view name, PlyType& type) {
    struct Named {
        std::string_view a, b;
        PlyType type;
    };
    static constexpr std::array<Named, 8> kTypes = {{{"char", "int8", PlyType::int8},
                                                     {"uchar", "uint8", PlyType::uint8},
                                                     {"short", "int16", PlyType::int16},
                                                     {"ushort", "uint16", PlyType::uint16},
                                                     {"int", "int32", PlyType::int32},
                                                     {"uint", "uint32", PlyType::uint32},
                                                     {"float", "float32", PlyType::float32},
                                                     {"double", "float64", PlyType::float64}}};
    for (const Named& named : kTypes) {
        if (name == named.a || name == named.b) {
            type = named.type;
            return true;
        }
    }
    return false;
}

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::float32;  // the value type, or a list's item type
    bool is_list = false;
    PlyType count_type = PlyType::uint8;
};

struct PlyElement {
    std::string name;
    uint64_t count = 0;
    std::vector<PlyProperty> properties;

    bool has_lists() const {
        return std::any_of(properties.begin(), properties.end(), [](const PlyProperty& p) { return p.is_list; });
    }
    // Bytes of one record when it has no lists.
    size_t fixed_size() const {
        size_t size = 0;
        for (const PlyProperty& p : properties) size += type_size(p.type);
        return size;
    }
    // What error messages call the records: "vertices", "faces", "edge elements".
    std::string noun() const {
        if (name == "vertex") return "vertices";
        if (name == "face") return "faces";
        return "'" + name + "' elements";
    }
};

enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };

struct PlyHeader {
    PlyFormat format = PlyFormat::ascii;
    std::vector<PlyElement> elements;
    size_t body_offset = 0;
    std::string texture;  // "comment TextureFile name", as MeshLab writes it
};

// Reads the header as the widely used readers do (rply, tinyply, vcglib, plyfile): lines may end in
// LF, CRLF or CR alone, keywords may be separated by any blanks, and a line that is none of the
// keywords (Blender 2.47 wrote "Created by Blender3D 247 ..." without "comment") is skipped with one
// warning per file.
class HeaderParser {
public:
    explicit HeaderParser(const ReadInput& input) : input_(input), lines_(input.data, input.data + input.size) {}

    PlyHeader parse() {
        std::string_view line;
        lines_.next(line);
        if (Tokens(line).rest() != "ply") fail("not a PLY file: the first line is not 'ply'");
        const bool cr_endings = ends_in_cr_alone();
        bool have_format = false;
        while (lines_.next(line)) {
            Tokens tokens(line);
            std::string_view keyword = tokens.next();
            if (keyword == "end_header") {
                if (!have_format) fail("header has no 'format' line");
                header_.body_offset = body_offset(cr_endings);
                warn_skipped();
                return std::move(header_);
            }
            if (keyword.empty() || keyword == "obj_info") continue;
            if (keyword == "comment") {
                comment(tokens);
            } else if (keyword == "format") {
                format(tokens);
                have_format = true;
            } else if (keyword == "element") {
                element(tokens);
            } else if (keyword == "property") {
                property(tokens);
            } else {
                skipped(line);
            }
        }
        fail("header has no 'end_header' line");
    }

private:
    // The line ending of the "ply" line is the file's.
    bool ends_in_cr_alone() const {
        const char* ending = lines_.ending();
        const char* end = input_.data + input_.size;
        return ending < end && *ending == '\r' && (ending + 1 == end || ending[1] != '\n');
    }
    // Binary data follows end_header's line ending, and may well start with a byte 0x0A: a file whose
    // lines end in CR alone (Rhino 6) loses no byte to an LF after it.
    size_t body_offset(bool cr_endings) const {
        const char* ending = lines_.ending();
        const char* end = input_.data + input_.size;
        size_t length = ending < end ? 1 : 0;
        if (!cr_endings && ending + 1 < end && ending[0] == '\r' && ending[1] == '\n') length = 2;
        return size_t(ending - input_.data) + length;
    }
    void skipped(std::string_view line) {
        if (skipped_lines_++ == 0) first_skipped_ = "PLY header line " + std::to_string(lines_.line()) + ": skipped " +
                                                    quoted(line) + ", which is not a PLY header keyword";
    }
    void warn_skipped() const {
        if (skipped_lines_ == 0) return;
        std::string message = first_skipped_;
        if (skipped_lines_ > 1) message += " (and " + std::to_string(skipped_lines_ - 1) + " more such lines)";
        input_.warn(message);
    }
    [[noreturn]] void fail(const std::string& what) const {
        input_.fail("PLY header line " + std::to_string(lines_.line()) + ": " + what);
    }
    void comment(Tokens& tokens) {
        if (tokens.next() == "TextureFile" && header_.texture.empty()) header_.texture = std::string(tokens.rest());
    }
    void format(Tokens& tokens) {
        std::string_view name = tokens.next();
        if (name == "ascii") header_.format = PlyFormat::ascii;
        else if (name == "binary_little_endian") header_.format = PlyFormat::binary_little_endian;
        else if (name == "binary_big_endian") header_.format = PlyFormat::binary_big_endian;
        else fail("unknown format " + quoted(name));
    }
    void element(Tokens& tokens) {
        PlyElement element;
        element.name = std::string(tokens.next());
        std::string_view count = tokens.next();
        if (element.name.empty() || count.empty()) fail("element needs a name and a count");
        if (count[0] == '-') fail("element '" + element.name + "' has a negative count " + std::string(count));
        if (!parse_number(count, element.count))
            fail("element '" + element.name + "' has a bad count " + quoted(count));
        header_.elements.push_back(std::move(element));
    }
    PlyType type(std::string_view name) const {
        PlyType t;
        if (!parse_type(name, t)) fail("unknown property type " + quoted(name));
        return t;
    }
    void property(Tokens& tokens) {
        if (header_.elements.empty()) fail("property before any element");
        PlyProperty p;
        std::string_view first = tokens.next();
        if (first == "list") {
            p.is_list = true;
            p.count_type = type(tokens.next());
            if (!is_integer(p.count_type)) fail("list count type must be an integer type");
            p.type = type(tokens.next());
        } else {
            p.type = type(first);
        }
        p.name = std::string(tokens.next());
        if (p.name.empty()) fail("property has no name");
        header_.elements.back().properties.push_back(std::move(p));
    }

    const ReadInput& input_;
    Lines lines_;
    PlyHeader header_;
    size_t skipped_lines_ = 0;
    std::string first_skipped_;
};

// ---- which vertex property feeds which attribute ---------------------------------------------------

enum Slot : int8_t { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kAlpha, kU, kV, kSlotCount, kNoSlot = -1 };

Slot slot_of(std::string_view name) {
    struct Named {
        std::string_view name;
        Slot slot;
    };
    static constexpr std::array<Named, 26> kNames = {{
        {"x", kX}, {"y", kY}, {"z", kZ},
        {"nx", kNx}, {"ny", kNy}, {"nz", kNz}, {"normal_x", kNx}, {"normal_y", kNy}, {"normal_z", kNz},
        {"red", kRed}, {"green", kGreen}, {"blue", kBlue}, {"alpha", kAlpha},
        {"diffuse_red", kRed}, {"diffuse_green", kGreen}, {"diffuse_blue", kBlue}, {"diffuse_alpha", kAlpha},
        {"u", kU}, {"v", kV}, {"s", kU}, {"t", kV},
        {"texture_u", kU}, {"texture_v", kV}, {"texture_s", kU}, {"texture_t", kV}, {"texcoord_u", kU},
    }};
    for (const Named& named : kNames)
        if (named.name == name) return named.slot;
    return kNoSlot;
}

struct VertexLayout {
    std::array<int, kSlotCount> property{};  // index into the element's properties, or -1
    std::vector<Slot> slot_of_property;      // the inverse, kNoSlot for skipped properties
    bool normals = false, colors = false, alpha = false, uvs = false;
};

VertexLayout vertex_layout(const ReadInput& input, const PlyElement& element) {
    VertexLayout layout;
    layout.property.fill(-1);
    for (size_t i = 0; i < element.properties.size(); ++i) {
        const PlyProperty& p = element.properties[i];
        Slot slot = slot_of(p.name);
        if (slot == kNoSlot || layout.property[slot] >= 0) continue;
        if (p.is_list) input.fail("vertex property '" + p.name + "' is a list, expected a number");
        layout.property[slot] = int(i);
    }
    auto all = [&](std::initializer_list<Slot> slots) {
        return std::all_of(slots.begin(), slots.end(), [&](Slot s) { return layout.property[s] >= 0; });
    };
    if (!all({kX, kY, kZ})) input.fail("PLY vertex element lacks an x, y or z property");
    layout.normals = all({kNx, kNy, kNz});
    layout.colors = all({kRed, kGreen, kBlue});
    layout.alpha = layout.colors && layout.property[kAlpha] >= 0;
    layout.uvs = all({kU, kV});
    // Forget partial groups (a lone nx), so nothing is stored for an attribute the mesh will not have.
    auto drop = [&](bool keep, std::initializer_list<Slot> slots) {
        if (!keep)
            for (Slot s : slots) layout.property[s] = -1;
    };
    drop(layout.normals, {kNx, kNy, kNz});
    drop(layout.colors, {kRed, kGreen, kBlue});
    drop(layout.alpha, {kAlpha});
    drop(layout.uvs, {kU, kV});
    layout.slot_of_property.assign(element.properties.size(), kNoSlot);
    for (int s = 0; s < kSlotCount; ++s)
        if (layout.property[s] >= 0) layout.slot_of_property[size_t(layout.property[s])] = Slot(s);
    return layout;
}

// Colour channels come as bytes, 16-bit, or float 0..1; the mesh keeps bytes.
uint8_t ply_color_byte(double value, PlyType type) {
    if (type == PlyType::uint16 || type == PlyType::int16) value /= 257.0;
    return color_byte(value, is_integer(type));
}

void size_attributes(Mesh& mesh, const VertexLayout& layout, size_t count) {
    reserve_huge(mesh.positions, 3 * count);
    mesh.positions.resize(3 * count);
    if (layout.normals) reserve_huge(mesh.normals, 3 * count), mesh.normals.resize(3 * count);
    if (layout.colors) reserve_huge(mesh.colors, 4 * count), mesh.colors.assign(4 * count, 255);  // opaque by default
    if (layout.uvs) reserve_huge(mesh.uvs, 2 * count), mesh.uvs.resize(2 * count);
}

void store(Mesh& mesh, Coordinates& coordinates, size_t vertex, Slot slot, double value, PlyType type) {
    if (slot <= kZ) mesh.positions[3 * vertex + size_t(slot)] = coordinates.relative(value, slot);
    else if (slot <= kNz) mesh.normals[3 * vertex + size_t(slot - kNx)] = float(value);
    else if (slot <= kAlpha) mesh.colors[4 * vertex + size_t(slot - kRed)] = ply_color_byte(value, type);
    else mesh.uvs[2 * vertex + size_t(slot - kU)] = float(value);
}

// Builds triangles from polygons, fanning around the first corner.
class TriangleSink {
public:
    explicit TriangleSink(std::vector<uint32_t>& out) : out_(out) {}
    void reserve_triangles(size_t count) {
        reserve_huge(out_, used_ + 3 * count);
        out_.resize(used_ + 3 * count);
    }
    void polygon(const uint32_t* corners, size_t n) {
        if (used_ + 3 * (n - 2) > out_.size()) out_.resize(std::max(2 * out_.size(), used_ + 3 * (n - 2)));
        for (size_t k = 1; k + 1 < n; ++k) {
            out_[used_++] = corners[0];
            out_[used_++] = corners[k];
            out_[used_++] = corners[k + 1];
        }
    }
    // Room for `triangles` more without growing, for loops that write directly.
    uint32_t* room(size_t triangles) { return used_ + 3 * triangles <= out_.size() ? out_.data() + used_ : nullptr; }
    size_t free_triangles() const { return (out_.size() - used_) / 3; }
    void advance(size_t triangles) { used_ += 3 * triangles; }
    void finish() { out_.resize(used_); }

private:
    std::vector<uint32_t>& out_;
    size_t used_ = 0;
};

// ---- binary ---------------------------------------------------------------------------------------

template <class T>
T byte_swapped(T value) {
    if constexpr (sizeof(T) == 1) return value;
    using U = std::conditional_t<sizeof(T) == 2, uint16_t, std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>;
    U bits;
    std::memcpy(&bits, &value, sizeof(T));
    if constexpr (sizeof(T) == 2) bits = __builtin_bswap16(bits);
    if constexpr (sizeof(T) == 4) bits = __builtin_bswap32(bits);
    if constexpr (sizeof(T) == 8) bits = __builtin_bswap64(bits);
    std::memcpy(&value, &bits, sizeof(T));
    return value;
}

template <class T, bool Swap>
T load(const char* p) {
    T value;
    std::memcpy(&value, p, sizeof(T));
    if constexpr (Swap) value = byte_swapped(value);
    return value;
}

// Calls fn(T{}) with the C++ type of a PLY type: one switch per column or element, not per value.
template <class Fn>
decltype(auto) with_type(PlyType type, Fn&& fn) {
    switch (type) {
        case PlyType::int8: return fn(int8_t{});
        case PlyType::uint8: return fn(uint8_t{});
        case PlyType::int16: return fn(int16_t{});
        case PlyType::uint16: return fn(uint16_t{});
        case PlyType::int32: return fn(int32_t{});
        case PlyType::uint32: return fn(uint32_t{});
        case PlyType::float32: return fn(float{});
        case PlyType::float64: break;
    }
    return fn(double{});
}

double load_number(const char* p, PlyType type, bool swap) {
    return with_type(type, [&]<class T>(T) {
        return double(swap ? load<T, true>(p) : load<T, false>(p));
    });
}

// One attribute of a run of vertices: strided source bytes to a strided float or byte array.
using FloatColumn = void (*)(const char* src, size_t stride, size_t n, float* dst, size_t dst_stride);
using ByteColumn = void (*)(const char* src, size_t stride, size_t n, uint8_t* dst);

template <class T, bool Swap>
void float_column(const char* src, size_t stride, size_t n, float* dst, size_t dst_stride) {
    for (size_t i = 0; i < n; ++i) dst[i * dst_stride] = float(load<T, Swap>(src + i * stride));
}

// A coordinate column, its origin subtracted in double before the value is rounded to a float.
using PositionColumn = void (*)(const char* src, size_t stride, size_t n, float* dst, double origin);

template <class T, bool Swap>
void position_column(const char* src, size_t stride, size_t n, float* dst, double origin) {
    for (size_t i = 0; i < n; ++i) dst[3 * i] = float(double(load<T, Swap>(src + i * stride)) - origin);
}

template <class T, bool Swap>
void color_column(const char* src, size_t stride, size_t n, uint8_t* dst) {
    constexpr PlyType kType = std::is_same_v<T, uint8_t> ? PlyType::uint8
                              : std::is_same_v<T, int8_t> ? PlyType::int8
                              : std::is_same_v<T, uint16_t> ? PlyType::uint16
                              : std::is_same_v<T, int16_t> ? PlyType::int16
                              : std::is_floating_point_v<T> ? PlyType::float32
                                                            : PlyType::int32;
    for (size_t i = 0; i < n; ++i) {
        if constexpr (std::is_same_v<T, uint8_t>) dst[4 * i] = uint8_t(src[i * stride]);
        else dst[4 * i] = ply_color_byte(double(load<T, Swap>(src + i * stride)), kType);
    }
}

FloatColumn float_column_for(PlyType type, bool swap) {
    return with_type(type, [&]<class T>(T) -> FloatColumn {
        return swap ? &float_column<T, true> : &float_column<T, false>;
    });
}
PositionColumn position_column_for(PlyType type, bool swap) {
    return with_type(type, [&]<class T>(T) -> PositionColumn {
        return swap ? &position_column<T, true> : &position_column<T, false>;
    });
}
ByteColumn color_column_for(PlyType type, bool swap) {
    return with_type(type, [&]<class T>(T) -> ByteColumn {
        return swap ? &color_column<T, true> : &color_column<T, false>;
    });
}

// Walks the binary body of a PLY file element by element.
class BinaryBody {
public:
    BinaryBody(const ReadInput& input, const PlyHeader& header, ReadTicker& ticker)
        : input_(input),
          p_(input.data + header.body_offset),
          end_(input.data + input.size),
          ticker_(ticker),
          swap_((header.format == PlyFormat::binary_big_endian) != (std::endian::native == std::endian::big)),
          coordinates_(input) {}

    void vertices(const PlyElement& element, const VertexLayout& layout, Mesh& mesh) {
        if (element.has_lists()) return vertices_with_lists(element, layout, mesh);
        const size_t stride = element.fixed_size();
        require_records(element, stride);
        size_attributes(mesh, layout, element.count);
        std::vector<size_t> offsets = property_offsets(element);
        if (element.count > 0) pick_origin(element, layout, offsets, mesh);
        constexpr size_t kChunk = 1 << 14;  // a chunk's source bytes stay in L2 across the columns
        for (size_t first = 0; first < element.count; first += kChunk) {
            const size_t n = std::min<size_t>(kChunk, element.count - first);
            vertex_chunk(element, layout, offsets, p_ + first * stride, stride, first, n, mesh);
            ticker_.at(size_t(p_ - input_.data) + (first + n) * stride);
        }
        p_ += element.count * stride;
    }

    void faces(const PlyElement& element, size_t list, uint32_t vertex_count, Mesh& mesh) {
        require_min_records(element, min_face_bytes(element, list));
        TriangleSink sink(mesh.indices);
        sink.reserve_triangles(element.count);
        const bool plain = element.properties.size() == 1 && type_size(element.properties[0].count_type) == 1 &&
                           type_size(element.properties[0].type) == 4;
        std::vector<uint32_t> corners;
        for (uint64_t face = 0; face < element.count;) {
            if (plain) face = swap_ ? plain_triangles<true>(face, element.count, vertex_count, sink)
                                    : plain_triangles<false>(face, element.count, vertex_count, sink);
            if (face == element.count) break;
            any_face(element, list, face, vertex_count, corners, sink);
            ++face;
            if ((face & 0xffff) == 0) ticker_.at(size_t(p_ - input_.data));
        }
        sink.finish();
    }

    void skip(const PlyElement& element) {
        if (element.properties.empty()) return;
        if (!element.has_lists()) {
            require_records(element, element.fixed_size());
            p_ += element.count * element.fixed_size();
            return;
        }
        for (uint64_t i = 0; i < element.count; ++i) {
            for (const PlyProperty& p : element.properties) skip_property(p, element, i);
            if ((i & 0xffff) == 0) ticker_.at(size_t(p_ - input_.data));
        }
    }

private:
    [[noreturn]] void truncated(const PlyElement& element, uint64_t complete) const {
        input_.fail("expected " + std::to_string(element.count) + " " + element.noun() + ", file ends after " +
                    std::to_string(complete));
    }
    size_t remaining() const { return size_t(end_ - p_); }

    // Checked before allocating, so a lying count cannot drive a huge allocation.
    void require_records(const PlyElement& element, size_t record_bytes) const {
        if (element.count > remaining() / record_bytes) truncated(element, remaining() / record_bytes);
    }
    void require_min_records(const PlyElement& element, size_t min_record_bytes) const {
        input_.require_room(element.count, element.noun(), remaining(), remaining() / min_record_bytes);
    }
    void need(size_t bytes, const PlyElement& element, uint64_t record) const {
        if (bytes > remaining()) truncated(element, record);
    }

    static std::vector<size_t> property_offsets(const PlyElement& element) {
        std::vector<size_t> offsets;
        size_t at = 0;
        for (const PlyProperty& p : element.properties) offsets.push_back(at), at += type_size(p.type);
        return offsets;
    }

    // From the first vertex's coordinates, before any column is stored against it.
    void pick_origin(const PlyElement& element, const VertexLayout& layout, const std::vector<size_t>& offsets,
                     Mesh& mesh) {
        for (int a = 0; a < 3; ++a) {
            const size_t prop = size_t(layout.property[kX + a]);
            coordinates_.relative(load_number(p_ + offsets[prop], element.properties[prop].type, swap_), a);
        }
        mesh.origin = coordinates_.origin();
    }

    void vertex_chunk(const PlyElement& element, const VertexLayout& layout, const std::vector<size_t>& offsets,
                      const char* src, size_t stride, size_t first, size_t n, Mesh& mesh) const {
        for (int s = 0; s < kSlotCount; ++s) {
            const int prop = layout.property[s];
            if (prop < 0) continue;
            const PlyType type = element.properties[size_t(prop)].type;
            const char* column = src + offsets[size_t(prop)];
            if (s >= kRed && s <= kAlpha) {
                color_column_for(type, swap_)(column, stride, n, &mesh.colors[4 * first + size_t(s - kRed)]);
            } else if (s == kX && mesh.origin == std::array<double, 3>{} && xyz_packed(element, layout, offsets)) {
                copy_xyz(column, stride, n, &mesh.positions[3 * first]);
                s = kZ;  // y and z came along
            } else if (s <= kZ) {
                position_column_for(type, swap_)(column, stride, n, &mesh.positions[3 * first + size_t(s)],
                                                 mesh.origin[size_t(s)]);
            } else {
                auto [dst, width, base] = float_target(s, mesh);
                float_column_for(type, swap_)(column, stride, n, dst + width * first + size_t(s - base), width);
            }
        }
    }

    struct FloatTarget {
        float* data;
        size_t width;
        int first_slot;
    };
    static FloatTarget float_target(int slot, Mesh& mesh) {
        if (slot <= kNz) return {mesh.normals.data(), 3, kNx};
        return {mesh.uvs.data(), 2, kU};
    }

    // The common case: float x y z next to each other in file byte order = host order.
    bool xyz_packed(const PlyElement& element, const VertexLayout& layout, const std::vector<size_t>& offsets) const {
        if (swap_) return false;
        for (int k = 0; k < 3; ++k) {
            const size_t prop = size_t(layout.property[kX + k]);
            if (element.properties[prop].type != PlyType::float32) return false;
            if (offsets[prop] != offsets[size_t(layout.property[kX])] + 4 * size_t(k)) return false;
        }
        return true;
    }
    static void copy_xyz(const char* src, size_t stride, size_t n, float* dst) {
        if (stride == 12) return void(std::memcpy(dst, src, 12 * n));
        for (size_t i = 0; i < n; ++i) std::memcpy(dst + 3 * i, src + i * stride, 12);
    }

    void vertices_with_lists(const PlyElement& element, const VertexLayout& layout, Mesh& mesh) {
        size_t min_bytes = 0;
        for (const PlyProperty& p : element.properties)
            min_bytes += p.is_list ? type_size(p.count_type) : type_size(p.type);
        require_min_records(element, min_bytes);
        size_attributes(mesh, layout, element.count);
        for (uint64_t v = 0; v < element.count; ++v) {
            for (size_t i = 0; i < element.properties.size(); ++i) {
                const PlyProperty& p = element.properties[i];
                const Slot slot = layout.slot_of_property[i];
                if (slot == kNoSlot) {
                    skip_property(p, element, v);
                    continue;
                }
                need(type_size(p.type), element, v);
                store(mesh, coordinates_, v, slot, load_number(p_, p.type, swap_), p.type);
                p_ += type_size(p.type);
            }
            if ((v & 0xffff) == 0) ticker_.at(size_t(p_ - input_.data));
        }
        mesh.origin = coordinates_.origin();
    }

    void skip_property(const PlyProperty& p, const PlyElement& element, uint64_t record) {
        if (!p.is_list) {
            need(type_size(p.type), element, record);
            p_ += type_size(p.type);
            return;
        }
        need(type_size(p.count_type), element, record);
        const double n = load_number(p_, p.count_type, swap_);
        p_ += type_size(p.count_type);
        if (n < 0)
            input_.fail(element.name + " " + std::to_string(record) + ": list '" + p.name + "' has negative length");
        need(size_t(n) * type_size(p.type), element, record);
        p_ += size_t(n) * type_size(p.type);
    }

    static size_t min_face_bytes(const PlyElement& element, size_t list) {
        size_t bytes = 0;
        for (size_t i = 0; i < element.properties.size(); ++i) {
            const PlyProperty& p = element.properties[i];
            bytes += p.is_list ? type_size(p.count_type) : type_size(p.type);
            if (i == list) bytes += 3 * type_size(p.type);
        }
        return bytes;
    }

    // Faces that are exactly "uchar 3, three 4-byte indices": as many in a row as possible, stopping at
    // anything else (polygon, bad index, end of data) for any_face() to handle or report.
    template <bool Swap>
    uint64_t plain_triangles(uint64_t face, uint64_t count, uint32_t vertex_count, TriangleSink& sink) {
        constexpr uint64_t kBatch = 1 << 16;
        while (face < count) {
            const uint64_t batch = std::min({count - face, kBatch, uint64_t(sink.free_triangles()),
                                             uint64_t(remaining() / 13)});
            uint32_t* out = sink.room(batch);
            uint64_t done = 0;
            for (; done < batch; ++done) {
                const char* record = p_ + 13 * done;
                if (record[0] != 3) break;
                const uint32_t a = load<uint32_t, Swap>(record + 1), b = load<uint32_t, Swap>(record + 5),
                               c = load<uint32_t, Swap>(record + 9);
                if (a >= vertex_count || b >= vertex_count || c >= vertex_count) break;
                out[3 * done] = a, out[3 * done + 1] = b, out[3 * done + 2] = c;
            }
            p_ += 13 * done;
            sink.advance(done);
            face += done;
            ticker_.at(size_t(p_ - input_.data));
            if (done < batch || batch == 0) break;
        }
        return face;
    }

    void any_face(const PlyElement& element, size_t list, uint64_t face, uint32_t vertex_count,
                  std::vector<uint32_t>& corners, TriangleSink& sink) {
        for (size_t i = 0; i < element.properties.size(); ++i) {
            const PlyProperty& p = element.properties[i];
            if (i != list) {
                skip_property(p, element, face);
                continue;
            }
            need(type_size(p.count_type), element, face);
            const double n = load_number(p_, p.count_type, swap_);
            p_ += type_size(p.count_type);
            if (n < 3) input_.fail("face " + std::to_string(face) + " has " + std::to_string(int64_t(n)) +
                                   " corners, at least 3 needed");
            const size_t item = type_size(p.type);
            need(size_t(n) * item, element, face);
            corners.resize(size_t(n));
            for (size_t k = 0; k < corners.size(); ++k, p_ += item)
                corners[k] = checked_index(load_number(p_, p.type, swap_), face, vertex_count);
            sink.polygon(corners.data(), corners.size());
        }
    }

    uint32_t checked_index(double index, uint64_t face, uint32_t vertex_count) const {
        if (!(index >= 0 && index < vertex_count))
            input_.fail("face " + std::to_string(face) + " indexes vertex " + std::to_string(int64_t(index)) + " of " +
                        std::to_string(vertex_count));
        return uint32_t(index);
    }

    const ReadInput& input_;
    const char* p_;
    const char* end_;
    ReadTicker& ticker_;
    bool swap_;
    Coordinates coordinates_;
};

// ---- ascii ----------------------------------------------------------------------------------------

class AsciiBody {
public:
    AsciiBody(const ReadInput& input, const PlyHeader& header, ReadTicker& ticker)
        : input_(input),
          tokens_(input.data + header.body_offset, input.data + input.size),
          ticker_(ticker),
          coordinates_(input) {}

    void vertices(const PlyElement& element, const VertexLayout& layout, Mesh& mesh) {
        require_values(element, 0);
        size_attributes(mesh, layout, element.count);
        for (uint64_t v = 0; v < element.count; ++v) {
            for (size_t i = 0; i < element.properties.size(); ++i) {
                const PlyProperty& p = element.properties[i];
                const Slot slot = layout.slot_of_property[i];
                if (slot == kNoSlot) {
                    skip_property(p, element, v);
                    continue;
                }
                if (slot <= kZ && !is_integer(p.type)) mesh.positions[3 * v + size_t(slot)] = coordinate(p.type, slot, element, v);
                else store(mesh, coordinates_, v, slot, number(p.type, element, v), p.type);
            }
            ticker_.at(offset());
        }
        mesh.origin = coordinates_.origin();
    }

    void faces(const PlyElement& element, size_t list, uint32_t vertex_count, Mesh& mesh) {
        TriangleSink sink(mesh.indices);
        require_values(element, 1);  // a corner at least: a face with too few fails on its own, more clearly
        sink.reserve_triangles(element.count);
        std::vector<uint32_t> corners;
        for (uint64_t face = 0; face < element.count; ++face) {
            for (size_t i = 0; i < element.properties.size(); ++i) {
                const PlyProperty& p = element.properties[i];
                if (i != list) {
                    skip_property(p, element, face);
                    continue;
                }
                const double n = number(p.count_type, element, face);
                if (n < 3) fail("face " + std::to_string(face) + " has " + std::to_string(int64_t(n)) +
                                " corners, at least 3 needed");
                corners.clear();
                for (double k = 0; k < n; ++k)
                    corners.push_back(index(number(p.type, element, face), face, vertex_count));
                sink.polygon(corners.data(), corners.size());
            }
            ticker_.at(offset());
        }
        sink.finish();
    }

    void skip(const PlyElement& element) {
        if (element.properties.empty()) return;
        require_values(element, 0);
        for (uint64_t i = 0; i < element.count; ++i) {
            for (const PlyProperty& p : element.properties) skip_property(p, element, i);
            ticker_.at(offset());
        }
    }

    // Anything after the last element means the header's counts were too small.
    void finish() {
        if (!tokens_.at_end())
            fail("unexpected data " + quoted(tokens_.next()) + " after the last element (header counts too small?)");
    }

private:
    size_t offset() const { return size_t(tokens_.position() - input_.data); }
    [[noreturn]] void fail(const std::string& what) const {
        input_.fail("line " + std::to_string(line_number(input_.data, tokens_.position())) + ": " + what);
    }

    // A record holds a value per property (a list at least its count) and `extra` more.
    void require_values(const PlyElement& element, size_t extra) const {
        const size_t left = input_.size - offset();
        input_.require_room(element.count, element.noun(), left, text_room(left, element.properties.size() + extra));
    }

    std::string_view next_token(const PlyElement& element, uint64_t record) {
        std::string_view token = tokens_.next();
        if (token.empty())
            input_.fail("expected " + std::to_string(element.count) + " " + element.noun() + ", file ends after " +
                        std::to_string(record));
        return token;
    }
    double number(PlyType type, const PlyElement& element, uint64_t record) {
        std::string_view token = next_token(element, record);
        double value = 0;
        bool ok;
        if (is_integer(type)) {
            int64_t i = 0;
            ok = parse_number(token, i);
            value = double(i);
        } else if (type == PlyType::float32) {
            float f = 0;  // parsed as float, so a float written by to_chars reads back bit-exact
            ok = parse_number(token, f);
            value = f;
        } else {
            ok = parse_number(token, value);
        }
        if (!ok) not_a_number(type, element, record, token);
        return value;
    }
    float coordinate(PlyType type, int axis, const PlyElement& element, uint64_t record) {
        std::string_view token = next_token(element, record);
        float value = 0;
        if (!coordinates_.parse(token, axis, value, type == PlyType::float32))
            not_a_number(type, element, record, token);
        return value;
    }
    [[noreturn]] void not_a_number(PlyType type, const PlyElement& element, uint64_t record, std::string_view token) const {
        fail(element.name + " " + std::to_string(record) + ": expected " + (is_integer(type) ? "an integer" : "a number") +
             ", found " + quoted(token));
    }

    void skip_property(const PlyProperty& p, const PlyElement& element, uint64_t record) {
        if (!p.is_list) return void(number(p.type, element, record));
        const double n = number(p.count_type, element, record);
        if (n < 0) fail(element.name + " " + std::to_string(record) + ": list '" + p.name + "' has negative length");
        for (double k = 0; k < n; ++k) number(p.type, element, record);
    }

    uint32_t index(double value, uint64_t face, uint32_t vertex_count) const {
        if (!(value >= 0 && value < vertex_count))
            fail("face " + std::to_string(face) + " indexes vertex " + std::to_string(int64_t(value)) + " of " +
                 std::to_string(vertex_count));
        return uint32_t(value);
    }

    const ReadInput& input_;
    Tokens tokens_;
    ReadTicker& ticker_;
    Coordinates coordinates_;
};

// ---- putting it together --------------------------------------------------------------------------

const PlyElement* find_element(const PlyHeader& header, std::string_view name, const ReadInput& input) {
    const PlyElement* found = nullptr;
    for (const PlyElement& element : header.elements) {
        if (element.name != name) continue;
        if (found) input.fail("PLY header has more than one '" + std::string(name) + "' element");
        found = &element;
    }
    return found;
}

size_t face_list(const ReadInput& input, const PlyElement& face) {
    for (size_t i = 0; i < face.properties.size(); ++i) {
        const PlyProperty& p = face.properties[i];
        if (p.name != "vertex_indices" && p.name != "vertex_index") continue;
        if (!p.is_list) input.fail("face property '" + p.name + "' is not a list");
        if (!is_integer(p.type)) input.fail("face property '" + p.name + "' has non-integer indices");
        return i;
    }
    input.fail("PLY face element has no vertex_indices list");
}

template <class Body>
void read_body(Body& body, const PlyHeader& header, const VertexLayout& layout, size_t list, uint32_t vertex_count,
               Mesh& mesh) {
    for (const PlyElement& element : header.elements) {
        if (element.name == "vertex") body.vertices(element, layout, mesh);
        else if (element.name == "face") body.faces(element, list, vertex_count, mesh);
        else body.skip(element);
    }
}

void check_positions(const ReadInput& input, const Mesh& mesh) {
    const size_t bad = first_non_finite(mesh.positions.data(), mesh.vertex_count());
    if (bad < mesh.vertex_count()) input.fail("vertex " + std::to_string(bad) + " has a NaN or infinite coordinate");
}


// ---- streaming ------------------------------------------------------------------------------------
// A binary PLY far larger than memory: faces are read in order with pread, and each corner's vertex is
// looked up in a cache of decoded pages of the vertex element, read from the file as faces need them.
// Scans list faces with strong locality in their vertex indices, so few pages are read twice.

// The input file, read with pread; remembers its size and modification time so that a file that
// another program rewrites during the build is reported, not built from two versions.
class InputFile {
public:
    InputFile(const std::filesystem::path& path, std::string name) : name_(std::move(name)) {
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0) throw InputError(name_ + ": cannot open (" + std::strerror(errno) + ")");
        stamp_ = stamp();
    }
    ~InputFile() { ::close(fd_); }
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    uint64_t size() const { return stamp_.size; }
    // Reads up to `n` bytes at `offset`; returns how many the file has there.
    size_t read(uint64_t offset, size_t n, char* to) const {
        size_t done = 0;
        while (done < n) {
            const ssize_t got = ::pread(fd_, to + done, n - done, off_t(offset + done));
            if (got < 0 && errno == EINTR) continue;
            if (got < 0) throw InputError(name_ + ": read error (" + std::strerror(errno) + ")");
            if (got == 0) break;
            done += size_t(got);
        }
        return done;
    }
    void check_unchanged() const {
        if (stamp() != stamp_)
            throw InputError(name_ + ": the file changed while it was being read; build again once it is complete");
    }

private:
    struct Stamp {
        uint64_t size;
        int64_t seconds, nanoseconds;
        bool operator==(const Stamp&) const = default;
    };
    Stamp stamp() const {
        struct stat st {};
        if (::fstat(fd_, &st) != 0) throw InputError(name_ + ": cannot stat (" + std::strerror(errno) + ")");
        if (!S_ISREG(st.st_mode)) throw InputError(name_ + ": not a regular file");
        return {uint64_t(st.st_size), int64_t(st.st_mtim.tv_sec), int64_t(st.st_mtim.tv_nsec)};
    }
    std::string name_;
    int fd_ = -1;
    Stamp stamp_{};
};

// Where a fixed-size element's columns go in a decoded page.
struct VertexColumns {
    std::vector<size_t> offsets;  // of each property within a record
    size_t stride = 0;
    bool swap = false;
};

// Decoded vertices [first, first + count) of the vertex element, positions against the origin.
struct VertexPage {
    std::vector<float> positions, normals, uvs;
    std::vector<uint8_t> colors;
};

class PlyStream final : public TriangleSource {
public:
    static constexpr uint32_t kPageVertices = 4096;

    PlyStream(std::unique_ptr<InputFile> file, const std::filesystem::path& path, std::string name, PlyHeader header,
              uint64_t vertex_offset, uint64_t face_offset, uint64_t cache_bytes, const std::array<double, 3>* origin)
        : file_(std::move(file)),
          path_(path),
          name_(std::move(name)),
          header_(std::move(header)),
          vertex_(*find(header_, "vertex")),
          face_(*find(header_, "face")),
          vertex_offset_(vertex_offset),
          face_offset_(face_offset),
          cache_bytes_(cache_bytes) {
        const ReadInput input = description();
        layout_ = vertex_layout(input, vertex_);
        list_ = face_list(input, face_);
        columns_.stride = vertex_.fixed_size();
        columns_.swap = (header_.format == PlyFormat::binary_big_endian) != (std::endian::native == std::endian::big);
        for (size_t at = 0; const PlyProperty& p : vertex_.properties) columns_.offsets.push_back(at), at += type_size(p.type);
        if (vertex_.count > (file_->size() - vertex_offset_) / std::max<size_t>(columns_.stride, 1))
            input.fail("expected " + std::to_string(vertex_.count) + " vertices, file ends after " +
                       std::to_string((file_->size() - vertex_offset_) / std::max<size_t>(columns_.stride, 1)));
        pick_origin(origin);
    }

    const std::string& name() const override { return name_; }
    AttributeSet attributes() const override { return {layout_.normals, layout_.colors, layout_.uvs}; }
    const std::string& texture() const override { return header_.texture; }
    std::array<double, 3> origin() const override { return origin_; }
    uint64_t vertex_count() const override { return vertex_.count; }
    uint64_t triangle_count() const override { return face_.count; }
    uint64_t memory_bytes() const override { return memory_; }

    void for_each(const std::function<void(const TriangleBatch&)>& visit, const Progress& progress) override;

private:
    static const PlyElement* find(const PlyHeader& header, std::string_view name) {
        for (const PlyElement& element : header.elements)
            if (element.name == name) return &element;
        return nullptr;
    }
    ReadInput description() const { return ReadInput{path_, name_, nullptr, 0, no_progress_, nullptr, nullptr}; }

    void pick_origin(const std::array<double, 3>* origin) {
        if (origin) return void(origin_ = *origin);
        if (vertex_.count == 0) return;
        std::vector<char> record(columns_.stride);
        file_->read(vertex_offset_, record.size(), record.data());
        for (int a = 0; a < 3; ++a) {
            const size_t prop = size_t(layout_.property[kX + a]);
            origin_[size_t(a)] = origin_near(load_number(record.data() + columns_.offsets[prop], vertex_.properties[prop].type, columns_.swap));
        }
    }

    class Cache;
    class Faces;

    std::unique_ptr<InputFile> file_;
    std::filesystem::path path_;
    std::string name_;
    PlyHeader header_;
    const PlyElement& vertex_;
    const PlyElement& face_;
    uint64_t vertex_offset_, face_offset_, cache_bytes_;
    VertexLayout layout_;
    size_t list_ = 0;
    VertexColumns columns_;
    std::array<double, 3> origin_{};
    uint64_t memory_ = 0;
    Progress no_progress_;
};

// Pages of decoded vertices, replaced by the clock (second-chance) rule.
class PlyStream::Cache {
public:
    Cache(const PlyStream& ply, uint64_t bytes) : ply_(ply) {
        const uint64_t pages = (ply.vertex_.count + kPageVertices - 1) / kPageVertices;
        page_slot_.assign(size_t(pages), -1);
        const AttributeSet a = ply.attributes();
        const uint64_t page_bytes = uint64_t(kPageVertices) * (12 + (a.normals ? 12 : 0) + (a.colors ? 4 : 0) + (a.uvs ? 8 : 0));
        slots_.resize(size_t(std::clamp<uint64_t>(bytes / page_bytes, 4, std::max<uint64_t>(pages, 4))));
        raw_.resize(size_t(kPageVertices) * ply.columns_.stride);
    }
    uint64_t memory_bytes() const {
        uint64_t bytes = page_slot_.size() * sizeof(int32_t) + raw_.size();
        for (const Slot& s : slots_)
            bytes += 4 * (s.vertices.positions.capacity() + s.vertices.normals.capacity() + s.vertices.uvs.capacity()) + s.vertices.colors.capacity();
        return bytes;
    }

    // Appends vertex v's values to the batch.
    void append(uint32_t v, TriangleBatch& batch) {
        const VertexPage& page = page_of(v / kPageVertices);
        const size_t i = v % kPageVertices;
        batch.positions.insert(batch.positions.end(), &page.positions[3 * i], &page.positions[3 * i] + 3);
        if (!page.normals.empty()) batch.normals.insert(batch.normals.end(), &page.normals[3 * i], &page.normals[3 * i] + 3);
        if (!page.colors.empty()) batch.colors.insert(batch.colors.end(), &page.colors[4 * i], &page.colors[4 * i] + 4);
        if (!page.uvs.empty()) batch.uvs.insert(batch.uvs.end(), &page.uvs[2 * i], &page.uvs[2 * i] + 2);
    }

private:
    struct Slot {
        int64_t page = -1;
        bool referenced = false;
        VertexPage vertices;
    };
    const VertexPage& page_of(uint32_t page) {
        const int32_t at = page_slot_[page];
        if (at >= 0) {
            slots_[size_t(at)].referenced = true;
            return slots_[size_t(at)].vertices;
        }
        while (slots_[hand_].referenced) slots_[hand_].referenced = false, hand_ = (hand_ + 1) % slots_.size();
        Slot& slot = slots_[hand_];
        if (slot.page >= 0) page_slot_[size_t(slot.page)] = -1;
        slot.page = page;
        slot.referenced = true;
        page_slot_[page] = int32_t(hand_);
        hand_ = (hand_ + 1) % slots_.size();
        decode(page, slot.vertices);
        return slot.vertices;
    }
    void decode(uint32_t page, VertexPage& out);

    const PlyStream& ply_;
    std::vector<int32_t> page_slot_;
    std::vector<Slot> slots_;
    std::vector<char> raw_;
    size_t hand_ = 0;
};

void PlyStream::Cache::decode(uint32_t page, VertexPage& out) {
    const uint64_t first = uint64_t(page) * kPageVertices;
    const size_t n = size_t(std::min<uint64_t>(kPageVertices, ply_.vertex_.count - first));
    const VertexColumns& c = ply_.columns_;
    const uint64_t offset = ply_.vertex_offset_ + first * c.stride;
    if (ply_.file_->read(offset, n * c.stride, raw_.data()) != n * c.stride)
        ply_.description().fail("the file is shorter than when it was opened: vertex " + std::to_string(first) + " is gone");
    const VertexLayout& layout = ply_.layout_;
    out.positions.resize(3 * n);
    if (layout.normals) out.normals.resize(3 * n);
    if (layout.colors) out.colors.assign(4 * n, 255);  // opaque unless the file has alpha
    if (layout.uvs) out.uvs.resize(2 * n);
    for (int s = 0; s < kSlotCount; ++s) {
        const int prop = layout.property[s];
        if (prop < 0) continue;
        const PlyType type = ply_.vertex_.properties[size_t(prop)].type;
        const char* column = raw_.data() + c.offsets[size_t(prop)];
        if (s <= kZ) position_column_for(type, c.swap)(column, c.stride, n, &out.positions[size_t(s)], ply_.origin_[size_t(s)]);
        else if (s <= kNz) float_column_for(type, c.swap)(column, c.stride, n, &out.normals[size_t(s - kNx)], 3);
        else if (s <= kAlpha) color_column_for(type, c.swap)(column, c.stride, n, &out.colors[size_t(s - kRed)]);
        else float_column_for(type, c.swap)(column, c.stride, n, &out.uvs[size_t(s - kU)], 2);
    }
    const size_t bad = first_non_finite(out.positions.data(), n);
    if (bad < n) ply_.description().fail("vertex " + std::to_string(first + bad) + " has a NaN or infinite coordinate");
    for (std::vector<float>* values : {&out.positions, &out.normals, &out.uvs})
        for (float& x : *values) x += 0.0f;  // −0 as +0, as weld() has it
}

// The face element, read in order through a window of the file; polygons are fanned around their
// first corner as the in-memory reader fans them.
class PlyStream::Faces {
public:
    static constexpr size_t kWindow = size_t(4) << 20;

    // No larger than what is left of the file: a small file's faces cost no 4 MiB buffer.
    explicit Faces(const PlyStream& ply) : ply_(ply), offset_(ply.face_offset_) {
        window_.resize(size_t(std::clamp<uint64_t>(ply.file_->size() - std::min(ply.file_->size(), offset_), 64, kWindow)));
    }

    // Appends the corners of up to `triangles` more triangles; false when every face has been read.
    bool next(std::vector<uint32_t>& corners, size_t triangles) {
        corners.clear();
        while (face_ < ply_.face_.count && corners.size() < 3 * triangles) {
            if (!record(corners)) refill();
        }
        return !corners.empty();
    }

private:
    // One face from the window; false (nothing consumed) when the window ends inside it.
    bool record(std::vector<uint32_t>& corners) {
        const bool swap = ply_.columns_.swap;
        const char* p = window_.data() + begin_;
        const char* end = window_.data() + end_;
        const size_t before = corners.size();
        for (size_t i = 0; i < ply_.face_.properties.size(); ++i) {
            const PlyProperty& prop = ply_.face_.properties[i];
            if (!prop.is_list) {
                if (size_t(end - p) < type_size(prop.type)) return undo(corners, before);
                p += type_size(prop.type);
                continue;
            }
            if (size_t(end - p) < type_size(prop.count_type)) return undo(corners, before);
            const double n = load_number(p, prop.count_type, swap);
            p += type_size(prop.count_type);
            if (n < 0) fail(ply_.face_.name + " " + std::to_string(face_) + ": list '" + prop.name + "' has negative length");
            if (i == ply_.list_ && n < 3)
                fail("face " + std::to_string(face_) + " has " + std::to_string(int64_t(n)) + " corners, at least 3 needed");
            const size_t item = type_size(prop.type);
            const uint64_t file_left = ply_.file_->size() - (offset_ + uint64_t(p - window_.data()));
            if (n * double(item) > double(file_left)) truncated();
            if (double(end - p) < n * double(item)) return undo(corners, before);
            if (i == ply_.list_) fan(p, size_t(n), item, corners);
            p += size_t(n) * item;
        }
        begin_ = size_t(p - window_.data());
        ++face_;
        return true;
    }
    void fan(const char* p, size_t n, size_t item, std::vector<uint32_t>& corners) const {
        const PlyType type = ply_.face_.properties[ply_.list_].type;
        // Most scans: triangles of 32-bit indices in the machine's byte order, copied as they are.
        if (n == 3 && !ply_.columns_.swap && (type == PlyType::uint32 || type == PlyType::int32)) {
            uint32_t v[3];
            std::memcpy(v, p, sizeof v);
            const uint64_t count = ply_.vertex_.count;
            const bool negative = type == PlyType::int32 && ((v[0] | v[1] | v[2]) >> 31) != 0;
            if (!negative && v[0] < count && v[1] < count && v[2] < count) {
                corners.insert(corners.end(), v, v + 3);
                return;
            }
        }
        auto corner = [&](size_t k) {
            const double index = load_number(p + k * item, type, ply_.columns_.swap);
            if (!(index >= 0 && index < double(ply_.vertex_.count)))
                fail("face " + std::to_string(face_) + " indexes vertex " + std::to_string(int64_t(index)) + " of " +
                     std::to_string(ply_.vertex_.count));
            return uint32_t(index);
        };
        const uint32_t first = corner(0);
        uint32_t previous = corner(1);
        for (size_t k = 2; k < n; ++k) {
            const uint32_t next = corner(k);
            corners.insert(corners.end(), {first, previous, next});
            previous = next;
        }
    }
    static bool undo(std::vector<uint32_t>& corners, size_t before) {
        corners.resize(before);
        return false;
    }
    // Moves the unread tail to the front and reads more after it; a face longer than the whole window
    // (a polygon of a million corners) makes the window grow.
    void refill() {
        const size_t tail = end_ - begin_;
        if (begin_ == 0 && end_ == window_.size()) window_.resize(2 * window_.size());
        std::memmove(window_.data(), window_.data() + begin_, tail);
        offset_ += begin_;
        begin_ = 0, end_ = tail;
        const size_t got = ply_.file_->read(offset_ + tail, window_.size() - tail, window_.data() + tail);
        if (got == 0) truncated();
        end_ += got;
    }
    [[noreturn]] void truncated() const {
        fail("expected " + std::to_string(ply_.face_.count) + " faces, file ends after " + std::to_string(face_));
    }
    [[noreturn]] void fail(const std::string& what) const { ply_.description().fail(what); }

    const PlyStream& ply_;
    std::vector<char> window_;
    uint64_t offset_;  // file offset of window_[0]
    size_t begin_ = 0, end_ = 0;  // the window's unread bytes
    uint64_t face_ = 0;
};

// Two batches in flight: a reader thread fills one while the caller visits the other, in order. A
// build's passes spend about as long decoding the file as on what they do with the triangles, so the
// two overlap on two cores. What the reader throws is rethrown to the caller after the batches before it.
class BatchHandoff {
public:
    // On the reader thread: fill(batch) fills the next batch, false once there are no more.
    void produce(const std::function<bool(TriangleBatch&)>& fill) {
        try {
            for (int i = 0;; i ^= 1) {
                {
                    std::unique_lock lock(mutex_);
                    changed_.wait(lock, [&] { return !full_[i] || stop_; });
                    if (stop_) return;
                }
                const bool more = fill(slots_[i]);  // the caller touches only full slots
                std::lock_guard lock(mutex_);
                (more ? full_[i] : done_) = true;
                changed_.notify_all();
                if (!more) return;
            }
        } catch (...) {
            std::lock_guard lock(mutex_);
            error_ = std::current_exception();
            done_ = true;
            changed_.notify_all();
        }
    }
    // On the caller's thread: visits every batch in order.
    void consume(const std::function<void(const TriangleBatch&)>& visit) {
        for (int i = 0;; i ^= 1) {
            {
                std::unique_lock lock(mutex_);
                changed_.wait(lock, [&] { return full_[i] || done_; });
                if (!full_[i]) {
                    if (error_) std::rethrow_exception(error_);
                    return;
                }
            }
            visit(slots_[i]);
            std::lock_guard lock(mutex_);
            full_[i] = false;
            changed_.notify_all();
        }
    }
    // Makes produce() return (the caller stopped early: cancelled, or its visit threw).
    void stop() {
        std::lock_guard lock(mutex_);
        stop_ = true;
        changed_.notify_all();
    }

private:
    std::mutex mutex_;
    std::condition_variable changed_;
    TriangleBatch slots_[2];
    bool full_[2] = {false, false};
    bool done_ = false, stop_ = false;
    std::exception_ptr error_;
};

void PlyStream::for_each(const std::function<void(const TriangleBatch&)>& visit, const Progress& progress) {
    constexpr size_t kBatch = 1 << 15;
    file_->check_unchanged();
    Cache cache(*this, cache_bytes_);
    Faces faces(*this);
    std::vector<uint32_t> corners;
    BatchHandoff handoff;
    std::thread reader([&] {
        handoff.produce([&](TriangleBatch& batch) {
            if (!faces.next(corners, kBatch)) return false;
            batch.clear();
            for (uint32_t v : corners) cache.append(v, batch);
            const uint64_t batch_bytes = 4 * (batch.positions.capacity() + batch.normals.capacity() + batch.uvs.capacity()) +
                                         batch.colors.capacity();
            memory_ = std::max(memory_, cache.memory_bytes() + Faces::kWindow + 2 * batch_bytes);  // two in flight
            return true;
        });
    });
    struct JoinOnExit {
        BatchHandoff& handoff;
        std::thread& reader;
        ~JoinOnExit() {
            handoff.stop();
            reader.join();
        }
    } join{handoff, reader};
    handoff.consume([&](const TriangleBatch& batch) {
        progress.check();
        visit(batch);
    });
    file_->check_unchanged();
}

// The byte offset of each element's records, as far as they can be known without reading the data:
// an element with lists has a size only its records tell.
std::vector<uint64_t> fixed_offsets(const PlyHeader& header) {
    std::vector<uint64_t> offsets;
    uint64_t at = header.body_offset;
    for (const PlyElement& element : header.elements) {
        offsets.push_back(at);
        at = element.has_lists() || at == UINT64_MAX ? UINT64_MAX : at + element.count * element.fixed_size();
    }
    return offsets;
}

}  // namespace

std::unique_ptr<TriangleSource> open_ply_stream(const std::filesystem::path& path, const std::string& name,
                                                const std::array<double, 3>* origin, uint64_t cache_bytes,
                                                std::vector<std::string>& warnings) {
    auto file = std::make_unique<InputFile>(path, name);
    constexpr size_t kHeaderBytes = size_t(1) << 20;  // headers are a few hundred bytes; comments rarely reach this
    std::string head(size_t(std::min<uint64_t>(kHeaderBytes, file->size())), '\0');
    head.resize(file->read(0, head.size(), head.data()));
    if (!head.starts_with("ply") || head.find("end_header") == std::string::npos) return nullptr;
    const Progress no_progress;
    std::vector<std::string> header_warnings;  // passed on only if the file streams: else the reader warns
    const ReadInput input{path, name, head.data(), head.size(), no_progress, &header_warnings, origin};
    PlyHeader header = HeaderParser(input).parse();
    if (header.format == PlyFormat::ascii) return nullptr;
    const std::vector<uint64_t> offsets = fixed_offsets(header);
    uint64_t vertex_offset = UINT64_MAX, face_offset = UINT64_MAX;
    for (size_t i = 0; i < header.elements.size(); ++i) {
        const PlyElement& element = header.elements[i];
        if (element.name == "vertex" && !element.has_lists() && vertex_offset == UINT64_MAX) vertex_offset = offsets[i];
        else if (element.name == "vertex") return nullptr;  // several, or with lists: the in-memory reader says
        if (element.name == "face" && face_offset == UINT64_MAX) face_offset = offsets[i];
        else if (element.name == "face") return nullptr;
    }
    if (vertex_offset == UINT64_MAX || face_offset == UINT64_MAX) return nullptr;
    const PlyElement* vertex = nullptr;
    for (const PlyElement& element : header.elements)
        if (element.name == "vertex") vertex = &element;
    if (vertex->count >= UINT32_MAX) input.fail("too many vertices (" + std::to_string(vertex->count) + ")");
    warnings.insert(warnings.end(), header_warnings.begin(), header_warnings.end());
    return std::make_unique<PlyStream>(std::move(file), path, name, std::move(header), vertex_offset, face_offset, cache_bytes, origin);
}

uint64_t ply_face_count(const ReadInput& input) {
    const PlyHeader header = HeaderParser(input).parse();
    const PlyElement* face = find_element(header, "face", input);
    return face ? face->count : 0;
}

Mesh read_ply(const ReadInput& input) {
    const PlyHeader header = HeaderParser(input).parse();
    const PlyElement* vertex = find_element(header, "vertex", input);
    const PlyElement* face = find_element(header, "face", input);
    if (!vertex) input.fail("PLY file has no vertex element");
    if (vertex->count >= UINT32_MAX) input.fail("too many vertices (" + std::to_string(vertex->count) + ")");
    const VertexLayout layout = vertex_layout(input, *vertex);
    const size_t list = face ? face_list(input, *face) : 0;
    const uint32_t vertex_count = uint32_t(vertex->count);

    Mesh mesh;
    mesh.texture = header.texture;
    ReadTicker ticker(input.progress, input.size);
    if (header.format == PlyFormat::ascii) {
        AsciiBody body(input, header, ticker);
        read_body(body, header, layout, list, vertex_count, mesh);
        body.finish();
    } else {
        BinaryBody body(input, header, ticker);
        read_body(body, header, layout, list, vertex_count, mesh);
    }
    check_positions(input, mesh);
    return mesh;
}

}  // namespace strata::detail

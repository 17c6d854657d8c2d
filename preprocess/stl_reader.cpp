// STL reader, binary and ASCII (keywords in any case: admesh's block.stl is all capitals). STL is a
// triangle soup (every triangle has its own three corners), so this emits three vertices per triangle
// and leaves it to weld() to make the mesh indexed. Facet normals are ignored: they are often wrong and
// the corners' order already gives the orientation.
#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <numeric>
#include <string>

#include "preprocess/mesh_readers.h"

namespace strata::detail {
namespace {

constexpr size_t kHeaderBytes = 84;     // 80 free-form bytes + uint32 triangle count
constexpr size_t kTriangleBytes = 50;   // normal, three corners (12 floats), uint16 attribute

uint32_t triangle_count(const ReadInput& input) {
    uint32_t count;
    std::memcpy(&count, input.data + 80, 4);
    if constexpr (std::endian::native == std::endian::big) count = __builtin_bswap32(count);
    return count;
}

// Binary STLs may start with "solid" too (SolidWorks writes that): a size that matches the count settles
// it, otherwise an ASCII file's second line starts with "facet" (or "endsolid", when it is empty).
bool is_ascii(const ReadInput& input) {
    if (input.size >= kHeaderBytes && kHeaderBytes + kTriangleBytes * uint64_t(triangle_count(input)) == input.size)
        return false;
    Tokens tokens(input.data, input.data + input.size);
    if (!is_keyword(tokens.next(), "solid")) return false;
    tokens.skip_line();  // the solid's name, however long
    const std::string_view next = tokens.next();
    return is_keyword(next, "facet") || is_keyword(next, "endsolid") || is_keyword(next, "end");
}

void check_corners(const ReadInput& input, const Mesh& mesh) {
    const size_t bad = first_non_finite(mesh.positions.data(), mesh.vertex_count());
    if (bad < mesh.vertex_count())
        input.fail("triangle " + std::to_string(bad / 3) + " has a NaN or infinite coordinate");
}

// Binary STL holds floats, so there is no precision to gain, but the tiles of a model share one
// origin; a float's offset from an origin near it is exact. Nothing to do when the origin is 0.
void relative_to_origin(const ReadInput& input, Mesh& mesh) {
    if (mesh.positions.empty()) return;
    Coordinates coordinates(input);
    for (int a = 0; a < 3; ++a) coordinates.relative(mesh.positions[size_t(a)], a);
    mesh.origin = coordinates.origin();
    if (mesh.origin == std::array<double, 3>{}) return;
    for (size_t i = 0; i < mesh.positions.size(); ++i)
        mesh.positions[i] = float(double(mesh.positions[i]) - mesh.origin[i % 3]);
}

void sequential_indices(Mesh& mesh) {
    reserve_huge(mesh.indices, mesh.vertex_count());
    mesh.indices.resize(mesh.vertex_count());
    std::iota(mesh.indices.begin(), mesh.indices.end(), 0u);
}

// The triangles a binary STL holds. Some writers leave the header's count wrong (ZanderCAD writes 0:
// MeshLab #1281): when the size is exactly a whole number of triangles, the size is believed.
uint64_t binary_triangles(const ReadInput& input) {
    if (input.size < kHeaderBytes)
        input.fail("too small for a binary STL (" + std::to_string(input.size) + " bytes) and not an ASCII STL");
    const uint64_t count = triangle_count(input);
    const uint64_t present = (input.size - kHeaderBytes) / kTriangleBytes;
    if (count != present && (input.size - kHeaderBytes) % kTriangleBytes == 0) {
        input.warn("the header says " + std::to_string(count) + " triangles, but the file's size is exactly " +
                   std::to_string(present) + ": read " + std::to_string(present));
        return present;
    }
    if (present < count)  // extra bytes after the triangles are tolerated; missing ones are not
        input.fail("expected " + std::to_string(count) + " triangles, file ends after " + std::to_string(present));
    return count;
}

Mesh read_binary(const ReadInput& input) {
    const uint64_t count = binary_triangles(input);
    if (3 * count >= UINT32_MAX) input.fail("too many triangles (" + std::to_string(count) + ")");
    Mesh mesh;
    reserve_huge(mesh.positions, 9 * count);
    mesh.positions.resize(9 * count);
    ReadTicker ticker(input.progress, input.size);
    const char* src = input.data + kHeaderBytes;
    for (uint64_t t = 0; t < count; ++t) {
        std::memcpy(&mesh.positions[9 * t], src + kTriangleBytes * t + 12, 36);
        if ((t & 0xffff) == 0) ticker.at(kHeaderBytes + kTriangleBytes * t);
    }
    if constexpr (std::endian::native == std::endian::big) {
        for (float& f : mesh.positions) {
            uint32_t bits = __builtin_bswap32(std::bit_cast<uint32_t>(f));
            f = std::bit_cast<float>(bits);
        }
    }
    relative_to_origin(input, mesh);
    check_corners(input, mesh);
    sequential_indices(mesh);
    return mesh;
}

class AsciiParser {
public:
    explicit AsciiParser(const ReadInput& input)
        : input_(input),
          tokens_(input.data, input.data + input.size),
          ticker_(input.progress, input.size),
          coordinates_(input) {}

    Mesh parse() {
        for (std::string_view token = tokens_.next(); !token.empty(); token = tokens_.next()) {
            if (is_keyword(token, "end")) token = ended(tokens_.next());  // "end loop", "end solid"
            if (is_keyword(token, "solid") || is_keyword(token, "endsolid")) tokens_.skip_line();  // then a free-form name
            else if (is_keyword(token, "facet")) facet_normal();
            else if (is_keyword(token, "outer")) expect("loop"), corners_ = 0;
            else if (is_keyword(token, "vertex")) vertex();
            else if (is_keyword(token, "endloop")) end_loop();
            else if (!is_keyword(token, "endfacet")) fail("unexpected " + quoted(token));
            ticker_.at(size_t(tokens_.position() - input_.data));
        }
        if (corners_ != 0) input_.fail("file ends inside a facet");
        mesh_.origin = coordinates_.origin();
        check_corners(input_, mesh_);
        return std::move(mesh_);
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        input_.fail("line " + std::to_string(line_number(input_.data, tokens_.position())) + ": " + what);
    }
    void expect(std::string_view word) {
        std::string_view token = tokens_.next();
        if (!is_keyword(token, word)) fail("expected '" + std::string(word) + "', found " + quoted(token));
    }
    // "end loop", "end facet" and "end solid" as two words (MeshLab #194, numpy-stl #206).
    std::string_view ended(std::string_view word) const {
        for (std::string_view keyword : {"endloop", "endfacet", "endsolid"})
            if (is_keyword(word, keyword.substr(3))) return keyword;
        fail("unexpected 'end' before " + quoted(word));
    }
    float coordinate(int axis) {
        std::string_view token = tokens_.next();
        float value = 0;
        if (!coordinates_.parse(token, axis, value)) fail("expected a number, found " + quoted(token));
        return value;
    }
    // The normal is not used, so it is not parsed either: writers put NaN there in every spelling
    // ("nan", "-nan", "NaN", "-1.#IND": OpenSCAD #1225, helix-toolkit #1150).
    void facet_normal() {
        expect("normal");
        for (int k = 0; k < 3; ++k) tokens_.next();
    }
    void vertex() {
        for (int k = 0; k < 3; ++k) mesh_.positions.push_back(coordinate(k));
        ++corners_;
    }
    // A loop is normally a triangle; a longer one is fanned (its corners are already stored in order).
    void end_loop() {
        if (corners_ < 3) fail("facet has " + std::to_string(corners_) + " vertices, at least 3 needed");
        const uint32_t first = uint32_t(mesh_.vertex_count() - corners_);
        for (uint32_t k = 1; k + 1 < corners_; ++k)
            mesh_.indices.insert(mesh_.indices.end(), {first, first + k, first + k + 1});
        corners_ = 0;
    }

    const ReadInput& input_;
    Tokens tokens_;
    ReadTicker ticker_;
    Coordinates coordinates_;
    Mesh mesh_;
    uint32_t corners_ = 0;
};

}  // namespace

Mesh read_stl(const ReadInput& input) { return is_ascii(input) ? AsciiParser(input).parse() : read_binary(input); }

}  // namespace strata::detail

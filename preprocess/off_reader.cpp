// OFF reader (Geomview object file format, ASCII): "OFF" with optional ST/C/N prefixes, counts on the
// header line or the next, one vertex per line, then one polygon per line ("n i0 .. i(n-1) [colour]").
// Read line by line rather than as a token stream, because optional trailing face colours make the
// token stream ambiguous.
#include <algorithm>
#include <string>
#include <vector>

#include "preprocess/mesh_readers.h"

namespace strata::detail {
namespace {

struct OffHeader {
    bool uvs = false, colors = false, normals = false;
    uint64_t vertices = 0, faces = 0;
};

class OffParser {
public:
    explicit OffParser(const ReadInput& input)
        : input_(input),
          lines_(input.data, input.data + input.size),
          ticker_(input.progress, input.size),
          coordinates_(input) {}

    Mesh parse() {
        header();
        Mesh mesh;
        vertices(mesh);
        faces(mesh);
        mesh.origin = coordinates_.origin();
        const size_t bad = first_non_finite(mesh.positions.data(), mesh.vertex_count());
        if (bad < mesh.vertex_count())
            input_.fail("vertex " + std::to_string(bad) + " has a NaN or infinite coordinate");
        return mesh;
    }
    uint64_t face_count() {
        header();
        return header_.faces;
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        input_.fail("line " + std::to_string(lines_.line()) + ": " + what);
    }

    // The next line that is not blank once its '#' comment is cut off.
    bool content_line(std::string_view& line) {
        while (lines_.next(line)) {
            line = line.substr(0, line.find('#'));
            if (!Tokens(line).at_end()) return true;
        }
        return false;
    }
    std::string_view required_line(uint64_t expected, uint64_t done, const char* noun) {
        std::string_view line;
        if (!content_line(line))
            input_.fail("expected " + std::to_string(expected) + " " + noun + ", file ends after " +
                        std::to_string(done));
        return line;
    }

    void header() {
        std::string_view line;
        if (!content_line(line)) input_.fail("no OFF header");
        Tokens tokens(line);
        std::string_view keyword = tokens.next();
        const size_t off = keyword.find("OFF");
        if (off == std::string_view::npos) fail("expected an OFF header, found " + quoted(keyword));
        const std::string_view prefix = keyword.substr(0, off);
        const std::string_view glued = keyword.substr(off + 3);  // "OFF1234 5678 0": ModelNet's files
        if (prefix.find('4') != std::string_view::npos) fail("4D OFF is not supported");
        header_.uvs = prefix.find("ST") != std::string_view::npos;
        header_.colors = prefix.find('C') != std::string_view::npos;
        header_.normals = prefix.find('N') != std::string_view::npos;
        if (prefix.find('n') != std::string_view::npos) dimension(tokens);
        if (Tokens peek = tokens; peek.next() == "BINARY") fail("binary OFF is not supported");
        if (glued.empty() && tokens.at_end()) {
            if (!content_line(line)) input_.fail("OFF header has no vertex and face counts");
            tokens = Tokens(line);
        }
        header_.vertices = count(glued.empty() ? tokens.next() : glued, "vertex");
        header_.faces = count(tokens.next(), "face");
        if (header_.vertices >= UINT32_MAX) fail("too many vertices (" + std::to_string(header_.vertices) + ")");
    }
    void dimension(Tokens& tokens) {
        std::string_view token = tokens.next();
        if (token.empty()) {
            std::string_view line;
            if (!content_line(line)) input_.fail("nOFF header has no dimension");
            tokens = Tokens(line);
            token = tokens.next();
        }
        if (token != "3") fail("only 3-dimensional nOFF is supported, found dimension " + quoted(token));
    }
    uint64_t count(std::string_view token, const char* what) const {
        if (!token.empty() && token[0] == '-') fail(std::string("negative ") + what + " count " + std::string(token));
        uint64_t value = 0;
        if (!parse_number(token, value)) fail(std::string("bad ") + what + " count " + quoted(token));
        return value;
    }

    // `count` records of `values` numbers each must fit in the text that is left.
    void require_room(uint64_t count, size_t values, const char* noun) const {
        const size_t left = size_t(input_.data + input_.size - lines_.position());
        input_.require_room(count, noun, left, text_room(left, values));
    }

    float number(Tokens& tokens, uint64_t vertex) const {
        std::string_view token = tokens.next();
        float value = 0;
        if (!parse_number(token, value)) not_a_number(token, vertex);
        return value;
    }
    float coordinate(Tokens& tokens, int axis, uint64_t vertex) {
        std::string_view token = tokens.next();
        float value = 0;
        if (!coordinates_.parse(token, axis, value)) not_a_number(token, vertex);
        return value;
    }
    [[noreturn]] void not_a_number(std::string_view token, uint64_t vertex) const {
        fail("vertex " + std::to_string(vertex) + ": expected a number, found " +
             (token.empty() ? std::string("end of line") : quoted(token)));
    }

    void vertices(Mesh& mesh) {
        require_room(header_.vertices, 3 + (header_.normals ? 3 : 0) + (header_.colors ? 3 : 0) + (header_.uvs ? 2 : 0),
                     "vertices");
        const size_t count = size_t(header_.vertices);
        mesh.positions.reserve(3 * count);
        if (header_.normals) mesh.normals.reserve(3 * count);
        if (header_.colors) mesh.colors.reserve(4 * count);
        if (header_.uvs) mesh.uvs.reserve(2 * count);
        for (uint64_t v = 0; v < header_.vertices; ++v) {
            Tokens tokens(required_line(header_.vertices, v, "vertices"));
            for (int k = 0; k < 3; ++k) mesh.positions.push_back(coordinate(tokens, k, v));
            if (header_.normals)
                for (int k = 0; k < 3; ++k) mesh.normals.push_back(number(tokens, v));
            if (header_.colors) color(tokens, v, mesh);
            if (header_.uvs)
                for (int k = 0; k < 2; ++k) mesh.uvs.push_back(number(tokens, v));
            ticker_.at(size_t(lines_.position() - input_.data));
        }
    }

    // COFF colours are r g b [a], as floats 0..1 or as integers 0..255 (any value above 1 says which).
    void color(Tokens& tokens, uint64_t v, Mesh& mesh) {
        float rgba[4] = {0, 0, 0, 1};
        Tokens remaining = tokens;
        size_t left = 0;
        while (!remaining.next().empty()) ++left;
        const size_t channels = left >= (header_.uvs ? 6u : 4u) ? 4 : 3;
        for (size_t k = 0; k < channels; ++k) rgba[k] = number(tokens, v);
        const bool bytes = std::any_of(rgba, rgba + 4, [](float c) { return c > 1.0f; });
        if (bytes && channels == 3) rgba[3] = 255;
        for (float c : rgba) mesh.colors.push_back(color_byte(c, bytes));
    }

    void faces(Mesh& mesh) {
        require_room(header_.faces, 2, "faces");  // "n i": a face with too few corners fails on its own, more clearly
        mesh.indices.reserve(3 * size_t(header_.faces));
        std::vector<uint32_t> corners;
        for (uint64_t f = 0; f < header_.faces; ++f) {
            Tokens tokens(required_line(header_.faces, f, "faces"));
            const int64_t n = integer(tokens, f);
            if (n < 3) fail("face " + std::to_string(f) + " has " + std::to_string(n) + " corners, at least 3 needed");
            corners.clear();
            for (int64_t k = 0; k < n; ++k) corners.push_back(index(integer(tokens, f), f));
            for (size_t k = 1; k + 1 < corners.size(); ++k)
                mesh.indices.insert(mesh.indices.end(), {corners[0], corners[k], corners[k + 1]});
            ticker_.at(size_t(lines_.position() - input_.data));
        }
    }
    int64_t integer(Tokens& tokens, uint64_t face) const {
        std::string_view token = tokens.next();
        int64_t value = 0;
        if (!parse_number(token, value))
            fail("face " + std::to_string(face) + ": expected an integer, found " +
                 (token.empty() ? std::string("end of line") : quoted(token)));
        return value;
    }
    uint32_t index(int64_t value, uint64_t face) const {
        if (value < 0 || uint64_t(value) >= header_.vertices)
            fail("face " + std::to_string(face) + " indexes vertex " + std::to_string(value) + " of " +
                 std::to_string(header_.vertices));
        return uint32_t(value);
    }

    const ReadInput& input_;
    Lines lines_;
    ReadTicker ticker_;
    Coordinates coordinates_;
    OffHeader header_;
};

}  // namespace

Mesh read_off(const ReadInput& input) { return OffParser(input).parse(); }

uint64_t off_face_count(const ReadInput& input) { return OffParser(input).face_count(); }

}  // namespace strata::detail

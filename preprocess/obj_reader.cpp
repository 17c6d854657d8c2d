// Wavefront OBJ reader: v (with optional r g b), vt, vn, f in all four corner forms with negative
// (relative) indices, polygons fanned. OBJ indexes positions, uvs and normals separately; the mesh has
// one vertex per distinct (v, vt, vn) triple, found through a per-position chain of its triples (seams
// are few, so chains are short, and no hash map is needed). mtllib/usemtl give Mesh::texture.
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "preprocess/mesh_readers.h"

namespace strata::detail {
namespace {

constexpr uint32_t kNone = UINT32_MAX;

// Keywords that carry nothing the mesh keeps (groups, smoothing, curves, lines, points, ...).
bool ignored_keyword(std::string_view keyword) {
    static constexpr std::array<std::string_view, 31> kIgnored = {
        "o",    "g",    "s",   "l",   "p",      "vp",       "mg",        "cstype",   "deg",   "bmat", "step",
        "curv", "curv2", "surf", "parm", "trim", "hole",     "scrv",      "sp",       "end",   "con",  "lod",
        "bevel", "maplib", "usemap", "ctech", "stech", "shadow_obj", "trace_obj", "c_interp", "d_interp"};
    return std::find(kIgnored.begin(), kIgnored.end(), keyword) != kIgnored.end();
}

// ---- .mtl: only the diffuse texture matters ---------------------------------------------------------

// The file name of a map_Kd line, after its options ("-s 1 1 1 -o 0 0 0 -clamp on tex.png").
std::string map_file_name(Tokens tokens) {
    for (;;) {
        Tokens before = tokens;
        std::string_view option = tokens.next();
        if (option.size() < 2 || option[0] != '-') return std::string(before.rest());
        if (option == "-o" || option == "-s" || option == "-t") {
            // up to three numbers
            for (int k = 0; k < 3; ++k) {
                Tokens peek = tokens;
                double value;
                if (!parse_number(peek.next(), value)) break;
                tokens = peek;
            }
        } else {
            const int args = option == "-mm" ? 2 : 1;  // -blendu on, -bm 1, -clamp on, -texres 512, ...
            for (int k = 0; k < args; ++k) tokens.next();
        }
    }
}

struct MaterialTextures {
    std::map<std::string, std::string, std::less<>> by_material;
    std::string first;
};

void read_mtl(const std::filesystem::path& path, MaterialTextures& textures) {
    std::ifstream file(path, std::ios::binary);
    if (!file) return;  // a missing .mtl only costs the texture name
    std::stringstream buffer;
    buffer << file.rdbuf();
    const std::string text = buffer.str();
    Lines lines(text.data(), text.data() + text.size());
    std::string_view line;
    std::string material;
    while (lines.next(line)) {
        Tokens tokens(line);
        std::string_view keyword = tokens.next();
        if (keyword == "newmtl") material = std::string(tokens.rest());
        if (keyword != "map_Kd") continue;
        std::string name = map_file_name(tokens);
        if (name.empty()) continue;
        if (textures.first.empty()) textures.first = name;
        textures.by_material.emplace(material, name);
    }
}

// "mtllib a b.mtl" names one file with a space or two files; try the whole name first.
std::vector<std::filesystem::path> mtl_candidates(const std::filesystem::path& dir, std::string_view rest) {
    std::vector<std::filesystem::path> paths = {dir / std::string(rest)};
    Tokens tokens(rest);
    for (std::string_view name = tokens.next(); !name.empty(); name = tokens.next())
        if (name != rest) paths.push_back(dir / std::string(name));
    return paths;
}

// ---- the parser -----------------------------------------------------------------------------------

class ObjParser {
public:
    explicit ObjParser(const ReadInput& input)
        : input_(input),
          lines_(input.data, input.data + input.size),
          ticker_(input.progress, input.size),
          coordinates_(input) {}

    Mesh parse() {
        std::string_view physical;
        while (lines_.next(physical)) {
            const std::string_view line = continued(physical);
            Tokens tokens(line.substr(0, line.find('#')));  // some writers end lines with a comment
            std::string_view keyword = tokens.next();
            if (keyword.empty()) continue;
            dispatch(keyword, tokens);
            ticker_.at(size_t(lines_.position() - input_.data));
        }
        if (positions_.empty() && indices_.empty() && !first_unknown_.empty())
            input_.fail("not an OBJ file: unexpected " + first_unknown_);
        return build();
    }

private:
    [[noreturn]] void fail(const std::string& what) const {
        input_.fail("line " + std::to_string(lines_.line()) + ": " + what);
    }

    // A line whose last non-blank is a backslash goes on in the next one (Rhino wraps long face lines so:
    // trimesh #1103, helix-toolkit #152).
    static size_t continuation_at(std::string_view line) {
        size_t end = line.size();
        while (end > 0 && is_blank(line[end - 1])) --end;
        return end > 0 && line[end - 1] == '\\' ? end - 1 : std::string_view::npos;
    }
    std::string_view continued(std::string_view line) {
        size_t backslash = continuation_at(line);
        if (backslash == std::string_view::npos) return line;
        joined_.clear();
        for (;;) {
            joined_.append(line.substr(0, backslash)).push_back(' ');
            if (!lines_.next(line)) return joined_;
            backslash = continuation_at(line);
            if (backslash == std::string_view::npos) return joined_.append(line);
        }
    }

    void dispatch(std::string_view keyword, Tokens& tokens) {
        if (keyword == "v") vertex(tokens);
        else if (keyword == "vt") texcoord(tokens);
        else if (keyword == "vn") normal(tokens);
        else if (keyword == "f") face(tokens);
        else if (keyword == "mtllib") mtllibs_.emplace_back(tokens.rest());
        else if (keyword == "usemtl") usemtl(tokens.rest());
        else if (!ignored_keyword(keyword) && first_unknown_.empty())
            first_unknown_ = quoted(keyword) + " on line " + std::to_string(lines_.line());
    }

    // Reads up to `max` numbers into values; fails on a non-number or on fewer than `min`.
    size_t numbers(Tokens& tokens, float* values, size_t min, size_t max, const char* what) {
        size_t n = 0;
        for (std::string_view token = tokens.next(); !token.empty() && n < max; token = tokens.next()) {
            if (!parse_number(token, values[n]))
                fail(std::string(what) + ": expected a number, found " + quoted(token));
            ++n;
        }
        if (n < min) fail(std::string(what) + " needs " + std::to_string(min) + " numbers, found " + std::to_string(n));
        return n;
    }

    void vertex(Tokens& tokens) {
        float values[7] = {};
        for (int a = 0; a < 3; ++a) {
            std::string_view token = tokens.next();
            if (token.empty()) fail("v needs 3 numbers, found " + std::to_string(a));
            if (!coordinates_.parse(token, a, values[a])) fail("v: expected a number, found " + quoted(token));
        }
        const size_t n = 3 + numbers(tokens, values + 3, 0, 4, "v");
        if (!std::isfinite(values[0]) || !std::isfinite(values[1]) || !std::isfinite(values[2]))
            fail("vertex " + std::to_string(positions_.size() / 3 + 1) + " has a NaN or infinite coordinate");
        positions_.insert(positions_.end(), values, values + 3);
        first_wedge_.push_back(kNone);
        if (n >= 6) {
            // "v x y z r g b": colours 0..1 (a few writers use 0..255, which a value above 1 gives away).
            // Vertices before the first coloured one become white.
            colors_.resize(4 * (first_wedge_.size() - 1), 255);
            const bool bytes = values[3] > 1 || values[4] > 1 || values[5] > 1;
            for (int k = 3; k < 6; ++k)
                colors_.push_back(color_byte(values[k], bytes));
            colors_.push_back(255);
        } else if (!colors_.empty()) {
            colors_.insert(colors_.end(), 4, 255);
        }
    }
    void texcoord(Tokens& tokens) {
        float values[3] = {};
        numbers(tokens, values, 1, 3, "vt");
        uvs_.insert(uvs_.end(), values, values + 2);
    }
    void normal(Tokens& tokens) {
        float values[3] = {};
        numbers(tokens, values, 3, 3, "vn");
        normals_.insert(normals_.end(), values, values + 3);
    }
    void usemtl(std::string_view material) {
        if (std::find(used_materials_.begin(), used_materials_.end(), material) == used_materials_.end())
            used_materials_.emplace_back(material);
    }

    // One index field: 1-based, or negative counting back from the last element read so far.
    uint32_t resolve(std::string_view field, size_t count, const char* kind) const {
        int64_t index = 0;
        if (!parse_number(field, index)) fail("face " + std::to_string(face_count_) + ": bad index " + quoted(field));
        const int64_t resolved = index < 0 ? int64_t(count) + index : index - 1;
        if (index == 0 || resolved < 0 || resolved >= int64_t(count))
            fail("face " + std::to_string(face_count_) + " indexes " + kind + " " + std::to_string(index) + " of " +
                 std::to_string(count));
        return uint32_t(resolved);
    }

    // "v", "v/vt", "v//vn" or "v/vt/vn" → the mesh vertex for that triple.
    uint32_t corner(std::string_view token) {
        const size_t slash1 = token.find('/');
        const size_t slash2 = slash1 == std::string_view::npos ? slash1 : token.find('/', slash1 + 1);
        const uint32_t v = resolve(token.substr(0, slash1), first_wedge_.size(), "vertex");
        uint32_t vt = kNone, vn = kNone;
        if (slash1 != std::string_view::npos) {
            const size_t length = slash2 == std::string_view::npos ? slash2 : slash2 - slash1 - 1;
            const std::string_view t = token.substr(slash1 + 1, length);
            if (!t.empty()) vt = resolve(t, uvs_.size() / 2, "texture coordinate");
            // An empty normal field is no normal: Wings3D writes "1//", others "1/1/" (trimesh #808).
            const std::string_view n = slash2 == std::string_view::npos ? std::string_view() : token.substr(slash2 + 1);
            if (!n.empty()) vn = resolve(n, normals_.size() / 3, "normal");
        }
        return wedge(v, vt, vn);
    }

    uint32_t wedge(uint32_t v, uint32_t vt, uint32_t vn) {
        for (uint32_t w = first_wedge_[v]; w != kNone; w = next_wedge_[w])
            if (wedge_vt_[w] == vt && wedge_vn_[w] == vn) return w;
        if (wedge_v_.size() >= kNone - 1) fail("too many distinct vertices");
        const uint32_t w = uint32_t(wedge_v_.size());
        wedge_v_.push_back(v);
        wedge_vt_.push_back(vt);
        wedge_vn_.push_back(vn);
        next_wedge_.push_back(first_wedge_[v]);
        first_wedge_[v] = w;
        any_vt_ |= vt != kNone;
        any_vn_ |= vn != kNone;
        return w;
    }

    void face(Tokens& tokens) {
        ++face_count_;
        corners_.clear();
        for (std::string_view token = tokens.next(); !token.empty(); token = tokens.next())
            corners_.push_back(corner(token));
        if (corners_.size() < 3)
            fail("face " + std::to_string(face_count_) + " has " + std::to_string(corners_.size()) +
                 " corners, at least 3 needed");
        for (size_t k = 1; k + 1 < corners_.size(); ++k)
            indices_.insert(indices_.end(), {corners_[0], corners_[k], corners_[k + 1]});
    }

    Mesh build() {
        Mesh mesh;
        mesh.origin = coordinates_.origin();
        const size_t n = wedge_v_.size();
        mesh.positions.resize(3 * n);
        if (!colors_.empty()) mesh.colors.resize(4 * n);
        if (any_vt_) mesh.uvs.resize(2 * n);  // corners without vt get (0, 0)
        if (any_vn_) mesh.normals.resize(3 * n);
        for (size_t w = 0; w < n; ++w) {
            std::copy_n(&positions_[3 * size_t(wedge_v_[w])], 3, &mesh.positions[3 * w]);
            if (!colors_.empty()) std::copy_n(&colors_[4 * size_t(wedge_v_[w])], 4, &mesh.colors[4 * w]);
            if (any_vt_ && wedge_vt_[w] != kNone) std::copy_n(&uvs_[2 * size_t(wedge_vt_[w])], 2, &mesh.uvs[2 * w]);
            if (any_vn_ && wedge_vn_[w] != kNone)
                std::copy_n(&normals_[3 * size_t(wedge_vn_[w])], 3, &mesh.normals[3 * w]);
        }
        mesh.indices = std::move(indices_);
        mesh.texture = texture();
        return mesh;
    }

    // The map_Kd of the first material used that has one, else the first map_Kd of the library.
    std::string texture() const {
        MaterialTextures textures;
        const std::filesystem::path dir = input_.path.parent_path();
        for (const std::string& lib : mtllibs_)
            for (const std::filesystem::path& candidate : mtl_candidates(dir, lib)) read_mtl(candidate, textures);
        for (const std::string& material : used_materials_) {
            auto found = textures.by_material.find(material);
            if (found != textures.by_material.end()) return found->second;
        }
        return textures.first;
    }

    const ReadInput& input_;
    Lines lines_;
    ReadTicker ticker_;
    Coordinates coordinates_;
    std::vector<float> positions_, uvs_, normals_;  // as the file lists them (positions from the origin)
    std::vector<uint8_t> colors_;                   // per v, empty unless some v has a colour
    std::vector<uint32_t> first_wedge_;             // per v: its latest triple, chained by next_wedge_
    std::vector<uint32_t> wedge_v_, wedge_vt_, wedge_vn_, next_wedge_;
    bool any_vt_ = false, any_vn_ = false;
    std::vector<uint32_t> indices_, corners_;
    size_t face_count_ = 0;
    std::vector<std::string> mtllibs_, used_materials_;
    std::string first_unknown_;
    std::string joined_;  // a line continued over several
};

}  // namespace

Mesh read_obj(const ReadInput& input) { return ObjParser(input).parse(); }

}  // namespace strata::detail

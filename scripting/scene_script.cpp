// The scene-script writer: a SceneState as the Lua that rebuilds it through the `strata` module. Each
// node is a `do … end` block nested as the scene is, so adding a node changes only its own lines in a
// diff and a script holds any number of nodes (Lua allows 200 locals at a time: only the path from the
// root is live). Numbers are written as the shortest text that reads back to the same bits.
#include "scripting/scene_script.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cxxabi.h>
#include <map>
#include <optional>
#include <stdexcept>
#include <typeinfo>

#include "preprocess/atomic_file.h"
#include "engine/scene/light.h"
#include "nodes/geometry.h"
#include "nodes/hlod_model.h"
#include "scripting/lua_util.h"
#include "scripting/wrap_scene.h"

namespace strata {

namespace {

namespace fs = std::filesystem;

// std::to_chars's shortest round-trip text (a float's own, which reads back through a double to the
// same float). −0 becomes "-0.0": Lua would read "-0" as the integer 0. Infinity (a far plane at
// infinity) is math.huge; NaN has no meaning to restore.
template <class T>
std::string number(T value) {
    if (std::isnan(value)) throw std::runtime_error("NaN cannot be written");
    if (std::isinf(value)) return value > 0 ? "math.huge" : "-math.huge";
    char text[64];
    const std::string s(text, std::to_chars(text, text + sizeof text, value).ptr);
    return s == "-0" ? "-0.0" : s;
}

template <class Vec>
std::string numbers(const Vec& v) {
    std::string s = "{";
    for (int i = 0; i < Vec::length(); ++i) s += (i ? ", " : "") + number(v[i]);
    return s + "}";
}

std::string numbers(const glm::dquat& q) { return numbers(glm::dvec4(q.w, q.x, q.y, q.z)); }

// A Lua string literal: quotes, backslashes, line breaks and other control characters escaped; other bytes
// (UTF-8) as they are.
std::string lua_string(std::string_view s) {
    std::string out = "\"";
    for (const unsigned char c : s) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += char(c);
        } else if (c == '\n') {
            out += "\\n";
        } else if (c < 0x20 || c == 0x7f) {
            char escape[8];
            std::snprintf(escape, sizeof escape, "\\%03d", c);  // three digits: a digit after it stays itself
            out += escape;
        } else {
            out += char(c);
        }
    }
    return out + "\"";
}

std::string boolean(bool b) { return b ? "true" : "false"; }

std::string type_of(const Node& node) {
    const char* mangled = typeid(node).name();
    int status = 0;
    char* demangled = abi::__cxa_demangle(mangled, nullptr, nullptr, &status);
    std::string name = status == 0 ? demangled : mangled;
    std::free(demangled);
    return name;
}

[[noreturn]] void cannot_write(const Node& node, const std::string& why) {
    throw std::runtime_error("node '" + node.name() + "' (" + type_of(node) + ") " + why);
}

struct Trs {
    glm::dvec3 translate;
    glm::dquat rotation;
    double scale;
};

// translate, quaternion and scale when strata.transform rebuilds exactly `m` from them (the readable
// form), else nothing. The quaternion must be one check_quat keeps as it is.
std::optional<Trs> exact_trs(const glm::dmat4& m) {
    const double scale = glm::length(glm::dvec3(m[0]));
    if (!(scale > 0)) return std::nullopt;
    const Trs trs{glm::dvec3(m[3]), glm::normalize(glm::quat_cast(glm::dmat3(m) / scale)), scale};
    const glm::dmat4 rebuilt = compose_transform(trs.translate, trs.rotation, trs.scale);
    if (!lua::is_unit(trs.rotation) || std::memcmp(&rebuilt, &m, sizeof m) != 0) return std::nullopt;  // bits, −0 too
    return trs;
}

class SceneWriter {
public:
    explicit SceneWriter(fs::path folder) : folder_(std::move(folder)) {}

    // The tree under `root`, which becomes the global `scene`.
    std::string tree(const NodePtr& root);

private:
    void line(int depth, const std::string& text) { out_ += std::string(4 * size_t(depth), ' ') + text + "\n"; }
    void count_uses(const Node& node, int depth);
    void children(const Node& node, const std::string& var, int depth);
    void settings(const Node& node, const std::string& var, int depth);
    std::string constructor(const Node& node, int depth) const;
    std::string transform(const Transform& t, int depth) const;
    std::string geometry(const Geometry& g) const;
    std::string file(const fs::path& path) const;

    fs::path folder_;
    std::map<const Node*, int> uses_;        // how often each node occurs in the tree
    std::map<const Node*, size_t> shared_;   // nodes occurring more than once, once written: their index
    std::string out_;
};

std::string SceneWriter::tree(const NodePtr& root) {
    count_uses(*root, 0);
    if (std::ranges::any_of(uses_, [](const auto& node_uses) { return node_uses.second > 1; }))
        line(0, "local shared = {}  -- nodes that occur more than once");
    line(0, "scene = " + constructor(*root, 0));
    settings(*root, "scene", 0);
    children(*root, "scene", 1);
    return std::move(out_);
}

// The script nests a block per level, and Lua reads 200 nested blocks at most ("too many C levels"): a
// deeper scene is refused here, before the writer recurses as deep.
constexpr int kMaxScriptDepth = 150;

void SceneWriter::count_uses(const Node& node, int depth) {
    if (depth > kMaxScriptDepth)
        cannot_write(node, "lies more than " + std::to_string(kMaxScriptDepth) +
                               " levels deep: a scene script cannot nest that deep (Lua reads 200 nested blocks at most)");
    if (++uses_[&node] > 1) return;  // its children are counted once: they are written once
    if (const auto* group = dynamic_cast<const Group*>(&node))
        for (const NodePtr& child : group->children()) count_uses(*child, depth + 1);
}

// Each child in a block of its own, its local named after its depth (n1, n2, …) so that it can add to
// its parent's; a node written before is added again by reference.
void SceneWriter::children(const Node& node, const std::string& var, int depth) {
    const auto* group = dynamic_cast<const Group*>(&node);
    if (!group) return;
    for (const NodePtr& child : group->children()) {
        if (const auto written = shared_.find(child.get()); written != shared_.end()) {
            line(depth - 1, var + ":add(shared[" + std::to_string(written->second) + "])");
            continue;
        }
        const std::string local = "n" + std::to_string(depth);
        line(depth - 1, "do");
        line(depth, "local " + local + " = " + constructor(*child, depth));
        settings(*child, local, depth);
        line(depth, var + ":add(" + local + ")");
        if (uses_[child.get()] > 1) {
            shared_[child.get()] = shared_.size() + 1;
            line(depth, "shared[" + std::to_string(shared_.size()) + "] = " + local);
        }
        children(*child, local, depth + 1);
        line(depth - 1, "end");
    }
}

// What the constructors do not take: level of detail, user values, visibility.
void SceneWriter::settings(const Node& node, const std::string& var, int depth) {
    if (const auto* model = dynamic_cast<const HlodModel*>(&node)) {
        const std::string detail = model->pixel_error() > 0 ? "pixel_error = " + number(model->pixel_error())
                                                            : "kappa0 = " + number(model->kappa0());
        line(depth, var + ":set_lod{ " + detail + ", morph = " + boolean(model->morph()) +
                        ", debug = " + lua_string(debug_view_name(model->debug_view())) +
                        ", boxes = " + boolean(model->show_cube_boxes()) + " }");
    }
    for (const auto& [key, value] : node.user_values()) {
        const std::string text = std::visit(
            [](const auto& v) {
                using V = std::decay_t<decltype(v)>;
                if constexpr (std::is_same_v<V, double>) return number(v);
                else if constexpr (std::is_same_v<V, std::string>) return lua_string(v);
                else return boolean(v);
            },
            value);
        line(depth, var + ":set(" + lua_string(key) + ", " + text + ")");
    }
    if (!node.visible()) line(depth, var + ":visible(false)");
}

std::string SceneWriter::constructor(const Node& node, int depth) const {
    const std::string name = "name = " + lua_string(node.name());
    if (const auto* model = dynamic_cast<const HlodModel*>(&node))
        return "strata.load(" + file(model->path()) + ", { " + name + " })";
    if (const auto* g = dynamic_cast<const Geometry*>(&node)) return geometry(*g);
    if (const auto* t = dynamic_cast<const Transform*>(&node)) return transform(*t, depth);
    if (dynamic_cast<const Group*>(&node)) return "strata.group{ " + name + " }";
    if (const auto* light = dynamic_cast<const DirectionalLight*>(&node))
        return "strata.light{ " + name + ", direction = " + numbers(light->direction) + ", color = " +
               numbers(light->color) + ", intensity = " + number(light->intensity) + " }";
    if (const auto* ambient = dynamic_cast<const AmbientLight*>(&node))
        return "strata.ambient{ " + name + ", color = " + numbers(ambient->color) + " }";
    cannot_write(node, "has no constructor in the Lua API");
}

std::string SceneWriter::transform(const Transform& t, int depth) const {
    std::string options = "name = " + lua_string(t.name());
    if (const std::optional<Trs> trs = exact_trs(t.matrix())) {
        if (trs->translate != glm::dvec3(0)) options += ", translate = " + numbers(trs->translate);
        if (trs->rotation != glm::dquat(1, 0, 0, 0)) options += ", quaternion = " + numbers(trs->rotation);
        if (trs->scale != 1) options += ", scale = " + number(trs->scale);
        return "strata.transform{ " + options + " }";
    }
    // A general matrix, one column a line.
    const std::string pad(4 * size_t(depth + 1), ' ');
    options += ", matrix = {\n";
    for (int column = 0; column < 4; ++column) {
        const glm::dvec4& c = t.matrix()[column];
        options += pad + number(c.x) + ", " + number(c.y) + ", " + number(c.z) + ", " + number(c.w) + ",\n";
    }
    return "strata.transform{ " + options + std::string(4 * size_t(depth), ' ') + "} }";
}

std::string SceneWriter::geometry(const Geometry& g) const {
    const std::string name = "name = " + lua_string(g.name());
    const glm::vec4& color = g.material.base_color;
    if (color.a != 1) cannot_write(g, "has a colour with alpha, which the Lua API cannot set");
    if (const auto* plane = std::get_if<PlaneSource>(&g.source()))
        return "strata.plane{ " + name + ", center = " + numbers(plane->center) + ", up = " + numbers(plane->up) +
               ", width = " + number(plane->width) + ", depth = " + number(plane->depth) +
               ", color = " + numbers(glm::vec3(color)) + " }";
    if (color != Material{}.base_color) cannot_write(g, "is a loaded mesh with a colour, which the Lua API cannot set");
    if (const auto* path = std::get_if<fs::path>(&g.source()))
        return "strata.load(" + file(*path) + ", { " + name + " })";
    cannot_write(g, "is a mesh built in code, with no file or plane to rebuild it from");
}

// `path` relative to the script's folder, read back against wherever that folder is then.
std::string SceneWriter::file(const fs::path& path) const {
    return "here .. " + lua_string(fs::relative(fs::absolute(path), folder_).generic_string());
}

std::string camera_lua(const Camera& c) {
    std::string s = "camera = strata.camera{\n";
    s += "    position = " + numbers(c.position) + ", fov = " + number(c.fov_y_degrees) + ",\n";
    s += "    orientation = " + numbers(c.orientation) + ",\n";
    s += "    width = " + std::to_string(c.width) + ", height = " + std::to_string(c.height) +
         ", orthographic = " + boolean(c.projection == ProjectionKind::orthographic) +
         ", ortho_height = " + number(c.ortho_height) + ",\n";
    // 0 means "fit the scene", strata.camera's default.
    if (c.near_clip != 0) s += "    near = " + number(c.near_clip) + ",\n";
    if (c.far_clip != 0) s += "    far = " + number(c.far_clip) + ",\n";
    return s + "}\n";
}

std::string bookmarks_lua(const std::vector<Bookmark>& bookmarks) {
    if (bookmarks.empty()) return "bookmarks = {}\n";
    std::string s = "bookmarks = {\n";
    for (const Bookmark& b : bookmarks)
        s += "    { name = " + lua_string(b.name) + ", position = " + numbers(b.position) + ", orientation = " +
             numbers(b.orientation) + ", fov = " + number(b.fov_degrees) + " },\n";
    return s + "}\n";
}

// A key as strata.path takes it.
std::string key_lua(const Keyframe& key) {
    std::string s = "{ position = " + numbers(key.position);
    if (key.orientation) s += ", orientation = " + numbers(*key.orientation);
    if (key.target) s += ", target = " + numbers(*key.target);
    s += ", fov = " + number(key.fov_degrees);
    if (key.duration) s += ", duration = " + number(*key.duration);
    if (key.handles.in) s += ", handle_in = " + numbers(*key.handles.in);
    if (key.handles.out) s += ", handle_out = " + numbers(*key.handles.out);
    return s + " }";
}

std::string path_lua(const CameraPath& path) {
    const PathOptions& o = path.options();
    std::string s = "strata.path{\n";
    s += "        spline = " + lua_string(to_string(o.positions)) +
         ", orientation = " + lua_string(to_string(o.orientations)) +
         ", speed = " + lua_string(o.constant_speed ? "constant" : "natural") +
         ", easing = " + lua_string(to_string(o.easing)) + ", up = " + numbers(o.up) + ",\n";
    if (o.total_duration) s += "        duration = " + number(*o.total_duration) + ",\n";
    if (o.ease_seconds) s += "        ease_seconds = " + number(*o.ease_seconds) + ",\n";
    s += "        keys = {\n";
    for (const Keyframe& key : path.keys()) s += "            " + key_lua(key) + ",\n";
    return s + "        },\n    }";
}

std::string paths_lua(const SceneState& state) {
    if (state.paths.empty()) return "paths = {}\n";
    std::string s = "paths = {\n";
    for (const auto& [name, path] : state.paths) s += "    [" + lua_string(name) + "] = " + path_lua(*path) + ",\n";
    return s + "}\n";
}

}  // namespace

std::string scene_to_lua(const SceneState& state, const fs::path& script_path) {
    try {
        if (!state.scene) throw std::runtime_error("there is no scene");
        std::string s =
            "-- A Strata scene script (strata.save_scene). `strata run`, `strata shell` and `strata view` run it; it\n"
            "-- sets the globals scene, camera, bookmarks and paths. Files are named relative to this script's folder.\n"
            "local strata = require \"strata\"\n"
            "local here = debug.getinfo(1, \"S\").source:match(\"^@(.*[/\\\\])\") or \"\"  -- this script's folder\n\n";
        s += SceneWriter(fs::absolute(script_path).parent_path()).tree(state.scene) + "\n";
        s += (state.camera ? camera_lua(*state.camera) : "camera = nil\n") + "\n";
        s += bookmarks_lua(state.bookmarks) + "\n";
        return s + paths_lua(state);
    } catch (const std::runtime_error& e) {
        throw std::runtime_error("cannot save " + script_path.string() + ": " + e.what());
    }
}

void save_scene_script(const SceneState& state, const fs::path& script_path) {
    const std::string text = scene_to_lua(state, script_path);  // first: a scene that cannot be written leaves no file
    AtomicOutputFile file(script_path);
    file.write(text.data(), text.size());
    file.commit();
}

}  // namespace strata

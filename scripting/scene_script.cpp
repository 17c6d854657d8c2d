// The scene-script writer: a SceneState as the Lua that rebuilds it through the `strata` module. Each
// node is a `do … end` block nested as the scene is, so adding a node changes only its own lines in a
// diff and a script holds any number of nodes (Lua allows 200 locals at a time: only the path from the
// root is live). Numbers are written as the shortest text that reads back to the same bits.
#include "scripting/scene_script.h"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <variant>

#include "preprocess/atomic_file.h"
#include "scripting/node_types.h"
#include "scripting/script_text.h"

namespace strata {

namespace {

namespace fs = std::filesystem;

using script::boolean;
using script::number;
using script::numbers;

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
        script::cannot_write(node, "lies more than " + std::to_string(kMaxScriptDepth) +
                               " levels deep: a scene script cannot nest that deep (Lua reads 200 nested blocks at most)");
    if (++uses_[&node] > 1) return;  // its children are counted once: they are written once
    if (node_type_of(node).builds_children) return;
    if (const auto* group = dynamic_cast<const Group*>(&node))
        for (const NodePtr& child : group->children()) count_uses(*child, depth + 1);
}

// Each child in a block of its own, its local named after its depth (n1, n2, …) so that it can add to
// its parent's; a node written before is added again by reference.
void SceneWriter::children(const Node& node, const std::string& var, int depth) {
    const auto* group = dynamic_cast<const Group*>(&node);
    if (!group || node_type_of(node).builds_children) return;
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

// What the constructors do not take: the type's own settings, user values, visibility.
void SceneWriter::settings(const Node& node, const std::string& var, int depth) {
    std::vector<std::string> lines;
    for (const NodeType* type : type_chain(node_type_of(node)))
        if (type->settings) type->settings(node, var, lines);
    for (const std::string& text : lines) line(depth, text);
    for (const auto& [key, value] : node.user_values()) {
        const std::string text = std::visit(
            [](const auto& v) {
                using V = std::decay_t<decltype(v)>;
                if constexpr (std::is_same_v<V, double>) return number(v);
                else if constexpr (std::is_same_v<V, std::string>) return script::string(v);
                else return boolean(v);
            },
            value);
        line(depth, var + ":set(" + script::string(key) + ", " + text + ")");
    }
    if (!node.visible()) line(depth, var + ":visible(false)");
}

std::string SceneWriter::constructor(const Node& node, int depth) const {
    const NodeType& type = node_type_of(node);
    if (!type.constructor) script::cannot_write(node, "has no constructor in the Lua API");
    return type.constructor(node, script::Place{folder_, depth});
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
        s += "    { name = " + script::string(b.name) + ", position = " + numbers(b.position) + ", orientation = " +
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
    s += "        spline = " + script::string(to_string(o.positions)) +
         ", orientation = " + script::string(to_string(o.orientations)) +
         ", speed = " + script::string(o.constant_speed ? "constant" : "natural") +
         ", easing = " + script::string(to_string(o.easing)) + ", up = " + numbers(o.up) + ",\n";
    if (o.total_duration) s += "        duration = " + number(*o.total_duration) + ",\n";
    if (o.ease_seconds) s += "        ease_seconds = " + number(*o.ease_seconds) + ",\n";
    s += "        keys = {\n";
    for (const Keyframe& key : path.keys()) s += "            " + key_lua(key) + ",\n";
    return s + "        },\n    }";
}

std::string paths_lua(const SceneState& state) {
    if (state.paths.empty()) return "paths = {}\n";
    std::string s = "paths = {\n";
    for (const auto& [name, path] : state.paths) s += "    [" + script::string(name) + "] = " + path_lua(*path) + ",\n";
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

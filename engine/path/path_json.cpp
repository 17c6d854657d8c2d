// Path JSON: CameraPath to and from JSON text and files.
//
// Schema (version 1). Only "version" and "keys" are required; the others default as in PathOptions and
// Keyframe. Unknown fields are errors, so a misspelt option never passes silently.
// {
//   "version": 1,
//   "interpolation": "catmull-rom" | "bezier" | "linear",
//   "orientation": "squad" | "slerp" | "look-at",
//   "constant_speed": true,
//   "easing": "none" | "ease-in" | "ease-out" | "ease-in-out",
//   "ease_seconds": 2.0,                  (optional: each ramp's length)
//   "total_duration": 20.0,               (optional)
//   "up": [0, 1, 0],
//   "keys": [
//     { "position": [x, y, z],
//       "orientation": [w, x, y, z]  or  "target": [x, y, z],     (exactly one)
//       "fov": 50,                        (vertical, degrees)
//       "duration": 2.5,                  (optional: seconds to the next key)
//       "handle_in": [x, y, z], "handle_out": [x, y, z] },       (optional, Bézier control points)
//     ...
//   ]
// }
#include <algorithm>
#include <array>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "preprocess/atomic_file.h"
#include "engine/path/camera_path.h"

namespace strata {

namespace {

using Json = nlohmann::ordered_json;

constexpr int schema_version = 1;

Json to_array(const glm::dvec3& v) { return Json::array({v.x, v.y, v.z}); }

Json key_to_json(const Keyframe& key) {
    Json out;
    out["position"] = to_array(key.position);
    if (key.orientation) {
        const glm::dquat& q = *key.orientation;
        out["orientation"] = Json::array({q.w, q.x, q.y, q.z});
    }
    if (key.target) out["target"] = to_array(*key.target);
    out["fov"] = key.fov_degrees;
    if (key.duration) out["duration"] = *key.duration;
    if (key.handles.in) out["handle_in"] = to_array(*key.handles.in);
    if (key.handles.out) out["handle_out"] = to_array(*key.handles.out);
    return out;
}

// Reading: every error names where it is ("key 3: ...") and the field.
[[noreturn]] void fail(const std::string& where, const std::string& message) {
    throw std::runtime_error(where + message);
}

void reject_unknown_fields(const Json& object, std::initializer_list<std::string_view> known, const std::string& where) {
    for (const auto& [name, value] : object.items())
        if (std::find(known.begin(), known.end(), name) == known.end()) fail(where, "unknown field \"" + name + "\"");
}

const Json* find(const Json& object, const char* name) {
    const auto it = object.find(name);
    return it == object.end() ? nullptr : &*it;
}

double number_field(const Json& value, const char* name, const std::string& where) {
    if (!value.is_number()) fail(where, "field \"" + std::string(name) + "\" must be a number");
    return value.get<double>();
}

template <size_t N>
std::array<double, N> numbers_field(const Json& value, const char* name, const std::string& where) {
    if (!value.is_array() || value.size() != N || !std::all_of(value.begin(), value.end(), [](const Json& v) { return v.is_number(); }))
        fail(where, "field \"" + std::string(name) + "\" must be an array of " + std::to_string(N) + " numbers");
    std::array<double, N> numbers;
    for (size_t i = 0; i < N; ++i) numbers[i] = value[i].get<double>();
    return numbers;
}

glm::dvec3 vec3_field(const Json& value, const char* name, const std::string& where) {
    const auto v = numbers_field<3>(value, name, where);
    return {v[0], v[1], v[2]};
}

std::optional<glm::dvec3> optional_vec3(const Json& object, const char* name, const std::string& where) {
    const Json* value = find(object, name);
    if (!value) return std::nullopt;
    return vec3_field(*value, name, where);
}

template <typename Enum>
Enum enum_field(const Json& object, const char* name, Enum fallback, std::optional<Enum> (*parse)(std::string_view),
                const char* choices) {
    const Json* value = find(object, name);
    if (!value) return fallback;
    const std::optional<Enum> parsed = value->is_string() ? parse(value->get<std::string>()) : std::nullopt;
    if (!parsed) fail("", "field \"" + std::string(name) + "\" must be one of " + choices);
    return *parsed;
}

Keyframe key_from_json(const Json& object, size_t index) {
    const std::string where = "key " + std::to_string(index) + ": ";
    if (!object.is_object()) fail(where, "must be an object");
    reject_unknown_fields(object, {"position", "orientation", "target", "fov", "duration", "handle_in", "handle_out"}, where);
    Keyframe key;
    const Json* position = find(object, "position");
    if (!position) fail(where, "missing field \"position\"");
    key.position = vec3_field(*position, "position", where);
    if (const Json* orientation = find(object, "orientation")) {
        const auto q = numbers_field<4>(*orientation, "orientation", where);
        key.orientation = glm::dquat(q[0], q[1], q[2], q[3]);
    }
    key.target = optional_vec3(object, "target", where);
    if (const Json* fov = find(object, "fov")) key.fov_degrees = number_field(*fov, "fov", where);
    if (const Json* duration = find(object, "duration")) key.duration = number_field(*duration, "duration", where);
    key.handles.in = optional_vec3(object, "handle_in", where);
    key.handles.out = optional_vec3(object, "handle_out", where);
    return key;
}

PathOptions options_from_json(const Json& root) {
    PathOptions options;
    options.positions = enum_field(root, "interpolation", options.positions, parse_interpolation,
                                   "\"catmull-rom\", \"bezier\", \"linear\"");
    options.orientations = enum_field(root, "orientation", options.orientations, parse_orientation_interpolation,
                                      "\"squad\", \"slerp\", \"look-at\"");
    options.easing = enum_field(root, "easing", options.easing, parse_easing,
                                "\"none\", \"ease-in\", \"ease-out\", \"ease-in-out\"");
    if (const Json* constant_speed = find(root, "constant_speed")) {
        if (!constant_speed->is_boolean()) fail("", "field \"constant_speed\" must be true or false");
        options.constant_speed = constant_speed->get<bool>();
    }
    if (const Json* ramp = find(root, "ease_seconds")) options.ease_seconds = number_field(*ramp, "ease_seconds", "");
    if (const Json* total = find(root, "total_duration"))
        options.total_duration = number_field(*total, "total_duration", "");
    if (const Json* up = find(root, "up")) options.up = vec3_field(*up, "up", "");
    return options;
}

void check_version(const Json& root) {
    const Json* version = find(root, "version");
    if (!version) fail("", "missing field \"version\"");
    if (!version->is_number_integer() || version->get<long long>() != schema_version)
        fail("", "unsupported version " + version->dump() + " (this build reads version " +
                     std::to_string(schema_version) + ")");
}

}  // namespace

std::string CameraPath::to_json() const {
    Json root;
    root["version"] = schema_version;
    root["interpolation"] = to_string(options_.positions);
    root["orientation"] = to_string(options_.orientations);
    root["constant_speed"] = options_.constant_speed;
    root["easing"] = to_string(options_.easing);
    if (options_.ease_seconds) root["ease_seconds"] = *options_.ease_seconds;
    if (options_.total_duration) root["total_duration"] = *options_.total_duration;
    root["up"] = to_array(options_.up);
    root["keys"] = Json::array();
    for (const Keyframe& key : keys_) root["keys"].push_back(key_to_json(key));
    return root.dump(2) + "\n";
}

CameraPath CameraPath::from_json(std::string_view text, std::string_view source) {
    const std::string prefix = std::string(source) + ": ";
    try {
        const Json root = Json::parse(text);
        if (!root.is_object()) fail("", "the top level must be an object");
        reject_unknown_fields(root, {"version", "interpolation", "orientation", "constant_speed", "easing",
                                     "ease_seconds", "total_duration", "up", "keys"}, "");
        check_version(root);
        const Json* keys_json = find(root, "keys");
        if (!keys_json || !keys_json->is_array()) fail("", "field \"keys\" must be an array of keys");
        std::vector<Keyframe> keys;
        for (size_t i = 0; i < keys_json->size(); ++i) keys.push_back(key_from_json((*keys_json)[i], i));
        return checked(std::move(keys), options_from_json(root));
    } catch (const Json::exception& error) {  // syntax, or a number out of a double's range
        throw std::runtime_error(prefix + "not valid JSON: " + error.what());
    } catch (const std::runtime_error& error) {
        throw std::runtime_error(prefix + error.what());
    }
}

CameraPath CameraPath::load(const std::filesystem::path& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + file.string());
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) throw std::runtime_error("cannot read " + file.string());
    return from_json(text.str(), file.string());
}

void CameraPath::save(const std::filesystem::path& file) const {
    const std::string text = to_json();
    AtomicOutputFile out(file);
    out.write(text.data(), text.size());
    out.commit();
}

}  // namespace strata

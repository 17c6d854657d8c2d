// OpenSceneGraph .path files: reading keys from osg::AnimationPath text, and writing paths in it.
#include "engine/path/osg_path.h"

#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>

#include "preprocess/atomic_file.h"

namespace strata {

namespace {

// time, position x y z, quaternion x y z w
constexpr size_t numbers_per_point = 8;

struct ControlPoint {
    double time;
    glm::dvec3 position;
    glm::dquat rotation;
};

std::vector<std::string_view> split_whitespace(std::string_view line) {
    std::vector<std::string_view> tokens;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        const size_t start = i;
        while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
        if (i > start) tokens.push_back(line.substr(start, i - start));
    }
    return tokens;
}

// Parses one line, or returns nothing for a blank line; `where` is "<source>:<line>: ".
std::optional<ControlPoint> parse_point(std::string_view line, const std::string& where) {
    const std::vector<std::string_view> tokens = split_whitespace(line);
    if (tokens.empty()) return std::nullopt;
    if (tokens.size() != numbers_per_point)
        throw std::runtime_error(where + "expected 8 numbers (time px py pz qx qy qz qw), got " +
                                 std::to_string(tokens.size()) + " fields");
    std::array<double, numbers_per_point> v;
    for (size_t i = 0; i < numbers_per_point; ++i) {
        const char* end = tokens[i].data() + tokens[i].size();
        const auto [stop, error] = std::from_chars(tokens[i].data(), end, v[i]);
        if (error != std::errc() || stop != end)
            throw std::runtime_error(where + "\"" + std::string(tokens[i]) + "\" is not a number");
        if (!std::isfinite(v[i])) throw std::runtime_error(where + "\"" + std::string(tokens[i]) + "\" is not finite");
    }
    const glm::dquat rotation(v[7], v[4], v[5], v[6]);  // OSG writes x y z w
    const double norm = glm::length(rotation);
    if (norm < 1e-12) throw std::runtime_error(where + "zero quaternion");
    return ControlPoint{v[0], {v[1], v[2], v[3]}, rotation / norm};
}

std::string shortest(double value) {
    std::array<char, 32> buffer;
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    return std::string(buffer.data(), result.ptr);
}

void write_point(std::ostream& out, double time, const Pose& pose) {
    const glm::dvec3& p = pose.position;
    const glm::dquat& q = pose.orientation;
    out << shortest(time) << ' ' << shortest(p.x) << ' ' << shortest(p.y) << ' ' << shortest(p.z) << ' '
        << shortest(q.x) << ' ' << shortest(q.y) << ' ' << shortest(q.z) << ' ' << shortest(q.w) << '\n';
}

}  // namespace

std::vector<Keyframe> read_osg_path(std::istream& in, std::string_view source) {
    std::vector<Keyframe> keys;
    double previous_time = 0;
    std::string line;
    for (size_t number = 1; std::getline(in, line); ++number) {
        const std::string where = std::string(source) + ":" + std::to_string(number) + ": ";
        const std::optional<ControlPoint> point = parse_point(line, where);
        if (!point) continue;
        if (!keys.empty()) {
            if (point->time <= previous_time)
                throw std::runtime_error(where + "time " + shortest(point->time) + " does not follow " +
                                         shortest(previous_time));
            keys.back().duration = point->time - previous_time;
        }
        previous_time = point->time;
        Keyframe key;
        key.position = point->position;
        key.orientation = point->rotation;
        keys.push_back(key);
    }
    if (in.bad()) throw std::runtime_error(std::string(source) + ": read error");
    if (keys.size() < 2)
        throw std::runtime_error(std::string(source) + ": a camera path needs at least 2 control points, got " +
                                 std::to_string(keys.size()));
    return keys;
}

CameraPath import_osg_path(const std::filesystem::path& file, PathOptions options) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error("cannot read " + file.string());
    std::vector<Keyframe> keys = read_osg_path(in, file.string());
    try {
        return CameraPath::from_keys(std::move(keys), options);
    } catch (const std::runtime_error& error) {
        throw std::runtime_error(file.string() + ": " + error.what());
    }
}

void write_osg_path(const CameraPath& path, std::ostream& out, std::optional<double> fps) {
    if (fps) {
        const std::vector<Pose> frames = path.frames(*fps);
        for (size_t i = 0; i < frames.size(); ++i) write_point(out, double(i) / *fps, frames[i]);
        return;
    }
    for (size_t key = 0; key < path.key_count(); ++key) {
        const double time = path.key_time(key);
        write_point(out, time, path.sample(time));
    }
}

void export_osg_path(const CameraPath& path, const std::filesystem::path& file, std::optional<double> fps) {
    std::ostringstream text;
    write_osg_path(path, text, fps);
    const std::string bytes = text.str();
    AtomicOutputFile out(file);
    out.write(bytes.data(), bytes.size());
    out.commit();
}

}  // namespace strata

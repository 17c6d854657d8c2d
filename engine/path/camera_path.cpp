// CameraPath: checks keys and options, builds the splines and timing, and samples poses.
#include "engine/path/camera_path.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "engine/path/rotation.h"

namespace strata {

namespace {

// Keys, targets, handles and up lie within this many metres of the origin (a thousand times the Earth's
// orbit): beyond it the squares in chord and arc lengths overflow a double and the path has no length.
constexpr double farthest_coordinate = 1e15;

[[noreturn]] void fail_key(size_t key, const std::string& message) {
    throw std::runtime_error("key " + std::to_string(key) + ": " + message);
}

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
bool finite(const glm::dquat& q) { return std::isfinite(q.w) && finite(glm::dvec3(q.x, q.y, q.z)); }

// Finite and within farthest_coordinate on every axis.
bool within_reach(const glm::dvec3& v) {
    return finite(v) && std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)}) <= farthest_coordinate;
}

[[noreturn]] void fail_reach(size_t key, const std::string& what) {
    fail_key(key, what + " is not finite or lies beyond " + message_number(farthest_coordinate) + " m");
}

void check_view(const Keyframe& key, size_t index, OrientationInterpolation orientations) {
    if (key.orientation && key.target) fail_key(index, "give an orientation or a target, not both");
    if (!key.orientation && !key.target) fail_key(index, "give an orientation or a target");
    if (orientations == OrientationInterpolation::look_at && !key.target)
        fail_key(index, "orientation \"look-at\" needs a target at every key");
    if (key.orientation) {
        if (!finite(*key.orientation)) fail_key(index, "orientation is not finite");
        if (glm::length(*key.orientation) < 1e-12) fail_key(index, "orientation is a zero quaternion");
    } else {
        if (!within_reach(*key.target)) fail_reach(index, "target");
        if (*key.target == key.position) fail_key(index, "target equals position: nowhere to look");
    }
}

void check_key(const Keyframe& key, size_t index, bool last, const PathOptions& options) {
    if (!within_reach(key.position)) fail_reach(index, "position");
    check_view(key, index, options.orientations);
    if (!(key.fov_degrees > 0 && key.fov_degrees < 180))
        fail_key(index, "fov must be in (0, 180) degrees, got " + message_number(key.fov_degrees));
    if (key.duration) {
        if (last) fail_key(index, "duration on the last key, which starts no segment");
        if (!(std::isfinite(*key.duration) && *key.duration > 0))
            fail_key(index, "duration must be a positive number of seconds, got " + message_number(*key.duration));
    }
    if (key.handles.in && !within_reach(*key.handles.in)) fail_reach(index, "handle_in");
    if (key.handles.out && !within_reach(*key.handles.out)) fail_reach(index, "handle_out");
}

void check_options(const PathOptions& options) {
    const auto& total = options.total_duration;
    if (total && !(std::isfinite(*total) && *total > 0))
        throw std::runtime_error("total_duration must be a positive number of seconds, got " + message_number(*total));
    const auto& ramp = options.ease_seconds;
    if (ramp && !(std::isfinite(*ramp) && *ramp >= 0))
        throw std::runtime_error("ease_seconds must be a number of seconds >= 0, got " + message_number(*ramp));
    if (!within_reach(options.up) || glm::length(options.up) == 0)
        throw std::runtime_error("up must be a non-zero vector within " + message_number(farthest_coordinate));
}

std::vector<glm::dvec3> positions_of(const std::vector<Keyframe>& keys) {
    std::vector<glm::dvec3> points;
    for (const Keyframe& key : keys) points.push_back(key.position);
    return points;
}

}  // namespace

CameraPath CameraPath::from_keys(std::vector<Keyframe> keys, PathOptions options) {
    try {
        return checked(std::move(keys), std::move(options));
    } catch (const std::runtime_error& error) {
        throw std::runtime_error(std::string("camera path: ") + error.what());
    }
}

CameraPath CameraPath::checked(std::vector<Keyframe> keys, PathOptions options) {
    check_options(options);
    if (keys.size() < 2) throw std::runtime_error("a path needs at least 2 keys, got " + std::to_string(keys.size()));
    for (size_t i = 0; i < keys.size(); ++i) check_key(keys[i], i, i + 1 == keys.size(), options);
    CameraPath path;
    path.keys_ = std::move(keys);
    path.options_ = options;
    path.build();
    return path;
}

void CameraPath::build() {
    std::vector<BezierHandles> handles;
    for (const Keyframe& key : keys_) handles.push_back(key.handles);
    const std::vector<glm::dvec3> points = positions_of(keys_);
    positions_ = make_segments(points, options_.positions, handles);
    for (const CubicSegment& segment : positions_) arc_lengths_.emplace_back(segment);

    for (const Keyframe& key : keys_)
        key_orientations_.push_back(key.orientation ? glm::normalize(*key.orientation)
                                                    : look_at_orientation(key.position, *key.target, options_.up));
    align_hemispheres(key_orientations_);
    squad_controls_ = squad_controls(key_orientations_);
    if (options_.orientations == OrientationInterpolation::look_at) {
        std::vector<glm::dvec3> targets;
        for (const Keyframe& key : keys_) targets.push_back(*key.target);
        targets_ = make_segments(targets, options_.positions);
    }

    std::vector<std::optional<double>> given;
    for (size_t i = 0; i + 1 < keys_.size(); ++i) given.push_back(keys_[i].duration);
    const std::vector<double> durations = segment_durations(given, timing_weights(), options_.total_duration);
    starts_.assign(1, 0.0);
    for (double duration : durations) starts_.push_back(starts_.back() + duration);
    compute_fov_slopes();
    easing_ = EasingCurve(options_.easing, duration(), options_.ease_seconds.value_or(EasingCurve::default_ramp(duration())));
}

std::vector<double> CameraPath::timing_weights() const {
    if (!options_.constant_speed) return natural_spans(positions_of(keys_), options_.positions);
    std::vector<double> lengths;
    for (const ArcLength& arc : arc_lengths_) lengths.push_back(arc.total());
    return lengths;
}

// Monotone cubic (Fritsch–Butland) through the keys' fields of view over path time: C1, and never
// overshoots, so the fov stays between its neighbouring keys' values (and inside (0, 180)).
void CameraPath::compute_fov_slopes() {
    const size_t n = keys_.size();
    std::vector<double> h(n - 1), slope(n - 1);
    for (size_t i = 0; i + 1 < n; ++i) {
        h[i] = starts_[i + 1] - starts_[i];
        slope[i] = (keys_[i + 1].fov_degrees - keys_[i].fov_degrees) / h[i];
    }
    fov_slopes_.assign(n, 0.0);
    fov_slopes_.front() = slope.front();
    fov_slopes_.back() = slope.back();
    for (size_t i = 1; i + 1 < n; ++i) {
        if (slope[i - 1] * slope[i] <= 0) continue;  // a turning point: flat, or it would overshoot
        fov_slopes_[i] = 3 * (h[i - 1] + h[i]) /
                         ((2 * h[i] + h[i - 1]) / slope[i - 1] + (h[i] + 2 * h[i - 1]) / slope[i]);
    }
}

double CameraPath::key_time(size_t key) const { return easing_.clock_time(starts_.at(key)); }

double CameraPath::length() const {
    double total = 0;
    for (const ArcLength& arc : arc_lengths_) total += arc.total();
    return total;
}

std::pair<size_t, double> CameraPath::locate(double path_time) const {
    const size_t last_segment = keys_.size() - 2;
    const size_t after = size_t(std::upper_bound(starts_.begin(), starts_.end(), path_time) - starts_.begin());
    const size_t segment = std::min(after == 0 ? 0 : after - 1, last_segment);
    const double u = (path_time - starts_[segment]) / (starts_[segment + 1] - starts_[segment]);
    return {segment, std::clamp(u, 0.0, 1.0)};
}

glm::dvec3 CameraPath::position_at(size_t segment, double u) const {
    if (!options_.constant_speed) return positions_[segment].point(u);
    const ArcLength& arc = arc_lengths_[segment];
    return positions_[segment].point(arc.parameter_at(u * arc.total()));
}

glm::dquat CameraPath::orientation_at(size_t segment, double u, const glm::dvec3& position) const {
    const glm::dquat &a = key_orientations_[segment], &b = key_orientations_[segment + 1];
    switch (options_.orientations) {
        case OrientationInterpolation::squad:
            return squad(a, b, squad_controls_[segment], squad_controls_[segment + 1], u);
        case OrientationInterpolation::look_at: {
            const glm::dvec3 target = targets_[segment].point(u);
            // The camera passing through its own target has nowhere to look: turn as slerp would.
            if (glm::length(target - position) > 1e-12 * (1 + glm::length(position)))
                return look_at_orientation(position, target, options_.up);
            break;
        }
        case OrientationInterpolation::slerp:
            break;
    }
    return slerp_arc(a, b, u);
}

double CameraPath::fov_at(size_t segment, double u) const {
    const double h = starts_[segment + 1] - starts_[segment];
    const double u2 = u * u, u3 = u2 * u;
    return (2 * u3 - 3 * u2 + 1) * keys_[segment].fov_degrees + (u3 - 2 * u2 + u) * h * fov_slopes_[segment] +
           (-2 * u3 + 3 * u2) * keys_[segment + 1].fov_degrees + (u3 - u2) * h * fov_slopes_[segment + 1];
}

Pose CameraPath::sample(double seconds) const {
    const auto [segment, u] = locate(easing_.path_time(seconds));
    Pose pose;
    pose.position = position_at(segment, u);
    pose.orientation = orientation_at(segment, u, pose.position);
    pose.fov_degrees = fov_at(segment, u);
    return pose;
}

size_t CameraPath::frame_count(double fps) const {
    if (!(std::isfinite(fps) && fps > 0))
        throw std::invalid_argument("camera path: fps must be a positive number, got " + message_number(fps));
    return size_t(std::floor(duration() * fps + 1e-9)) + 1;
}

std::vector<Pose> CameraPath::frames(double fps) const {
    const size_t count = frame_count(fps);
    std::vector<Pose> poses;
    poses.reserve(count);
    for (size_t i = 0; i < count; ++i) poses.push_back(sample(double(i) / fps));
    return poses;
}

namespace {

constexpr std::array<std::pair<Interpolation, std::string_view>, 3> interpolation_names{{
    {Interpolation::linear, "linear"}, {Interpolation::catmull_rom, "catmull-rom"}, {Interpolation::bezier, "bezier"}}};
constexpr std::array<std::pair<OrientationInterpolation, std::string_view>, 3> orientation_names{{
    {OrientationInterpolation::slerp, "slerp"},
    {OrientationInterpolation::squad, "squad"},
    {OrientationInterpolation::look_at, "look-at"}}};
constexpr std::array<std::pair<Easing, std::string_view>, 4> easing_names{{
    {Easing::none, "none"}, {Easing::ease_in, "ease-in"}, {Easing::ease_out, "ease-out"}, {Easing::ease_in_out, "ease-in-out"}}};

template <typename Table, typename Enum>
std::string_view name_in(const Table& table, Enum value) {
    for (const auto& [entry, name] : table)
        if (entry == value) return name;
    return "?";
}

template <typename Table>
auto value_in(const Table& table, std::string_view name) -> std::optional<typename Table::value_type::first_type> {
    for (const auto& [entry, entry_name] : table)
        if (entry_name == name) return entry;
    return std::nullopt;
}

}  // namespace

std::string_view to_string(Interpolation value) { return name_in(interpolation_names, value); }
std::string_view to_string(OrientationInterpolation value) { return name_in(orientation_names, value); }
std::string_view to_string(Easing value) { return name_in(easing_names, value); }
std::optional<Interpolation> parse_interpolation(std::string_view name) { return value_in(interpolation_names, name); }
std::optional<OrientationInterpolation> parse_orientation_interpolation(std::string_view name) {
    return value_in(orientation_names, name);
}
std::optional<Easing> parse_easing(std::string_view name) { return value_in(easing_names, name); }

}  // namespace strata

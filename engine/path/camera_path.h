// CameraPath: a scripted flythrough. Keyframes (position, orientation or look-at target, field of view,
// optional duration), the splines between them and the timing (durations, constant speed, easing),
// sampled by time or frame by frame; saved and loaded as JSON (path_json.cpp).
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "engine/path/curve.h"
#include "engine/path/timing.h"

namespace strata {

// How the view turns from key to key.
enum class OrientationInterpolation {
    slerp,    // constant angular speed within a segment; angular velocity jumps at keys
    squad,    // Shoemake's spherical cubic: smooth turns through the keys
    look_at,  // every key has a target: the targets follow the position spline's kind and the camera
              // looks at the moving target at every instant (an orbit stays locked on its subject)
};

struct Keyframe {
    glm::dvec3 position{0};
    // Exactly one of the two: the camera's orientation (camera-local to world: it looks down its −Z with
    // +Y up, as Camera::orientation), or a point to look at with PathOptions::up as up.
    std::optional<glm::dquat> orientation;
    std::optional<glm::dvec3> target;
    double fov_degrees = 50;          // vertical field of view, as Camera::fov_y_degrees
    std::optional<double> duration;   // seconds from this key to the next (not on the last key)
    BezierHandles handles;            // used by Interpolation::bezier only; missing ones are automatic
};

struct PathOptions {
    Interpolation positions = Interpolation::catmull_rom;
    OrientationInterpolation orientations = OrientationInterpolation::squad;
    // Within every segment the camera covers equal distances in equal times (arc-length
    // reparameterization), and segments without a duration get time in proportion to their length, so
    // the whole path runs at one speed. A segment with its own duration runs at its own constant speed.
    // Off: the spline parameter is uniform in time and segments without a duration share time in
    // proportion to the spline's knot spans, which keeps the velocity continuous at keys.
    bool constant_speed = true;
    Easing easing = Easing::none;
    std::optional<double> ease_seconds;     // each ramp's length; default EasingCurve::default_ramp
    std::optional<double> total_duration;   // see segment_durations (timing.h)
    glm::dvec3 up{0, 1, 0};                 // the up of look-at targets
};

// What a camera takes from the path at one instant.
struct Pose {
    glm::dvec3 position{0};
    glm::dquat orientation{1, 0, 0, 0};  // unit length
    double fov_degrees = 50;
};

// Sampling: clock time → path time (easing) → the segment and the fraction u of its time elapsed.
// Positions follow u through arc length (constant_speed) or directly as the spline parameter;
// orientations (slerp, squad, or the look-at of the target spline) follow u, so a turn is spread evenly
// over its segment; the fov follows a monotone cubic through the keys' values over path time.
class CameraPath {
public:
    // Checks the keys and options, and throws std::runtime_error("camera path: key 3: ...") naming the
    // key and field at fault: fewer than 2 keys, a non-finite number, neither or both of orientation and
    // target, a zero quaternion, a target on the key's position, fov outside (0, 180), a duration ≤ 0 or
    // on the last key, a total_duration ≤ 0 or too short for the given durations, a segment that neither
    // moves nor has a duration, a negative ease_seconds or ramps longer than the path, a zero up vector,
    // look_at without a target at every key. Keys and options are kept as given (a
    // quaternion need not be unit length; it is normalized where used).
    static CameraPath from_keys(std::vector<Keyframe> keys, PathOptions options = {});

    // JSON (schema in path_json.cpp). Errors are std::runtime_error starting with `source` (the file name
    // for load) and naming the key index and field.
    static CameraPath from_json(std::string_view text, std::string_view source = "camera path JSON");
    std::string to_json() const;
    static CameraPath load(const std::filesystem::path& file);
    // Writes a temporary file beside `file` and renames it over `file`.
    void save(const std::filesystem::path& file) const;

    const std::vector<Keyframe>& keys() const { return keys_; }
    const PathOptions& options() const { return options_; }
    size_t key_count() const { return keys_.size(); }

    double duration() const { return starts_.back(); }
    // The clock time at which the camera is at key `key` (easing moves it from the key's path time).
    double key_time(size_t key) const;
    // The length of the position curve.
    double length() const;

    // The pose at `seconds` (clamped to [0, duration()]).
    Pose sample(double seconds) const;
    // floor(duration · fps) + 1: frame i is at i / fps, so the last frame is at the end or just before.
    // (A rounding slack of 1e-9 frame keeps a duration like 0.7 s at 10 fps from losing its last frame.)
    size_t frame_count(double fps) const;
    std::vector<Pose> frames(double fps) const;

private:
    CameraPath() = default;
    // from_keys without the "camera path: " prefix on its errors (from_json puts the source there).
    static CameraPath checked(std::vector<Keyframe> keys, PathOptions options);
    void build();
    std::vector<double> timing_weights() const;
    void compute_fov_slopes();

    // Where path time `path_time` falls: the segment and the fraction of its duration.
    std::pair<size_t, double> locate(double path_time) const;
    glm::dvec3 position_at(size_t segment, double u) const;
    glm::dquat orientation_at(size_t segment, double u, const glm::dvec3& position) const;
    double fov_at(size_t segment, double u) const;

    std::vector<Keyframe> keys_;
    PathOptions options_;
    std::vector<CubicSegment> positions_;
    std::vector<ArcLength> arc_lengths_;
    std::vector<CubicSegment> targets_;               // look_at only
    std::vector<glm::dquat> key_orientations_;        // hemisphere-aligned
    std::vector<glm::dquat> squad_controls_;
    std::vector<double> fov_slopes_;                  // degrees per second at each key
    std::vector<double> starts_;                      // path time at each key; the last is the duration
    EasingCurve easing_;
};

// The names JSON (and scripts) use: "linear", "catmull-rom", "bezier"; "slerp", "squad", "look-at";
// "none", "ease-in", "ease-out", "ease-in-out". The parsers return nothing for any other name.
std::string_view to_string(Interpolation interpolation);
std::string_view to_string(OrientationInterpolation orientation);
std::string_view to_string(Easing easing);
std::optional<Interpolation> parse_interpolation(std::string_view name);
std::optional<OrientationInterpolation> parse_orientation_interpolation(std::string_view name);
std::optional<Easing> parse_easing(std::string_view name);

}  // namespace strata

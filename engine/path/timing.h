// Timing: how long each segment of a camera path lasts, and the easing that maps clock time to path
// time (slow start and stop without changing the duration).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace strata {

enum class Easing { none, ease_in, ease_out, ease_in_out };

// Each segment's duration in seconds. `given` holds the keys' own durations (one per segment);
// `weights` how the others share their time (arc length, or the spline's natural spans).
//   - Without `total`: given durations are kept; each other segment's share is 1 s on average.
//   - With `total` and every duration given: all are scaled alike so that they sum to `total`.
//   - With `total` and some missing: given ones are kept, the others share what is left of `total`.
// Throws std::runtime_error naming the key whose segment cannot get a duration: nothing left of `total`,
// or a weight of 0 (the camera neither moves nor has a duration there).
std::vector<double> segment_durations(const std::vector<std::optional<double>>& given,
                                      const std::vector<double>& weights, std::optional<double> total);

// Maps clock time t in [0, duration] to path time: with easing, a ramp of `ramp` seconds at the eased
// ends where the path's speed grows from 0 along a smoothstep (velocity continuous, zero acceleration at
// both ends of the ramp), and a uniformly faster cruise between, so that the duration stays the same.
// Outside the ramps, path time runs at one constant rate: constant speed stays constant.
class EasingCurve {
public:
    EasingCurve() = default;
    // Throws std::runtime_error when the ramps do not fit in the duration.
    EasingCurve(Easing easing, double duration, double ramp);

    // The ramp when none is given: a quarter of the duration, at most 2 s.
    static double default_ramp(double duration);

    double path_time(double clock_time) const;
    // The inverse: when the clock reaches `path_time` (bisection; path_time is strictly increasing).
    double clock_time(double path_time) const;
    double ramp_in() const { return ramp_in_; }
    double ramp_out() const { return ramp_out_; }

private:
    double duration_ = 0, ramp_in_ = 0, ramp_out_ = 0;
    double cruise_rate_ = 1;  // path seconds per clock second between the ramps
};

// A number as error messages of the path code show it ("2.5", "-1", "1e+300").
std::string message_number(double value);

}  // namespace strata

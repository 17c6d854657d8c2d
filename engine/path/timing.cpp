// Timing: segment durations of camera paths and the easing ramps.
#include "engine/path/timing.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <string>

namespace strata {

namespace {


}  // namespace

std::vector<double> segment_durations(const std::vector<std::optional<double>>& given,
                                      const std::vector<double>& weights, std::optional<double> total) {
    std::vector<double> durations(given.size(), 0.0);
    double given_sum = 0, missing_weight = 0;
    size_t missing = 0;
    for (size_t i = 0; i < given.size(); ++i) {
        if (given[i]) {
            durations[i] = *given[i];
            given_sum += *given[i];
            continue;
        }
        if (weights[i] <= 0)
            throw std::runtime_error("key " + std::to_string(i) + ": the camera does not move to key " +
                                     std::to_string(i + 1) + ", so the segment's time cannot follow from its "
                                     "length: give key " + std::to_string(i) + " a duration");
        missing_weight += weights[i];
        ++missing;
    }
    if (missing == 0) {
        // Every duration given: a total retimes the whole path, keeping the segments' proportions.
        if (total)
            for (double& duration : durations) duration *= *total / given_sum;
        return durations;
    }
    const double pool = total ? *total - given_sum : double(missing);
    if (pool <= 0)
        throw std::runtime_error("total_duration " + message_number(*total) + " leaves no time for the segments "
                                 "without a duration (the given durations sum to " + message_number(given_sum) + ")");
    for (size_t i = 0; i < given.size(); ++i)
        if (!given[i]) durations[i] = pool * weights[i] / missing_weight;
    return durations;
}

EasingCurve::EasingCurve(Easing easing, double duration, double ramp) : duration_(duration) {
    if (easing == Easing::ease_in || easing == Easing::ease_in_out) ramp_in_ = ramp;
    if (easing == Easing::ease_out || easing == Easing::ease_in_out) ramp_out_ = ramp;
    if (ramp_in_ + ramp_out_ > duration * (1 + 1e-12))
        throw std::runtime_error("ease_seconds " + message_number(ramp) + " does not fit in the path's duration " +
                                 message_number(duration) + (ramp_in_ > 0 && ramp_out_ > 0 ? " twice" : ""));
    // The ramps cover half the distance a cruise of the same time would: speed up the cruise to make up.
    cruise_rate_ = duration / (duration - (ramp_in_ + ramp_out_) / 2);
}

double EasingCurve::default_ramp(double duration) { return std::min(2.0, duration / 4); }

namespace {

// Distance covered over a ramp of length 1 at x ∈ [0, 1], the speed being smoothstep(x) = 3x² − 2x³.
double ramp_distance(double x) { return x * x * x * (1 - x / 2); }

}  // namespace

double EasingCurve::path_time(double t) const {
    t = std::clamp(t, 0.0, duration_);
    if (t < ramp_in_) return cruise_rate_ * ramp_in_ * ramp_distance(t / ramp_in_);
    if (t > duration_ - ramp_out_) return duration_ - cruise_rate_ * ramp_out_ * ramp_distance((duration_ - t) / ramp_out_);
    return cruise_rate_ * (t - ramp_in_ / 2);
}

double EasingCurve::clock_time(double path) const {
    if (path <= 0) return 0;
    if (path >= duration_) return duration_;
    if (ramp_in_ == 0 && ramp_out_ == 0) return path;
    double lo = 0, hi = duration_;
    for (int iteration = 0; iteration < 200 && hi - lo > 1e-15 * duration_; ++iteration) {
        const double middle = (lo + hi) / 2;
        (path_time(middle) < path ? lo : hi) = middle;
    }
    return (lo + hi) / 2;
}

std::string message_number(double value) {
    std::ostringstream out;
    out << value;
    return out.str();
}

}  // namespace strata

// Curve: cubic Bézier segments for linear, centripetal Catmull–Rom and Bézier paths; arc length.
#include "engine/path/curve.h"

#include <algorithm>
#include <cmath>

namespace strata {

glm::dvec3 CubicSegment::point(double s) const {
    const double r = 1 - s;
    return r * r * r * control[0] + 3 * r * r * s * control[1] + 3 * r * s * s * control[2] + s * s * s * control[3];
}

glm::dvec3 CubicSegment::derivative(double s) const {
    const double r = 1 - s;
    return 3 * r * r * (control[1] - control[0]) + 6 * r * s * (control[2] - control[1]) +
           3 * s * s * (control[3] - control[2]);
}

namespace {

// Chords shorter than this fraction of the longest count as coincident keys: a rounding-noise chord
// would otherwise lend its random direction to the neighbouring tangents.
constexpr double coincident_fraction = 1e-9;

std::vector<double> chord_lengths(const std::vector<glm::dvec3>& points) {
    std::vector<double> lengths(points.size() - 1);
    for (size_t i = 0; i + 1 < points.size(); ++i) lengths[i] = glm::length(points[i + 1] - points[i]);
    const double longest = *std::max_element(lengths.begin(), lengths.end());
    for (double& length : lengths)
        if (length <= coincident_fraction * longest) length = 0;
    return lengths;
}

// The derivative, with respect to the knot parameter, at each key (see make_segments).
std::vector<glm::dvec3> key_tangents(const std::vector<glm::dvec3>& p, const std::vector<double>& span) {
    const size_t n = p.size();
    std::vector<glm::dvec3> tangents(n, glm::dvec3(0));
    for (size_t j = 0; j < n; ++j) {
        const bool left = j > 0 && span[j - 1] > 0;
        const bool right = j + 1 < n && span[j] > 0;
        if (left && right) {
            const double d0 = span[j - 1], d1 = span[j];
            tangents[j] = (p[j] - p[j - 1]) / d0 - (p[j + 1] - p[j - 1]) / (d0 + d1) + (p[j + 1] - p[j]) / d1;
        } else if (left) {
            tangents[j] = (p[j] - p[j - 1]) / span[j - 1];
        } else if (right) {
            tangents[j] = (p[j + 1] - p[j]) / span[j];
        }
    }
    return tangents;
}

CubicSegment straight(const glm::dvec3& a, const glm::dvec3& b) {
    return {{a, a + (b - a) / 3.0, a + (b - a) * (2.0 / 3.0), b}};
}

}  // namespace

std::vector<double> natural_spans(const std::vector<glm::dvec3>& points, Interpolation interpolation) {
    std::vector<double> spans = chord_lengths(points);
    if (interpolation == Interpolation::catmull_rom)
        for (double& span : spans) span = std::sqrt(span);
    return spans;
}

std::vector<CubicSegment> make_segments(const std::vector<glm::dvec3>& points, Interpolation interpolation,
                                        const std::vector<BezierHandles>& handles) {
    const size_t count = points.size() - 1;
    std::vector<CubicSegment> segments(count);
    const std::vector<double> span = natural_spans(points, interpolation);
    const std::vector<glm::dvec3> tangents = key_tangents(points, span);
    for (size_t i = 0; i < count; ++i) {
        const glm::dvec3 &a = points[i], &b = points[i + 1];
        if (interpolation == Interpolation::linear || span[i] == 0) {
            segments[i] = straight(a, b);
        } else {
            segments[i] = {{a, a + tangents[i] * (span[i] / 3), b - tangents[i + 1] * (span[i] / 3), b}};
        }
        if (interpolation == Interpolation::bezier && !handles.empty()) {
            if (handles[i].out) segments[i].control[1] = *handles[i].out;
            if (handles[i + 1].in) segments[i].control[2] = *handles[i + 1].in;
        }
    }
    return segments;
}

namespace {

// Five-point Gauss–Legendre on [-1, 1]: exact for polynomials up to degree 9.
constexpr std::array<double, 5> gauss_nodes{0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640,
                                            0.9061798459386640};
constexpr std::array<double, 5> gauss_weights{0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                              0.2369268850561891, 0.2369268850561891};

}  // namespace

ArcLength::ArcLength(const CubicSegment& segment) : segment_(segment) {
    for (int k = 0; k < slices; ++k)
        cumulative_[k + 1] = cumulative_[k] + integrate(double(k) / slices, double(k + 1) / slices);
}

double ArcLength::integrate(double s0, double s1) const {
    const double half = (s1 - s0) / 2, middle = (s0 + s1) / 2;
    double sum = 0;
    for (size_t i = 0; i < gauss_nodes.size(); ++i)
        sum += gauss_weights[i] * glm::length(segment_.derivative(middle + half * gauss_nodes[i]));
    return sum * half;
}

double ArcLength::at(double s) const {
    s = std::clamp(s, 0.0, 1.0);
    const int k = std::min(int(s * slices), slices - 1);
    return cumulative_[k] + integrate(double(k) / slices, s);
}

double ArcLength::parameter_at(double length) const {
    if (length <= 0 || total() == 0) return 0;
    if (!(length < total())) return 1;  // also for a NaN total, which no bracket in the table holds
    const int k = int(std::upper_bound(cumulative_.begin(), cumulative_.end(), length) - cumulative_.begin()) - 1;
    double lo = double(k) / slices, hi = double(k + 1) / slices;
    const double slice_length = cumulative_[k + 1] - cumulative_[k];
    double s = lo + (hi - lo) * (slice_length > 0 ? (length - cumulative_[k]) / slice_length : 0.5);
    const double tolerance = 1e-12 * total();
    for (int iteration = 0; iteration < 60; ++iteration) {
        const double error = cumulative_[k] + integrate(double(k) / slices, s) - length;
        if (std::abs(error) <= tolerance) break;
        (error < 0 ? lo : hi) = s;
        const double speed = glm::length(segment_.derivative(s));
        const double newton = speed > 0 ? s - error / speed : lo;
        // Where the curve nearly stops (a handle on its key) Newton overshoots: bisect instead.
        s = newton > lo && newton < hi ? newton : (lo + hi) / 2;
    }
    return s;
}

}  // namespace strata

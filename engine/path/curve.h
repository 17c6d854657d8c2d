// Curve: the position splines of camera paths, every segment one cubic Bézier (linear, centripetal
// Catmull–Rom and Bézier all reduce to that form), and arc length along a segment and back.
#pragma once

#include <array>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

namespace strata {

// How positions move from key to key.
enum class Interpolation {
    linear,       // straight segments; velocity jumps at keys
    catmull_rom,  // centripetal (α = 0.5): through every key, C1, no cusps or self-intersections
    bezier,       // cubic Bézier: the keys' handles where given, automatic (Bessel) handles elsewhere
};

// One cubic Bézier segment, parameter s in [0, 1].
struct CubicSegment {
    std::array<glm::dvec3, 4> control;

    glm::dvec3 point(double s) const;
    glm::dvec3 derivative(double s) const;  // d point / ds
};

// The Bézier control points a key may carry (absolute positions), used by Interpolation::bezier only.
struct BezierHandles {
    std::optional<glm::dvec3> in;   // before the key: the segment ending at the key
    std::optional<glm::dvec3> out;  // after the key: the segment starting at the key
};

// The segments through `points` (at least 2): segment i runs from points[i] to points[i + 1].
// Catmull–Rom and automatic Bézier handles share one rule: the tangent at a key is the derivative of the
// parabola through it and its neighbours, with knots spaced |Δp|^0.5 (Catmull–Rom) or |Δp| (Bézier);
// for centripetal Catmull–Rom that is exactly the Barry–Goldman spline. A key with only one moving
// neighbour (an end, or beside a coincident key) takes that chord's direction, which is what reflecting
// the end keys (p₋₁ = 2p₀ − p₁) gives. Coincident keys make a segment that stays put; never a NaN.
// `handles` is empty or one per point.
std::vector<CubicSegment> make_segments(const std::vector<glm::dvec3>& points, Interpolation interpolation,
                                        const std::vector<BezierHandles>& handles = {});

// The spline's own parameter span of each segment: the knot spacing above (|Δp|^0.5 or |Δp|; |Δp| for
// linear). Giving segments durations in these proportions makes the velocity continuous at keys.
std::vector<double> natural_spans(const std::vector<glm::dvec3>& points, Interpolation interpolation);

// Arc length along one segment, tabulated (Gauss–Legendre per slice), and its inverse.
class ArcLength {
public:
    explicit ArcLength(const CubicSegment& segment);

    double total() const { return cumulative_.back(); }
    // The length of the curve from s = 0 to s.
    double at(double s) const;
    // The s at which the length from s = 0 is `length` (clamped to [0, total()]): the table brackets it,
    // then Newton's method, kept inside the bracket by bisection, refines it to ~1e-12 of the total.
    double parameter_at(double length) const;

private:
    static constexpr int slices = 32;

    double integrate(double s0, double s1) const;

    CubicSegment segment_;
    std::array<double, slices + 1> cumulative_{};
};

}  // namespace strata

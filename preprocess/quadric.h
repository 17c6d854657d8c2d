// Garland–Heckbert error quadrics: the weighted sum of squared distances to a set of planes,
// Q(p) = pᵀAp + 2b·p + c. Stored as the 10 unique coefficients plus the total weight, so that
// Q(p) / weight is a mean squared distance in the frame's units.
#pragma once

#include <cmath>

namespace strata {

struct Vec3 {
    float x, y, z;
};
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }

struct Quadric {
    float a00 = 0, a11 = 0, a22 = 0, a10 = 0, a20 = 0, a21 = 0;
    float b0 = 0, b1 = 0, b2 = 0;
    float c = 0;
    float weight = 0;

    // Adds the plane n·p + d = 0 (n of unit length) with the given weight.
    void add_plane(Vec3 n, float d, float w) {
        a00 += w * n.x * n.x;
        a11 += w * n.y * n.y;
        a22 += w * n.z * n.z;
        a10 += w * n.y * n.x;
        a20 += w * n.z * n.x;
        a21 += w * n.z * n.y;
        b0 += w * n.x * d;
        b1 += w * n.y * d;
        b2 += w * n.z * d;
        c += w * d * d;
        weight += w;
    }

    void add(const Quadric& q) {
        a00 += q.a00, a11 += q.a11, a22 += q.a22, a10 += q.a10, a20 += q.a20, a21 += q.a21;
        b0 += q.b0, b1 += q.b1, b2 += q.b2, c += q.c, weight += q.weight;
    }

    // Weighted sum of squared distances from p to the planes (never negative).
    float evaluate(Vec3 p) const {
        float rx = a00 * p.x + a10 * p.y + a20 * p.z + 2 * b0;
        float ry = a10 * p.x + a11 * p.y + a21 * p.z + 2 * b1;
        float rz = a20 * p.x + a21 * p.y + a22 * p.z + 2 * b2;
        float r = rx * p.x + ry * p.y + rz * p.z + c;
        return r > 0 ? r : 0;
    }
};

}  // namespace strata

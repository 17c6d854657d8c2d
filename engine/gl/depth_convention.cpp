// Reversed-Z depth state, projection and depth-to-distance conversion; the maths is derived in
// reversed_z_perspective().
#include "engine/gl/depth_convention.h"

#include <cmath>

#include "engine/gl/gl.h"

namespace strata::gl {

void use_reversed_z_depth() {
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_TRUE);
}

// Clip z = a·z_eye + b, clip w = -z_eye, window depth = z/w. Depth 1 at z_eye = -near and 0 at
// z_eye = -far give a = near/(far - near), b = near·far/(far - near); for far → ∞: a = 0, b = near.
glm::dmat4 reversed_z_perspective(double vertical_fov_radians, double aspect, double near, double far) {
    const double focal = 1.0 / std::tan(vertical_fov_radians / 2);
    const bool infinite = std::isinf(far);
    glm::dmat4 projection(0.0);
    projection[0][0] = focal / aspect;
    projection[1][1] = focal;
    projection[2][2] = infinite ? 0.0 : near / (far - near);
    projection[3][2] = infinite ? near : near * far / (far - near);
    projection[2][3] = -1.0;
    return projection;
}

// Inverting depth = (a·z_eye + b)/(-z_eye) for d = -z_eye: d = b/(depth + a) = near·far/(depth·(far - near) + near).
double eye_distance_from_depth(double depth, double near, double far) {
    if (std::isinf(far)) return near / depth;
    return near * far / (depth * (far - near) + near);
}

}  // namespace strata::gl

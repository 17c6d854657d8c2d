// The depth convention of every Strata framebuffer: REVERSED Z on a 32-bit float depth buffer.
//
//   ***  Near plane -> depth 1, far plane (or infinity) -> depth 0. Cleared to 0, test GL_GREATER,  ***
//   ***  clip-space z in [0, w] (glClipControl GL_ZERO_TO_ONE). Projections MUST come from          ***
//   ***  reversed_z_perspective() (or match it): a standard OpenGL projection draws nothing.         ***
//
// Why: float depth has most of its precision near 0; reversed Z puts that precision at the far end,
// where a standard mapping collapses everything beyond a few hundred near-distances onto 1. A huge
// scan seen from close up keeps millimetre depth resolution kilometres away, even with an infinite far
// plane, which is what the renderer should use.
#pragma once

#include <glm/mat4x4.hpp>

#include <limits>

namespace strata::gl {

inline constexpr float near_plane_depth = 1.0f;
inline constexpr float far_plane_depth = 0.0f;  // also the cleared depth: "nothing drawn here"
inline constexpr double infinite_far = std::numeric_limits<double>::infinity();

// Sets the context's depth state to the convention: glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE), depth
// test on, GL_GREATER, depth writes on. Framebuffer::bind() calls it.
void use_reversed_z_depth();

// A right-handed perspective projection (eye looks down -z) for the convention above. `far` may be
// infinite_far. Double precision: compose it with view matrices of survey-scale scenes before
// converting to float.
glm::dmat4 reversed_z_perspective(double vertical_fov_radians, double aspect, double near, double far = infinite_far);

// The distance along the view axis (-z in eye space, not the length of the ray to the eye) of a
// window-space depth written with reversed_z_perspective(near, far). Depth 0 gives `far` (infinity for
// an infinite far plane): the background.
double eye_distance_from_depth(double depth, double near, double far = infinite_far);

}  // namespace strata::gl

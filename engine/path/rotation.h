// Rotation: the quaternion tools of camera paths: look-at orientations, hemisphere-consistent keys,
// slerp and squad (Shoemake) with their intermediate control quaternions.
#pragma once

#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace strata {

// The orientation of a camera at `eye` looking at `target` (down its −Z), its +Y as close to `up` as
// can be; looking straight along `up`, the least aligned world axis stands in for it (as Camera::look_at).
// `target` must differ from `eye` and `up` be non-zero.
glm::dquat look_at_orientation(const glm::dvec3& eye, const glm::dvec3& target, const glm::dvec3& up);

// Flips signs so each quaternion has a non-negative dot product with the one before: q and −q are the
// same rotation, and interpolating between opposite signs would take the long way round.
void align_hemispheres(std::vector<glm::dquat>& keys);

// Spherical linear interpolation along the arc from a to b as given (no sign flip: squad needs the
// arc between its control quaternions as it is). Unit length result.
glm::dquat slerp_arc(const glm::dquat& a, const glm::dquat& b, double u);

// Squad's intermediate quaternion for each key of a hemisphere-aligned sequence:
// sᵢ = qᵢ·exp(−(log(qᵢ⁻¹qᵢ₊₁) + log(qᵢ⁻¹qᵢ₋₁))/4), and sᵢ = qᵢ at the two ends.
std::vector<glm::dquat> squad_controls(const std::vector<glm::dquat>& keys);

// Squad between keys a and b with their intermediates sa and sb: passes through a at u = 0 and b at
// u = 1 with angular velocity continuous across evenly timed keys.
glm::dquat squad(const glm::dquat& a, const glm::dquat& b, const glm::dquat& sa, const glm::dquat& sb, double u);

}  // namespace strata

// Rigid-body kinematics, templated on the scalar.
#pragma once

#include <Eigen/Geometry>

#include "stend/physics/rotations.hpp"

namespace stend::physics {

// Acceleration [m/s²] of a point fixed at r [m] in a rigid body turning at ω [rad/s] with angular
// acceleration α [rad/s²], relative to the acceleration of the body's origin; all three vectors
// and the result in the body frame (the lever arm):
//     a = ω×(ω×r) + α×r        (centripetal + tangential; no Coriolis term: the point is fixed)
template <typename T>
inline Vec3<T> point_acceleration(const Vec3<T>& omega, const Vec3<T>& alpha, const Vec3<T>& r) {
  return omega.cross(omega.cross(r)) + alpha.cross(r);
}

}  // namespace stend::physics

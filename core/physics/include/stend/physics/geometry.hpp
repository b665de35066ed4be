// core/physics in one include: units, passive rotations, the turntable chains and their
// kinematics, rigid-body point acceleration, local gravity. Templated on the scalar where a
// formula may be differentiated (double, ceres::Jet). Each formula is written once:
//   units.hpp        standard gravity, mg, µg, deg, deg/s, deg/h
//   rotations.hpp    Rx, Ry, Rz (frame rotated by a), mounting from roll-pitch-yaw
//   table_chain.hpp  the three-axis table chain and the paper's Table 1 chain, their ω and α
//   kinematics.hpp   the lever arm (acceleration of a point of a rigid body)
//   gravity.hpp      normal gravity, Earth rate, gravity's specific force through a (tilted) chain
#pragma once

#include "stend/physics/gravity.hpp"
#include "stend/physics/kinematics.hpp"
#include "stend/physics/rotations.hpp"
#include "stend/physics/table_chain.hpp"
#include "stend/physics/units.hpp"

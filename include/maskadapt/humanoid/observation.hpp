#pragma once
/// \file observation.hpp
/// The reference humanoid's state feature: motion/observation.hpp's s for its 22 bodies, R^328.
#include <maskadapt/core/types.hpp>
#include <maskadapt/humanoid/description.hpp>
#include <maskadapt/motion/observation.hpp>

namespace maskadapt {

/// Observation size of the reference humanoid.
inline constexpr Index kObservationDim = 328;
static_assert(1 + 3 * (kHumanoidNumBodies - 1) + 12 * kHumanoidNumBodies == kObservationDim);

}  // namespace maskadapt

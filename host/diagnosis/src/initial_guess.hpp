// Starting values of a family added to a fitted model (internal to the diagnosis library).
#pragma once

#include <vector>

#include "delta/diagnosis/effect_model.hpp"

namespace delta::diagnosis {

// Starting values of a family added to a fitted model, from the FIT residuals of that model.
// backlash: half the jump of the residual between falling and rising motion; transmission_error:
// a periodogram of the residual against the angle (quadratic trend removed), per joint.
// long_period: start transmission_error from the best long period fitted to the raw residual
// instead of the periodogram (only the restart after forward selection uses it: in the rounds a
// long-period ripple is flexible enough to stand in for geometry and mislead the greedy choice).
Parameters initial_guess(Family family, const Parameters& theta, const std::vector<Sample>& rows,
                         const std::vector<Vec3>& predicted, bool long_period = false);

// Starting values of transmission_error at the given periods: per joint, the amplitude and phase
// of that period fitted by least squares to the FIT residual of `predicted`.
Parameters ripple_start_at(const Parameters& theta, const std::vector<Sample>& rows, const std::vector<Vec3>& predicted,
                           const Vec3& period_deg);

}  // namespace delta::diagnosis

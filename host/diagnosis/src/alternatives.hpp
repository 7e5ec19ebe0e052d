// Equivalent explanations: other family sets that predict CHECK as well as the chosen one
// (internal to the diagnosis library).
#pragma once

#include <vector>

#include "candidate.hpp"
#include "floor_test.hpp"

namespace delta::diagnosis {

// Tries every one-for-one swap of the chosen set (and, for two or three families at the floor,
// every two-for-one swap), fitted like the selection's candidates. A set is equivalent when its held-out
// MSE is not worse than the chosen set's by more than the stopping rule's threshold or not
// significantly (paired z <= options.paired_z), and, whenever the chosen set passes the floor test,
// it passes it too or is not significantly worse than the chosen set (paired) in every part of the
// floor test it misses. `chosen` is the final model's prediction of the kept CHECK rows.
std::vector<Alternative> find_alternatives(const PipelineData& data, FamilySet chosen_families,
                                           const Parameters& chosen_theta, const std::vector<Vec3>& chosen,
                                           const NoiseModel& noise, bool chosen_at_floor);

}  // namespace delta::diagnosis

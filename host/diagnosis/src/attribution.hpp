// Attribution of the held-out gap: the ranked effects, and where the gap lives per subsystem and
// per workspace region (internal to the diagnosis library).
#pragma once

#include <vector>

#include "candidate.hpp"
#include "selection.hpp"

namespace delta::diagnosis {

// The kept families in the order they were added, each with the held-out RMSE of the model built
// up to it; then the rest by what they would still add to the final model (diagnosis.theta).
// `final_check` is the final model's prediction of the kept CHECK rows, `final_fit` of the FIT rows.
std::vector<EffectFinding> rank_findings(const PipelineData& data, const Selection& selection,
                                         const Diagnosis& diagnosis, const Vec3& final_rmse,
                                         const std::vector<Vec3>& final_fit);

// Held-out RMSE of the final model with one subsystem's families taken out (parameters as fitted).
std::vector<std::pair<std::string, Vec3>> subsystem_errors(const std::vector<Sample>& check, FamilySet families,
                                                           const Parameters& theta);

// Octant of a position in the box [low, high] (bit 0: x above the middle, 1: y, 2: z) and its label.
int octant_of(const Vec3& position, const Vec3& middle);
std::string octant_label(int octant);
Vec3 middle_of(const std::vector<Sample>& rows);

// Held-out RMSE per octant of the CHECK trajectory's bounding box, nominal and after.
std::vector<RegionError> region_errors(const std::vector<Sample>& check, const std::vector<Vec3>& nominal,
                                       const std::vector<Vec3>& after);

}  // namespace delta::diagnosis

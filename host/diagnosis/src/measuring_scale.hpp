// An effect outside the vocabulary: a uniform scale error of the measuring stage, tried when the
// fitted length families look like one (internal to the diagnosis library).
#pragma once

#include <optional>
#include <vector>

#include "candidate.hpp"
#include "floor_test.hpp"

namespace delta::diagnosis {

// Positions divided by (1 + scale): what the stage would have read without its scale error.
std::vector<Sample> unscaled(const std::vector<Sample>& rows, double scale);

struct ScaleModel {
  double scale = 0.0;
  double confidence_95 = 0.0;  // half width of the scale, from the curvature of the FIT cost
  FamilySet families;          // vocabulary families fitted with it
  Parameters theta;
  FitResult fit;  // of the other families, for their intervals (empty without them)
  std::vector<Vec3> fit_prediction, check_prediction;  // kept rows
  Vec3 holdout_rmse = Vec3::Zero();
};

// When the chosen set holds length families (upper_arm_length, lower_arm_length, radius_offset)
// whose fitted changes are one common relative change k of the nominal lengths
// (40, 68, 10 mm; the proportional part carries 90 % of their square sum), fits the chosen set
// without the length families on positions divided by (1 + s), s from k and refined by a parabola
// through three FIT costs. Returns nothing when the lengths do not look like a scale.
std::optional<ScaleModel> fit_measuring_scale(const PipelineData& data, FamilySet chosen, const Parameters& theta);

}  // namespace delta::diagnosis

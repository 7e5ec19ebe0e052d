// An effect outside the vocabulary: a scale error of the measuring stage, uniform (tried when the
// fitted length families look like one) or per axis (tried when the chosen set holds families that
// can imitate one) (internal to the diagnosis library).
#pragma once

#include <optional>
#include <vector>

#include "candidate.hpp"
#include "floor_test.hpp"

namespace delta::diagnosis {

// Positions divided by (1 + scale) axis by axis: what the stage would have read without its scale
// error.
std::vector<Sample> unscaled(const std::vector<Sample>& rows, const Vec3& scale);

struct ScaleModel {
  bool per_axis = false;              // false: one scale s of every axis
  Vec3 scale = Vec3::Zero();          // s_x, s_y, s_z (all equal when uniform)
  Vec3 confidence_95 = Vec3::Zero();  // half widths, from the curvature of the FIT cost
  FamilySet families;                 // vocabulary families fitted with it
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

// Families with which the vocabulary imitates a scale of one stage axis: the lengths, the encoder
// scales and the measuring frame.
FamilySet scale_imitators();

// A scale per stage axis fitted with the families `others` (started from theta's values):
// Gauss-Newton steps on the three scales alternating with refits of the other families. Returns
// nothing when a row becomes unreachable or a scale leaves +-10 %.
std::optional<ScaleModel> fit_axis_scale(const PipelineData& data, FamilySet others, const Parameters& theta);

}  // namespace delta::diagnosis

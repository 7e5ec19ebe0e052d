// Levenberg-Marquardt fit of the hybrid model's math-model effects (central-difference Jacobian).
#include "delta/nn/effect_fit.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "delta/model_error.hpp"
#include "delta/nn/levenberg_marquardt.hpp"
#include "delta/nn/trained_model.hpp"

namespace delta::nn {
namespace {

// Parameter vector in units of order one so that the damping mu I treats them alike:
// per chain j at 6 j: dL_A [mm], dL_B [mm], dr [mm], dphi [deg], offset [deg], scale [1e-3];
// then frame rx, ry [deg], tx, ty, tz [mm]; then backlash widths [deg] (their magnitude is used).
constexpr Eigen::Index kChainParameters = 6;
constexpr Eigen::Index kParameters = 3 * kChainParameters + 5 + 3;

EffectSet effects_of(const Eigen::VectorXd& x) {
  EffectSet effects;
  Vec3 upper, lower, radius, angle, offset, scale;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Index at = kChainParameters * j;
    upper[j] = x[at] * 1e-3;
    lower[j] = x[at + 1] * 1e-3;
    radius[j] = x[at + 2] * 1e-3;
    angle[j] = x[at + 3];
    offset[j] = x[at + 4];
    scale[j] = x[at + 5] * 1e-3;
  }
  effects.upper_arm_length_m = upper;
  effects.lower_arm_length_m = lower;
  effects.radius_offset_m = radius;
  effects.chain_angle_deg = angle;
  effects.joint_offset_deg = offset;
  effects.encoder_scale = scale;
  const Eigen::Index at = 3 * kChainParameters;
  effects.frame_misalignment =
      FrameMisalignment{Vec3(x[at], x[at + 1], 0.0), Vec3(x[at + 2], x[at + 3], x[at + 4]) * 1e-3};
  effects.backlash_deg = x.segment<3>(at + 5).cwiseAbs();
  return effects;
}

class EffectProblem : public LeastSquaresProblem {
 public:
  explicit EffectProblem(const std::vector<Sample>& samples) : samples_(samples) {}

  // Measured minus predicted angles, 3 per sample; false when a pose is unreachable.
  bool residuals(const Eigen::VectorXd& x, Eigen::VectorXd& out) const {
    std::vector<Vec3> predicted;
    if (!predict_in_time_order(effects_of(x), samples_, predicted)) return false;
    out.resize(3 * static_cast<Eigen::Index>(samples_.size()));
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      out.segment<3>(3 * static_cast<Eigen::Index>(i)) = samples_[i].alpha_deg - predicted[i];
    }
    return true;
  }

  double sum_squared_error(const Eigen::VectorXd& x) override {
    Eigen::VectorXd errors;
    return residuals(x, errors) ? errors.squaredNorm() : std::numeric_limits<double>::infinity();
  }

  NormalEquations normal_equations(const Eigen::VectorXd& x) override {
    Eigen::VectorXd errors, plus, minus;
    if (!residuals(x, errors)) throw std::invalid_argument("the math model cannot reach a recorded pose");
    Eigen::MatrixXd jacobian(errors.size(), x.size());
    constexpr double kStep = 1e-5;  // parameters are of order one (mm, deg, 1e-3)
    for (Eigen::Index p = 0; p < x.size(); ++p) {
      Eigen::VectorXd shifted = x;
      shifted[p] = x[p] + kStep;
      const bool plus_ok = residuals(shifted, plus);
      shifted[p] = x[p] - kStep;
      const bool minus_ok = residuals(shifted, minus);
      // Residual = measured - model, so d model / dx = -(d residual / dx).
      jacobian.col(p) =
          plus_ok && minus_ok ? Eigen::VectorXd((minus - plus) / (2.0 * kStep)) : Eigen::VectorXd::Zero(errors.size());
    }
    // Coefficient-based products: a summation order independent of the CPU's cache sizes.
    return {jacobian.transpose().lazyProduct(jacobian), jacobian.transpose().lazyProduct(errors)};
  }

 private:
  const std::vector<Sample>& samples_;
};

Vec3 rmse_of(const std::vector<Sample>& samples, const EffectSet& effects) {
  std::vector<Vec3> measured;
  for (const Sample& sample : samples) measured.push_back(sample.alpha_deg);
  return joint_error_stats(measured, predict_recording(effects, samples)).rmse_deg;
}

}  // namespace

bool predict_in_time_order(const EffectSet& effects, const std::vector<Sample>& samples, std::vector<Vec3>& predicted) {
  // The SPEC order: encoder_scale and transmission_error, then backlash, then joint_offset.
  EffectSet before_backlash = effects;
  before_backlash.backlash_deg.reset();
  before_backlash.joint_offset_deg.reset();
  std::array<Backlash, 3> play;
  for (int j = 0; j < 3; ++j) play[j] = Backlash(effects.backlash_deg ? (*effects.backlash_deg)[j] : 0.0);
  const Vec3 offset = effects.joint_offset_deg.value_or(Vec3::Zero());
  predicted.resize(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const IkSolution solution = math_model_angles(before_backlash, samples[i].position_m);
    if (!solution.ok()) return false;
    for (int j = 0; j < 3; ++j) predicted[i][j] = play[j].update(solution.alpha_deg[j]) + offset[j];
  }
  return true;
}

std::vector<Vec3> predict_recording(const EffectSet& effects, const std::vector<Sample>& samples) {
  std::vector<Vec3> predicted;
  if (!predict_in_time_order(effects, samples, predicted)) {
    throw std::invalid_argument("the math model cannot reach a recorded pose");
  }
  return predicted;
}

EffectFit fit_math_model_effects(const std::vector<Sample>& samples, int max_iterations) {
  EffectFit fit;
  fit.rmse_before_deg = rmse_of(samples, EffectSet{});
  EffectProblem problem(samples);
  LmOptions options;
  options.max_epochs = max_iterations;
  options.plateau_epochs = 5;
  options.plateau_fraction = 1e-6;
  // Start from the nominal robot with a little play: |b| has no slope at b = 0.
  Eigen::VectorXd start = Eigen::VectorXd::Zero(kParameters);
  start.tail<3>().setConstant(0.05);
  const LmResult result = levenberg_marquardt(problem, start, options);
  fit.effects = effects_of(result.x);
  fit.iterations = result.epochs;
  fit.rmse_after_deg = rmse_of(samples, fit.effects);
  return fit;
}

}  // namespace delta::nn

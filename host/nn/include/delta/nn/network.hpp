// The inverse-kinematics network of the paper: 3 inputs (plate position, m), H tanh hidden neurons,
// 3 linear outputs (joint angles, deg), with MATLAB mapminmax scaling of inputs and outputs to [-1, 1].
//
// Layout follows MATLAB's network object so an exported net maps one to one:
//   u = mapminmax(x)           = 2 (x - input_min) / (input_max - input_min) - 1
//   h = tanh(IW u + b1)        IW: H x 3, b1: H
//   v = LW h + b2              LW: 3 x H, b2: 3
//   alpha = mapminmax^-1(v)    = (v + 1) (output_max - output_min) / 2 + output_min
#pragma once

#include <string>

#include <Eigen/Core>

namespace delta::nn {

struct Network {
  Eigen::Vector3d input_min = Eigen::Vector3d::Constant(-1.0);   // metres
  Eigen::Vector3d input_max = Eigen::Vector3d::Constant(1.0);    // metres
  Eigen::Vector3d output_min = Eigen::Vector3d::Constant(-1.0);  // degrees
  Eigen::Vector3d output_max = Eigen::Vector3d::Constant(1.0);   // degrees
  Eigen::MatrixXd input_weights;                                 // IW{1,1}: hidden x 3
  Eigen::VectorXd hidden_bias;                                   // b{1}: hidden
  Eigen::MatrixXd output_weights;                                // LW{2,1}: 3 x hidden
  Eigen::Vector3d output_bias = Eigen::Vector3d::Zero();         // b{2}

  int hidden() const { return static_cast<int>(hidden_bias.size()); }
  Eigen::Vector3d scale_input(const Eigen::Vector3d& position_m) const;
  Eigen::Vector3d unscale_output(const Eigen::Vector3d& scaled) const;
  // Joint angles in degrees for a plate position in metres (float reference of every back end).
  Eigen::Vector3d evaluate(const Eigen::Vector3d& position_m) const;
};

}  // namespace delta::nn

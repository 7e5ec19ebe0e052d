// Float evaluation of the 3-H-3 tanh network with mapminmax scaling.
#include "delta/nn/network.hpp"

namespace delta::nn {

Eigen::Vector3d Network::scale_input(const Eigen::Vector3d& position_m) const {
  return (2.0 * (position_m - input_min).array() / (input_max - input_min).array() - 1.0).matrix();
}

Eigen::Vector3d Network::unscale_output(const Eigen::Vector3d& scaled) const {
  return ((scaled.array() + 1.0) * (output_max - output_min).array() / 2.0 + output_min.array()).matrix();
}

Eigen::Vector3d Network::evaluate(const Eigen::Vector3d& position_m) const {
  const Eigen::VectorXd hidden_out = (input_weights * scale_input(position_m) + hidden_bias).array().tanh().matrix();
  return unscale_output(output_weights * hidden_out + output_bias);
}

}  // namespace delta::nn

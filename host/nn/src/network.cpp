// Float evaluation of the 3-H-3 tanh network with mapminmax scaling.
#include "delta/nn/network.hpp"

#include <cmath>

namespace delta::nn {

Eigen::Vector3d Network::scale_input(const Eigen::Vector3d& position_m) const {
  return (2.0 * (position_m - input_min).array() / (input_max - input_min).array() - 1.0).matrix();
}

Eigen::Vector3d Network::unscale_output(const Eigen::Vector3d& scaled) const {
  return ((scaled.array() + 1.0) * (output_max - output_min).array() / 2.0 + output_min.array()).matrix();
}

Eigen::Vector3d Network::evaluate(const Eigen::Vector3d& position_m) const {
  // One hidden neuron at a time: no heap temporaries, so a pose costs the 25 tanh and little more.
  const Eigen::Vector3d scaled = scale_input(position_m);
  Eigen::Vector3d output = output_bias;
  for (Eigen::Index i = 0; i < hidden_bias.size(); ++i) {
    const double activation = std::tanh(input_weights(i, 0) * scaled[0] + input_weights(i, 1) * scaled[1] +
                                        input_weights(i, 2) * scaled[2] + hidden_bias[i]);
    output += output_weights.col(i) * activation;
  }
  return unscale_output(output);
}

}  // namespace delta::nn

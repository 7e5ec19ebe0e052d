// Test fixture: a 3-H-3 tanh network fitted in seconds (Levenberg-Marquardt) to the nominal inverse
// kinematics of the 10 mm cube, so fixed-point tests run on weights of realistic magnitude without
// depending on a shipped weights file.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Dense>

#include "delta/kinematics.hpp"
#include "delta/nn/network.hpp"

namespace delta::test {

// The paper's 10 mm cube: x, y in [-5, 5] mm, z in [-80.84, -70.84] mm (metres below).
inline Vec3 cube_min_m() { return Vec3(-0.005, -0.005, -0.08084); }
inline Vec3 cube_max_m() { return Vec3(0.005, 0.005, -0.07084); }

inline nn::Network fit_cube_network(std::uint32_t seed, int hidden = 25, int samples = 1500, int iterations = 150) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Geometry geometry = Geometry::nominal();
  std::vector<Vec3> positions;
  std::vector<Vec3> angles;
  while (static_cast<int>(positions.size()) < samples) {
    Vec3 p;
    for (int j = 0; j < 3; ++j) p[j] = cube_min_m()[j] + unit(rng) * (cube_max_m()[j] - cube_min_m()[j]);
    const IkSolution solution = inverse_kinematics(geometry, p);
    if (!solution.ok()) continue;
    positions.push_back(p);
    angles.push_back(solution.alpha_deg);
  }
  nn::Network net;
  net.input_min = cube_min_m();
  net.input_max = cube_max_m();
  net.output_min = net.output_max = angles[0];
  for (const Vec3& a : angles) {
    net.output_min = net.output_min.cwiseMin(a);
    net.output_max = net.output_max.cwiseMax(a);
  }
  std::normal_distribution<double> normal(0.0, 1.0);
  net.input_weights = Eigen::MatrixXd(hidden, 3);
  net.hidden_bias = Eigen::VectorXd(hidden);
  net.output_weights = Eigen::MatrixXd(3, hidden);
  for (int k = 0; k < hidden; ++k) {
    for (int j = 0; j < 3; ++j) net.input_weights(k, j) = normal(rng);
    net.hidden_bias(k) = normal(rng);
    for (int o = 0; o < 3; ++o) net.output_weights(o, k) = 0.3 * normal(rng);
  }
  net.output_bias.setZero();

  // Parameters: IW (row-major), b1, LW (row-major), b2. Residuals in the scaled output domain.
  const int n_params = hidden * 3 + hidden + 3 * hidden + 3;
  auto pack = [&](const nn::Network& n) {
    Eigen::VectorXd theta(n_params);
    int i = 0;
    for (int k = 0; k < hidden; ++k)
      for (int j = 0; j < 3; ++j) theta[i++] = n.input_weights(k, j);
    for (int k = 0; k < hidden; ++k) theta[i++] = n.hidden_bias(k);
    for (int o = 0; o < 3; ++o)
      for (int k = 0; k < hidden; ++k) theta[i++] = n.output_weights(o, k);
    for (int o = 0; o < 3; ++o) theta[i++] = n.output_bias(o);
    return theta;
  };
  auto unpack = [&](const Eigen::VectorXd& theta, nn::Network& n) {
    int i = 0;
    for (int k = 0; k < hidden; ++k)
      for (int j = 0; j < 3; ++j) n.input_weights(k, j) = theta[i++];
    for (int k = 0; k < hidden; ++k) n.hidden_bias(k) = theta[i++];
    for (int o = 0; o < 3; ++o)
      for (int k = 0; k < hidden; ++k) n.output_weights(o, k) = theta[i++];
    for (int o = 0; o < 3; ++o) n.output_bias(o) = theta[i++];
  };
  std::vector<Vec3> scaled_in(samples);
  std::vector<Vec3> scaled_out(samples);
  const Vec3 out_half = (net.output_max - net.output_min) / 2.0;
  for (int s = 0; s < samples; ++s) {
    scaled_in[s] = net.scale_input(positions[s]);
    scaled_out[s] = ((angles[s] - net.output_min).array() / out_half.array() - 1.0).matrix();
  }
  auto residuals = [&](const nn::Network& n, Eigen::MatrixXd* jacobian) {
    Eigen::VectorXd r(3 * samples);
    if (jacobian) jacobian->setZero(3 * samples, n_params);
    for (int s = 0; s < samples; ++s) {
      const Eigen::VectorXd h = (n.input_weights * scaled_in[s] + n.hidden_bias).array().tanh().matrix();
      const Eigen::Vector3d v = n.output_weights * h + n.output_bias;
      for (int o = 0; o < 3; ++o) {
        const int row = 3 * s + o;
        r[row] = v[o] - scaled_out[s][o];
        if (!jacobian) continue;
        for (int k = 0; k < hidden; ++k) {
          const double dh = n.output_weights(o, k) * (1.0 - h[k] * h[k]);
          for (int j = 0; j < 3; ++j) (*jacobian)(row, 3 * k + j) = dh * scaled_in[s][j];
          (*jacobian)(row, 3 * hidden + k) = dh;
          (*jacobian)(row, 4 * hidden + o * hidden + k) = h[k];
        }
        (*jacobian)(row, 7 * hidden + o) = 1.0;
      }
    }
    return r;
  };
  Eigen::VectorXd theta = pack(net);
  Eigen::MatrixXd jacobian;
  double damping = 1e-3;
  Eigen::VectorXd r = residuals(net, &jacobian);
  double cost = r.squaredNorm();
  for (int it = 0; it < iterations; ++it) {
    const Eigen::MatrixXd jtj = jacobian.transpose() * jacobian;
    const Eigen::VectorXd jtr = jacobian.transpose() * r;
    for (int attempt = 0; attempt < 10; ++attempt) {
      Eigen::MatrixXd a = jtj;
      a.diagonal().array() += damping;
      const Eigen::VectorXd step = a.ldlt().solve(-jtr);
      nn::Network trial = net;
      unpack(theta + step, trial);
      const Eigen::VectorXd r_trial = residuals(trial, nullptr);
      if (r_trial.squaredNorm() < cost) {
        theta += step;
        net = trial;
        damping = std::max(damping * 0.3, 1e-9);
        r = residuals(net, &jacobian);
        cost = r.squaredNorm();
        break;
      }
      damping *= 10.0;
    }
  }
  return net;
}

}  // namespace delta::test

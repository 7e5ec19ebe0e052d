// Benchmark: inference time per pose of the float network against the closed-form inverse kinematics.
// Usage: bench_nn_inference W.json [poses]. Prints a Markdown table (ns per pose, best of 5 runs).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "delta/kinematics.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/nn/weights_file.hpp"

namespace {

template <typename Function>
double best_ns_per_pose(const std::vector<delta::Vec3>& poses, Function&& evaluate, double& checksum) {
  double best = 1e300;
  for (int run = 0; run < 5; ++run) {
    const auto start = std::chrono::steady_clock::now();
    for (const delta::Vec3& pose : poses) checksum += evaluate(pose).sum();  // keeps the work observable
    const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start).count();
    best = std::min(best, ns / static_cast<double>(poses.size()));
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_nn_inference W.json [poses]\n");
    return 2;
  }
  try {
    const delta::nn::WeightsFile weights = delta::nn::read_weights_file(argv[1]);
    const std::size_t count = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 200000;
    std::mt19937_64 generator(1);
    std::uniform_real_distribution<double> xy(-0.005, 0.005), z(-0.0808, -0.0708);
    std::vector<delta::Vec3> poses(count);
    for (delta::Vec3& pose : poses) pose = delta::Vec3(xy(generator), xy(generator), z(generator));
    const delta::Geometry nominal = delta::Geometry::nominal();
    double checksum = 0.0;
    const double ik_ns = best_ns_per_pose(
        poses, [&](const delta::Vec3& p) { return delta::inverse_kinematics(nominal, p).alpha_deg; }, checksum);
    const double network_ns = best_ns_per_pose(
        poses, [&](const delta::Vec3& p) { return weights.network.evaluate(p); }, checksum);
    const double model_ns = best_ns_per_pose(
        poses, [&](const delta::Vec3& p) { return delta::nn::evaluate_model(weights, p).alpha_deg; }, checksum);
    std::printf("Inference per pose, %zu random poses in the 10 mm cube, best of 5 runs (checksum %.6g)\n\n", count,
                checksum);
    std::printf("| evaluation | ns per pose |\n|---|---|\n");
    std::printf("| closed-form inverse kinematics (nominal) | %.1f |\n", ik_ns);
    std::printf("| network 3-%d-3 (Network::evaluate) | %.1f |\n", weights.network.hidden(), network_ns);
    std::printf("| %s model of %s (float back end) | %.1f |\n", weights.model.c_str(), argv[1], model_ns);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_nn_inference: %s\n", error.what());
    return 2;
  }
  return 0;
}

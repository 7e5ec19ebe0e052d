// Random closed-loop drive of three joints for the bit-exactness tests: the golden controller
// on three plants, with random references (sinusoids, steps, one-period glitches over the whole
// int32 range), random play shifts (steps, jumps over the whole 10 bits) and random load torques. Each period gives the
// inputs and the golden outputs.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <random>

#include "delta/control/closed_loop.hpp"
#include "delta/geometry.hpp"
#include "delta/golden/joint_fixed.hpp"
#include "delta/joint_plant.hpp"

namespace delta::control {

inline std::uint64_t test_seed() {
  const char* text = std::getenv("DELTA_TEST_SEED");
  return text ? std::strtoull(text, nullptr, 10) : 20261121u;
}

class RandomClosedLoop {
 public:
  explicit RandomClosedLoop(std::uint64_t seed)
      : random_(seed),
        coefficients_(golden::make_fixed_coefficients(parameters_)),
        plants_{JointPlant(default_plant(), 30.0), JointPlant(default_plant(), 20.0),
                JointPlant(default_plant(), 40.0)} {
    for (int j = 0; j < 3; ++j) {
      drives_[j] = {plants_[j].shaft_angle_deg(), 1.0 + 4.0 * unit(), 0.1 + 2.0 * unit()};
    }
  }

  // Inputs of period k (call once per period, in order), then the golden update on them.
  const std::array<golden::JointFixedInput, 3>& next_inputs(long k) {
    const double t = k * parameters_.period_s;
    for (int j = 0; j < 3; ++j) {
      Drive& drive = drives_[j];
      if (unit() < 1e-3) drive.step_deg = 4.0 * (unit() - 0.5);
      if (unit() < 5e-4) drive.load_nm = 0.1 * (unit() - 0.5);
      const double reference =
          drive.base_deg + drive.step_deg + drive.amplitude_deg * std::sin(2.0 * kPi * drive.frequency_hz * t);
      inputs_[j].reference = golden::reference_code(reference, parameters_.encoder_resolution_deg);
      if (unit() < 2e-4) {
        inputs_[j].reference = static_cast<std::int32_t>(random_());
        ++glitches;
      }
      inputs_[j].encoder = static_cast<std::int16_t>(std::clamp(plants_[j].encoder_count(), -32768, 32767));
      // The play shift: small steps (a play being crossed), rare jumps anywhere in its kShiftBits.
      if (unit() < 0.05) drive.shift += static_cast<int>(std::floor(7.0 * unit())) - 3;
      constexpr int kShiftHalfRange = 1 << (golden::kShiftBits - 1);
      if (unit() < 1e-3) drive.shift = static_cast<int>(std::floor(2.0 * kShiftHalfRange * unit())) - kShiftHalfRange;
      drive.shift = std::clamp(drive.shift, -kShiftHalfRange, kShiftHalfRange - 1);
      inputs_[j].shift = static_cast<std::int16_t>(drive.shift);
    }
    if (k == 0) {
      for (int j = 0; j < 3; ++j) golden[j] = golden::fixed_rest_state(inputs_[j]);
    }
    for (int j = 0; j < 3; ++j) {
      golden::JointFixedStatus status;
      golden_current[j] = golden::fixed_update(coefficients_, golden[j], inputs_[j], status);
      golden_limited[j] = status.limited;
      overflows += status.overflow_count;
      limited_periods += status.limited;
    }
    return inputs_;
  }

  // The plants move for one period under the golden currents.
  void step_plants() {
    for (int j = 0; j < 3; ++j) {
      plants_[j].step(golden::current_from_code(golden_current[j]), parameters_.period_s, drives_[j].load_nm);
    }
  }

  std::uint16_t overflow_code() const { return static_cast<std::uint16_t>(std::min(overflows, 0xFFFF)); }

  std::array<golden::JointFixedState, 3> golden;
  std::array<std::int16_t, 3> golden_current{};
  std::array<bool, 3> golden_limited{};
  long limited_periods = 0, glitches = 0;
  int overflows = 0;

 private:
  struct Drive {
    double base_deg, amplitude_deg, frequency_hz, step_deg = 0.0, load_nm = 0.0;
    int shift = 0;  // play shift, counts
  };
  double unit() { return std::uniform_real_distribution<double>(0.0, 1.0)(random_); }

  std::mt19937_64 random_;
  golden::JointControllerParameters parameters_;
  golden::JointFixedCoefficients coefficients_;
  std::array<JointPlant, 3> plants_;
  std::array<Drive, 3> drives_;
  std::array<golden::JointFixedInput, 3> inputs_;
};

}  // namespace delta::control

// Host side of the HLS C-simulation (not synthesised): loads a golden QuantisedNetwork into the HLS
// weight struct and runs the HLS network on raw integer codes, so both models see the same codes.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>

#include "backlash_compensation.hpp"
#include "delta/golden/fixed_network.hpp"
#include "network.hpp"

namespace delta_hls {

// The golden formats this config implements; quantise with these to feed the HLS model.
template <class C>
delta::golden::Formats golden_formats() {
  delta::golden::Formats f;
  f.input_bits = C::input_bits;
  f.input_fraction_bits = C::input_fraction;
  f.scaled_input_bits = C::scaled_input_bits;
  f.input_weight_bits = C::input_weight_bits;
  f.input_weight_fraction_bits = C::input_weight_fraction;
  f.tanh_input_bits = C::tanh_input_bits;
  f.tanh_input_fraction_bits = C::tanh_input_fraction;
  f.tanh_segments_per_unit_log2 = C::tanh_segments_per_unit_log2;
  f.tanh_guard_bits = C::tanh_guard_bits;
  f.hidden_fraction_bits = C::hidden_fraction;
  f.output_weight_bits = C::output_weight_bits;
  f.output_weight_fraction_bits = C::output_weight_fraction;
  f.output_bits = C::output_bits;
  f.output_fraction_bits = C::output_fraction;
  f.half_play_bits = C::half_play_bits;
  return f;
}

inline bool same_formats(const delta::golden::Formats& a, const delta::golden::Formats& b) {
  return a.input_bits == b.input_bits && a.input_fraction_bits == b.input_fraction_bits &&
         a.scaled_input_bits == b.scaled_input_bits && a.input_weight_bits == b.input_weight_bits &&
         a.input_weight_fraction_bits == b.input_weight_fraction_bits && a.tanh_input_bits == b.tanh_input_bits &&
         a.tanh_input_fraction_bits == b.tanh_input_fraction_bits &&
         a.tanh_segments_per_unit_log2 == b.tanh_segments_per_unit_log2 && a.tanh_guard_bits == b.tanh_guard_bits &&
         a.hidden_fraction_bits == b.hidden_fraction_bits && a.output_weight_bits == b.output_weight_bits &&
         a.output_weight_fraction_bits == b.output_weight_fraction_bits && a.output_bits == b.output_bits &&
         a.output_fraction_bits == b.output_fraction_bits && a.half_play_bits == b.half_play_bits;
}

template <class C>
std::unique_ptr<NetworkWeights<C>> load_weights(const delta::golden::QuantisedNetwork& q) {
  if (q.hidden != C::hidden)
    throw std::invalid_argument("HLS config has " + std::to_string(C::hidden) + " hidden neurons, the network " +
                                std::to_string(q.hidden));
  if (!same_formats(q.formats, golden_formats<C>())) {
    throw std::invalid_argument("network quantised with formats other than the HLS config's");
  }
  auto weights = std::make_unique<NetworkWeights<C>>();
  const int acc1 = C::hidden_accumulator_fraction;
  const int acc2 = C::output_accumulator_fraction;
  for (int j = 0; j < C::inputs; ++j) {
    weights->input_centre[j] =
        fixed_from_code<typename C::input_t, C::input_bits, C::input_fraction>(q.input_centre[j]);
    // 2^-e as a code with the gain type's fraction bits; outside [2^-fraction, 2^(integer - 1)] it does not fit.
    const int gain_fraction = C::input_gain_bits - C::input_gain_integer;
    const int gain_exponent = gain_fraction - q.input_exponent[j];
    if (gain_exponent < 0 || gain_exponent >= C::input_gain_bits) {
      throw std::invalid_argument("input gain 2^" + std::to_string(-q.input_exponent[j]) +
                                  " outside the HLS gain type");
    }
    weights->input_gain[j] =
        fixed_from_code<typename C::input_gain_t, C::input_gain_bits + 1, C::input_gain_bits - C::input_gain_integer>(
            1LL << gain_exponent);
  }
  for (int k = 0; k < C::hidden; ++k) {
    for (int j = 0; j < C::inputs; ++j) {
      weights->input_weights[k][j] =
          fixed_from_code<typename C::input_weight_t, C::input_weight_bits, C::input_weight_fraction>(
              q.input_weights[C::inputs * k + j]);
    }
    weights->hidden_bias[k] = fixed_from_code<typename C::hidden_bias_t, C::hidden_bias_bits, acc1>(q.hidden_bias[k]);
  }
  for (int i = 0; i < C::tanh_segments; ++i) {
    weights->tanh_table[i] =
        fixed_from_code<typename C::tanh_entry_t, C::tanh_entry_fraction + 1, C::tanh_entry_fraction>(q.tanh_table[i]);
    weights->tanh_slope[i] =
        fixed_from_code<typename C::tanh_entry_t, C::tanh_entry_fraction + 1, C::tanh_entry_fraction>(q.tanh_slope[i]);
  }
  for (int o = 0; o < C::outputs; ++o) {
    for (int k = 0; k < C::hidden; ++k) {
      weights->output_weights[o][k] =
          fixed_from_code<typename C::output_weight_t, C::output_weight_bits, C::output_weight_fraction>(
              q.output_weights[C::hidden * o + k]);
    }
    weights->output_bias[o] = fixed_from_code<typename C::output_bias_t, C::output_bias_bits, acc2>(q.output_bias[o]);
  }
  return weights;
}

// The HLS network on raw input codes; returns raw output codes and the saturation bits.
template <class C>
std::array<std::int64_t, 3> evaluate_codes(const NetworkWeights<C>& weights,
                                           const std::array<std::int64_t, 3>& position_code,
                                           unsigned* saturation = nullptr) {
  typename C::input_t x[C::inputs];
  for (int j = 0; j < C::inputs; ++j) {
    x[j] = fixed_from_code<typename C::input_t, C::input_bits, C::input_fraction>(position_code[j]);
  }
  typename C::output_t alpha[C::outputs];
  typename C::saturation_t flags;
  network_core<C>(x, weights, alpha, flags);
  std::array<std::int64_t, 3> raw{};
  for (int o = 0; o < C::outputs; ++o) {
    raw[o] = fixed_to_code<C::output_bits, C::output_fraction>(alpha[o]);
  }
  if (saturation) *saturation = static_cast<unsigned>(flags.to_uint());
  return raw;
}

// The HLS backlash compensation on raw codes: golden half-plays in, the next references out; the
// state persists between calls until restart().
template <class C>
class CompensationCodes {
 public:
  explicit CompensationCodes(const delta::golden::QuantisedCompensation& q) {
    for (int o = 0; o < C::outputs; ++o) {
      half_play_[o] =
          fixed_from_code<typename C::half_play_t, C::half_play_bits + 1, C::output_fraction>(q.half_play[o]);
    }
  }
  void restart() {
    for (int o = 0; o < C::outputs; ++o) state_.reference[o] = 0;
    state_.started = false;
  }
  std::array<std::int64_t, 3> step(const std::array<std::int64_t, 3>& alpha_code) {
    typename C::output_t alpha[C::outputs], reference[C::outputs];
    for (int o = 0; o < C::outputs; ++o) {
      alpha[o] = fixed_from_code<typename C::output_t, C::output_bits, C::output_fraction>(alpha_code[o]);
    }
    backlash_compensation<C>(alpha, half_play_, state_, reference);
    std::array<std::int64_t, 3> raw{};
    for (int o = 0; o < C::outputs; ++o) raw[o] = fixed_to_code<C::output_bits, C::output_fraction>(reference[o]);
    return raw;
  }

 private:
  typename C::half_play_t half_play_[C::outputs];
  CompensationState<C> state_;
};

}  // namespace delta_hls

// Header-only HLS templates of the fixed-point 3-H-3 network (spec: hls/README.md), configured by
// one struct (network_config.hpp). Synthesizable: integer codes only, no dynamic memory, recursion or division;
// every loop labelled; pragmas driven by the config. Bit-exact to delta::golden::evaluate_raw.
#pragma once

// Loop labels name loops for Vitis HLS directives; the host compiler does not use them.
#pragma GCC diagnostic ignored "-Wunused-label"

#include "network_config.hpp"

namespace delta_hls {

// Every constant of one quantised network (the content of the exported .mem files, as values).
template <class C>
struct NetworkWeights {
  typename C::input_t input_centre[C::inputs];     // metres
  typename C::input_gain_t input_gain[C::inputs];  // 2^-e_j: u_j = (x_j - centre_j) 2^-e_j
  typename C::input_weight_t input_weights[C::hidden][C::inputs];
  typename C::hidden_bias_t hidden_bias[C::hidden];
  typename C::tanh_entry_t tanh_table[C::tanh_segments];              // T[i]
  typename C::tanh_entry_t tanh_slope[C::tanh_segments];              // D[i] = T[i+1] - T[i] >= 0
  typename C::output_weight_t output_weights[C::outputs][C::hidden];  // degrees per unit h
  typename C::output_bias_t output_bias[C::outputs];                  // degrees
};

enum SaturationBit { kScaledInputSaturated = 1, kTanhInputSaturated = 2, kOutputSaturated = 4 };

// Spec step 2: u_j = sat_16(round_shift(x_j - centre_j, shift_j)), as a multiplication by the exact
// power of two 2^-e_j followed by the rounding, saturating cast.
template <class C>
void scale_input(const typename C::input_t x[C::inputs], const NetworkWeights<C>& weights,
                 typename C::scaled_input_t u[C::inputs], bool& saturated) {
  typedef fixed_exact<C::offset_bits + C::input_gain_bits + 1,
                      (C::offset_bits - C::input_fraction) + C::input_gain_integer + 1>
      scaled_exact_t;
  typedef fixed_round_sat<(C::offset_bits - C::input_fraction) + C::input_gain_integer + 1 + (C::scaled_input_bits - 1),
                          (C::offset_bits - C::input_fraction) + C::input_gain_integer + 1>
      scaled_wide_t;
ScaleInput:
  for (int j = 0; j < C::inputs; ++j) {
    DELTA_HLS_PRAGMA(HLS UNROLL)
    const typename C::offset_t offset = x[j] - weights.input_centre[j];
    const scaled_exact_t scaled = offset * weights.input_gain[j];
    const scaled_wide_t rounded = scaled;
    u[j] = rounded;
    if (u[j] != rounded) saturated = true;
  }
}

// Spec step 4: tanh by table with linear interpolation, odd symmetry.
template <class C>
typename C::hidden_t tanh_interpolated(const typename C::tanh_input_t& n, const NetworkWeights<C>& weights,
                                       bool& saturated) {
  typedef ufixed_exact<C::tanh_input_bits, C::tanh_range_log2 + 1> magnitude_exact_t;
  typedef ufixed_exact<C::tanh_entry_fraction + C::tanh_fraction_bits + 1, 1> interpolation_t;
  magnitude_exact_t magnitude_exact;
  if (n < 0) {
    magnitude_exact = -n;
  } else {
    magnitude_exact = n;
  }
  const typename C::tanh_magnitude_t magnitude = magnitude_exact;  // only |n| = 2^range clamps
  if (magnitude != magnitude_exact) saturated = true;
  const typename C::tanh_index_t index = magnitude * (1 << C::tanh_segments_per_unit_log2);
  const typename C::tanh_fraction_t fraction = magnitude * (1 << C::tanh_segments_per_unit_log2) - index;
  const int i = index.to_int();
  const interpolation_t interpolated = weights.tanh_table[i] + weights.tanh_slope[i] * fraction;
  const typename C::hidden_magnitude_t rounded = interpolated;
  typename C::hidden_t h;
  if (n < 0) {
    h = -rounded;
  } else {
    h = rounded;
  }
  return h;
}

// Spec steps 3-4: n_k = sat(round_shift(b1'_k + sum_j IW'_kj u_j)), h_k = tanh(n_k).
template <class C>
void hidden_layer(const typename C::scaled_input_t u[C::inputs], const NetworkWeights<C>& weights,
                  typename C::hidden_t h[C::hidden], bool& saturated) {
HiddenNeuron:
  for (int k = 0; k < C::hidden; ++k) {
    typename C::hidden_accumulator_t accumulator = weights.hidden_bias[k];
  HiddenProduct:
    for (int j = 0; j < C::inputs; ++j) {
      accumulator += u[j] * weights.input_weights[k][j];
    }
    const typename C::tanh_input_wide_t rounded = accumulator;
    const typename C::tanh_input_t n = rounded;
    if (n != rounded) saturated = true;
    h[k] = tanh_interpolated<C>(n, weights, saturated);
  }
}

// Spec step 5: alpha_o = sat(round_shift(b2'_o + sum_k LW'_ok h_k)), degrees.
template <class C>
void output_layer(const typename C::hidden_t h[C::hidden], const NetworkWeights<C>& weights,
                  typename C::output_t alpha[C::outputs], bool& saturated) {
OutputNeuron:
  for (int o = 0; o < C::outputs; ++o) {
    typename C::output_accumulator_t accumulator = weights.output_bias[o];
  OutputProduct:
    for (int k = 0; k < C::hidden; ++k) {
      accumulator += h[k] * weights.output_weights[o][k];
    }
    const typename C::output_wide_t rounded = accumulator;
    alpha[o] = rounded;
    if (alpha[o] != rounded) saturated = true;
  }
}

// The whole network: raw input codes (metres, Q4.28) to raw output codes (degrees, Q10.14), with
// the saturation flags of this evaluation.
template <class C>
void network_core(const typename C::input_t x[C::inputs], const NetworkWeights<C>& weights,
                  typename C::output_t alpha[C::outputs], typename C::saturation_t& saturation) {
  // hls4ml's resource model: each multiplier serves reuse_factor products per inference.
  constexpr int multiplier_limit =
      (C::inputs * C::hidden + C::hidden * C::outputs + C::reuse_factor - 1) / C::reuse_factor;
  (void)multiplier_limit;
  DELTA_HLS_PRAGMA(HLS ALLOCATION operation instances = mul limit = multiplier_limit)
  typename C::scaled_input_t u[C::inputs];
  DELTA_HLS_PRAGMA(HLS ARRAY_PARTITION variable = u type = complete)
  typename C::hidden_t h[C::hidden];
  bool scaled_input_saturated = false;
  bool tanh_input_saturated = false;
  bool output_saturated = false;
  scale_input<C>(x, weights, u, scaled_input_saturated);
  hidden_layer<C>(u, weights, h, tanh_input_saturated);
  output_layer<C>(h, weights, alpha, output_saturated);
  saturation = (scaled_input_saturated ? kScaledInputSaturated : 0) | (tanh_input_saturated ? kTanhInputSaturated : 0) |
               (output_saturated ? kOutputSaturated : 0);
}

}  // namespace delta_hls

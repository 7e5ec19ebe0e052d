// Golden model: quantisation of a float network and the integer evaluation (hls/README.md).
#include "delta/golden/fixed_network.hpp"

#include <cmath>
#include <stdexcept>

namespace delta::golden {

void Formats::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(std::string("fixed-point formats: ") + what);
  };
  require(input_bits >= 2 && input_bits <= 40, "input_bits out of 2..40");
  require(scaled_input_bits >= 2 && scaled_input_bits <= 30, "scaled_input_bits out of 2..30");
  require(input_weight_bits >= 2 && input_weight_bits <= 30, "input_weight_bits out of 2..30");
  require(output_weight_bits >= 2 && output_weight_bits <= 30, "output_weight_bits out of 2..30");
  require(hidden_fraction_bits >= 1 && hidden_fraction_bits <= 28, "hidden_fraction_bits out of 1..28");
  require(tanh_range_log2() >= 0 && tanh_range_log2() <= 6, "tanh input range must be [-2^k, 2^k), k in 0..6");
  require(tanh_segments_per_unit_log2 >= 0 && tanh_fraction_shift() >= 0,
          "tanh segments finer than the tanh input LSB");
  require(tanh_guard_bits >= 0 && tanh_guard_bits <= 8, "tanh_guard_bits out of 0..8");
  require(half_play_bits >= 1 && half_play_bits < output_bits, "half_play_bits out of 1..output_bits - 1");
  require(half_play_step_bits >= 0 && half_play_step_bits < half_play_bits,
          "half_play_step_bits out of 0..half_play_bits - 1");
  require(hidden_accumulator_fraction_bits() >= tanh_input_fraction_bits,
          "tanh input finer than the hidden accumulator");
  require(output_accumulator_fraction_bits() >= output_fraction_bits, "output finer than its accumulator");
  require(output_bits >= 2 && output_bits <= 40, "output_bits out of 2..40");
}

void SaturationCounters::add(const SaturationCounters& other) {
  scaled_input += other.scaled_input;
  tanh_input += other.tanh_input;
  output += other.output;
  evaluations += other.evaluations;
}

std::int64_t round_shift(std::int64_t value, int shift) {
  if (shift <= 0) return value * (std::int64_t{1} << -shift);
  return (value + (std::int64_t{1} << (shift - 1))) >> shift;  // arithmetic shift: floor
}

std::int64_t saturate(std::int64_t value, int bits, bool* clamped) {
  const std::int64_t max = (std::int64_t{1} << (bits - 1)) - 1;
  const std::int64_t min = -(std::int64_t{1} << (bits - 1));
  const std::int64_t result = value > max ? max : (value < min ? min : value);
  if (clamped && result != value) *clamped = true;
  return result;
}

namespace {

// round(value * 2^fraction) as a code of `bits`; throws when it does not fit.
std::int64_t quantise_value(double value, int fraction, int bits, const std::string& what) {
  const double scaled = std::floor(std::ldexp(value, fraction) + 0.5);
  const double limit = std::ldexp(1.0, bits - 1);
  if (!std::isfinite(scaled) || scaled >= limit || scaled < -limit) {
    throw std::invalid_argument(what + " = " + std::to_string(value) + " saturates its format (" +
                                std::to_string(bits) + " bits, " + std::to_string(fraction) + " fraction bits)");
  }
  return static_cast<std::int64_t>(scaled);
}

}  // namespace

void fill_tanh_tables(QuantisedNetwork& q) {
  const Formats& f = q.formats;
  q.tanh_table.clear();
  q.tanh_slope.clear();
  // tanh table over |n| in [0, 2^range): entries in Q0.(F_h + G), capped so h <= 1 - 2^-F_h.
  const int segments = f.tanh_segments();
  const int entry_fraction = f.tanh_entry_fraction_bits();
  const std::int64_t entry_cap = ((std::int64_t{1} << f.hidden_fraction_bits) - 1) << f.tanh_guard_bits;
  std::vector<std::int64_t> entries;
  for (int i = 0; i <= segments; ++i) {
    // tanh is concave for n > 0, so a chord lies below it by up to step^2 |tanh''| / 8 mid-segment;
    // raising each node by half of that local figure halves the worst interpolation error.
    const double step = std::ldexp(1.0, -f.tanh_segments_per_unit_log2);
    const double n = i * step;
    const double t = std::tanh(n);
    const double curvature = 2.0 * t * (1.0 - t * t);  // |tanh''(n)|
    const double node = t + step * step * curvature / 16.0;
    const std::int64_t entry = static_cast<std::int64_t>(std::floor(std::ldexp(node, entry_fraction) + 0.5));
    entries.push_back(std::min(entry, entry_cap));
  }
  for (int i = 0; i < segments; ++i) {
    q.tanh_table.push_back(entries[i]);
    q.tanh_slope.push_back(entries[i + 1] - entries[i]);
  }
}

QuantisedNetwork quantise(const nn::Network& network, const Formats& formats) {
  formats.validate();
  QuantisedNetwork q;
  q.formats = formats;
  q.hidden = network.hidden();
  const int hidden = q.hidden;
  const Formats& f = formats;
  // Input: u_j = (x_j - centre_j) / 2^e_j with 2^e_j >= 1.25 * half range, so u stays in [-1, 1) up
  // to a quarter of a half-range beyond the trained range; the exact gain 2^e_j / half_range folds
  // into IW'. (1.5 cost the shipped weights' x and y one bit of u: 0.00070 instead of 0.00056 deg.)
  std::array<double, 3> half_range{};
  std::array<double, 3> centre_error{};  // quantised centre minus true centre, in mapminmax units
  for (int j = 0; j < 3; ++j) {
    half_range[j] = (network.input_max[j] - network.input_min[j]) / 2.0;
    const double centre = (network.input_max[j] + network.input_min[j]) / 2.0;
    if (!(half_range[j] > 0.0))
      throw std::invalid_argument("input range of input " + std::to_string(j + 1) + " is empty");
    q.input_exponent[j] = static_cast<int>(std::ceil(std::log2(1.25 * half_range[j])));
    q.input_shift[j] = f.input_fraction_bits + q.input_exponent[j] - (f.scaled_input_bits - 1);
    q.input_centre[j] =
        quantise_value(centre, f.input_fraction_bits, f.input_bits, "input centre " + std::to_string(j + 1));
    centre_error[j] =
        (std::ldexp(static_cast<double>(q.input_centre[j]), -f.input_fraction_bits) - centre) / half_range[j];
  }
  const int acc1_fraction = f.hidden_accumulator_fraction_bits();
  // Biases are limited to the tanh input range (bits of n plus the extra accumulator fraction bits).
  const int bias1_bits = f.tanh_input_bits + (acc1_fraction - f.tanh_input_fraction_bits);
  for (int k = 0; k < hidden; ++k) {
    double bias = network.hidden_bias(k);
    for (int j = 0; j < 3; ++j) {
      const double weight = network.input_weights(k, j) * std::ldexp(1.0, q.input_exponent[j]) / half_range[j];
      q.input_weights.push_back(quantise_value(weight, f.input_weight_fraction_bits, f.input_weight_bits,
                                               "IW'(" + std::to_string(k + 1) + "," + std::to_string(j + 1) + ")"));
      bias += network.input_weights(k, j) * centre_error[j];
    }
    q.hidden_bias.push_back(quantise_value(bias, acc1_fraction, bias1_bits, "b1'(" + std::to_string(k + 1) + ")"));
  }
  fill_tanh_tables(q);
  // Output: alpha = LW' h + b2' with the mapminmax unscaling folded in (degrees).
  const Vec3 output_half = (network.output_max - network.output_min) / 2.0;
  const int acc2_fraction = f.output_accumulator_fraction_bits();
  for (int o = 0; o < 3; ++o) {
    for (int k = 0; k < hidden; ++k) {
      q.output_weights.push_back(quantise_value(network.output_weights(o, k) * output_half[o],
                                                f.output_weight_fraction_bits, f.output_weight_bits,
                                                "LW'(" + std::to_string(o + 1) + "," + std::to_string(k + 1) + ")"));
    }
    const double bias = (network.output_bias[o] + 1.0) * output_half[o] + network.output_min[o];
    q.output_bias[o] = quantise_value(bias, acc2_fraction, f.output_bits + (acc2_fraction - f.output_fraction_bits),
                                      "b2'(" + std::to_string(o + 1) + ")");
  }
  return q;
}

std::int64_t tanh_code(const QuantisedNetwork& q, std::int64_t tanh_input, bool* clamped) {
  const Formats& f = q.formats;
  const int shift = f.tanh_fraction_shift();
  const std::int64_t magnitude_limit = (static_cast<std::int64_t>(f.tanh_segments()) << shift) - 1;
  std::int64_t magnitude = tanh_input < 0 ? -tanh_input : tanh_input;
  if (magnitude > magnitude_limit) {
    magnitude = magnitude_limit;  // only n = -2^range: tanh is flat there
    if (clamped) *clamped = true;
  }
  const std::int64_t index = magnitude >> shift;
  const std::int64_t fraction = magnitude & ((std::int64_t{1} << shift) - 1);
  const std::int64_t interpolated = (q.tanh_table[index] << shift) + q.tanh_slope[index] * fraction;
  const std::int64_t hidden = round_shift(interpolated, shift + f.tanh_guard_bits);
  return tanh_input < 0 ? -hidden : hidden;
}

ScaledInput scale_input(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& position_code) {
  ScaledInput in;
  for (int j = 0; j < 3; ++j) {
    const std::int64_t offset = position_code[j] - q.input_centre[j];
    in.code[j] = saturate(round_shift(offset, q.input_shift[j]), q.formats.scaled_input_bits, &in.saturated);
  }
  return in;
}

std::array<std::int16_t, 3> setpoint_input(const QuantisedNetwork& q,
                                           const std::array<std::int64_t, 3>& position_code) {
  const ScaledInput in = scale_input(q, position_code);
  return {static_cast<std::int16_t>(in.code[0]), static_cast<std::int16_t>(in.code[1]),
          static_cast<std::int16_t>(in.code[2])};
}

RawOutput evaluate_scaled(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& scaled,
                          SaturationCounters* counters, bool scaled_input_saturated) {
  const Formats& f = q.formats;
  RawOutput out;
  out.scaled_input_saturated = scaled_input_saturated;
  const int tanh_shift = f.hidden_accumulator_fraction_bits() - f.tanh_input_fraction_bits;
  std::vector<std::int64_t> hidden(q.hidden);
  for (int k = 0; k < q.hidden; ++k) {
    std::int64_t accumulator = q.hidden_bias[k];
    for (int j = 0; j < 3; ++j) accumulator += q.input_weights[3 * k + j] * scaled[j];
    const std::int64_t n = saturate(round_shift(accumulator, tanh_shift), f.tanh_input_bits, &out.tanh_input_saturated);
    hidden[k] = tanh_code(q, n, &out.tanh_input_saturated);
  }
  const int output_shift = f.output_accumulator_fraction_bits() - f.output_fraction_bits;
  for (int o = 0; o < 3; ++o) {
    std::int64_t accumulator = q.output_bias[o];
    for (int k = 0; k < q.hidden; ++k) accumulator += q.output_weights[q.hidden * o + k] * hidden[k];
    out.alpha[o] = saturate(round_shift(accumulator, output_shift), f.output_bits, &out.output_saturated);
  }
  if (counters) {
    counters->scaled_input += out.scaled_input_saturated;
    counters->tanh_input += out.tanh_input_saturated;
    counters->output += out.output_saturated;
    ++counters->evaluations;
  }
  return out;
}

RawOutput evaluate_raw(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& position_code,
                       SaturationCounters* counters) {
  const ScaledInput in = scale_input(q, position_code);
  return evaluate_scaled(q, in.code, counters, in.saturated);
}

std::array<std::int64_t, 3> encode_position(const Formats& formats, const Vec3& position_m, bool* clamped) {
  std::array<std::int64_t, 3> code{};
  const double limit = std::ldexp(1.0, formats.input_bits - 1);
  for (int j = 0; j < 3; ++j) {
    double scaled = std::floor(std::ldexp(position_m[j], formats.input_fraction_bits) + 0.5);
    if (!(scaled < limit)) scaled = limit - 1.0;  // also catches NaN
    if (scaled < -limit) scaled = -limit;
    if (clamped && scaled != std::floor(std::ldexp(position_m[j], formats.input_fraction_bits) + 0.5)) *clamped = true;
    code[j] = static_cast<std::int64_t>(scaled);
  }
  return code;
}

double decode_angle_deg(const Formats& formats, std::int64_t raw) {
  return std::ldexp(static_cast<double>(raw), -formats.output_fraction_bits);
}

QuantisedCompensation quantise_compensation(const Vec3& half_play_deg, const Formats& formats) {
  formats.validate();
  QuantisedCompensation q;
  for (int j = 0; j < 3; ++j) {
    const std::string what = "backlash half-play of joint " + std::to_string(j + 1);
    if (!(half_play_deg[j] >= 0.0)) throw std::invalid_argument(what + " must be a number >= 0");
    const int step_bits = formats.half_play_step_bits;
    const double scaled =
        std::ldexp(std::floor(std::ldexp(half_play_deg[j], formats.output_fraction_bits - step_bits) + 0.5), step_bits);
    if (scaled > std::ldexp(1.0, formats.half_play_bits) - 1.0) {
      throw std::invalid_argument(what + " (" + std::to_string(half_play_deg[j]) + " deg) does not fit " +
                                  std::to_string(formats.half_play_bits) + " unsigned bits of output LSBs");
    }
    q.half_play[j] = static_cast<std::int64_t>(scaled);
  }
  return q;
}

std::int64_t compensate_joint(std::int64_t half_play, std::int64_t static_code, std::int64_t reference, bool started) {
  return started ? reference + play(static_code - reference, half_play) : static_code;
}

std::array<std::int64_t, 3> compensate(const QuantisedCompensation& compensation, CompensationState& state,
                                       const std::array<std::int64_t, 3>& static_codes) {
  for (int j = 0; j < 3; ++j) {
    state.reference[j] =
        compensate_joint(compensation.half_play[j], static_codes[j], state.reference[j], state.started);
  }
  state.started = true;
  return state.reference;
}

}  // namespace delta::golden

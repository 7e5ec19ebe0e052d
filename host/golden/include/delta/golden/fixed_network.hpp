// Bit-accurate golden model of the fixed-point 3-H-3 network: plain integer C++, no fixed-point
// library. hls/README.md is the specification; every function here implements one step of it.
//
// Codes are two's-complement integers held in int64_t; a format is (bits, fraction bits):
// value = code * 2^-fraction. round_shift is round-half-up (add half an LSB, arithmetic shift right)
// and saturate clamps to [-2^(bits-1), 2^(bits-1) - 1]: the modes ap_fixed (AP_RND, AP_SAT) and
// sc_fixed (SC_RND, SC_SAT) share.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "delta/geometry.hpp"
#include "delta/nn/network.hpp"

namespace delta::golden {

// Word lengths of every step. The defaults are the chosen formats (hls/README.md derives them);
// the word-length sweep varies one field at a time.
struct Formats {
  int input_fraction_bits = 28;  // raw input: position in metres, LSB 2^-28 m (3.7 nm), 32 bits
  int input_bits = 32;
  int scaled_input_bits = 16;            // u: (x - centre) / 2^e, Q1.15, in [-1, 1)
  int input_weight_bits = 24;            // IW' = IW * 2^e / half_range, signed
  int input_weight_fraction_bits = 19;   //   Q5.19
  int tanh_input_bits = 21;              // n: hidden pre-activation, signed, range [-8, 8)
  int tanh_input_fraction_bits = 17;     //   Q4.17
  int tanh_segments_per_unit_log2 = 7;   // table step 2^-7 over |n| in [0, 8): 1024 segments
  int tanh_guard_bits = 3;               // table entries carry 3 bits below the hidden LSB
  int hidden_fraction_bits = 17;         // h = tanh(n): Q1.17 in 18 bits, |h| <= 1 - 2^-17
  int output_weight_bits = 24;           // LW' = LW * output half-range, degrees per unit h
  int output_weight_fraction_bits = 17;  //   Q7.17
  int output_bits = 24;                  // alpha: degrees, Q10.14, in [-512, 512) deg
  int output_fraction_bits = 14;
  int half_play_bits = 16;  // h: backlash half-play, unsigned, output LSBs: [0, 4) deg
  // h is a whole number of 2^half_play_step_bits output LSBs (2^-10 deg): the board's references
  // (Q24.8 counts = round_shift(25 y, 4), setpoint_interpolation.hpp) then move by exactly 25 h / 16.
  int half_play_step_bits = 4;

  int hidden_bits() const { return hidden_fraction_bits + 1; }
  int tanh_range_log2() const { return tanh_input_bits - 1 - tanh_input_fraction_bits; }  // 3: [-8, 8)
  int tanh_segments() const { return 1 << (tanh_range_log2() + tanh_segments_per_unit_log2); }
  int tanh_fraction_shift() const { return tanh_input_fraction_bits - tanh_segments_per_unit_log2; }
  int tanh_entry_fraction_bits() const { return hidden_fraction_bits + tanh_guard_bits; }
  int hidden_accumulator_fraction_bits() const { return scaled_input_bits - 1 + input_weight_fraction_bits; }
  int output_accumulator_fraction_bits() const { return hidden_fraction_bits + output_weight_fraction_bits; }
  // The compensation's difference s - r and shifted angle s -/+ h: one bit above the output.
  int compensation_difference_bits() const { return output_bits + 1; }
  // Throws std::invalid_argument when a combination cannot work (e.g. a shift that would be negative).
  void validate() const;
};

// The deployed model's backlash compensation on output codes (hls/README.md, "Backlash
// compensation"): per joint a half-play h (unsigned, half_play_bits, output LSBs) and the
// reference r it last produced. For each new network answer s, in time order:
//   first answer:  r = s
//   s - r > h:     r = s - h      (moving up: the reference lags s by h)
//   s - r < -h:    r = s + h      (moving down)
//   otherwise:     r unchanged    (inside the play)
// s - r needs compensation_difference_bits(); the new r never leaves the output format, because
// s - h > r >= min in the second case and s + h < r <= max in the third: nothing to saturate.
struct QuantisedCompensation {
  std::array<std::int64_t, 3> half_play{};  // h_j in output LSBs, whole multiples of 2^half_play_step_bits
  bool any() const { return half_play[0] != 0 || half_play[1] != 0 || half_play[2] != 0; }
};

struct CompensationState {
  std::array<std::int64_t, 3> reference{};  // r_j: the last reference code
  bool started = false;                     // false until the first answer (after reset)
};

// Everything the arithmetic needs, as integer codes (the content of the exported .mem files).
struct QuantisedNetwork {
  Formats formats;
  int hidden = 0;
  std::array<std::int64_t, 3> input_centre{};  // raw input code of the trained range's centre
  std::array<int, 3> input_shift{};            // u_j = sat(round_shift(x_j - centre_j, shift_j))
  std::array<int, 3> input_exponent{};         // e_j: u_j = (x_j - centre_j) / 2^e_j (metres)
  std::vector<std::int64_t> input_weights;     // H x 3, row-major, IW' in Q(w1)
  std::vector<std::int64_t> hidden_bias;       // H, in the hidden accumulator's format
  std::vector<std::int64_t> tanh_table;        // tanh(i 2^-A), i = 0..segments, guard-bit format
  std::vector<std::int64_t> tanh_slope;        // table[i + 1] - table[i], i = 0..segments-1
  std::vector<std::int64_t> output_weights;    // 3 x H, row-major, LW' in Q(w2), degrees
  std::array<std::int64_t, 3> output_bias{};   // b2' in the output accumulator's format, degrees
  // The deployed model's half-plays (zero for the plain network): not used by the network's
  // arithmetic; exported to the board (half_play.mem) and covered by the weights CRC.
  QuantisedCompensation compensation;
};

// Counts of casts that clamped. Inside the trained range all of them must stay zero.
struct SaturationCounters {
  std::uint64_t scaled_input = 0;  // u left [-1, 1): position beyond the representable margin
  std::uint64_t tanh_input = 0;    // n left the tanh input format (harmless past |n| = 8: tanh is flat)
  std::uint64_t output = 0;        // alpha left the output format
  std::uint64_t evaluations = 0;
  void add(const SaturationCounters& other);
  std::uint64_t errors() const { return scaled_input + output; }  // casts that change the result
};

struct RawOutput {
  std::array<std::int64_t, 3> alpha{};  // degrees * 2^output_fraction_bits
  bool scaled_input_saturated = false;
  bool tanh_input_saturated = false;
  bool output_saturated = false;
};

// Half-plays in degrees -> codes: to the nearest whole number of 2^half_play_step_bits output LSBs
// (round half up). Throws std::invalid_argument for a negative or
// non-finite half-play or one beyond half_play_bits.
QuantisedCompensation quantise_compensation(const Vec3& half_play_deg, const Formats& formats = Formats());

// The play's dead band on a difference d = s - r: d - h (d > h), d + h (d < -h), else 0. The one
// definition: the golden compensation (r' = r + play(s - r, h)) and the board's interpolation
// (play(C - B, H), setpoint_interpolation.hpp) both use it.
inline std::int64_t play(std::int64_t difference, std::int64_t half_play) {
  if (difference > half_play) return difference - half_play;
  if (difference < -half_play) return difference + half_play;
  return 0;
}

// One joint's step of the play (above); `started` false makes r = s.
std::int64_t compensate_joint(std::int64_t half_play, std::int64_t static_code, std::int64_t reference, bool started);

// All three joints: the joint references for the network's answers `static_codes`, updating `state`.
std::array<std::int64_t, 3> compensate(const QuantisedCompensation& compensation, CompensationState& state,
                                       const std::array<std::int64_t, 3>& static_codes);

// Primitive casts, shared by the golden model and its tests.
std::int64_t round_shift(std::int64_t value, int shift);  // round half up; shift <= 0 shifts left
std::int64_t saturate(std::int64_t value, int bits, bool* clamped);

// Quantises a float network into the formats. Throws std::invalid_argument naming the parameter
// when a weight or bias would saturate its format (the export refuses such weights).
QuantisedNetwork quantise(const nn::Network& network, const Formats& formats = Formats());

// The tanh table and slopes of q.formats (part of quantise; the board's gateware holds them).
void fill_tanh_tables(QuantisedNetwork& q);

// tanh(n) for a tanh-input code n, as a hidden code (Q1.F_h): table with linear interpolation.
std::int64_t tanh_code(const QuantisedNetwork& q, std::int64_t tanh_input, bool* clamped = nullptr);

// The network on raw input codes (positions, metres * 2^input_fraction_bits):
// evaluate_scaled(scale_input(position_code)).
RawOutput evaluate_raw(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& position_code,
                       SaturationCounters* counters = nullptr);

// Spec step 2, which the host does for the board (the setpoint carries u): u_j =
// sat_16(round_shift(x_j - centre_j, shift_j)).
struct ScaledInput {
  std::array<std::int64_t, 3> code{};  // u_j, Q1.15
  bool saturated = false;              // a position beyond the representable margin
};
ScaledInput scale_input(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& position_code);
// scale_input's codes as a setpoint carries them (link::SetpointPayload::input_code).
std::array<std::int16_t, 3> setpoint_input(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& position_code);

// Spec steps 3-6 on scaled inputs u (what the board's network computes from a setpoint).
// `scaled_input_saturated` is carried into the result and the counters.
RawOutput evaluate_scaled(const QuantisedNetwork& q, const std::array<std::int64_t, 3>& scaled,
                          SaturationCounters* counters = nullptr, bool scaled_input_saturated = false);

// Host-side conversions of the interface (not part of the hardware): round half up, saturated.
std::array<std::int64_t, 3> encode_position(const Formats& formats, const Vec3& position_m, bool* clamped = nullptr);
double decode_angle_deg(const Formats& formats, std::int64_t raw);

}  // namespace delta::golden

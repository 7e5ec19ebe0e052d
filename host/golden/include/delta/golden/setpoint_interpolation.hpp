// Golden model of the board's setpoint interpolation (docs/board_link.md, "Setpoints, the network
// and the joints"): the network's answer y per joint becomes a reference in Q24.8 encoder counts
// that the joints reach linearly over one setpoint period of PeriodsPerSetpoint (10) control
// periods. Integer arithmetic only, bit for bit what the RTL must compute:
//
//   C   = round_shift(25 * y, 4)                 y: raw output code (Q10.14 deg) -> Q24.8 counts, exact
//   D   = saturate_16(play(C - B, H))            B: the reference at the segment start
//   r_k = B + round_shift(D * K_k, 14)           K_k = round(k 2^14 / 10), k = 0 .. 9
//   B'  = B + D                                  the next segment's start
//
// round_shift(v, s) = floor((v + 2^(s-1)) / 2^s), an arithmetic shift (golden::round_shift).
// play(d, H) = d - H (d > H), d + H (d < -H), else 0: the deployed model's backlash compensation
// (H = 25 h / 16 per joint, h its half-play code; H = 0 for the plain network, play(d, 0) = d).
// Because h is a whole number of 16 output LSBs, round_shift(25 (s -/+ h), 4) = C -/+ H and
// d > H exactly when s - r > h for the golden compensation's r (golden::compensate), so the
// segment targets B + D are round_shift(25 r, 4) of its references while the reference follows
// them (no slew limit, hold or drives off in between): tests/link/setpoint_interpolation_test.cpp.
// Hold or underrun: D = 0. Drives off: the reference is the encoder count << 8.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "delta/board_facts.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/joint_fixed.hpp"

namespace delta::golden {

namespace interpolation {

constexpr int kPeriods = board::kPeriodsPerSetpoint;                 // control periods per setpoint (segment)
constexpr int kWeightShift = board::kInterpolationShift;             // K_k in units of 2^-14
constexpr int kDeltaBits = board::kSegmentDeltaBits;                 // D: signed, saturated
constexpr int kReferenceFractionBits = 8;                            // references: Q24.8 encoder counts (int32)
constexpr int kAnswerFractionBits = Formats().output_fraction_bits;  // y: Q10.14 degrees
static_assert(board::kControlRateHz == board::kSetpointRateHz * kPeriods,
              "PeriodsPerSetpoint disagrees with the rates");

// Q10.14 degrees -> Q24.8 counts is a multiplication by (counts per degree) 2^8 / 2^14 = 25600 / 2^14,
// reduced to the smallest integer pair: 25 / 2^4 (the same result bit for bit: 25600 y + 2^13 is
// 2^10 (25 y + 2^3)).
constexpr std::int64_t kCountsPerDegree = 1'000'000 / board::kEncoderCountMicrodeg;  // 100
static_assert(1'000'000 % board::kEncoderCountMicrodeg == 0, "an encoder count is not a whole fraction of a degree");
struct AnswerScale {
  std::int64_t factor;
  int shift;
};
constexpr AnswerScale reduced_answer_scale() {
  AnswerScale scale{kCountsPerDegree << kReferenceFractionBits, kAnswerFractionBits};
  while (scale.shift > 0 && scale.factor % 2 == 0) {
    scale.factor /= 2;
    --scale.shift;
  }
  return scale;
}
constexpr AnswerScale kAnswerScale = reduced_answer_scale();
static_assert(kAnswerScale.factor == 25 && kAnswerScale.shift == 4, "docs/board_link.md writes round_shift(25 y, 4)");

// K_k = round(k 2^14 / 10), rounded half up in integers: (2 k 2^14 + 10) / 20.
constexpr std::int32_t weight(int k) {
  return static_cast<std::int32_t>((2 * (std::int64_t{k} << kWeightShift) + kPeriods) / (2 * kPeriods));
}
constexpr std::array<std::int32_t, kPeriods> make_weights() {
  std::array<std::int32_t, kPeriods> weights{};
  for (int k = 0; k < kPeriods; ++k) weights[k] = weight(k);
  return weights;
}
constexpr std::array<std::int32_t, kPeriods> kWeights = make_weights();
static_assert(kWeights[0] == 0 && kWeights[1] == 1638 && kWeights[9] == 14746, "K_k = (k 16384 + 5) / 10");

static_assert(kAnswerScale.shift == Formats().half_play_step_bits, "H = 25 h / 16 must be exact");
// The widest H the format can carry, Q24.8 counts.
constexpr std::int64_t kWidestHalfPlay =
    ((std::int64_t{1} << Formats().half_play_bits) - 1) * kAnswerScale.factor >> kAnswerScale.shift;
static_assert(kWidestHalfPlay < (std::int64_t{1} << board::kHalfPlayBits),
              "HalfPlayBits (delta_board_pkg.sv) must hold the widest half-play");

constexpr std::int32_t kDeltaMax = (std::int32_t{1} << (kDeltaBits - 1)) - 1;  // 32767
constexpr std::int32_t kDeltaMin = -(std::int32_t{1} << (kDeltaBits - 1));     // -32768

// C: a network output code (24-bit signed, Q10.14 degrees) as a reference in Q24.8 counts.
inline std::int32_t reference_counts(std::int32_t answer_code) {
  return static_cast<std::int32_t>(round_shift(kAnswerScale.factor * answer_code, kAnswerScale.shift));
}

// H: a half-play code h (output LSBs, golden::QuantisedCompensation) in Q24.8 counts, 25 h / 16
// exactly. Throws std::invalid_argument for a negative h or one that is not a whole number of
// 2^half_play_step_bits LSBs (the board's compensation would then differ from the golden one).
inline std::int32_t half_play_counts(std::int64_t half_play_code) {
  constexpr std::int64_t kStep = std::int64_t{1} << Formats().half_play_step_bits;
  if (half_play_code < 0 || half_play_code % kStep != 0 || half_play_code >> Formats().half_play_bits != 0) {
    throw std::invalid_argument("half-play code " + std::to_string(half_play_code) + " is not a whole number of " +
                                std::to_string(kStep) + " output LSBs below 2^" +
                                std::to_string(Formats().half_play_bits));
  }
  return reference_counts(static_cast<std::int32_t>(half_play_code));
}

inline std::array<std::int32_t, 3> half_play_counts(const QuantisedCompensation& compensation) {
  return {half_play_counts(compensation.half_play[0]), half_play_counts(compensation.half_play[1]),
          half_play_counts(compensation.half_play[2])};
}

// An encoder count (0.01 deg) as a reference in Q24.8 counts: the reference with the drives off.
inline std::int32_t encoder_reference(std::int16_t count) {
  return static_cast<std::int32_t>(std::int64_t{count} * (std::int64_t{1} << kReferenceFractionBits));
}

struct SegmentDelta {
  std::int32_t value = 0;  // D, Q.8 counts, in [kDeltaMin, kDeltaMax]
  bool saturated = false;  // C - B did not fit
};

// D = saturate_16(play(C - B, H)).
inline SegmentDelta segment_delta(std::int32_t target, std::int32_t start, std::int32_t half_play = 0) {
  const std::int64_t change = play(std::int64_t{target} - start, half_play);
  SegmentDelta delta;
  delta.saturated = change > kDeltaMax || change < kDeltaMin;
  delta.value = static_cast<std::int32_t>(change > kDeltaMax ? kDeltaMax : change < kDeltaMin ? kDeltaMin : change);
  return delta;
}

// The play shift s of a joint for the controller's next period (whole counts, kShiftBits signed):
//   s = floor((clamp(C - r, -H, H) + g) / 256)
// with C the network's latest answer and r the reference the joint holds (Q24.8 counts): where the
// answer stands in the play, so the controller, which takes reference + 256 s and encoder + s
// (delta/golden/joint_fixed.hpp), sees the motor, in counts as a motor encoder would, rather than
// the encoder behind the play. While the play is closed s is constant (nothing changes); while the
// answer crosses it s follows the answer count by count and moves the joint although the encoder
// holds. The resting shift (below) with the drives off; 0 for H = 0. The grid offset g (play_shift_offset) keeps both
// ends of the play, -H and +H, at least a quarter count from a count boundary, so an answer wobbling by a few LSBs at
// the end of the play, where every steady motion sits, never flips s: with g = 0 a round play (H a whole number of
// counts plus the 2^-10 deg quantisation) would sit right at one. The board computes s every period in the
// interpolator's update (reference_interpolator.sv).
constexpr std::int32_t play_shift_offset(std::int32_t half_play) {
  const std::int32_t quarter = (half_play >> 6) & 3;  // which quarter of a count H mod 256 is in
  return quarter == 1 || quarter == 2 ? 0 : 128;      // ends at +-(H mod 256), or at 128 +- it
}
inline std::int16_t play_shift(std::int64_t difference, std::int32_t half_play) {
  const std::int64_t place = difference < -half_play ? -half_play : difference > half_play ? half_play : difference;
  return static_cast<std::int16_t>((place + play_shift_offset(half_play)) >> 8);  // arithmetic shift: floor
}
// The resting shift: s at the end of the play on the side where it was last taken up (`rising`:
// the joint's encoder count last stepped up). The board writes it with the drives off and after
// the enable until the first answer (reference_interpolator.sv), so the controller's shift does
// not step at the enable; a first answer at the count plus that end (C - r = +-H) keeps it. 0 for
// H = 0.
inline std::int16_t resting_shift(bool rising, std::int32_t half_play) {
  return play_shift(rising ? half_play : -half_play, half_play);
}
static_assert(((kWidestHalfPlay + 128) >> 8) < (1 << (golden::kShiftBits - 1)),
              "the play shift of the widest half-play must fit golden::kShiftBits");

// r_k = B + round_shift(D K_k, 14), k = 0 .. kPeriods - 1. (B + D: the next segment's start.)
// The sum wraps like a 32-bit register; the travel keeps references far inside it.
inline std::int32_t interpolated(std::int32_t start, std::int32_t delta, int k) {
  return static_cast<std::int32_t>(start + round_shift(std::int64_t{delta} * kWeights.at(k), kWeightShift));
}

// B' = B + D.
inline std::int32_t next_start(std::int32_t start, std::int32_t delta) {
  return static_cast<std::int32_t>(std::int64_t{start} + delta);
}

}  // namespace interpolation

// The three joints' interpolators, segment by segment, as the board runs them:
//   follow_encoders(counts)   drives off: r = count << 8 (and a later segment starts there);
//   begin_segment(answer)     a setpoint played: B := B + D of the segment that ended, D from y;
//   begin_hold_segment()      hold or underrun: B := B + D, then D = 0;
//   reference(k)              r_k of the current segment, k = 0 .. 9.
class SetpointInterpolator {
 public:
  static constexpr int kJoints = 3;
  using References = std::array<std::int32_t, kJoints>;  // Q24.8 counts

  SetpointInterpolator() = default;
  // `half_plays`: H_j (Q24.8 counts) of the deployed model's compensation, as in half_play.mem.
  explicit SetpointInterpolator(const References& half_plays) : half_plays_(half_plays) {}

  void follow_encoders(const std::array<std::int16_t, kJoints>& counts) {
    for (int j = 0; j < kJoints; ++j) {
      start_[j] = interpolation::encoder_reference(counts[j]);
      delta_[j] = 0;
    }
    enabled_ = false;
  }

  // `answer`: the network's raw output codes (Q10.14 deg), 24-bit signed.
  void begin_segment(const std::array<std::int32_t, kJoints>& answer) {
    for (int j = 0; j < kJoints; ++j) {
      start_[j] = interpolation::next_start(start_[j], delta_[j]);
      const interpolation::SegmentDelta delta =
          interpolation::segment_delta(interpolation::reference_counts(answer[j]), start_[j], half_plays_[j]);
      delta_[j] = delta.value;
      if (delta.saturated) ++saturations_[j];
    }
    enabled_ = true;
  }

  void begin_hold_segment() {
    for (int j = 0; j < kJoints; ++j) {
      start_[j] = interpolation::next_start(start_[j], delta_[j]);
      delta_[j] = 0;
    }
    enabled_ = true;
  }

  References reference(int k) const {
    References r{};
    for (int j = 0; j < kJoints; ++j) r[j] = interpolation::interpolated(start_[j], delta_[j], k);
    return r;
  }
  std::array<References, interpolation::kPeriods> segment() const {
    std::array<References, interpolation::kPeriods> periods{};
    for (int k = 0; k < interpolation::kPeriods; ++k) periods[k] = reference(k);
    return periods;
  }

  const References& start() const { return start_; }  // B
  const References& delta() const { return delta_; }  // D
  bool enabled() const { return enabled_; }           // false while following the encoders
  // Segments whose D saturated, per joint (the reference catches up in the next segments).
  const std::array<std::uint64_t, kJoints>& saturations() const { return saturations_; }

 private:
  References half_plays_{};
  References start_{};
  References delta_{};
  std::array<std::uint64_t, kJoints> saturations_{};
  bool enabled_ = false;
};

}  // namespace delta::golden

// HLS template of the deployed model's backlash compensation (spec: hls/README.md, "Backlash
// compensation"): per joint a play of half-width h on the network's answers, in time order.
// Synthesizable: compare, add, subtract and saturating casts only. Bit-exact to
// delta::golden::compensate.
#pragma once

#pragma GCC diagnostic ignored "-Wunused-label"

#include "network_config.hpp"

namespace delta_hls {

// The play's memory: the last reference of each joint, and whether there was an answer since reset.
template <class C>
struct CompensationState {
  typename C::output_t reference[C::outputs];
  bool started = false;
};

// For each joint: the first answer passes; then the reference holds while the answer s stays within
// h of it, and follows at s - h (s rising past it) or s + h (falling past it). s - h > r >= min and
// s + h < r <= max, so the new reference always fits the output format (no saturation).
template <class C>
void backlash_compensation(const typename C::output_t alpha[C::outputs],
                           const typename C::half_play_t half_play[C::outputs], CompensationState<C>& state,
                           typename C::output_t reference[C::outputs]) {
CompensateJoint:
  for (int o = 0; o < C::outputs; ++o) {
    const typename C::compensation_difference_t difference = alpha[o] - state.reference[o];
    const typename C::compensation_difference_t below = -half_play[o];
    typename C::output_t next = state.reference[o];
    if (!state.started) {
      next = alpha[o];
    } else if (difference > half_play[o]) {
      const typename C::compensation_difference_t shifted = alpha[o] - half_play[o];
      next = shifted;
    } else if (difference < below) {
      const typename C::compensation_difference_t shifted = alpha[o] + half_play[o];
      next = shifted;
    }
    state.reference[o] = next;
    reference[o] = next;
  }
  state.started = true;
}

}  // namespace delta_hls

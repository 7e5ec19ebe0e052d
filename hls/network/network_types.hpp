// Fixed-point type mapping of the HLS network: one source, ap_fixed under Vitis HLS, sc_fixed under
// SystemC here. Only the modes both libraries share are used: round half up (AP_RND / SC_RND) with
// saturation (AP_SAT / SC_SAT) at the casts the spec names, truncation only where the value is
// exact, and wrap-around never (every exact type is wide enough by construction).
#pragma once

#if defined(__SYNTHESIS__) || defined(DELTA_HLS_USE_AP_FIXED)
#include <ap_fixed.h>
#include <ap_int.h>

namespace delta_hls {
// Rounding (half up) and saturating cast target.
template <int W, int I>
using fixed_round_sat = ap_fixed<W, I, AP_RND, AP_SAT>;
template <int W, int I>
using ufixed_round_sat = ap_ufixed<W, I, AP_RND, AP_SAT>;
// Truncating and saturating (the tanh input magnitude: its only clamp is |n| = 8 -> 8 - LSB).
template <int W, int I>
using ufixed_trunc_sat = ap_ufixed<W, I, AP_TRN, AP_SAT>;
// Exact: holds every value assigned to it (products, sums, constants).
template <int W, int I>
using fixed_exact = ap_fixed<W, I, AP_TRN, AP_WRAP>;
template <int W, int I>
using ufixed_exact = ap_ufixed<W, I, AP_TRN, AP_WRAP>;
template <int W>
using uint_t = ap_uint<W>;
}  // namespace delta_hls

#else
#ifndef SC_INCLUDE_FX
#define SC_INCLUDE_FX
#endif
#include <systemc.h>

namespace delta_hls {
template <int W, int I>
using fixed_round_sat = sc_dt::sc_fixed<W, I, sc_dt::SC_RND, sc_dt::SC_SAT>;
template <int W, int I>
using ufixed_round_sat = sc_dt::sc_ufixed<W, I, sc_dt::SC_RND, sc_dt::SC_SAT>;
template <int W, int I>
using ufixed_trunc_sat = sc_dt::sc_ufixed<W, I, sc_dt::SC_TRN, sc_dt::SC_SAT>;
template <int W, int I>
using fixed_exact = sc_dt::sc_fixed<W, I, sc_dt::SC_TRN, sc_dt::SC_WRAP>;
template <int W, int I>
using ufixed_exact = sc_dt::sc_ufixed<W, I, sc_dt::SC_TRN, sc_dt::SC_WRAP>;
template <int W>
using uint_t = sc_dt::sc_uint<W>;
}  // namespace delta_hls
#endif

// Fixed-point type mapping of every HLS block: one source, ap_fixed under Vitis HLS, sc_fixed under
// SystemC here. Only what both libraries share is used: add, subtract, multiply, compare, in-place
// constant shifts (<<=, >>=), assignment and to_int64(); rounding half up (AP_RND / SC_RND) with
// saturation (AP_SAT / SC_SAT) at the casts the specifications name, truncation only where the
// value is exact, and wrap-around never (every exact type is wide enough by construction).
#pragma once

#include <cstdint>

#if defined(__SYNTHESIS__) || defined(DELTA_HLS_USE_AP_FIXED)
#include <ap_fixed.h>
#include <ap_int.h>

namespace delta_hls {
// Rounding (half up) and saturating cast target.
template <int W, int I>
using fixed_round_sat = ap_fixed<W, I, AP_RND, AP_SAT>;
template <int W, int I>
using ufixed_round_sat = ap_ufixed<W, I, AP_RND, AP_SAT>;
// Truncating and saturating: the value is exact at this LSB, only its range is clamped.
template <int W, int I>
using fixed_trunc_sat = ap_fixed<W, I, AP_TRN, AP_SAT>;
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
using fixed_trunc_sat = sc_dt::sc_fixed<W, I, sc_dt::SC_TRN, sc_dt::SC_SAT>;
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

// Vitis HLS reads pragmas given through _Pragma; a host compiler sees nothing (no unknown-pragma noise).
#if defined(__SYNTHESIS__) || defined(DELTA_HLS_USE_AP_FIXED)
#define DELTA_HLS_PRAGMA(text) _Pragma(#text)
#else
#define DELTA_HLS_PRAGMA(text)
#endif

namespace delta_hls {

// Bits of the smallest power of two >= value (value <= 2^62): sizes accumulators from their sums.
constexpr int ceil_log2(long long value) {
  int bits = 0;
  while ((1LL << bits) < value) ++bits;
  return bits;
}

constexpr int max_bits(int a, int b) { return a > b ? a : b; }

// The value code * 2^-Fraction of a signed integer code of Bits bits, in any type with at least
// Fraction fraction bits and Bits - Fraction integer bits: exact, integers only (the code enters
// an integer-valued type, then moves right by a constant shift).
template <class T, int Bits, int Fraction>
T fixed_from_code(std::int64_t code) {
  fixed_exact<Bits + Fraction, Bits> wide = code;
  wide >>= Fraction;
  const T value = wide;
  return value;
}

// The integer code value * 2^Fraction of a value with Fraction fraction bits and at most Bits bits
// (signed or unsigned): exact.
template <int Bits, int Fraction, class T>
std::int64_t fixed_to_code(const T& value) {
  fixed_exact<Bits + 1 + Fraction, Bits + 1> wide = value;
  wide <<= Fraction;
  return wide.to_int64();
}

}  // namespace delta_hls

// C-simulation testbench of the joint synthesis top (Vitis csim and cosim, and CTest here): every
// output code, and in C simulation every state code and the compiled-in coefficients, against the
// golden vectors that tests/control/joint_golden_vectors.cpp writes from the golden model in closed loop.
// Usage: joint_top_tb [joint_golden_vectors.txt] [--ports-only]; exit 0 only if every code matches
// and every period the file announces (its closing line `end N`) was read.
// --ports-only (C/RTL co-simulation) compares the ports alone: there the states live in the RTL.
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "joint_top.hpp"

namespace {

typedef DeltaJointConfig C;
const int kStateFields = 8;

struct Mismatches {
  long long count = 0;
  void report(long long period, const char* what, int index, long long top, long long golden) {
    if (top != golden && ++count <= 5) {
      std::fprintf(stderr, "period %lld %s[%d]: top %lld, golden %lld\n", period, what, index, top, golden);
    }
  }
};

void state_codes(const delta_hls::JointState<C>& s, long long codes[kStateFields]) {
  codes[0] = delta_hls::fixed_to_code<C::reference_bits, C::reference_fraction>(s.reference);
  codes[1] = delta_hls::fixed_to_code<C::state_bits, C::state_fraction>(s.reference_velocity);
  codes[2] = delta_hls::fixed_to_code<C::state_bits, C::state_fraction>(s.reference_acceleration);
  codes[3] = delta_hls::fixed_to_code<C::encoder_bits, 0>(s.encoder);
  codes[4] = delta_hls::fixed_to_code<C::state_bits, C::state_fraction>(s.velocity);
  codes[5] = delta_hls::fixed_to_code<C::state_bits, C::state_fraction>(s.disturbance);
  codes[6] = delta_hls::fixed_to_code<C::current_bits, C::current_fraction>(s.current);
  codes[7] = delta_hls::fixed_to_code<C::shift_bits, 0>(s.shift);
}

}  // namespace

int main(int argc, char** argv) {
  const char* path = "joint_golden_vectors.txt";
  bool ports_only = false;
  for (int n = 1; n < argc; ++n) {
    if (std::strcmp(argv[n], "--ports-only") == 0) {
      ports_only = true;
    } else {
      path = argv[n];
    }
  }
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "joint_top_tb: cannot read %s\n", path);
    return 2;
  }
  static const char* const kStateNames[kStateFields] = {"state reference",
                                                        "state reference_velocity",
                                                        "state reference_acceleration",
                                                        "state encoder",
                                                        "state velocity",
                                                        "state disturbance",
                                                        "state current",
                                                        "state shift"};
  long long periods = 0;
  long long periods_written = -1;  // from the closing "end N" line: a cut file fails
  bool coefficients_checked = false;
  Mismatches mismatches;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      if (line.find("seed") != std::string::npos) std::printf("joint_top_tb: %s\n", line.c_str() + 2);
      continue;
    }
    std::istringstream fields(line);
    if (line.compare(0, 4, "end ") == 0) {
      std::string word;
      fields >> word >> periods_written;
      break;
    }
    if (line.compare(0, 12, "coefficients") == 0) {
      std::string word;
      long long golden[9];
      fields >> word;
      for (long long& code : golden) fields >> code;
      if (!fields) {
        std::fprintf(stderr, "joint_top_tb: %s: malformed coefficients line\n", path);
        return 2;
      }
      if (!ports_only) {
        const delta_hls::JointCoefficientCodes c = joint_top_coefficient_codes();
        const long long top[9] = {c.reference_gain,    c.velocity_encoder_gain,     c.velocity_current_gain,
                                  c.disturbance_gain,  c.disturbance_velocity_gain, c.law_acceleration_gain,
                                  c.law_velocity_gain, c.law_position_gain,         c.current_limit};
        for (int n = 0; n < 9; ++n) mismatches.report(-1, "coefficient", n, top[n], golden[n]);
        coefficients_checked = true;
      }
      continue;
    }
    long long reference_code[3], encoder_code[3], shift_code[3], current_expected[3], limited_expected,
        overflow_expected;
    long long state_expected[3][kStateFields];
    for (long long& code : reference_code) fields >> code;
    for (long long& code : encoder_code) fields >> code;
    for (long long& code : shift_code) fields >> code;
    for (long long& code : current_expected) fields >> code;
    fields >> limited_expected >> overflow_expected;
    for (auto& joint : state_expected) {
      for (long long& code : joint) fields >> code;
    }
    if (!fields) {
      std::fprintf(stderr, "joint_top_tb: %s: malformed line for period %lld\n", path, periods);
      return 2;
    }
    C::reference_t reference[C::joints];
    C::encoder_t encoder[C::joints];
    C::shift_t shift[C::joints];
    C::current_t current[C::joints];
    C::limited_t limited;
    C::overflow_count_t overflow_count;
    for (int j = 0; j < C::joints; ++j) {
      reference[j] =
          delta_hls::fixed_from_code<C::reference_t, C::reference_bits, C::reference_fraction>(reference_code[j]);
      encoder[j] = delta_hls::fixed_from_code<C::encoder_t, C::encoder_bits, 0>(encoder_code[j]);
      shift[j] = delta_hls::fixed_from_code<C::shift_t, C::shift_bits, 0>(shift_code[j]);
    }
    joint_top(reference, encoder, shift, current, limited, overflow_count);
    for (int j = 0; j < C::joints; ++j) {
      mismatches.report(periods, "current", j,
                        delta_hls::fixed_to_code<C::current_bits, C::current_fraction>(current[j]),
                        current_expected[j]);
    }
    mismatches.report(periods, "limited", -1, limited.to_uint(), limited_expected);
    mismatches.report(periods, "overflow_count", -1, overflow_count.to_uint(), overflow_expected);
    if (!ports_only) {
      for (int j = 0; j < C::joints; ++j) {
        long long top[kStateFields];
        state_codes(joint_top_state(j), top);
        for (int n = 0; n < kStateFields; ++n)
          mismatches.report(periods, kStateNames[n], j, top[n], state_expected[j][n]);
      }
    }
    ++periods;
  }
  std::printf("joint_top_tb: %lld periods x %d joints, %s, %lld mismatching codes\n", periods, C::joints,
              ports_only ? "ports only" : "ports, states and coefficients", mismatches.count);
  if (periods_written != periods) {
    std::fprintf(stderr, "joint_top_tb: %s: %lld periods read, the file says %lld\n", path, periods, periods_written);
  }
  const bool complete = periods_written == periods && (ports_only || coefficients_checked);
  return periods > 0 && complete && mismatches.count == 0 ? 0 : 1;
}

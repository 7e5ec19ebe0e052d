// C-simulation testbench of the synthesis top (Vitis csim and cosim, and CTest here): every raw
// output code against the golden vectors that `deltactl quantise --vectors N` writes.
// Usage: network_top_tb [golden_vectors.txt]; exit 0 only if every code matches.
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "network_top.hpp"

int main(int argc, char** argv) {
  const char* path = argc > 1 ? argv[1] : "golden_vectors.txt";
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "network_top_tb: cannot read %s\n", path);
    return 2;
  }
  long long vectors = 0;
  long long mismatches = 0;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    long long x_code[3];
    long long y_expected[3];
    if (!(fields >> x_code[0] >> x_code[1] >> x_code[2] >> y_expected[0] >> y_expected[1] >> y_expected[2])) {
      std::fprintf(stderr, "network_top_tb: %s: malformed line %lld\n", path, vectors + 1);
      return 2;
    }
    DeltaNetworkConfig::input_t x[3];
    DeltaNetworkConfig::output_t y[3];
    for (int j = 0; j < 3; ++j) {
      x[j] = delta_hls::fixed_from_code<DeltaNetworkConfig::input_t, DeltaNetworkConfig::input_bits,
                                        DeltaNetworkConfig::input_fraction>(x_code[j]);
    }
    delta_network(x, y);
    for (int o = 0; o < 3; ++o) {
      const long long code =
          delta_hls::fixed_to_code<DeltaNetworkConfig::output_bits, DeltaNetworkConfig::output_fraction>(y[o]);
      if (code != y_expected[o] && ++mismatches <= 5) {
        std::fprintf(stderr, "vector %lld output %d: top %lld, golden %lld\n", vectors, o, code, y_expected[o]);
      }
    }
    ++vectors;
  }
  std::printf("network_top_tb: %lld vectors, %lld mismatching codes\n", vectors, mismatches);
  return vectors > 0 && mismatches == 0 ? 0 : 1;
}

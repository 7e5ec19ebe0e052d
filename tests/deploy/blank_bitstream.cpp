// deploy_blank_bitstream OUT.bin: writes an all-zero iCE40 UP5K bitstream (an empty design), the
// stand-in the deploy scripts' tests flash and package where no real bitstream is built.
#include <fstream>
#include <iostream>
#include <vector>

#include "delta/deploy/bitstream.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: deploy_blank_bitstream OUT.bin\n";
    return 2;
  }
  const std::vector<std::uint8_t> bytes = delta::deploy::blank_up5k_bitstream();
  std::ofstream out(argv[1], std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) {
    std::cerr << argv[1] << ": cannot write\n";
    return 1;
  }
  return 0;
}

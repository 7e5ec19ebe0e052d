// libFuzzer harness: the MATLAB .mat importer (through libmatio) on arbitrary bytes.
#include "delta/input_error.hpp"
#include "delta/nn/matlab_exchange.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = delta::fuzz::as_file(data, size, ".mat");
  try {
    delta::nn::import_matlab(path);
  } catch (const delta::InputError&) {
  }
  return 0;
}

// libFuzzer harness: the weights-file reader (W.json) on arbitrary bytes.
#include <string>

#include "delta/input_error.hpp"
#include "delta/nn/weights_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const delta::nn::WeightsFile weights =
        delta::nn::parse_weights_file(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
    // Accepted weights must survive their own writer and reader.
    delta::nn::parse_weights_file(delta::nn::weights_file_text(weights), "again.json");
  } catch (const delta::InputError&) {
  }
  return 0;
}

// libFuzzer harness: the effect-file reader (JSON) on arbitrary bytes.
#include <string>

#include "delta/effect_file.hpp"
#include "delta/input_error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const delta::EffectSet effects =
        delta::parse_effects(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
    // What was accepted must write back and read again to the same set.
    const std::string again = delta::effects_to_json(effects).dump();
    if (delta::effects_to_json(delta::parse_effects(again, "again.json")).dump() != again) std::abort();
  } catch (const delta::InputError&) {
  }
  return 0;
}

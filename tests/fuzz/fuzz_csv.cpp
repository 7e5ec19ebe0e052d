// libFuzzer harness: the CSV reader (recordings and positions) on arbitrary bytes.
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "delta/csv.hpp"
#include "delta/input_error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::istringstream input(std::string(reinterpret_cast<const char*>(data), size));
  try {
    const delta::CsvTable table = delta::parse_csv(input, "fuzz.csv", {"t_s", "x_m", "z_m"});
    if (table.rows.empty() || table.rows.size() != table.line_numbers.size()) std::abort();
  } catch (const delta::InputError&) {
  }
  return 0;
}

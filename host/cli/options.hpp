// Range checks of numeric command-line options, on the text before CLI11 converts it: a negative
// number never wraps into an unsigned option, and NaN, infinity, fractions where a count is meant,
// or absurd sizes are refused at parse time (exit 2, the message names the option).
#pragma once

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "delta/csv.hpp"

namespace delta::options {

// A whole number in [minimum, maximum], written in decimal.
inline CLI::Validator whole_number(long long minimum, long long maximum) {
  const std::string range = std::to_string(minimum) + ".." + std::to_string(maximum);
  return CLI::Validator(
      [minimum, maximum, range](std::string& text) -> std::string {
        errno = 0;
        char* end = nullptr;
        const long long value = std::strtoll(text.c_str(), &end, 10);
        if (text.empty() || *end != '\0' || errno == ERANGE || value < minimum || value > maximum) {
          return "expected a whole number in " + range + ", got '" + text.substr(0, 40) + "'";
        }
        return "";
      },
      "INT in " + range);
}

// A finite number in [minimum, maximum]; with `exclude_minimum`, the minimum itself is refused.
inline CLI::Validator real_number(double minimum, double maximum, bool exclude_minimum = false) {
  char text_range[80];
  std::snprintf(text_range, sizeof(text_range), "%s%g, %g]", exclude_minimum ? "(" : "[", minimum, maximum);
  const std::string range = text_range;
  return CLI::Validator(
      [minimum, maximum, exclude_minimum, range](std::string& text) -> std::string {
        const std::optional<double> parsed = parse_decimal(text);
        const double value = parsed.value_or(NAN);
        const bool inside =
            std::isfinite(value) && value <= maximum && (exclude_minimum ? value > minimum : value >= minimum);
        if (!parsed || !inside) {
          return "expected a finite number in " + range + ", got '" + text.substr(0, 40) + "'";
        }
        return "";
      },
      "NUMBER in " + range);
}

// A seed: any whole number from 0 to 2^63 - 1 (never a negative one wrapped into 2^64 - 1).
inline CLI::Validator seed() { return whole_number(0, std::numeric_limits<long long>::max()); }

}  // namespace delta::options

// The lab PC's configuration file: parser and validator (format in config.hpp).
#include "delta/deploy/config.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "delta/board_facts.hpp"
#include "delta/csv.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/input_error.hpp"

namespace delta::deploy {

const double kBoardSlewDegS = static_cast<double>((1 << (golden::interpolation::kDeltaBits - 1)) - 1) /
                              (1 << golden::interpolation::kReferenceFractionBits) * board::kEncoderCountDeg *
                              board::kSetpointRateHz;

namespace {

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

enum class Kind { kPath, kNumber, kInteger, kAddress };

struct KeySpec {
  Kind kind;
  double min;               // numbers: the lower bound
  double max;               // numbers: the closed upper bound (value <= max)
  bool min_closed = false;  // value >= min (else value > min)
  const char* why = "";     // what the bounds are, for the message
};

const std::map<std::string, std::map<std::string, KeySpec>>& schema() {
  static const std::map<std::string, std::map<std::string, KeySpec>> keys = {
      {"board", {{"port", {Kind::kPath, 0, 0}}, {"baud", {Kind::kInteger, 0, 12e6}}}},
      {"network", {{"weights", {Kind::kPath, 0, 0}}, {"bitstream", {Kind::kPath, 0, 0}}}},
      {"limits",
       {{"following_error_deg", {Kind::kNumber, board::kEncoderCountDeg, 45, true, " (one encoder count to 45 deg)"}},
        {"velocity_deg_s",
         {Kind::kNumber, kMinVelocityDegS, kBoardSlewDegS, true, " (the board's slew limit is the top)"}}}},
      {"service",
       {{"socket", {Kind::kPath, 0, 0}}, {"http", {Kind::kAddress, 0, 0}}, {"http_token_file", {Kind::kPath, 0, 0}}}},
  };
  return keys;
}

std::string folder_of(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
}

std::string resolve(const std::string& value, const std::string& config_path) {
  if (value.empty() || value[0] == '/') return value;
  return folder_of(config_path) + "/" + value;
}

bool is_regular_file(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

double parse_number(const std::string& value, const std::string& file, std::size_t line, const std::string& key) {
  errno = 0;
  const std::optional<double> number = parse_decimal(value);
  if (!number || errno == ERANGE || !std::isfinite(*number)) {
    throw InputError(file, line, key + ": not a number: " + quoted_excerpt(value));
  }
  return *number;
}

}  // namespace

DeployConfig parse_config(const std::string& text, const std::string& path, FileChecks files) {
  const bool check_files = files == FileChecks::kExist;
  DeployConfig config;
  config.path = path;
  std::istringstream lines(text);
  std::string raw;
  std::string section;
  std::set<std::string> seen;
  std::size_t line = 0;
  std::size_t weights_line = 0;
  std::size_t bitstream_line = 0;
  while (std::getline(lines, raw)) {
    ++line;
    const std::string content = trim(raw);
    if (content.empty() || content[0] == '#' || content[0] == ';') continue;
    if (content.front() == '[') {
      if (content.back() != ']') throw InputError(path, line, "section header without ']': " + quoted_excerpt(content));
      section = trim(content.substr(1, content.size() - 2));
      if (!schema().count(section)) {
        throw InputError(path, line,
                         "unknown section " + quoted_excerpt(section) + " (known: board, network, limits, service)");
      }
      if (!seen.insert("[" + section + "]").second) {
        throw InputError(path, line, "section [" + section + "] given twice");
      }
      continue;
    }
    const auto equals = content.find('=');
    if (equals == std::string::npos) throw InputError(path, line, "expected 'key = value': " + quoted_excerpt(content));
    const std::string key = trim(content.substr(0, equals));
    const std::string value = trim(content.substr(equals + 1));
    if (section.empty()) throw InputError(path, line, "key " + quoted_excerpt(key) + " before any [section]");
    const auto& keys = schema().at(section);
    const auto spec = keys.find(key);
    if (spec == keys.end()) {
      std::string known;
      for (const auto& [name, unused] : keys) known += (known.empty() ? "" : ", ") + name;
      throw InputError(path, line,
                       "unknown key " + quoted_excerpt(key) + " in [" + section + "] (known: " + known + ")");
    }
    if (!seen.insert(section + "." + key).second) {
      throw InputError(path, line, "duplicate key " + key + " in [" + section + "]");
    }
    const std::string name = section + "." + key;
    switch (spec->second.kind) {
      case Kind::kPath: {
        if (value.empty() && key != "bitstream") throw InputError(path, line, name + ": empty");
        if (value.find_first_of(" \t") != std::string::npos) {
          throw InputError(path, line, name + ": a path with blanks: " + quoted_excerpt(value));
        }
        const std::string resolved = resolve(value, path);
        if (key == "port") {
          if (value[0] != '/')
            throw InputError(path, line, name + ": not an absolute device path: " + quoted_excerpt(value));
          config.port = value;
        } else if (key == "socket" || key == "http_token_file") {
          if (value[0] != '/') throw InputError(path, line, name + ": not an absolute path: " + quoted_excerpt(value));
          (key == "socket" ? config.socket : config.http_token_file) = value;
        } else if (key == "weights") {
          if (check_files && !is_regular_file(resolved)) {
            throw InputError(path, line, name + ": no such file: " + resolved);
          }
          config.weights = resolved;
          weights_line = line;
        } else {
          if (check_files && !value.empty() && !is_regular_file(resolved)) {
            throw InputError(path, line, name + ": no such file: " + resolved);
          }
          config.bitstream = resolved;
          bitstream_line = line;
        }
        break;
      }
      case Kind::kAddress: {  // ADDR:PORT, the port a whole number in [1, 65535]
        const auto colon = value.rfind(':');
        const std::string port = colon == std::string::npos ? "" : value.substr(colon + 1);
        const bool digits =
            !port.empty() && port.size() <= 5 && port.find_first_not_of("0123456789") == std::string::npos;
        if (colon == 0 || !digits || std::stol(port) < 1 || std::stol(port) > 65535) {
          throw InputError(path, line, name + ": expected ADDR:PORT (e.g. 127.0.0.1:8080): " + quoted_excerpt(value));
        }
        config.http = value;
        break;
      }
      case Kind::kNumber:
      case Kind::kInteger: {
        const double number = parse_number(value, path, line, name);
        if (spec->second.kind == Kind::kInteger && number != std::floor(number)) {
          throw InputError(path, line, name + ": not a whole number: " + quoted_excerpt(value));
        }
        const KeySpec& bounds = spec->second;
        if (!((bounds.min_closed ? number >= bounds.min : number > bounds.min) && number <= bounds.max)) {
          std::ostringstream reason;
          reason << name << ": " << value << " out of range " << (bounds.min_closed ? "[" : "(") << bounds.min << ", "
                 << bounds.max << "]" << bounds.why;
          throw InputError(path, line, reason.str());
        }
        if (key == "baud") {
          if (static_cast<long long>(number) != board::kLinkBaud) {
            throw InputError(path, line,
                             name + ": " + value + " differs from the board's link rate " +
                                 std::to_string(board::kLinkBaud) + " (rtl/board/delta_board_pkg.sv)");
          }
          config.baud = static_cast<long long>(number);
        } else if (key == "following_error_deg") {
          config.following_error_deg = number;
        } else {
          config.velocity_deg_s = number;
        }
        break;
      }
    }
  }
  if (weights_line == 0) throw InputError(path, 0, "network.weights missing (the W.json the board was built from)");
  if (bitstream_line != 0 && !config.bitstream.empty() && config.bitstream == config.weights) {
    throw InputError(path, bitstream_line, "network.bitstream is the weights file " + config.weights);
  }
  if (config.baud == 0) config.baud = board::kLinkBaud;
  return config;
}

DeployConfig read_config(const std::string& path, FileChecks files) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    throw InputError(path, 0, std::string("cannot open configuration file: ") + std::strerror(errno));
  }
  if (S_ISDIR(info.st_mode)) throw InputError(path, 0, "is a folder, not a configuration file");
  if (!S_ISREG(info.st_mode)) throw InputError(path, 0, "not a regular file (a device, FIFO or socket)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open configuration file: ") + std::strerror(errno));
  std::string text(kMaxConfigBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  if (text.size() > kMaxConfigBytes) {
    throw InputError(path, 0, "larger than " + std::to_string(kMaxConfigBytes >> 10) + " KiB: not a configuration");
  }
  if (text.find('\0') != std::string::npos) throw InputError(path, 0, "not a text file (NUL byte)");
  return parse_config(text, path, files);
}

void check_service_can_run(const DeployConfig& config) {
  golden::read_board_weights(config.weights);  // InputError: the weights file, the reason
}

std::string describe(const DeployConfig& config) {
  std::ostringstream out;
  out << "[board]\nport = " << config.port << "\nbaud = " << config.baud << "\n[network]\nweights = " << config.weights
      << "\nbitstream = " << config.bitstream << "\n[limits]\nfollowing_error_deg = " << config.following_error_deg
      << "\nvelocity_deg_s = " << config.velocity_deg_s << "\n[service]\nsocket = " << config.socket
      << "\nhttp = " << config.http << "\nhttp_token_file = " << config.http_token_file << "\n";
  return out.str();
}

}  // namespace delta::deploy

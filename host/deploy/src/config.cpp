// The lab PC's configuration file: parser and validator (format in config.hpp).
#include "delta/deploy/config.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "delta/board_facts.hpp"
#include "delta/input_error.hpp"

namespace delta::deploy {
namespace {

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

enum class Kind { kPath, kNumber, kInteger };

struct KeySpec {
  Kind kind;
  double min;  // numbers: the open lower bound (value > min)
  double max;  // numbers: the closed upper bound (value <= max)
};

const std::map<std::string, std::map<std::string, KeySpec>>& schema() {
  static const std::map<std::string, std::map<std::string, KeySpec>> keys = {
      {"board", {{"port", {Kind::kPath, 0, 0}}, {"baud", {Kind::kInteger, 0, 12e6}}}},
      {"network", {{"weights", {Kind::kPath, 0, 0}}, {"bitstream", {Kind::kPath, 0, 0}}}},
      {"limits", {{"following_error_deg", {Kind::kNumber, 0, 45}}, {"velocity_deg_s", {Kind::kNumber, 0, 3600}}}},
      {"service", {{"socket", {Kind::kPath, 0, 0}}}},
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
  char* end = nullptr;
  const double number = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size() || errno == ERANGE || !std::isfinite(number)) {
    throw InputError(file, line, key + ": not a number: " + quoted_excerpt(value));
  }
  return number;
}

}  // namespace

DeployConfig parse_config(const std::string& text, const std::string& path) {
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
        } else if (key == "socket") {
          if (value[0] != '/') throw InputError(path, line, name + ": not an absolute path: " + quoted_excerpt(value));
          config.socket = value;
        } else if (key == "weights") {
          if (!is_regular_file(resolved)) throw InputError(path, line, name + ": no such file: " + resolved);
          config.weights = resolved;
          weights_line = line;
        } else {
          if (!value.empty() && !is_regular_file(resolved)) {
            throw InputError(path, line, name + ": no such file: " + resolved);
          }
          config.bitstream = resolved;
          bitstream_line = line;
        }
        break;
      }
      case Kind::kNumber:
      case Kind::kInteger: {
        const double number = parse_number(value, path, line, name);
        if (spec->second.kind == Kind::kInteger && number != std::floor(number)) {
          throw InputError(path, line, name + ": not a whole number: " + quoted_excerpt(value));
        }
        if (!(number > spec->second.min && number <= spec->second.max)) {
          std::ostringstream reason;
          reason << name << ": " << value << " out of range (" << spec->second.min << ", " << spec->second.max << "]";
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

DeployConfig read_config(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open configuration file");
  std::ostringstream text;
  text << in.rdbuf();
  if (text.str().find('\0') != std::string::npos) throw InputError(path, 0, "not a text file (NUL byte)");
  return parse_config(text.str(), path);
}

std::string describe(const DeployConfig& config) {
  std::ostringstream out;
  out << "[board]\nport = " << config.port << "\nbaud = " << config.baud << "\n[network]\nweights = " << config.weights
      << "\nbitstream = " << config.bitstream << "\n[limits]\nfollowing_error_deg = " << config.following_error_deg
      << "\nvelocity_deg_s = " << config.velocity_deg_s << "\n[service]\nsocket = " << config.socket << "\n";
  return out.str();
}

}  // namespace delta::deploy

// The lab PC's configuration file, /etc/deltactl/deltactl.conf (format in docs/lab_setup.md,
// "The configuration file", and in the shipped example host/deploy/conf/deltactl.conf):
// `[section]` lines, then `key = value` lines; `#` starts a comment line; blank lines are skipped.
// Every key is known, given at most once and valid, or the file is bad input (InputError: file,
// line, reason; the command line exits 2).
#pragma once

#include <string>

namespace delta::deploy {

constexpr const char* kDefaultConfigPath = "/etc/deltactl/deltactl.conf";
constexpr const char* kDefaultPort = "/dev/delta-board";  // the udev symlink (70-delta-board.rules)

struct DeployConfig {
  std::string path;                  // the file read
  std::string port = kDefaultPort;   // [board] port: a device path (/dev/..., e.g. /dev/serial/by-id/...)
  long long baud = 0;                // [board] baud: the link rate (0: the board's, board::kLinkBaud)
  std::string weights;               // [network] weights: W.json (required, must exist)
  std::string bitstream;             // [network] bitstream: the .bin for `deltactl flash` (optional)
  double following_error_deg = 2.0;  // [limits] following_error_deg: (0, 45]
  double velocity_deg_s = 100.0;     // [limits] velocity_deg_s: (0, 3600], every streamed sample
  std::string socket = "/run/deltactl/deltactl.sock";  // [service] socket: absolute path
};

// Reads and validates `path`. Relative paths in the file are taken relative to the file's folder.
DeployConfig read_config(const std::string& path);

// Parses `text` as if read from `path` (tests; read_config uses it).
DeployConfig parse_config(const std::string& text, const std::string& path);

// The file as `key = value` lines, every value resolved (what `deltactl config check` prints).
std::string describe(const DeployConfig& config);

}  // namespace delta::deploy

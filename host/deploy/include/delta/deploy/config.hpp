// The lab PC's configuration file, /etc/deltactl/deltactl.conf (format in docs/lab_setup.md,
// "The configuration file", and in the shipped example host/deploy/conf/deltactl.conf):
// `[section]` lines, then `key = value` lines; `#` starts a comment line; blank lines are skipped.
// Every key is known, given at most once and valid, or the file is bad input (InputError: file,
// line, reason; the command line exits 2). The limits are bounded by what the board can do: a
// velocity above the board's slew limit (kBoardSlewDegS) is refused, and so is a bound finer than
// one encoder count.
#pragma once

#include <cstddef>
#include <string>

namespace delta::deploy {

constexpr const char* kDefaultConfigPath = "/etc/deltactl/deltactl.conf";
constexpr const char* kDefaultPort = "/dev/delta-board";  // the udev symlink (70-delta-board.rules)

// The board's slew limit: a segment's reference change saturates at 2^(SegmentDeltaBits-1) - 1
// Q24.8 encoder counts per setpoint period (docs/board_link.md): 1279.96 deg/s.
extern const double kBoardSlewDegS;
// One encoder count (EncoderCountMicrodeg): the finest following-error bound, degrees.
extern const double kEncoderCountDeg;
// The lowest joint velocity limit, deg/s: a smaller value (1e-300) is a mistake, not a limit.
constexpr double kMinVelocityDegS = 1.0;
// A configuration is a few hundred bytes; larger (or /dev/zero) is refused before it is read.
constexpr std::size_t kMaxConfigBytes = 64u << 10;

struct DeployConfig {
  std::string path;                  // the file read
  std::string port = kDefaultPort;   // [board] port: a device path (/dev/..., e.g. /dev/serial/by-id/...)
  long long baud = 0;                // [board] baud: the link rate (0: the board's, board::kLinkBaud)
  std::string weights;               // [network] weights: W.json (required, must exist)
  std::string bitstream;             // [network] bitstream: the .bin for `deltactl flash` (optional)
  double following_error_deg = 2.0;  // [limits] following_error_deg: [kEncoderCountDeg, 45]
  double velocity_deg_s = 100.0;     // [limits] velocity_deg_s: [kMinVelocityDegS, kBoardSlewDegS], every sample
  std::string socket = "/run/deltactl/deltactl.sock";  // [service] socket: absolute path
  std::string http;                                    // [service] http: the dashboard's ADDR:PORT ("": no dashboard)
  std::string http_token_file;  // [service] http_token_file: absolute path ("": the serve's default)
};

// What read_config checks of the files the configuration names.
enum class FileChecks {
  kExist,  // the weights (and a bitstream, if named) are regular files: what serve, doctor, flash need
  kNone,   // syntax and values only (`host ctl`, which needs only the socket)
};

// Reads and validates `path` (a regular file of at most kMaxConfigBytes). Relative paths in the
// file are taken relative to the file's folder.
DeployConfig read_config(const std::string& path, FileChecks files = FileChecks::kExist);

// What `deltactl config check` adds to read_config: the weights file loaded with the loader the
// service uses (golden::read_board_weights: readable, valid JSON, a network the board runs).
// InputError names the weights file and the reason.
void check_service_can_run(const DeployConfig& config);

// Parses `text` as if read from `path` (tests; read_config uses it).
DeployConfig parse_config(const std::string& text, const std::string& path, FileChecks files = FileChecks::kExist);

// The file as `key = value` lines, every value resolved (what `deltactl config check` prints).
std::string describe(const DeployConfig& config);

}  // namespace delta::deploy

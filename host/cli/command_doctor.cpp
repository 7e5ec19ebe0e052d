// deltactl doctor: checks a lab PC for the controller and prints a table (check, verdict, what was
// found, fix). Checks that need hardware or an installed file say so (skip) instead of failing.
// Exit 0 when no check fails, 1 otherwise; a bad configuration is a failed check like the others.
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <array>
#include <climits>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/deploy/board_probe.hpp"
#include "delta/deploy/config.hpp"
#include "delta/deploy/doctor.hpp"
#include "delta/gateware.hpp"
#include "delta/input_error.hpp"
#include "options.hpp"

namespace delta {
namespace {

using deploy::Check;
using deploy::Verdict;

struct DoctorOptions {
  std::string config = deploy::kDefaultConfigPath;
  bool config_given = false;
  std::string port;
  bool json = false;
  double latency_s = 10.0;
};

std::string read_first_line(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  if (in) std::getline(in, line);
  return line;
}

// stdout of a shell command (first line), and whether it could run at all.
std::string command_output(const std::string& command) {
  std::string out;
  if (FILE* pipe = ::popen((command + " 2>/dev/null").c_str(), "r")) {
    std::array<char, 256> buffer{};
    if (std::fgets(buffer.data(), buffer.size(), pipe)) out = buffer.data();
    ::pclose(pipe);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

bool have_systemctl() { return ::access("/usr/bin/systemctl", X_OK) == 0 || ::access("/bin/systemctl", X_OK) == 0; }

std::string real_path(const std::string& path) {
  char resolved[PATH_MAX];
  return ::realpath(path.c_str(), resolved) ? std::string(resolved) : path;
}

Check check_device(const std::string& port) {
  Check check{"board device", Verdict::kOk, port, ""};
  struct stat info {};
  if (::stat(port.c_str(), &info) != 0) {
    check.verdict = Verdict::kFail;
    check.detail = port + ": not present (needs the board on USB)";
    check.fix = "plug in the iCEBreaker; check `ls -l /dev/delta-board` and /lib/udev/rules.d/70-delta-board.rules";
    return check;
  }
  check.detail = port + " -> " + real_path(port);
  if (!S_ISCHR(info.st_mode)) {
    check.verdict = Verdict::kFail;
    check.detail += ": not a character device";
    check.fix = "set [board] port to the board's tty";
  } else if (::access(port.c_str(), R_OK | W_OK) != 0) {
    check.verdict = Verdict::kFail;
    check.detail += ": no read/write access";
    check.fix = "sudo adduser $USER deltactl (then log in again): the board's UART is group deltactl's";
  }
  return check;
}

Check check_latency_timer(const std::string& port) {
  Check check{"latency timer", Verdict::kSkip, "", ""};
  const std::string device = real_path(port);
  const auto slash = device.rfind('/');
  const std::string tty = slash == std::string::npos ? device : device.substr(slash + 1);
  const std::string sysfs = "/sys/class/tty/" + tty + "/device/latency_timer";
  const std::string value = read_first_line(sysfs);
  if (value.empty()) {
    check.detail = device + ": not an FTDI device (no " + sysfs + ")";
    return check;
  }
  check.detail = sysfs + " = " + value + " ms";
  if (value == "1") {
    check.verdict = Verdict::kOk;
  } else {
    check.verdict = Verdict::kFail;
    check.fix = "install 70-delta-board.rules (ATTR{latency_timer}=\"1\"), then sudo udevadm trigger";
  }
  return check;
}

Check check_modem_manager() {
  Check check{"ModemManager", Verdict::kSkip, "", ""};
  if (!have_systemctl()) {
    check.detail = "no systemctl";
    return check;
  }
  const std::string state = command_output("systemctl is-active ModemManager");
  if (state.empty()) {
    check.detail = "systemd is not running (container?): cannot ask";
    return check;
  }
  check.detail = "ModemManager: " + (state.empty() ? std::string("unknown") : state);
  if (state == "active") {
    check.verdict = Verdict::kWarn;
    check.fix = "the rules set ID_MM_DEVICE_IGNORE=1 for the board; or sudo systemctl disable --now ModemManager";
  } else {
    check.verdict = Verdict::kOk;
  }
  return check;
}

std::string limit_text(rlim_t value) { return value == RLIM_INFINITY ? "unlimited" : std::to_string(value); }

Check check_rtprio() {
  Check check{"RT priority", Verdict::kOk, "", ""};
  rlimit limit{};
  ::getrlimit(RLIMIT_RTPRIO, &limit);
  check.detail = "RLIMIT_RTPRIO soft " + limit_text(limit.rlim_cur) + ", hard " + limit_text(limit.rlim_max) +
                 (::geteuid() == 0 ? " (root: not limited)" : "");
  if (::geteuid() != 0 && limit.rlim_cur < 80) {
    check.verdict = Verdict::kFail;
    check.fix = "the service has LimitRTPRIO=90; for a shell: '@deltactl - rtprio 90' in /etc/security/limits.d/";
  }
  return check;
}

Check check_memlock() {
  Check check{"memlock", Verdict::kOk, "", ""};
  rlimit limit{};
  ::getrlimit(RLIMIT_MEMLOCK, &limit);
  check.detail = "RLIMIT_MEMLOCK soft " + limit_text(limit.rlim_cur) + ", hard " + limit_text(limit.rlim_max) +
                 (::geteuid() == 0 ? " (root: not limited)" : "");
  constexpr rlim_t kNeeded = 64ull << 20;
  if (::geteuid() != 0 && limit.rlim_cur != RLIM_INFINITY && limit.rlim_cur < kNeeded) {
    check.verdict = Verdict::kWarn;
    check.fix = "the service has LimitMEMLOCK=infinity; for a shell: '@deltactl - memlock unlimited' in limits.d";
  }
  return check;
}

Check check_kernel() {
  Check check{"kernel", Verdict::kOk, "", ""};
  utsname name{};
  ::uname(&name);
  const bool realtime = read_first_line("/sys/kernel/realtime") == "1" ||
                        std::string(name.version).find("PREEMPT_RT") != std::string::npos;
  check.detail = std::string(name.release) + " " + name.version + (realtime ? " (PREEMPT_RT)" : " (not PREEMPT_RT)");
  if (!realtime) {
    check.verdict = Verdict::kWarn;
    check.fix = "sudo apt install linux-image-rt-amd64 and reboot into it";
  }
  return check;
}

Check check_wake_latency(double seconds) {
  Check check{"wake latency", Verdict::kOk, "", ""};
  const controller::WakeLatencyProbe probe = controller::measure_wake_latency(seconds, 80);
  const controller::WakeLatency& latency = probe.latency;
  std::ostringstream detail;
  detail << std::fixed << std::setprecision(1) << latency.count() << " wake-ups at 1 kHz"
         << (probe.realtime_note.empty() ? " (SCHED_FIFO 80)" : " (SCHED_OTHER: no RT priority)") << ": p99 "
         << latency.percentile_us(99) << " us, max " << latency.max_us()
         << " us: " << deploy::latency_band(latency.max_us());
  check.detail = detail.str();
  check.verdict = deploy::latency_verdict(latency.max_us());
  if (check.verdict != Verdict::kOk) {
    check.fix = "PREEMPT_RT kernel, RT priority allowed, BIOS: C-states and SMT off; isolcpus for the controller";
  }
  return check;
}

Check check_identify(const std::string& port, const deploy::DeployConfig* config, const std::string& config_note) {
  Check check{"board identify", Verdict::kSkip, "", ""};
  struct stat info {};
  if (::stat(port.c_str(), &info) != 0) {
    check.detail = "needs the board: " + port + " not present";
    return check;
  }
  const int baud = config ? static_cast<int>(config->baud) : static_cast<int>(board::kLinkBaud);
  link::IdentifyPayload board;
  try {
    board = deploy::identify_board(port, baud, 1000);
  } catch (const std::exception& error) {
    check.verdict = Verdict::kFail;
    check.detail = error.what();
    check.fix = "is the bitstream on the board? deltactl flash; is the service holding the port? (it is exclusive)";
    return check;
  }
  // The model is data the host loads (deltactl host load): identify's weights CRC is the loaded
  // model's, 0 with none (a board after power-up, a reset or a flash).
  const bool model = board.weights_crc != 0;
  check.detail = "protocol " + std::to_string(board.protocol_version) + ", build id " + deploy::hex32(board.build_id) +
                 (model ? ", model CRC-32 " + deploy::hex32(board.weights_crc) : ", no model loaded");
  check.verdict = Verdict::kOk;
  if (board.build_id != static_cast<std::uint32_t>(kGatewareBuildId)) {
    check.verdict = Verdict::kFail;
    check.detail += "; this deltactl expects build id " + deploy::hex32(kGatewareBuildId);
    check.fix = "deltactl flash (the package's bitstream), or install the deltactl built with the board's gateware";
  }
  if (!config) {
    check.detail += "; model not compared: " + config_note;
    if (check.verdict == Verdict::kOk) check.verdict = Verdict::kWarn;
    return check;
  }
  const std::uint32_t crc = deploy::weights_file_crc(config->weights);
  const std::string load = "deltactl host load --port " + port + " --weights " + config->weights;
  if (!model) {
    if (check.verdict == Verdict::kOk) check.verdict = Verdict::kWarn;
    check.detail += " (" + config->weights + " has " + deploy::hex32(crc) + ")";
    if (check.fix.empty()) check.fix = load + " (or start the service: it loads its configured model)";
  } else if (crc != board.weights_crc) {
    check.verdict = Verdict::kFail;
    check.detail += "; " + config->weights + " has " + deploy::hex32(crc);
    if (check.fix.empty()) check.fix = load;
  } else {
    check.detail += " = " + config->weights;
  }
  return check;
}

Check check_service() {
  Check check{"service", Verdict::kSkip, "", ""};
  if (!have_systemctl()) {
    check.detail = "no systemctl";
    return check;
  }
  const std::string state = command_output("systemctl is-active deltactl.service");
  const std::string enabled = command_output("systemctl is-enabled deltactl.service");
  if (state.empty()) {
    check.detail = "systemd is not running (container?): cannot ask";
    return check;
  }
  check.detail = "deltactl.service: " + (state.empty() ? std::string("unknown") : state) + ", " +
                 (enabled.empty() ? std::string("not installed") : enabled);
  if (state == "active") {
    check.verdict = Verdict::kOk;
  } else if (state == "failed") {
    check.verdict = Verdict::kFail;
    check.fix = "journalctl -u deltactl.service; deltactl config check";
  } else {
    check.verdict = Verdict::kWarn;
    check.fix = "sudo systemctl enable --now deltactl.service";
  }
  return check;
}

void print_table(const std::vector<Check>& checks) {
  std::size_t name_width = 5;
  for (const Check& check : checks) name_width = std::max(name_width, check.name.size());
  std::cout << std::left << std::setw(static_cast<int>(name_width)) << "check"
            << "  verdict  detail\n";
  for (const Check& check : checks) {
    std::cout << std::left << std::setw(static_cast<int>(name_width)) << check.name << "  " << std::setw(7)
              << deploy::verdict_name(check.verdict) << "  " << check.detail << '\n';
    if (!check.fix.empty()) {
      std::cout << std::string(name_width + 11, ' ') << "fix: " << check.fix << '\n';
    }
  }
}

void doctor(const DoctorOptions& options) {
  // A bad configuration is a FAIL line, not the end: the other checks still run (the port falls
  // back to the default when the file does not parse; the weights are compared only when they load).
  std::unique_ptr<deploy::DeployConfig> config;
  std::string config_port = deploy::kDefaultPort;
  std::string config_note;
  Check config_check{"config", Verdict::kOk, "", ""};
  struct stat info {};
  if (options.config_given || ::stat(options.config.c_str(), &info) == 0) {
    try {
      const deploy::DeployConfig parsed = deploy::read_config(options.config);
      config_port = parsed.port;
      deploy::check_service_can_run(parsed);
      config = std::make_unique<deploy::DeployConfig>(parsed);
      config_check.detail = config->path + ": valid";
    } catch (const InputError& error) {
      config_check = {"config", Verdict::kFail, error.what(),
                      "correct what it names (deltactl config check --config " + options.config + ")"};
      config_note = "the configuration is invalid";
    }
  } else {
    config_note = "no " + options.config + " (install the package or pass --config)";
    config_check = {"config", Verdict::kWarn, config_note, "sudo apt install ./deltactl_*.deb"};
  }
  const std::string port = !options.port.empty() ? options.port : config_port;
  std::vector<Check> checks;
  checks.push_back(config_check);
  checks.push_back(check_device(port));
  checks.push_back(check_latency_timer(port));
  checks.push_back(check_modem_manager());
  checks.push_back(check_rtprio());
  checks.push_back(check_memlock());
  checks.push_back(check_kernel());
  checks.push_back(check_wake_latency(options.latency_s));
  checks.push_back(check_identify(port, config.get(), config_note));
  checks.push_back(check_service());
  bool failed = false;
  for (const Check& check : checks) failed = failed || check.verdict == Verdict::kFail;
  if (options.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const Check& check : checks) {
      out.push_back({{"check", check.name},
                     {"verdict", deploy::verdict_name(check.verdict)},
                     {"detail", check.detail},
                     {"fix", check.fix}});
    }
    std::cout << out.dump(2) << '\n';
  } else {
    print_table(checks);
  }
  if (failed) throw CommandExit{kExitFailure};
}

const RegisterCommand kRegister("doctor", 92, [](CLI::App& root) {
  auto options = std::make_shared<DoctorOptions>();
  auto* sub = root.add_subcommand("doctor", "Check this PC for the controller: device, latency, RT, board, service");
  sub->footer(
      "\nPrints every check with a verdict (ok, warn, FAIL, skip: needs hardware) and the fix of a failure.\n"
      "Exit 0 when no check fails, 1 otherwise. Example: deltactl doctor --latency-seconds 10");
  sub->add_option("--config", options->config, "configuration file")
      ->capture_default_str()
      ->each([options](const std::string&) { options->config_given = true; });
  sub->add_option("--port", options->port, "board device (default: [board] port of the config, /dev/delta-board)");
  sub->add_option("--latency-seconds", options->latency_s, "duration of the 1 kHz wake-latency probe")
      ->check(options::real_number(0.1, 600.0))
      ->capture_default_str();
  sub->add_flag("--json", options->json, "print the checks as JSON");
  sub->callback([options] { doctor(*options); });
});

}  // namespace
}  // namespace delta

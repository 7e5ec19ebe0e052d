// The operator's dashboard of `deltactl host serve --http ADDR:PORT` (docs/dashboard.md): one page
// (web/ assets, no build step) and a small HTTP API (cpp-httplib) beside the control socket.
//
//   GET  /                      the page (and its assets)
//   GET  /api/status            the controller's status with state, homed, drives_enabled, fault
//                               (null or the cause), run (played, planned, seconds, percent, feed),
//                               estop (latched, source, board_time_s) as the controller gives it
//   GET  /api/telemetry         Server-Sent Events: first `event: history` (the kept minutes), then
//                               one `data:` event every 40 ms (new samples + the status)
//   GET  /api/trajectories      the named trajectories of `deltactl simulate`
//   GET  /api/recordings        the recordings folder; /api/recordings/NAME.csv (download) and
//                               /api/recordings/NAME.png (its `deltactl plot`)
//   POST /api/home | run {"trajectory", "duration"} | hold | resume | stop | clear | estop
//
// Every POST goes through the control socket's dispatch (the same JSON-lines requests as `host
// ctl`). Security: a POST needs `Authorization: Bearer TOKEN` (401) and, when the browser sends an
// Origin, the server's own (403); a GET from another host than the loopback needs the token too;
// on every listener the Host header must be one of the server's names (the loopback's, the --http
// address, the machine's name, the bound addresses: no DNS rebinding). The token file is created
// (random, mode 0600) when absent and refused when others may read it.
//
// Threads: the front door (http_front_door.hpp) reads every request's head against a deadline
// and hands it to a lane: the e-stop and the other commands of a client with the token each have
// threads no read, plot or telemetry stream can take; cpp-httplib routes and answers. One
// publisher thread turns the telemetry into events every 40 ms. Telemetry comes in through
// on_telemetry() from the board thread or a run's recording thread, never the real-time streaming
// thread; a slow browser only loses events (each client reads a ring at its own pace).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "delta/controller/host_run.hpp"

namespace delta::controller {

struct DashboardOptions {
  std::string address = "127.0.0.1";  // --http ADDR:PORT
  int port = 0;
  std::string token_file;     // the bearer token (created 0600 when absent)
  std::string record_folder;  // the recordings listed and plotted
  std::string web_root;       // "" : find_web_root()
  int max_streams = 16;       // telemetry clients at once (more: 503), each a thread
  double history_s = 300.0;   // telemetry kept for a reload
};

// "ADDR:PORT" (or "[v6]:PORT") into options; InputError-free: HostFailure(exit 2) naming the text.
void parse_http_address(const std::string& text, DashboardOptions& options);

// The web assets: $DELTACTL_WEB_ROOT, else the shipped data's web/ (shipped_data.hpp: a build's
// links to the source tree's host/controller/web; the package's is /usr/share/deltactl/web).
std::string find_web_root();

// The rule for a recording's file name, the dashboard's listing and the control socket's `run
// --record` alike: NAME.csv of letters, digits, '-', '_' and '.', not starting with '.', at most
// 200 characters. "" when `file_name` follows it, else the rule it breaks.
std::string recording_name_problem(const std::string& file_name);

// What the dashboard asks of the controller.
struct DashboardBackend {
  std::function<nlohmann::json()> status;                         // as the control socket's status
  std::function<nlohmann::json(const nlohmann::json&)> dispatch;  // one control-socket request, its reply
};

class Dashboard {
 public:
  // Reads or creates the token file and binds the listener (HostFailure: exit 2 bad options or
  // token file, exit 1 address in use); serves from start() until stop() or destruction.
  Dashboard(const DashboardOptions& options, DashboardBackend backend);
  ~Dashboard();
  void start();
  void stop();
  // One telemetry frame (any thread but the streaming loop's; cheap: kept at 50 Hz in a ring).
  void on_telemetry(const TelemetryRecord& record);
  // "http://ADDR:PORT" as bound.
  std::string url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace delta::controller

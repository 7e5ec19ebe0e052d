// `deltactl host serve`: the long-running host controller (deltactl.service). It owns the board's
// serial port and answers a local control socket (AF_UNIX stream, JSON lines) for
// `deltactl host ctl` and any other client.
//
// Threads: the board thread owns the port and the link session: it connects (identify; the board
// must run this checkout's gateware and W.json's weights), reads telemetry while idle (no
// telemetry for the link bound: disconnected, the port closed and opened again every second), and
// executes the clients' commands and runs one at a time (RunJob, the same as `host run`). Each
// client has a thread; feed hold, resume and stop go straight to the running job. The main thread
// accepts clients, tells systemd READY=1, STATUS= and WATCHDOG=1 (only while the board thread is
// alive), and on SIGTERM/SIGINT stops a run in a controlled way, disables the drives, then exits.
// Nothing enables the drives except an `enable` or `run` request; never after a fault, a
// reconnect or a restart by itself.
//
// Protocol: one JSON object per line each way. Requests: {"cmd": C, ...} with C one of
//   status | home | enable | disable | clear-fault | hold | resume | stop | estop
//   run {"trajectory": NAME|/abs/FILE.csv, "duration": S, "record": /abs/OUT.csv (default: a
//       new file in the recordings folder), "wait": true}
// Replies: {"ok": true|false, "exit": CODE, "error": "...", ...}; a run with "wait" answers
// {"event": "started", ...}, then {"event": "progress", "played", "planned", "feed"} every second,
// then {"event": "finished", "ok", "exit", "outcome", "error", "summary", "record"}. CODE is what
// `host run` would exit with (0, 2 bad request, 3 fault/not ready/refused, 4 link lost, 5 mismatch).
// estop: the drives off ahead of anything queued (a streaming run's loop disables at its next
// cycle; otherwise a disable goes first in the board thread's queue); never refused as busy.
#pragma once

#include <csignal>
#include <memory>
#include <string>

#include "delta/controller/stream_plan.hpp"

namespace delta::controller {

struct ServeOptions {
  std::string port;           // the board's serial device (resolve_port)
  std::string weights_path;   // W.json the board must run
  std::string socket_path;    // the control socket
  std::string record_folder;  // where runs without "record" are recorded
  int link_timeout_ms = 100;
  double following_error_deg = 2.0;
  StreamLimits limits;
  std::string http;             // the dashboard's ADDR:PORT ("": none; dashboard.hpp)
  std::string http_token_file;  // its bearer token (created 0600 when absent)
};

class HostServer {
 public:
  // Reads the weights (InputError), binds the socket (HostFailure, exit 1 if it is in use).
  explicit HostServer(const ServeOptions& options);
  ~HostServer();
  // Serves until `stop_signal` becomes non-zero; returns the exit code (0 after a clean stop).
  int run(const volatile std::sig_atomic_t& stop_signal);
  // The dashboard's "http://ADDR:PORT" as bound ("" without --http).
  std::string dashboard_url() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// systemd's sd_notify(3) without libsystemd: one datagram to $NOTIFY_SOCKET (nothing when unset).
void notify_systemd(const std::string& message);

}  // namespace delta::controller

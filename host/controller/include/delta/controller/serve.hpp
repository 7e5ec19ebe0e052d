// `deltactl host serve`: the long-running host controller (deltactl.service). It owns the board's
// serial port and answers a local control socket (AF_UNIX stream, JSON lines) for
// `deltactl host ctl` and any other client.
//
// Threads: the board thread owns the port and the link session: it connects (identify; the board
// must run this checkout's gateware; one without W.json's model, the drives off, is given it:
// model_load.hpp, status "model_load" says how that went), reads telemetry while idle (no
// telemetry for the link bound: disconnected, the port closed and opened again every second), and
// executes the clients' commands and runs one at a time (RunJob, the same as `host run`). Each
// client has a thread, at most kMaxClients at once (one more is answered "busy" and closed, but
// its stop, estop or hold is carried out first; a client silent for kClientIdleSeconds is
// closed), each ended and freed when its client goes: any number of connections over time costs
// no memory. Feed hold, resume and stop go straight to the
// running job. The main thread accepts clients, tells systemd READY=1, STATUS= and WATCHDOG=1 (only
// while the board thread is alive), and on SIGTERM/SIGINT/SIGHUP/SIGQUIT stops a run in a
// controlled way, disables the drives, then exits (in bounded time: a run ends within about 1 s).
// Nothing enables the drives except an `enable` or `run` request; never after a fault, a
// reconnect or a restart by itself. After `enable` the drives hold the arms where they are and
// the idle board thread keeps the link alive (a hold every few ms feeds the board's watchdog)
// until `disable`, a run, a fault or a link loss.
//
// Protocol: one JSON object per line each way (at most 64 KiB; any bytes: a line that is not a
// JSON object of the right types is answered with exit 2; text in replies is valid UTF-8, bytes
// that were not shown as \xHH). Requests: {"cmd": C, ...} with C one of
//   status | home | enable | disable | clear-fault | load | hold | resume | stop | estop
//   (load: the configured W.json's model onto the board again, the drives off, as at a connection:
//   {"ok", "weights_crc", "frames", "seconds"}; refused, exit 3, with the drives on)
//   run {"trajectory": NAME|/abs/FILE.csv|move:..., "duration": S (0 < S <= kMaxRunSeconds; 0 or
//       absent: all of it), "record": NAME.csv (in the recordings folder: a relative name is taken
//       there, an absolute one must lie inside it; an existing file is never replaced; default: a
//       new run-TIME.csv, numbered if taken), "wait": true|false}
// Replies: {"ok": true|false, "exit": CODE, "error": "...", ...}; a run with "wait" answers
// {"event": "started", "record"}, then {"event": "progress", "played", "planned", "feed"} every
// second, then {"event": "finished", "ok", "exit", "outcome", "error", "summary", "record"}; the run
// stops at rest if that client goes away (closes its socket) before the end. Without "wait":
// {"ok": true, "event": "queued", "record"}. CODE is what `host run` would exit with (0, 2 bad
// request, 3 fault/not ready/refused/busy, 4 link lost, 5 mismatch).
// estop: latched first, then the drives off ahead of anything queued (a streaming run's loop
// disables at its next cycle, a homing ends at its next frame, queued work that would move is
// refused; a disable goes first in the board thread's queue); never refused as busy; answered
// when the drives are off. While latched ("state": "e-stopped", "estop": {"latched", "source",
// "board_time_s"} in status), home, enable and run are refused for every client (exit 3) until
// clear-fault, which clears the board's fault and the latch. SIGUSR1 to serve is an e-stop too.
// stop also ends a homing (drives off, not homed).
#pragma once

#include <csignal>
#include <memory>
#include <string>

#include "delta/controller/stream_plan.hpp"
#include "delta/link/session.hpp"

namespace delta::controller {

struct ServeOptions {
  std::string port;           // the board's serial device (resolve_port)
  std::string weights_path;   // W.json the board must run (loaded onto it when it has another model or none)
  std::string socket_path;    // the control socket
  std::string record_folder;  // where runs without "record" are recorded
  int link_timeout_ms = link::kLinkTimeoutMs;
  double following_error_deg = 2.0;
  StreamLimits limits;
  std::string http;             // the dashboard's ADDR:PORT ("": none; dashboard.hpp)
  std::string http_token_file;  // its bearer token (created 0600 when absent)
};

constexpr int kMaxClients = 32;
constexpr int kClientIdleSeconds = 60;

class HostServer {
 public:
  // Reads the weights (InputError), makes the recordings folder, binds the socket (HostFailure:
  // exit 1 if another controller serves there; exit 2 if the path is something else than a socket,
  // which is never removed).
  explicit HostServer(const ServeOptions& options);
  ~HostServer();  // removes the socket if it is still the one bound here
  // Serves until `stop_signal` becomes non-zero; returns the exit code (0 after a clean stop).
  int run(const volatile std::sig_atomic_t& stop_signal);
  // One request line answered as the socket answers it (a run is queued: "wait" is taken as
  // false); one reply line without the newline. For other front ends (a dashboard) while run() serves.
  std::string handle(const std::string& request_line);
  // A counter a signal handler increments (SIGUSR1 in `host serve`): each change is an e-stop from
  // the "signal", latched as a client's estop is. Set before run().
  void set_estop_signal(const volatile std::sig_atomic_t* count);
  // The dashboard's "http://ADDR:PORT" as bound ("" without --http).
  std::string dashboard_url() const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;  // shared with the client threads
};

// systemd's sd_notify(3) without libsystemd: one datagram to $NOTIFY_SOCKET (nothing when unset).
void notify_systemd(const std::string& message);

}  // namespace delta::controller

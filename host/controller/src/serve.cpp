// deltactl host serve (see serve.hpp).
#include "delta/controller/serve.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "delta/board_facts.hpp"
#include "delta/controller/dashboard.hpp"
#include "delta/controller/homing.hpp"
#include "delta/controller/model_load.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/exit_codes.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/input_error.hpp"
#include "delta/utf8_text.hpp"

namespace delta::controller {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The board's state now: what waits in the device's buffer is read and dropped, then the next frame.
link::TelemetryPayload fresh_telemetry(link::LinkSession& session) {
  session.poll_frames();
  while (session.take_telemetry()) {
  }
  return session.next_telemetry();
}

json failure(int code, const std::string& error) {
  return {{"ok", false}, {"exit", code}, {"error", escape_invalid_utf8(error)}};
}
json success() { return {{"ok", true}, {"exit", 0}}; }

// One reply line; text that is not UTF-8 has been escaped where it is put in, and is replaced here
// if any got through (dump never throws).
std::string reply_line(const json& message) { return message.dump(-1, ' ', false, json::error_handler_t::replace); }

bool send_line(int fd, const json& message) {
  const std::string text = reply_line(message) + "\n";
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// The recording a client names, as serve writes it: a relative NAME in `folder`, an absolute path
// only directly inside it (its folder resolved: links cannot lead out; the file name by the
// dashboard's rule, recording_name_problem, so every recording is listed); "" takes a new
// run-TIME.csv there.
// InputError (exit 2) otherwise. `folder` is canonical.
std::string confined_record_path(const std::string& folder, const std::string& name, const std::string& stamp) {
  namespace fs = std::filesystem;
  if (name.empty()) return folder + "/run-" + stamp + ".csv";
  const fs::path asked = fs::path(name).is_absolute() ? fs::path(name) : fs::path(folder) / name;
  const fs::path file = asked.filename();
  if (file.empty() || file == "." || file == "..") throw InputError(name, 0, "a recording needs a file name");
  std::error_code error;
  const fs::path parent = fs::canonical(asked.parent_path(), error);
  const std::string inside = parent.string() + "/";
  if (error) {
    throw InputError(name, 0,
                     "no folder " + asked.parent_path().string() + " (name a plain file, written in " + folder + ")");
  }
  if (inside.compare(0, folder.size() + 1, folder + "/") != 0) {
    throw InputError(
        name, 0,
        "recordings are written in the controller's recordings folder " + folder + " (a plain file name goes there)");
  }
  if (const std::string why = recording_name_problem(file.string()); !why.empty()) throw InputError(name, 0, why);
  if (parent.string() != folder) {  // the dashboard lists the folder's own files: none in subfolders
    throw InputError(name, 0,
                     "recordings are written in the controller's recordings folder " + folder +
                         " itself (a plain file name goes there)");
  }
  return (parent / file).string();
}

std::string timestamp() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  ::gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y%m%dT%H%M%SZ", &tm);
  return text;
}

}  // namespace

void notify_systemd(const std::string& message) {
  const char* path = std::getenv("NOTIFY_SOCKET");
  if (!path || !*path) return;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  const std::string name = path;
  if (name.size() >= sizeof address.sun_path) return;
  std::copy(name.begin(), name.end(), address.sun_path);
  if (name[0] == '@') address.sun_path[0] = '\0';  // abstract namespace
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return;
  const auto length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name.size());
  ::sendto(fd, message.data(), message.size(), MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&address), length);
  ::close(fd);
}

struct HostServer::Impl {
  ServeOptions options;
  golden::BoardWeights weights;
  std::string record_folder;  // canonical
  int listen_fd = -1;
  dev_t socket_device = 0;  // the socket bound here (removed at the end only if still it)
  ino_t socket_inode = 0;
  std::atomic<bool> shutting_down{false};
  const volatile std::sig_atomic_t* stop_signal = nullptr;
  const volatile std::sig_atomic_t* estop_signal = nullptr;  // counts SIGUSR1 (set_estop_signal)

  // ---- the board thread's view, for status (guarded by mutex) ----
  std::mutex mutex;
  std::string connection = "disconnected";  // disconnected | connected | mismatch
  std::string note = "not yet connected";
  std::optional<link::IdentifyPayload> identify;
  std::optional<link::TelemetryPayload> telemetry;
  std::string model_load;  // the last load of the configured model at a connection ("" before any)
  std::string port_name;
  json last_run;                    // null until a run ended
  std::shared_ptr<RunJob> running;  // queued or running
  bool holding_enabled = false;     // drives on by `enable`: the idle loop keeps the link alive
  std::atomic<std::int64_t> heartbeat_ns{0};

  // ---- the e-stop latch (guarded by mutex) ----
  // Set by an estop from any front end (socket, dashboard, SIGUSR1): from then on home, enable and
  // run are refused for every client until an explicit clear-fault (POST /api/clear). Nothing else
  // clears it: not a reconnect, not a queued request, not the end of the run it stopped.
  struct EstopLatch {
    bool latched = false;
    std::string source;                  // who asked first: socket | dashboard | signal
    std::optional<double> board_time_s;  // the board's time then (null: no telemetry yet)
  };
  EstopLatch estop_latch;
  std::string estop_file;                      // the latch kept across a restart: <recordings>/.estop-latched (JSON)
  bool homing = false;                         // the board thread is homing (a stop, an estop or the shutdown ends it)
  bool homing_interrupted = false;             // the last homing failed or was stopped (no homing since)
  volatile std::sig_atomic_t homing_stop = 0;  // non-zero: the homing ends now, drives off

  // ---- client threads: counted, each ends on its own ----
  std::mutex clients_mutex;
  std::condition_variable clients_gone;
  int clients = 0;

  // ---- work for the board thread ----
  struct Work {
    std::string command;  // home, enable, disable, clear-fault, run
    std::shared_ptr<RunJob> job;
    std::string record;
    json reply;
    bool done = false;
  };
  std::deque<std::shared_ptr<Work>> queue;
  std::condition_variable work_done;
  std::unique_ptr<Dashboard> dashboard;  // --http: fed telemetry by the board thread

  void observed(const link::TelemetryPayload& t) {
    if (!dashboard) return;
    TelemetryRecord record;
    record.telemetry = t;
    dashboard->on_telemetry(record);
  }

  void beat() { heartbeat_ns.store(Clock::now().time_since_epoch().count()); }

  json status() {
    std::shared_ptr<RunJob> job;
    std::optional<link::TelemetryPayload> t;
    bool homing_now = false;
    json out = success();
    {
      std::lock_guard<std::mutex> lock(mutex);
      out["connection"] = connection;
      out["note"] = escape_invalid_utf8(note);
      out["port"] = escape_invalid_utf8(port_name.empty() ? options.port : port_name);
      out["weights"] = escape_invalid_utf8(options.weights_path);
      out["weights_crc"] = golden::hex_word(weights_crc(weights.network), 32);
      out["gateware_build_id"] = golden::hex_word(kGatewareBuildId, 32);
      out["recordings"] = escape_invalid_utf8(record_folder);
      if (identify) {
        const bool model = telemetry && board_has_model(*telemetry);
        out["board"] = {{"gateware_build_id", golden::hex_word(identify->build_id, 32)},
                        {"weights_crc", model ? json(golden::hex_word(identify->weights_crc, 32)) : json()},
                        {"model", model ? "loaded" : "none"},
                        {"protocol", identify->protocol_version}};
      }
      out["model_load"] = model_load.empty() ? json() : json(escape_invalid_utf8(model_load));
      t = telemetry;
      job = running;
      homing_now = homing;
      out["last_run"] = last_run;
      out["estop"] = estop_json();
    }
    RunProgress p;
    if (job) {
      // The run's thread reads the telemetry meanwhile: its newest frame is the board's state now.
      p = job->progress();
      if (p.telemetry) t = p.telemetry;
      out["run"] = {{"played", p.played}, {"planned", p.planned}, {"feed", feed_name(p.feed)}};
    }
    out["state"] = out["estop"]["latched"].get<bool>()   ? "e-stopped"
                   : out["connection"] == "disconnected" ? state_name(HostState::kDisconnected)
                   : t                                   ? state_name(state_of(*t))
                                                         : "unknown";
    if (t) {
      out["description"] = link::describe_state(*t);
      out["fault_bits"] = t->fault_cause;
      out["board_fault_bits"] = t->board_fault;
      out["estop_on_board"] = t->estop;
      out["fault"] = t->has(link::TelemetryFlag::kFault) ? json(link::describe_fault(*t)) : json();
      Referencing referencing = board_referencing(*t);
      // A homing that a fault ended (a board e-stop included: the board forgets it was homing)
      // leaves the board's homed flag from its set-home: not homed by hand, but unfinished.
      const bool interrupted = homing_interrupted && referencing != Referencing::kHomeSwitches;
      if (interrupted) referencing = Referencing::kNone;
      out["homed_by"] = referencing == Referencing::kHomeSwitches ? "reference"
                        : referencing == Referencing::kHand       ? "hand"
                                                                  : "none";
      out["homing_unfinished"] = (interrupted || homing_unfinished(*t)) && !homing_now;
      out["referencing"] = unreferenced_reason(*t);  // "" when homed at the references
      out["board_time_s"] = t->tick / 1e4;
      out["encoder_deg"] = {t->count_deg(0), t->count_deg(1), t->count_deg(2)};
      out["counters"] = {{"bad_frames", t->bad_frames},
                         {"underruns", t->underruns},
                         {"rejected", t->rejected},
                         {"slew_limits", t->slew_limits},
                         {"saturations", t->saturations}};
    }
    return out;
  }

  // Waits for the board thread to take and finish `work`.
  json submit(const std::shared_ptr<Work>& work) {
    if (std::optional<json> busy = enqueue(work)) return *busy;
    return wait_for(work);
  }
  // The work queued for the board thread, or the reply that refuses it (busy).
  std::optional<json> enqueue(const std::shared_ptr<Work>& work) {
    std::lock_guard<std::mutex> lock(mutex);
    if (moves(work->command) && estop_latch.latched) return estop_refusal(work->command);
    if (running || !queue.empty()) return failure(kExitFault, "busy: a run or command is going on (stop it first)");
    queue.push_back(work);
    if (work->job) running = work->job;  // taken by the board thread next
    return std::nullopt;
  }
  static bool moves(const std::string& command) { return command == "home" || command == "enable" || command == "run"; }
  // The refusal of `command` while the e-stop is latched (mutex held).
  json estop_refusal(const std::string& command) const {
    std::string when;
    if (estop_latch.board_time_s) {
      char text[48];
      std::snprintf(text, sizeof text, " at board time %.3f s", *estop_latch.board_time_s);
      when = text;
    }
    json refusal = failure(kExitFault, command + " refused: e-stopped (by the " + estop_latch.source + when +
                                           "); nothing moves until a clear (deltactl host ctl clear-fault, or "
                                           "POST /api/clear, or Clear on the dashboard)");
    refusal["state"] = "e-stopped";
    return refusal;
  }
  // The latch written where a restarted controller finds it (mutex held); a failure to write is
  // said, and the latch holds in this process all the same.
  void keep_latch() const {
    std::ofstream out(estop_file, std::ios::trunc);
    out << estop_json().dump() << '\n';
    if (!out) std::cerr << "host serve: cannot keep the e-stop latch in " << estop_file << " across a restart\n";
  }
  // A latch left by an earlier controller (not cleared before it stopped) holds here too.
  void restore_latch() {
    std::ifstream in(estop_file);
    if (!in) return;
    const json kept = json::parse(in, nullptr, false);
    estop_latch.latched = true;
    estop_latch.source = kept.is_object() && kept.value("source", json()).is_string()
                             ? kept["source"].get<std::string>() + ", before a restart"
                             : std::string("controller before a restart");
    if (kept.is_object() && kept.value("board_time_s", json()).is_number()) {
      estop_latch.board_time_s = kept["board_time_s"].get<double>();
    }
    std::cerr << "host serve: e-stopped (by the " << estop_latch.source << ", " << estop_file
              << "): nothing moves until a clear-fault" << std::endl;
  }
  json estop_json() const {  // mutex held
    return {{"latched", estop_latch.latched},
            {"source", estop_latch.latched ? json(estop_latch.source) : json(nullptr)},
            {"board_time_s", estop_latch.board_time_s ? json(*estop_latch.board_time_s) : json(nullptr)}};
  }
  json wait_for(const std::shared_ptr<Work>& work) {
    std::unique_lock<std::mutex> lock(mutex);
    work_done.wait(lock, [&] { return work->done || shutting_down.load(); });
    return work->done ? work->reply : failure(kExitFault, "the controller is shutting down");
  }

  // The board thread's link: the port, its session (none while disconnected) and its clocks.
  struct BoardLink {
    std::unique_ptr<io::SerialPort> port;
    std::unique_ptr<link::LinkSession> session;
    Clock::time_point last_frame = Clock::now(), last_hold = Clock::now(), next_attempt = Clock::now();
  };

  void disconnect(BoardLink& b, const std::string& why) {
    b.session.reset();
    b.port.reset();
    std::lock_guard<std::mutex> lock(mutex);
    connection = "disconnected";
    note = why;
    telemetry.reset();
    holding_enabled = false;
  }

  // Opens the port and identifies the board; loads the configured model onto a board without it.
  void connect_board_link(BoardLink& b) {
    try {
      b.port = open_board_port(options.port);
      b.session = std::make_unique<link::LinkSession>(*b.port, host_session_options(options.link_timeout_ms));
      Connected c = connect_board(*b.session);
      // The configured model onto a board without it (a board starts with none: after a
      // power-up, a reset or a flash), with the drives off; a failed load is said and the
      // board stays "mismatch" (runs refused) until the next connection tries again.
      std::string loaded;
      if (c.identify.build_id == kGatewareBuildId && !c.telemetry.has(link::TelemetryFlag::kDriveEnable) &&
          !(board_has_model(c.telemetry) && c.identify.weights_crc == weights_crc(weights.network))) {
        try {
          const ModelLoaded load = load_board_model(*b.session, c, weights.network, b.port->name());
          c.identify = b.session->identify();
          c.telemetry = load.telemetry;
          loaded = "; loaded its model " + golden::hex_word(load.crc, 32) + " (" + std::to_string(load.frames) +
                   " frames in " + std::to_string(static_cast<int>(load.seconds * 1000 + 0.5)) + " ms)";
          std::cerr << "host serve: " << b.port->name() << ": loaded the model " << options.weights_path << " ("
                    << golden::hex_word(load.crc, 32) << "), " << load.frames << " frames in "
                    << static_cast<int>(load.seconds * 1000 + 0.5) << " ms" << std::endl;
        } catch (const HostFailure& error) {
          if (error.code() == kExitLinkLost) throw;
          loaded = std::string("; the model's load failed: ") + error.what();
          std::cerr << "host serve: " << error.what() << std::endl;
          if (b.session->last_telemetry()) c.telemetry = *b.session->last_telemetry();
        }
      }
      std::string mismatch;
      try {
        check_board_identity(c, weights, options.weights_path, b.port->name());
      } catch (const HostFailure& error) {
        mismatch = error.what();
      }
      std::lock_guard<std::mutex> lock(mutex);
      connection = mismatch.empty() ? "connected" : "mismatch";
      note = (mismatch.empty() ? std::string("identified") : mismatch) + loaded;
      model_load = loaded.empty() ? model_load : loaded.substr(2);
      identify = c.identify;
      telemetry = c.telemetry;
      port_name = b.port->name();
      b.last_frame = Clock::now();
    } catch (const HostFailure& error) {
      disconnect(b, error.what());
    } catch (const link::LinkError& error) {
      disconnect(b, error.what());
    }
  }

  // The next piece of work from the queue, executed on the board (false: none queued).
  bool run_queued_work(BoardLink& b) {
    std::shared_ptr<Work> work;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!queue.empty()) {
        work = queue.front();
        queue.pop_front();
        if (work->job) running = work->job;
      }
    }
    if (!work) return false;
    json reply;
    try {
      reply = execute(*b.session, *work);
    } catch (const HostFailure& error) {
      reply = failure(error.code(), error.what());
    } catch (const link::LinkError& error) {
      reply = failure(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
    } catch (const std::exception& error) {
      reply = failure(kExitFailure, error.what());
    }
    finish(work, reply, b.session.get());
    if (reply.value("exit", 0) == kExitLinkLost) disconnect(b, reply.value("error", std::string("link lost")));
    b.last_frame = Clock::now();
    return true;
  }

  // Idle: keep reading the telemetry (the board sends it at 1 kHz); after `enable`, keep the
  // drives' hold alive (idempotent; it feeds the board's 50 ms watchdog). False: the link was lost.
  bool idle_turn(BoardLink& b) {
    try {
      b.session->poll_frames();
      std::optional<link::TelemetryPayload> newest;
      while (auto frame = b.session->take_telemetry()) newest = *frame;
      if (newest) {
        observed(*newest);
        b.last_frame = Clock::now();
        std::lock_guard<std::mutex> lock(mutex);
        telemetry = newest;
        if (!newest->has(link::TelemetryFlag::kDriveEnable)) holding_enabled = false;
      } else if (Clock::now() - b.last_frame > std::chrono::milliseconds(options.link_timeout_ms)) {
        disconnect(b, "no telemetry for " + std::to_string(options.link_timeout_ms) + " ms: link lost");
        return false;
      }
      bool keep_alive = false;
      {
        std::lock_guard<std::mutex> lock(mutex);
        keep_alive = holding_enabled;
      }
      if (keep_alive && Clock::now() - b.last_hold >= std::chrono::milliseconds(10)) {
        b.session->send_command(link::Command::kHold);
        b.last_hold = Clock::now();
      }
    } catch (const link::LinkError& error) {
      disconnect(b, std::string("link lost: ") + error.what());
      return false;
    }
    return true;
  }

  // ---------------------------------------------------------------------------------------------
  void board_thread() {
    BoardLink b;
    while (!shutting_down.load()) {
      beat();
      try {
        if (!b.session) {
          if (Clock::now() < b.next_attempt) {
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            fail_queued("the board is not connected: " + note_copy());
            continue;
          }
          b.next_attempt = Clock::now() + std::chrono::seconds(1);
          connect_board_link(b);
          continue;
        }
        if (run_queued_work(b)) continue;
        if (!idle_turn(b)) continue;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      } catch (const std::exception& error) {  // nothing may end this thread but the shutdown
        disconnect(b, std::string("error: ") + error.what());
      }
    }
    // Shutting down: whatever the state, the drives off (a run has stopped itself by now).
    if (b.session) {
      try {
        if (b.session->last_telemetry() && b.session->last_telemetry()->has(link::TelemetryFlag::kDriveEnable)) {
          b.session->disable();
        }
      } catch (const link::LinkError&) {
      }
    }
    fail_queued("the controller is shutting down");
  }

  // The end of a piece of work: its reply, the run (if any) no longer busy.
  void finish(const std::shared_ptr<Work>& work, const json& reply, link::LinkSession* session) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (work->job) {
        if (running == work->job) running.reset();
        last_run = reply;
      }
      if (session && session->last_telemetry()) telemetry = *session->last_telemetry();
      work->reply = reply;
      work->done = true;
    }
    work_done.notify_all();
  }

  std::string note_copy() {
    std::lock_guard<std::mutex> lock(mutex);
    return note;
  }

  void fail_queued(const std::string& why) {
    std::deque<std::shared_ptr<Work>> failed;
    {
      std::lock_guard<std::mutex> lock(mutex);
      failed.swap(queue);
    }
    for (auto& work : failed) finish(work, failure(kExitLinkLost, why), nullptr);
  }

  json execute(link::LinkSession& session, Work& work) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (moves(work.command) && estop_latch.latched) return estop_refusal(work.command);
      if (connection == "mismatch" && (work.command == "run" || work.command == "enable")) {
        return failure(kExitMismatch, note);
      }
      holding_enabled = false;  // whatever comes now ends the idle hold (a run refuses drives on)
    }
    const std::string name = port_name;
    if (work.command == "home") {
      const link::TelemetryPayload t = fresh_telemetry(session);
      if (t.has(link::TelemetryFlag::kDriveEnable)) {
        return failure(kExitFault, name + ": the drives are on; home only with the drives off");
      }
      // Against the references (homing.hpp): the drives move the arms to their home switches. A
      // stop, an estop or the shutdown ends it at the next telemetry frame with the drives off.
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (estop_latch.latched) return estop_refusal(work.command);  // an estop since the check above
        if (shutting_down.load()) return failure(kExitFault, "home refused: the controller is shutting down");
        homing = true;
        homing_stop = 0;
      }
      struct Done {
        Impl& s;
        ~Done() {
          std::lock_guard<std::mutex> lock(s.mutex);
          s.homing = false;
        }
      } done{*this};
      try {
        home_at_references(
            session, weights, homing_options(),
            [](const std::string& line) { std::cerr << "host serve: " << line << std::endl; }, &homing_stop);
        std::lock_guard<std::mutex> lock(mutex);
        homing_interrupted = false;
      } catch (const std::exception&) {
        std::lock_guard<std::mutex> lock(mutex);
        homing_interrupted = true;
        if (homing_stop == 0) throw;
        throw HostFailure(kExitFault, "home stopped (" + std::string(estop_latch.latched ? "e-stop" : "stop") +
                                          "): drives off, not homed");
      }
    } else if (work.command == "enable") {
      // Drives on, holding the arms where they are; the idle loop keeps the hold alive.
      session.enable();
      try {
        session.hold();
      } catch (const link::LinkError&) {
        try {
          session.disable();
        } catch (const link::LinkError&) {
          session.send_command(link::Command::kDisable);
        }
        throw;
      }
      std::lock_guard<std::mutex> lock(mutex);
      holding_enabled = true;
    } else if (work.command == "load") {
      // The configured model onto the board again (as at a connection), the drives off.
      Connected c;
      c.identify = session.identify();
      c.telemetry = fresh_telemetry(session);
      const ModelLoaded load = load_board_model(session, c, weights.network, name);
      const link::IdentifyPayload now = session.identify();
      const std::string said = "loaded its model " + golden::hex_word(load.crc, 32) + " (" +
                               std::to_string(load.frames) + " frames in " +
                               std::to_string(static_cast<int>(load.seconds * 1000 + 0.5)) + " ms)";
      std::cerr << "host serve: " << name << ": " << said << std::endl;
      std::lock_guard<std::mutex> lock(mutex);
      identify = now;
      model_load = said;
      connection = "connected";  // load_board_model checked the gateware and the model's CRC
      note = "identified; " + said;
      json reply = success();
      reply["weights_crc"] = golden::hex_word(load.crc, 32);
      reply["frames"] = load.frames;
      reply["seconds"] = load.seconds;
      reply["state"] = state_name(state_of(*session.last_telemetry()));
      return reply;
    } else if (work.command == "disable") {
      session.disable();
    } else if (work.command == "board-estop") {
      // The e-stop's own work: the board latches its e-stop (drives off, a clear-fault needed), and
      // a disable follows for a board whose gateware has no e-stop command.
      try {
        session.estop();
      } catch (const link::LinkError&) {
        session.disable();
      }
    } else if (work.command == "clear-fault") {
      // The explicit clear: the board's latched fault (if any), then the e-stop latch.
      if (fresh_telemetry(session).has(link::TelemetryFlag::kFault)) {
        const link::TelemetryPayload cleared = session.clear_fault();
        // Counts a fault left unreferenced (a homing it ended, or set by hand) stay provisional:
        // homing again with the drives off (no motion) keeps the board saying so after the clear.
        if (cleared.homed_unreferenced()) {
          session.command(link::Command::kHomeStart,
                          [](const link::TelemetryPayload& f) { return f.has(link::TelemetryFlag::kHoming); });
        }
      }
      std::lock_guard<std::mutex> lock(mutex);
      if (estop_latch.latched) std::cerr << "host serve: e-stop cleared" << std::endl;
      estop_latch = EstopLatch{};
      std::error_code ignored;
      std::filesystem::remove(estop_file, ignored);
    } else if (work.command == "run") {
      const link::TelemetryPayload t0 = fresh_telemetry(session);
      static const volatile std::sig_atomic_t no_signal = 0;
      if (dashboard) work.job->observe([this](const TelemetryRecord& r) { dashboard->on_telemetry(r); });
      const RunOutcome outcome = work.job->execute(
          session, name, t0, stop_signal ? *stop_signal : no_signal, [](const std::string&) {},
          [this](const RunProgress&) { beat(); });
      std::string error = outcome.error;
      if (error.empty() && outcome.code > 128) {
        error = "stopped by signal " + std::to_string(outcome.code - 128) + " to the controller (at rest, drives off)";
      }
      json reply = {{"ok", outcome.code == 0},
                    {"exit", outcome.code},
                    {"outcome", outcome.outcome},
                    {"error", escape_invalid_utf8(error)},
                    {"summary", escape_invalid_utf8(outcome.summary)},
                    {"record", escape_invalid_utf8(outcome.record)},
                    {"played", outcome.played},
                    {"planned", outcome.planned}};
      return reply;
    }
    json reply = success();
    reply["state"] = state_name(state_of(*session.last_telemetry()));
    return reply;
  }

  // ---------------------------------------------------------------------------------------------
  void client_thread(int fd) {
    try {
      std::string buffer;
      char chunk[4096];
      auto last_request = Clock::now();
      while (!shutting_down.load()) {
        if (Clock::now() - last_request > std::chrono::seconds(kClientIdleSeconds)) break;
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, 200) <= 0) continue;
        const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
        if (n <= 0) break;
        buffer.append(chunk, static_cast<std::size_t>(n));
        std::size_t end;
        bool open = true;
        while (open && (end = buffer.find('\n')) != std::string::npos) {
          const std::string line = buffer.substr(0, end);
          buffer.erase(0, end + 1);
          if (!line.empty()) open = answer(fd, line);
          last_request = Clock::now();
        }
        if (!open) break;
        if (buffer.size() > 65536) {
          send_line(fd, failure(kExitBadInput, "request line longer than 64 KiB"));
          break;
        }
      }
    } catch (const std::exception&) {  // a client never ends the controller
    }
    ::close(fd);
  }

  // ---------------------------------------------------------------------------------------------
  // Accepting. A client gets its own thread, up to kMaxClients at once. One beyond them waits on the
  // accepting thread's poll set, at most kOverflowWaitMs, for its request line: a stop, an e-stop or
  // a feed hold is always carried out (idle or silent clients must never keep an operator from
  // stopping the robot, however many there are); anything else is answered busy.
  static constexpr int kOverflowWaitMs = 100;
  static constexpr std::size_t kMaxOverflow = 512;
  struct Overflow {
    int fd;
    std::string line;
    Clock::time_point deadline;
    bool answered = false;
  };

  void admit(const std::shared_ptr<Impl>& shared, int client, std::vector<Overflow>& overflow) {
    // A client that does not read its replies cannot hold a thread for long.
    const timeval send_timeout{2, 0};
    ::setsockopt(client, SOL_SOCKET, SO_SNDTIMEO, &send_timeout, sizeof send_timeout);
    bool admitted = false;
    {
      std::lock_guard<std::mutex> lock(clients_mutex);
      if (clients < kMaxClients) {
        ++clients;
        admitted = true;
      }
    }
    if (!admitted) {
      if (overflow.size() >= kMaxOverflow) {
        send_line(client, overflow_busy());
        ::close(client);
      } else {
        overflow.push_back({client, std::string(), Clock::now() + std::chrono::milliseconds(kOverflowWaitMs)});
      }
      return;
    }
    ::fcntl(client, F_SETFL, ::fcntl(client, F_GETFL) & ~O_NONBLOCK);  // its thread polls and blocks
    try {
      std::thread([shared, client] {
        shared->client_thread(client);
        std::lock_guard<std::mutex> lock(shared->clients_mutex);
        --shared->clients;
        shared->clients_gone.notify_all();
      }).detach();
    } catch (const std::system_error&) {  // no thread to be had now: refused, not fatal
      ::close(client);
      std::lock_guard<std::mutex> lock(clients_mutex);
      --clients;
    }
  }

  json overflow_busy() const {
    return failure(kExitFault, "busy: " + std::to_string(kMaxClients) +
                                   " clients are connected; try again later (stop, estop and hold are always taken)");
  }

  // What an overflow client has sent; its line answered when complete.
  void read_overflow(const std::shared_ptr<Impl>& shared, Overflow& o) {
    char chunk[4096];
    const ssize_t n = ::recv(o.fd, chunk, sizeof chunk, 0);
    if (n <= 0) {
      o.answered = true;  // gone (or nothing): closed by settle_overflow
      return;
    }
    o.line.append(chunk, static_cast<std::size_t>(n));
    const std::size_t end = o.line.find('\n');
    if (end == std::string::npos) {
      if (o.line.size() > sizeof chunk) {
        send_line(o.fd, overflow_busy());
        o.answered = true;
      }
      return;
    }
    o.answered = true;
    json refusal;
    const std::optional<json> request = parse_request(o.line.substr(0, end), refusal);
    const std::string command = request ? (*request)["cmd"].get<std::string>() : std::string();
    if (command != "stop" && command != "estop" && command != "hold") {
      send_line(o.fd, overflow_busy());
      return;
    }
    // An e-stop is latched and its disable queued now, not after a thread starts.
    const std::shared_ptr<Work> begun = command == "estop" ? estop_begin("socket") : nullptr;
    // The reply (an e-stop's waits for the drives off) on a thread of its own: the accepting thread goes on.
    const int fd = ::dup(o.fd);
    if (fd < 0) return;
    const json asked = *request;
    try {
      std::thread([shared, fd, asked, begun] {
        const int flags = ::fcntl(fd, F_GETFL);
        ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
        send_line(fd, begun ? shared->estop_reply(begun) : shared->reply_to(asked));
        ::close(fd);
      }).detach();
    } catch (const std::system_error&) {
      ::close(fd);
    }
  }

  // Overflow clients answered, gone or past their time: closed (the late ones told busy).
  void settle_overflow(std::vector<Overflow>& overflow) {
    const auto now = Clock::now();
    for (auto it = overflow.begin(); it != overflow.end();) {
      if (!it->answered && now >= it->deadline) {
        send_line(it->fd, overflow_busy());
        it->answered = true;
      }
      if (it->answered) {
        ::close(it->fd);
        it = overflow.erase(it);
      } else {
        ++it;
      }
    }
  }

  // The request as a JSON object with a string "cmd", or the reply that refuses it.
  static std::optional<json> parse_request(const std::string& line, json& refusal) {
    json request;
    try {
      request = json::parse(line);
    } catch (const json::exception& error) {
      refusal = failure(kExitBadInput, std::string("not JSON: ") + error.what());
      return std::nullopt;
    }
    if (!request.is_object() || !request.contains("cmd") || !request["cmd"].is_string()) {
      refusal = failure(kExitBadInput, "a request is {\"cmd\": ...}");
      return std::nullopt;
    }
    return request;
  }

  // Answers one request line on a client's socket; false when the client is gone.
  bool answer(int fd, const std::string& line) {
    json refusal;
    const std::optional<json> request = parse_request(line, refusal);
    if (!request) return send_line(fd, refusal);
    if ((*request)["cmd"] == "run") {
      const auto wait = request->find("wait");
      if (wait == request->end() || (wait->is_boolean() && wait->get<bool>())) return answer_run_waiting(fd, *request);
    }
    return send_line(fd, reply_to(*request));
  }

  // Every request but a run that waits: the reply.
  json reply_to(const json& request, const std::string& source = "socket") {
    try {
      const std::string command = request["cmd"];
      if (command == "status") return status();
      if (command == "hold" || command == "resume" || command == "stop") {
        std::shared_ptr<RunJob> job;
        {
          std::lock_guard<std::mutex> lock(mutex);
          job = running;
        }
        const FeedRequest feed = command == "hold"     ? FeedRequest::kHold
                                 : command == "resume" ? FeedRequest::kResume
                                                       : FeedRequest::kStop;
        if (!job || !job->request(feed)) {
          if (command == "stop" && stop_homing()) {
            json reply = success();
            reply["event"] = "stop: the homing ends, drives off";
            return reply;
          }
          return failure(kExitFault, "no run is streaming");
        }
        return success();
      }
      if (command == "estop") return estop(source);
      if (command == "home" || command == "enable" || command == "disable" || command == "clear-fault" ||
          command == "load") {
        auto work = std::make_shared<Work>();
        work->command = command;
        return submit(work);
      }
      if (command == "run") {
        std::shared_ptr<Work> work;
        json refused;
        if (!make_run(request, work, refused)) return refused;
        if (std::optional<json> busy = enqueue(work)) return *busy;
        json reply = success();
        reply["event"] = "queued";
        reply["record"] = escape_invalid_utf8(work->record);
        return reply;
      }
      return failure(kExitBadInput,
                     "unknown command '" + command +
                         "' (status, run, hold, resume, stop, estop, home, enable, disable, clear-fault, load)");
    } catch (const std::exception& error) {
      return failure(kExitFailure, error.what());
    }
  }

  // The e-stop: latched first (from now on nothing that moves is taken, from any client), then the
  // drives off ahead of anything queued: a streaming run's loop disables at its next cycle, a
  // homing ends at its next telemetry frame, work queued that would move is refused, and a disable
  // goes first in the board thread's queue. Answered when that disable is done (the drives off).
  json estop(const std::string& source) { return estop_reply(estop_begin(source)); }
  // The e-stop's answer once its disable (estop_begin's work) is done, or 3 s have passed.
  json estop_reply(const std::shared_ptr<Work>& work) {
    std::unique_lock<std::mutex> lock(mutex);
    work_done.wait_for(lock, std::chrono::seconds(3), [&] { return work->done || shutting_down.load(); });
    json reply = work->done ? work->reply
                            : failure(kExitLinkLost,
                                      "estop: the drives' disable was not confirmed within 3 s (the board's "
                                      "watchdog turns them off 250 ms after the last frame); the e-stop stays latched");
    if (work->done && reply.value("ok", false)) reply["event"] = "estop: drives off; latched until a clear-fault";
    reply["estop"] = estop_json();
    reply["state"] = "e-stopped";
    return reply;
  }
  // The part of the e-stop that does not wait (the signal's, on the accepting thread): the disable queued.
  std::shared_ptr<Work> estop_begin(const std::string& source) {
    std::shared_ptr<RunJob> job;
    std::deque<std::shared_ptr<Work>> refused;
    auto work = std::make_shared<Work>();
    work->command = "board-estop";
    {
      std::lock_guard<std::mutex> lock(mutex);
      job = running;
    }
    // The board's time now: a streaming run's newest frame, else the board thread's.
    std::optional<link::TelemetryPayload> now = job ? job->progress().telemetry : std::nullopt;
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!now) now = telemetry;
      if (!estop_latch.latched) {
        estop_latch.latched = true;
        estop_latch.source = source;
        estop_latch.board_time_s = now ? std::optional<double>(now->tick / 1e4) : std::optional<double>();
        std::cerr << "host serve: e-stop by the " << source << " (latched until a clear-fault)" << std::endl;
        keep_latch();
      }
      job = running;
      for (auto it = queue.begin(); it != queue.end();) {
        if (moves((*it)->command)) {
          refused.push_back(*it);
          it = queue.erase(it);
        } else {
          ++it;
        }
      }
      if (homing) homing_stop = SIGUSR1;
      queue.push_front(work);
    }
    for (auto& w : refused) finish(w, estop_refusal_locked(w->command), nullptr);
    if (job) job->request(FeedRequest::kEstop);
    return work;
  }
  json estop_refusal_locked(const std::string& command) {
    std::lock_guard<std::mutex> lock(mutex);
    return estop_refusal(command);
  }

  // A stop while the board thread homes: the homing ends at its next frame, drives off.
  bool stop_homing() {
    std::lock_guard<std::mutex> lock(mutex);
    if (!homing) return false;
    homing_stop = SIGINT;
    return true;
  }

  // The service's homing: every frame it reads is the board's state now (status, the e-stop's
  // board time), feeds the dashboard and proves the board thread alive (systemd's watchdog).
  HomingOptions homing_options() {
    HomingOptions o;
    o.on_telemetry = [this](const link::TelemetryPayload& t) {
      beat();
      observed(t);
      std::lock_guard<std::mutex> lock(mutex);
      telemetry = t;
    };
    return o;
  }

  // One control-socket request through the same dispatch (a run is queued: no "wait"), for the dashboard.
  json dispatch(const json& request) {
    json refusal;
    const std::optional<json> checked = parse_request(request.dump(), refusal);
    return checked ? reply_to(*checked, "dashboard") : refusal;
  }

  // A run request checked whole (types, ranges, the trajectory, the recording's name); false with
  // the refusal otherwise.
  bool make_run(const json& request, std::shared_ptr<Work>& work, json& refused) {
    RunRequest run;
    run.link_timeout_ms = options.link_timeout_ms;
    run.limits = options.limits;
    run.following_error_deg = options.following_error_deg;
    const auto trajectory = request.find("trajectory");
    const auto duration = request.find("duration");
    const auto record = request.find("record");
    const auto wait = request.find("wait");
    const std::string usage = " (run needs \"trajectory\": a string; optional \"duration\": seconds, 0 < S <= " +
                              std::to_string(static_cast<int>(kMaxRunSeconds)) +
                              ", \"record\": a file name, \"wait\": true or false)";
    if (trajectory == request.end() || !trajectory->is_string() || trajectory->get<std::string>().empty()) {
      refused = failure(kExitBadInput, "run: \"trajectory\" missing or not a string" + usage);
      return false;
    }
    if (duration != request.end() &&
        (!duration->is_number() || !(duration->get<double>() >= 0.0 && duration->get<double>() <= kMaxRunSeconds))) {
      refused = failure(kExitBadInput, "run: \"duration\" is not a number of seconds in range" + usage);
      return false;
    }
    if (record != request.end() && !record->is_string()) {
      refused = failure(kExitBadInput, "run: \"record\" is not a string" + usage);
      return false;
    }
    if (wait != request.end() && !wait->is_boolean()) {
      refused = failure(kExitBadInput, "run: \"wait\" is not true or false" + usage);
      return false;
    }
    run.trajectory = trajectory->get<std::string>();
    run.duration_s = duration == request.end() ? 0.0 : duration->get<double>();
    const std::string name = record == request.end() ? std::string() : record->get<std::string>();
    run.record_mode = name.empty() ? RecordMode::kNewNumbered : RecordMode::kNew;
    work = std::make_shared<Work>();
    work->command = "run";
    try {
      run.record = confined_record_path(record_folder, name, timestamp());
      work->job = std::make_shared<RunJob>(weights, run);
    } catch (const HostFailure& error) {
      refused = failure(error.code(), error.what());
      return false;
    } catch (const InputError& error) {
      refused = failure(kExitBadInput, error.what());
      return false;
    } catch (const std::invalid_argument& error) {
      refused = failure(kExitBadInput, run.trajectory + ": " + error.what());
      return false;
    } catch (const std::exception& error) {  // std::bad_alloc and the like: refused, serve goes on
      refused = failure(kExitFailure, run.trajectory + ": " + error.what());
      return false;
    }
    work->record = work->job->record_path();
    return true;
  }

  // A run that reports its progress to the client, and stops at rest if the client goes away.
  bool answer_run_waiting(int fd, const json& request) {
    std::shared_ptr<Work> work;
    json refused;
    if (!make_run(request, work, refused)) return send_line(fd, refused);
    // Busy is answered before anything says the run started.
    if (std::optional<json> busy = enqueue(work)) return send_line(fd, *busy);
    std::atomic<bool> finished{false};
    json reply;
    std::thread waiter([&] {
      try {
        reply = wait_for(work);
      } catch (const std::exception& error) {
        reply = failure(kExitFailure, error.what());
      }
      finished.store(true);
    });
    bool open = send_line(fd, json{{"ok", true}, {"event", "started"}, {"record", escape_invalid_utf8(work->record)}});
    bool stop_asked = false;
    auto next = Clock::now() + std::chrono::seconds(1);
    while (!finished.load()) {
      pollfd p{fd, 0, 0};
      ::poll(&p, 1, 20);
      if (p.revents & (POLLHUP | POLLERR)) open = false;  // the client closed its socket
      if (open && Clock::now() >= next) {
        const RunProgress progress = work->job->progress();
        open = send_line(fd, json{{"event", "progress"},
                                  {"played", progress.played},
                                  {"planned", progress.planned},
                                  {"feed", feed_name(progress.feed)}});
        next += std::chrono::seconds(1);
      }
      if (!open && !stop_asked) {  // the client went away: its run ends at rest
        work->job->request(FeedRequest::kStop);
        stop_asked = true;
      }
    }
    waiter.join();
    reply["event"] = "finished";
    return send_line(fd, reply) && open;
  }
};

HostServer::HostServer(const ServeOptions& options) : impl_(std::make_shared<Impl>()) {
  impl_->options = options;
  impl_->weights = golden::read_board_weights(options.weights_path);
  std::error_code error;
  std::filesystem::create_directories(options.record_folder, error);
  impl_->record_folder = std::filesystem::canonical(options.record_folder, error).string();
  if (error) {
    throw HostFailure(kExitBadInput, "--record-folder '" + options.record_folder + "': " + error.message());
  }
  impl_->estop_file = impl_->record_folder + "/.estop-latched";
  impl_->restore_latch();
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (options.socket_path.empty() || options.socket_path.size() >= sizeof address.sun_path) {
    throw HostFailure(kExitBadInput, "--socket '" + options.socket_path + "': empty or longer than " +
                                         std::to_string(sizeof address.sun_path - 1) + " characters");
  }
  std::copy(options.socket_path.begin(), options.socket_path.end(), address.sun_path);
  struct stat present {};
  if (::lstat(options.socket_path.c_str(), &present) == 0 && !S_ISSOCK(present.st_mode)) {
    throw HostFailure(kExitBadInput, "--socket " + options.socket_path +
                                         ": exists and is not a socket; not replaced (name a new path)");
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  // A socket file nobody answers on is left over from a controller that died: replaced.
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) {
    ::close(fd);
    throw HostFailure(kExitFailure, options.socket_path + ": another controller is serving there");
  }
  if (S_ISSOCK(present.st_mode)) ::unlink(options.socket_path.c_str());
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 || ::listen(fd, SOMAXCONN) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw HostFailure(kExitFailure, options.socket_path + ": cannot listen: " + why);
  }
  ::chmod(options.socket_path.c_str(), 0660);
  struct stat bound {};
  if (::lstat(options.socket_path.c_str(), &bound) == 0) {
    impl_->socket_device = bound.st_dev;
    impl_->socket_inode = bound.st_ino;
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);  // accepting drains the backlog, never blocks
  impl_->listen_fd = fd;
  if (!options.http.empty()) {
    try {
      DashboardOptions http;
      parse_http_address(options.http, http);
      http.token_file = options.http_token_file;
      http.record_folder = options.record_folder;
      Impl* s = impl_.get();
      impl_->dashboard = std::make_unique<Dashboard>(
          http,
          DashboardBackend{[s] { return s->status(); }, [s](const json& request) { return s->dispatch(request); }});
    } catch (...) {
      ::close(fd);
      impl_->listen_fd = -1;
      ::unlink(options.socket_path.c_str());
      throw;
    }
  }
}

void HostServer::set_estop_signal(const volatile std::sig_atomic_t* count) { impl_->estop_signal = count; }

std::string HostServer::dashboard_url() const { return impl_->dashboard ? impl_->dashboard->url() : ""; }

HostServer::~HostServer() {
  if (impl_->listen_fd >= 0) {
    ::close(impl_->listen_fd);
    struct stat present {};
    if (::lstat(impl_->options.socket_path.c_str(), &present) == 0 && S_ISSOCK(present.st_mode) &&
        present.st_dev == impl_->socket_device && present.st_ino == impl_->socket_inode) {
      ::unlink(impl_->options.socket_path.c_str());  // ours still: another's is left alone
    }
  }
}

std::string HostServer::handle(const std::string& request_line) {
  json refusal;
  const std::optional<json> request = Impl::parse_request(request_line, refusal);
  return reply_line(request ? impl_->reply_to(*request) : refusal);
}

int HostServer::run(const volatile std::sig_atomic_t& stop_signal) {
  const std::shared_ptr<Impl> shared = impl_;
  Impl& s = *shared;
  s.stop_signal = &stop_signal;
  s.beat();
  std::thread board([&s] { s.board_thread(); });
  if (s.dashboard) s.dashboard->start();
  notify_systemd("READY=1\nSTATUS=serving on " + s.options.socket_path);
  std::int64_t watchdog_us = 0;
  if (const char* usec = std::getenv("WATCHDOG_USEC")) watchdog_us = std::atoll(usec);
  auto next_ping = Clock::now();
  std::string last_status;
  std::sig_atomic_t estops_seen = s.estop_signal ? *s.estop_signal : 0;
  std::vector<Impl::Overflow> overflow;
  while (stop_signal == 0) {
    if (s.estop_signal && *s.estop_signal != estops_seen) {  // SIGUSR1: the e-stop, latched
      estops_seen = *s.estop_signal;
      s.estop_begin("signal");
    }
    // The listening socket and every client beyond kMaxClients still owing its line, in one poll:
    // silent connections wait side by side, never one after another.
    std::vector<pollfd> fds{{s.listen_fd, POLLIN, 0}};
    for (const Impl::Overflow& o : overflow) fds.push_back({o.fd, POLLIN, 0});
    if (::poll(fds.data(), fds.size(), 20) > 0) {
      for (std::size_t i = 1; i < fds.size(); ++i) {
        if (fds[i].revents != 0) s.read_overflow(shared, overflow[i - 1]);
      }
      if (fds[0].revents & POLLIN) {
        for (int accepted = 0; accepted < 64; ++accepted) {  // the whole backlog, a bounded batch
          const int client = ::accept4(s.listen_fd, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
          if (client < 0) break;
          s.admit(shared, client, overflow);
        }
      }
    }
    s.settle_overflow(overflow);
    const auto now = Clock::now();
    if (watchdog_us > 0 && now >= next_ping) {
      // Only while the board thread goes round its loop (or a run reports progress).
      const auto age = now.time_since_epoch().count() - s.heartbeat_ns.load();
      if (age < watchdog_us * 1000 / 2) notify_systemd("WATCHDOG=1");
      next_ping = now + std::chrono::microseconds(watchdog_us / 4);
    }
    const json status = s.status();
    const std::string line = "STATUS=" + status.value("state", std::string()) + " (" +
                             status.value("connection", std::string()) + ": " + status.value("note", std::string()) +
                             ")";
    if (line != last_status) {
      notify_systemd(line);
      last_status = line;
    }
  }
  notify_systemd("STOPPING=1");
  // A run sees the same signal and stops at rest (within about 1 s); the board thread then
  // disables and ends. Bounded: after 5 s the shutdown goes on (the board's watchdog stops the torque).
  const auto give_up = Clock::now() + std::chrono::seconds(5);
  for (Impl::Overflow& o : overflow) ::close(o.fd);
  overflow.clear();
  for (;;) {
    s.stop_homing();  // a homing ends at its next frame, drives off
    {
      std::lock_guard<std::mutex> lock(s.mutex);
      if (!s.running && !s.homing) break;
      if (s.running) s.running->request(FeedRequest::kStop);  // a queued run must not start now
    }
    if (Clock::now() > give_up) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (s.dashboard) s.dashboard->stop();
  s.shutting_down.store(true);
  s.work_done.notify_all();
  board.join();
  // Clients see the shutdown within 200 ms; the detached threads share Impl, so one still blocked
  // (a slow file system) is left to the process's exit.
  std::unique_lock<std::mutex> lock(s.clients_mutex);
  s.clients_gone.wait_for(lock, std::chrono::seconds(3), [&s] { return s.clients == 0; });
  return kExitOk;
}

}  // namespace delta::controller

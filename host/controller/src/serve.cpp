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
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "delta/board_facts.hpp"
#include "delta/controller/dashboard.hpp"
#include "delta/controller/homing.hpp"
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
constexpr double kCountDeg = board::kEncoderCountMicrodeg * 1e-6;

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
// only inside it (its folder resolved: links cannot lead out); "" takes a new run-TIME.csv there.
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
                     "no folder " + asked.parent_path().string() + " (the controller makes none: name a file in " +
                         folder + ", or in a folder that is there)");
  }
  if (inside.compare(0, folder.size() + 1, folder + "/") != 0) {
    throw InputError(
        name, 0,
        "recordings are written in the controller's recordings folder " + folder + " (a plain file name goes there)");
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

  // ---- the board thread's view, for status (guarded by mutex) ----
  std::mutex mutex;
  std::string connection = "disconnected";  // disconnected | connected | mismatch
  std::string note = "not yet connected";
  std::optional<link::IdentifyPayload> identify;
  std::optional<link::TelemetryPayload> telemetry;
  std::string port_name;
  json last_run;                    // null until a run ended
  std::shared_ptr<RunJob> running;  // queued or running
  bool holding_enabled = false;     // drives on by `enable`: the idle loop keeps the link alive
  std::atomic<std::int64_t> heartbeat_ns{0};

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
        out["board"] = {{"gateware_build_id", golden::hex_word(identify->build_id, 32)},
                        {"weights_crc", golden::hex_word(identify->weights_crc, 32)},
                        {"protocol", identify->protocol_version}};
      }
      t = telemetry;
      job = running;
      out["last_run"] = last_run;
    }
    RunProgress p;
    if (job) {
      // The run's thread reads the telemetry meanwhile: its newest frame is the board's state now.
      p = job->progress();
      if (p.telemetry) t = p.telemetry;
      out["run"] = {{"played", p.played}, {"planned", p.planned}, {"feed", feed_name(p.feed)}};
    }
    out["state"] = out["connection"] == "disconnected" ? state_name(HostState::kDisconnected)
                   : t                                 ? state_name(state_of(*t))
                                                       : "unknown";
    if (t) {
      out["description"] = link::describe_state(*t);
      out["fault_bits"] = t->fault_cause;
      out["board_time_s"] = t->tick / 1e4;
      out["encoder_deg"] = {t->counts[0] * kCountDeg, t->counts[1] * kCountDeg, t->counts[2] * kCountDeg};
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
    if (running || !queue.empty()) return failure(kExitFault, "busy: a run or command is going on (stop it first)");
    queue.push_back(work);
    return std::nullopt;
  }
  json wait_for(const std::shared_ptr<Work>& work) {
    std::unique_lock<std::mutex> lock(mutex);
    work_done.wait(lock, [&] { return work->done || shutting_down.load(); });
    return work->done ? work->reply : failure(kExitFault, "the controller is shutting down");
  }

  // ---------------------------------------------------------------------------------------------
  void board_thread() {
    std::unique_ptr<io::SerialPort> port;
    std::unique_ptr<link::LinkSession> session;
    auto disconnect = [&](const std::string& why) {
      session.reset();
      port.reset();
      std::lock_guard<std::mutex> lock(mutex);
      connection = "disconnected";
      note = why;
      telemetry.reset();
      holding_enabled = false;
    };
    auto last_frame = Clock::now();
    auto last_hold = Clock::now();
    auto next_attempt = Clock::now();
    while (!shutting_down.load()) {
      beat();
      try {
        if (!session) {
          if (Clock::now() < next_attempt) {
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            fail_queued("the board is not connected: " + note_copy());
            continue;
          }
          next_attempt = Clock::now() + std::chrono::seconds(1);
          try {
            port = open_board_port(options.port);
            session = std::make_unique<link::LinkSession>(*port, host_session_options(options.link_timeout_ms));
            const Connected c = connect_board(*session);
            std::string mismatch;
            try {
              check_board_identity(c.identify, weights, options.weights_path, port->name());
            } catch (const HostFailure& error) {
              mismatch = error.what();
            }
            std::lock_guard<std::mutex> lock(mutex);
            connection = mismatch.empty() ? "connected" : "mismatch";
            note = mismatch.empty() ? "identified" : mismatch;
            identify = c.identify;
            telemetry = c.telemetry;
            port_name = port->name();
            last_frame = Clock::now();
          } catch (const HostFailure& error) {
            disconnect(error.what());
          } catch (const link::LinkError& error) {
            disconnect(error.what());
          }
          continue;
        }
        std::shared_ptr<Work> work;
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (!queue.empty()) {
            work = queue.front();
            queue.pop_front();
            if (work->job) running = work->job;
          }
        }
        if (work) {
          json reply;
          try {
            reply = execute(*session, *work);
          } catch (const HostFailure& error) {
            reply = failure(error.code(), error.what());
          } catch (const link::LinkError& error) {
            reply =
                failure(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
          } catch (const std::exception& error) {
            reply = failure(kExitFailure, error.what());
          }
          finish(work, reply, session.get());
          if (reply.value("exit", 0) == kExitLinkLost) disconnect(reply.value("error", std::string("link lost")));
          last_frame = Clock::now();
          continue;
        }
        // Idle: keep reading the telemetry (the board sends it at 1 kHz); after `enable`, keep the
        // drives' hold alive (idempotent; it feeds the board's 50 ms watchdog).
        try {
          session->poll_frames();
          std::optional<link::TelemetryPayload> newest;
          while (auto frame = session->take_telemetry()) newest = *frame;
          if (newest) {
            observed(*newest);
            last_frame = Clock::now();
            std::lock_guard<std::mutex> lock(mutex);
            telemetry = newest;
            if (!newest->has(link::TelemetryFlag::kDriveEnable)) holding_enabled = false;
          } else if (Clock::now() - last_frame > std::chrono::milliseconds(options.link_timeout_ms)) {
            disconnect("no telemetry for " + std::to_string(options.link_timeout_ms) + " ms: link lost");
            continue;
          }
          bool keep_alive = false;
          {
            std::lock_guard<std::mutex> lock(mutex);
            keep_alive = holding_enabled;
          }
          if (keep_alive && Clock::now() - last_hold >= std::chrono::milliseconds(10)) {
            session->send_command(link::Command::kHold);
            last_hold = Clock::now();
          }
        } catch (const link::LinkError& error) {
          disconnect(std::string("link lost: ") + error.what());
          continue;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      } catch (const std::exception& error) {  // nothing may end this thread but the shutdown
        disconnect(std::string("error: ") + error.what());
      }
    }
    // Shutting down: whatever the state, the drives off (a run has stopped itself by now).
    if (session) {
      try {
        if (session->last_telemetry() && session->last_telemetry()->has(link::TelemetryFlag::kDriveEnable)) {
          session->disable();
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
      // Against the references (homing.hpp): the drives move the arms to their home switches.
      home_at_references(session, weights, HomingOptions{},
                         [](const std::string& line) { std::cerr << "host serve: " << line << std::endl; });
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
    } else if (work.command == "disable") {
      session.disable();
    } else if (work.command == "clear-fault") {
      session.clear_fault();
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

  // A client beyond kMaxClients, on the accepting thread: a stop, an e-stop or a feed hold is
  // always answered (idle clients must never keep an operator from stopping the robot); anything
  // else is refused as busy. Its request line must come within kOverflowWaitMs.
  void answer_overflow(int fd) {
    static constexpr int kOverflowWaitMs = 100;
    const json busy = failure(kExitFault, "busy: " + std::to_string(kMaxClients) +
                                              " clients are connected; try again later (stop, estop and hold are "
                                              "always taken)");
    std::string line;
    char chunk[4096];
    const auto deadline = Clock::now() + std::chrono::milliseconds(kOverflowWaitMs);
    while (line.find('\n') == std::string::npos && line.size() < sizeof chunk) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd p{fd, POLLIN, 0};
      if (left <= 0 || ::poll(&p, 1, static_cast<int>(left)) <= 0) break;
      const ssize_t n = ::recv(fd, chunk, sizeof chunk - line.size(), 0);
      if (n <= 0) break;
      line.append(chunk, static_cast<std::size_t>(n));
    }
    const std::size_t end = line.find('\n');
    json refusal;
    const std::optional<json> request =
        end == std::string::npos ? std::nullopt : parse_request(line.substr(0, end), refusal);
    const std::string command = request ? (*request)["cmd"].get<std::string>() : std::string();
    send_line(fd, command == "stop" || command == "estop" || command == "hold" ? reply_to(*request) : busy);
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
  json reply_to(const json& request) {
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
        if (!job || !job->request(feed)) return failure(kExitFault, "no run is streaming");
        return success();
      }
      if (command == "estop") return estop();
      if (command == "home" || command == "enable" || command == "disable" || command == "clear-fault") {
        auto work = std::make_shared<Work>();
        work->command = command;
        return submit(work);
      }
      if (command == "run") {
        std::shared_ptr<Work> work;
        json refused;
        if (!make_run(request, work, refused)) return refused;
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (running || !queue.empty()) return failure(kExitFault, "busy: a run or command is going on");
          queue.push_back(work);
          running = work->job;  // taken by the board thread next
        }
        json reply = success();
        reply["event"] = "queued";
        reply["record"] = escape_invalid_utf8(work->record);
        return reply;
      }
      return failure(kExitBadInput,
                     "unknown command '" + command +
                         "' (status, run, hold, resume, stop, estop, home, enable, disable, clear-fault)");
    } catch (const std::exception& error) {
      return failure(kExitFailure, error.what());
    }
  }

  // The drives off ahead of anything queued; a run queued but not started never enables.
  json estop() {
    std::shared_ptr<RunJob> job;
    auto work = std::make_shared<Work>();
    work->command = "disable";
    {
      std::lock_guard<std::mutex> lock(mutex);
      job = running;
      if (!job) queue.push_front(work);
    }
    if (job) {
      job->request(FeedRequest::kEstop);
      json reply = success();
      reply["event"] = "estop: the run's loop disables the drives";
      return reply;
    }
    std::unique_lock<std::mutex> lock(mutex);
    work_done.wait_for(lock, std::chrono::seconds(2), [&] { return work->done || shutting_down.load(); });
    return work->done ? work->reply : failure(kExitLinkLost, "estop: the board thread did not answer within 2 s");
  }

  // One control-socket request through the same dispatch (a run is queued: no "wait"), for the dashboard.
  json dispatch(const json& request) {
    json refusal;
    const std::optional<json> checked = parse_request(request.dump(), refusal);
    return checked ? reply_to(*checked) : refusal;
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
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 || ::listen(fd, 64) != 0) {
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
  while (stop_signal == 0) {
    pollfd p{s.listen_fd, POLLIN, 0};
    if (::poll(&p, 1, 100) > 0 && (p.revents & POLLIN)) {
      const int client = ::accept4(s.listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
      if (client >= 0) {
        // A client that does not read its replies cannot hold a thread for long.
        const timeval send_timeout{2, 0};
        ::setsockopt(client, SOL_SOCKET, SO_SNDTIMEO, &send_timeout, sizeof send_timeout);
        bool admitted = false;
        {
          std::lock_guard<std::mutex> lock(s.clients_mutex);
          if (s.clients < kMaxClients) {
            ++s.clients;
            admitted = true;
          }
        }
        if (!admitted) {
          s.answer_overflow(client);
          ::close(client);
        } else {
          try {
            std::thread([shared, client] {
              shared->client_thread(client);
              std::lock_guard<std::mutex> lock(shared->clients_mutex);
              --shared->clients;
              shared->clients_gone.notify_all();
            }).detach();
          } catch (const std::system_error&) {  // no thread to be had now: refused, not fatal
            ::close(client);
            std::lock_guard<std::mutex> lock(s.clients_mutex);
            --s.clients;
          }
        }
      }
    }
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
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(s.mutex);
      if (!s.running) break;
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

// deltactl host serve (see serve.hpp).
#include "delta/controller/serve.hpp"

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
#include <list>
#include <mutex>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "delta/board_facts.hpp"
#include "delta/command.hpp"
#include "delta/controller/dashboard.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/input_error.hpp"

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

json failure(int code, const std::string& error) { return {{"ok", false}, {"exit", code}, {"error", error}}; }
json success() { return {{"ok", true}, {"exit", 0}}; }

bool send_line(int fd, const json& message) {
  const std::string text = message.dump() + "\n";
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::send(fd, text.data() + done, text.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
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
  BoardWeights weights;
  int listen_fd = -1;
  std::atomic<bool> shutting_down{false};
  const volatile std::sig_atomic_t* stop_signal = nullptr;

  // ---- the board thread's view, for status (guarded by mutex) ----
  std::mutex mutex;
  std::string connection = "disconnected";  // disconnected | connected | mismatch
  std::string note = "not yet connected";
  std::optional<link::IdentifyPayload> identify;
  std::optional<link::TelemetryPayload> telemetry;
  std::string port_name;
  json last_run;  // null until a run ended
  std::shared_ptr<RunJob> running;
  std::atomic<std::int64_t> heartbeat_ns{0};

  // ---- work for the board thread ----
  struct Work {
    std::string command;  // home, enable, disable, clear-fault, run
    std::shared_ptr<RunJob> job;
    std::string record;
    std::function<void(const json&)> started;  // run: when the plan is made and the drives are on (or not)
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
    std::lock_guard<std::mutex> lock(mutex);
    json out = success();
    out["connection"] = connection;
    out["note"] = note;
    out["port"] = port_name.empty() ? options.port : port_name;
    out["weights"] = options.weights_path;
    out["weights_crc"] = golden::hex_word(weights_crc(weights.network), 32);
    out["gateware_build_id"] = golden::hex_word(kGatewareBuildId, 32);
    if (identify) {
      out["board"] = {{"gateware_build_id", golden::hex_word(identify->build_id, 32)},
                      {"weights_crc", golden::hex_word(identify->weights_crc, 32)},
                      {"protocol", identify->protocol_version}};
    }
    out["state"] = connection == "disconnected" ? state_name(HostState::kDisconnected)
                   : telemetry                  ? state_name(state_of(*telemetry))
                                                : "unknown";
    if (telemetry) {
      const link::TelemetryPayload& t = *telemetry;
      out["description"] = link::describe_state(t);
      out["fault_bits"] = t.fault_cause;
      out["board_time_s"] = t.tick / 1e4;
      out["encoder_deg"] = {t.counts[0] * kCountDeg, t.counts[1] * kCountDeg, t.counts[2] * kCountDeg};
      out["counters"] = {{"bad_frames", t.bad_frames},
                         {"underruns", t.underruns},
                         {"rejected", t.rejected},
                         {"slew_limits", t.slew_limits},
                         {"saturations", t.saturations}};
    }
    if (running) {
      const RunProgress p = running->progress();
      out["run"] = {{"played", p.played}, {"planned", p.planned}, {"feed", feed_name(p.feed)}};
      if (p.planned > 0) {
        // The streaming thread reads the telemetry meanwhile: the snapshot above is from the start.
        out["state"] = p.feed == FeedState::kHeld ? "holding" : "running";
        out["description"] = std::string("drives on, ") + feed_name(p.feed);
      }
    }
    out["last_run"] = last_run;
    return out;
  }

  // Waits for the board thread to take and finish `work`.
  json submit(const std::shared_ptr<Work>& work) {
    std::unique_lock<std::mutex> lock(mutex);
    if (running || !queue.empty()) return failure(kExitFault, "busy: a run or command is going on (stop it first)");
    queue.push_back(work);
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
    };
    auto last_frame = Clock::now();
    auto next_attempt = Clock::now();
    while (!shutting_down.load()) {
      beat();
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
          reply = failure(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
        } catch (const std::exception& error) {
          reply = failure(kExitFailure, error.what());
        }
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (work->job) {
            running.reset();
            last_run = reply;
          }
          if (session->last_telemetry()) telemetry = *session->last_telemetry();
          work->reply = reply;
          work->done = true;
        }
        work_done.notify_all();
        if (reply.value("exit", 0) == kExitLinkLost) disconnect(reply.value("error", std::string("link lost")));
        last_frame = Clock::now();
        continue;
      }
      // Idle: keep reading the telemetry (the board sends it at 1 kHz).
      try {
        session->poll_frames();
        std::optional<link::TelemetryPayload> newest;
        while (auto frame = session->take_telemetry()) newest = *frame;
        if (newest) {
          observed(*newest);
          last_frame = Clock::now();
          std::lock_guard<std::mutex> lock(mutex);
          telemetry = newest;
        } else if (Clock::now() - last_frame > std::chrono::milliseconds(options.link_timeout_ms)) {
          disconnect("no telemetry for " + std::to_string(options.link_timeout_ms) + " ms: link lost");
          continue;
        }
      } catch (const link::LinkError& error) {
        disconnect(std::string("link lost: ") + error.what());
        continue;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
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

  std::string note_copy() {
    std::lock_guard<std::mutex> lock(mutex);
    return note;
  }

  void fail_queued(const std::string& why) {
    std::lock_guard<std::mutex> lock(mutex);
    if (queue.empty()) return;
    for (auto& work : queue) {
      work->reply = failure(kExitLinkLost, why);
      work->done = true;
    }
    queue.clear();
    work_done.notify_all();
  }

  json execute(link::LinkSession& session, Work& work) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (connection == "mismatch" && (work.command == "run" || work.command == "enable")) {
        return failure(kExitMismatch, note);
      }
    }
    const std::string name = port_name;
    if (work.command == "home") {
      const link::TelemetryPayload t = fresh_telemetry(session);
      if (t.has(link::TelemetryFlag::kDriveEnable)) {
        return failure(kExitFault,
                       name + ": the drives are on; home only with the drives off and the arms on their fixture");
      }
      session.set_home();
    } else if (work.command == "enable") {
      session.enable();
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
      json reply = {{"ok", outcome.code == 0},  {"exit", outcome.code},       {"outcome", outcome.outcome},
                    {"error", error},           {"summary", outcome.summary}, {"record", work.record},
                    {"played", outcome.played}, {"planned", outcome.planned}};
      return reply;
    }
    json reply = success();
    reply["state"] = state_name(state_of(*session.last_telemetry()));
    return reply;
  }

  // ---------------------------------------------------------------------------------------------
  void client_thread(int fd) {
    std::string buffer;
    char chunk[4096];
    while (!shutting_down.load()) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 200) <= 0) continue;
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n <= 0) break;
      buffer.append(chunk, static_cast<std::size_t>(n));
      if (buffer.size() > 65536) {
        send_line(fd, failure(kExitBadInput, "request line longer than 64 KiB"));
        break;
      }
      std::size_t end;
      bool open = true;
      while (open && (end = buffer.find('\n')) != std::string::npos) {
        const std::string line = buffer.substr(0, end);
        buffer.erase(0, end + 1);
        if (!line.empty()) open = answer(fd, line);
      }
      if (!open) break;
    }
    ::close(fd);
  }

  // Answers one request; false when the client is gone.
  bool answer(int fd, const std::string& line) {
    json request;
    try {
      request = json::parse(line);
    } catch (const json::exception& error) {
      return send_line(fd, failure(kExitBadInput, std::string("not JSON: ") + error.what()));
    }
    if (!request.is_object() || !request.contains("cmd") || !request["cmd"].is_string()) {
      return send_line(fd, failure(kExitBadInput, "a request is {\"cmd\": ...}"));
    }
    const std::string command = request["cmd"];
    if (command == "status") return send_line(fd, status());
    if (command == "hold" || command == "resume" || command == "stop") {
      std::shared_ptr<RunJob> job;
      {
        std::lock_guard<std::mutex> lock(mutex);
        job = running;
      }
      const FeedRequest feed = command == "hold"     ? FeedRequest::kHold
                               : command == "resume" ? FeedRequest::kResume
                                                     : FeedRequest::kStop;
      if (!job || !job->request(feed)) return send_line(fd, failure(kExitFault, "no run is streaming"));
      return send_line(fd, success());
    }
    if (command == "estop") return send_line(fd, estop());
    if (command == "home" || command == "enable" || command == "disable" || command == "clear-fault") {
      auto work = std::make_shared<Work>();
      work->command = command;
      return send_line(fd, submit(work));
    }
    if (command == "run") return answer_run(fd, request);
    return send_line(fd, failure(kExitBadInput, "unknown command '" + command +
                                                    "' (status, run, hold, resume, stop, estop, home, enable, "
                                                    "disable, clear-fault)"));
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

  // One control-socket request through the same dispatch (answer()), for the dashboard.
  json dispatch(const json& request) {
    int fds[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
      return failure(kExitFailure, std::string("socketpair: ") + std::strerror(errno));
    }
    answer(fds[0], request.dump());  // replies are one short line (no "wait"): within the buffer
    ::close(fds[0]);
    std::string text;
    char chunk[4096];
    ssize_t n;
    while ((n = ::recv(fds[1], chunk, sizeof chunk, 0)) > 0) text.append(chunk, static_cast<std::size_t>(n));
    ::close(fds[1]);
    while (!text.empty() && text.back() == '\n') text.pop_back();
    const auto last = text.rfind('\n');
    try {
      return json::parse(last == std::string::npos ? text : text.substr(last + 1));
    } catch (const json::exception&) {
      return failure(kExitFailure, "no reply from the dispatch");
    }
  }

  bool answer_run(int fd, const json& request) {
    RunRequest run;
    run.link_timeout_ms = options.link_timeout_ms;
    run.limits = options.limits;
    run.following_error_deg = options.following_error_deg;
    try {
      run.trajectory = request.at("trajectory").get<std::string>();
      run.duration_s = request.value("duration", 0.0);
      run.record = request.value("record", std::string());
    } catch (const json::exception& error) {
      return send_line(fd, failure(kExitBadInput, std::string("run: ") + error.what() +
                                                      " (needs \"trajectory\"; optional \"duration\", \"record\")"));
    }
    if (run.record.empty()) {
      std::error_code ignored;
      std::filesystem::create_directories(options.record_folder, ignored);
      run.record = options.record_folder + "/run-" + timestamp() + ".csv";
    }
    const bool wait = request.value("wait", true);
    auto work = std::make_shared<Work>();
    work->command = "run";
    work->record = run.record;
    try {
      work->job = std::make_shared<RunJob>(weights, run);
    } catch (const HostFailure& error) {
      return send_line(fd, failure(error.code(), error.what()));
    } catch (const InputError& error) {
      return send_line(fd, failure(kExitBadInput, error.what()));
    }
    if (!wait) {
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (running || !queue.empty()) return send_line(fd, failure(kExitFault, "busy: a run is going on"));
        queue.push_back(work);
        running = work->job;  // taken by the board thread next
      }
      json reply = success();
      reply["event"] = "queued";
      reply["record"] = run.record;
      return send_line(fd, reply);
    }
    std::atomic<bool> finished{false};
    json reply;
    std::thread waiter([&] {
      reply = submit(work);
      finished.store(true);
    });
    bool open = send_line(fd, json{{"ok", true}, {"event", "started"}, {"record", run.record}});
    auto next = Clock::now() + std::chrono::seconds(1);
    while (!finished.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (open && Clock::now() >= next) {
        const RunProgress p = work->job->progress();
        open = send_line(
            fd, json{{"event", "progress"}, {"played", p.played}, {"planned", p.planned}, {"feed", feed_name(p.feed)}});
        next += std::chrono::seconds(1);
      }
    }
    waiter.join();
    reply["event"] = "finished";
    return send_line(fd, reply) && open;
  }
};

HostServer::HostServer(const ServeOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  impl_->weights = read_board_weights(options.weights_path);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (options.socket_path.empty() || options.socket_path.size() >= sizeof address.sun_path) {
    throw HostFailure(kExitBadInput, "--socket '" + options.socket_path + "': empty or longer than " +
                                         std::to_string(sizeof address.sun_path - 1) + " characters");
  }
  std::copy(options.socket_path.begin(), options.socket_path.end(), address.sun_path);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  // A socket file nobody answers on is left over from a controller that died: replaced.
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) {
    ::close(fd);
    throw HostFailure(kExitFailure, options.socket_path + ": another controller is serving there");
  }
  ::unlink(options.socket_path.c_str());
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 || ::listen(fd, 8) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw HostFailure(kExitFailure, options.socket_path + ": cannot listen: " + why);
  }
  ::chmod(options.socket_path.c_str(), 0660);
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
      ::unlink(options.socket_path.c_str());
      throw;
    }
  }
}

HostServer::~HostServer() {
  if (impl_->listen_fd >= 0) {
    ::close(impl_->listen_fd);
    ::unlink(impl_->options.socket_path.c_str());
  }
}

std::string HostServer::dashboard_url() const { return impl_->dashboard ? impl_->dashboard->url() : ""; }

int HostServer::run(const volatile std::sig_atomic_t& stop_signal) {
  Impl& s = *impl_;
  s.stop_signal = &stop_signal;
  s.beat();
  std::thread board([&s] { s.board_thread(); });
  if (s.dashboard) s.dashboard->start();
  std::list<std::thread> clients;
  notify_systemd("READY=1\nSTATUS=serving on " + s.options.socket_path);
  std::int64_t watchdog_us = 0;
  if (const char* usec = std::getenv("WATCHDOG_USEC")) watchdog_us = std::atoll(usec);
  auto next_ping = Clock::now();
  std::string last_status;
  while (stop_signal == 0) {
    pollfd p{s.listen_fd, POLLIN, 0};
    if (::poll(&p, 1, 100) > 0 && (p.revents & POLLIN)) {
      const int client = ::accept4(s.listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
      if (client >= 0) clients.emplace_back([&s, client] { s.client_thread(client); });
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
  // A run sees the same signal and stops at rest; the board thread then disables and ends.
  {
    std::shared_ptr<RunJob> job;
    {
      std::lock_guard<std::mutex> lock(s.mutex);
      job = s.running;
    }
    if (job) {
      while (true) {
        {
          std::lock_guard<std::mutex> lock(s.mutex);
          if (!s.running) break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
  }
  if (s.dashboard) s.dashboard->stop();
  s.shutting_down.store(true);
  s.work_done.notify_all();
  board.join();
  for (std::thread& client : clients) client.join();
  return kExitOk;
}

}  // namespace delta::controller

// The operator's dashboard: HTTP API, telemetry events and the page's assets (see dashboard.hpp).
#include "delta/controller/dashboard.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "delta/board_facts.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/exit_codes.hpp"
#include "delta/input_error.hpp"
#include "delta/recording_plot.hpp"
#include "delta/shipped_data.hpp"
#include "delta/trajectory.hpp"

namespace delta::controller {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;
constexpr double kCountDeg = board::kEncoderCountMicrodeg * 1e-6;
constexpr int kPublishMs = 40;             // one telemetry event per 40 ms: 25 events per second
constexpr std::uint32_t kKeepTicks = 200;  // a sample kept per 20 ms of board time (ticks of 100 us)
constexpr std::size_t kEventRing = 64;     // events a client may lag behind before it skips ahead

// One kept sample: [t_s, enc1..3 deg, ref1..3 deg, cur1..3 A, plate ref x,y,z mm (null: none),
// flags, fault cause, underruns].
json sample_json(const TelemetryRecord& r) {
  const link::TelemetryPayload& t = r.telemetry;
  json row = json::array();
  row.push_back(t.tick / 1e4);
  for (int k = 0; k < 3; ++k) row.push_back(std::round(t.counts[k] * kCountDeg * 1e4) / 1e4);
  for (int k = 0; k < 3; ++k) row.push_back(std::round(t.references[k] / 256.0 * kCountDeg * 1e4) / 1e4);
  for (int k = 0; k < 3; ++k) row.push_back(std::round(t.currents[k] * kCurrentCodeA * 1e4) / 1e4);
  for (int k = 0; k < 3; ++k) {
    const double mm = r.reference_m[k] * 1e3;
    row.push_back(r.stream_sample >= 0 && std::isfinite(mm) ? json(std::round(mm * 1e4) / 1e4) : json(nullptr));
  }
  row.push_back(t.flags);
  row.push_back(t.fault_cause);
  row.push_back(t.underruns);
  return row;
}

// A JSON array of elements that are JSON texts already.
template <typename Iterator>
std::string json_array(Iterator first, Iterator last) {
  std::size_t size = 2;
  for (Iterator it = first; it != last; ++it) size += it->size() + 1;
  std::string text;
  text.reserve(size);
  text += '[';
  for (Iterator it = first; it != last; ++it) {
    if (it != first) text += ',';
    text += *it;
  }
  text += ']';
  return text;
}

bool is_loopback_address(const std::string& address) {
  return address.rfind("127.", 0) == 0 || address == "::1" || address.rfind("::ffff:127.", 0) == 0 ||
         address == "localhost";
}

bool equal_constant_time(const std::string& a, const std::string& b) {
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i) difference |= static_cast<unsigned char>(a[i] ^ b[i % (b.size() + 1)]);
  return difference == 0;
}

std::string trim(std::string text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  std::size_t first = 0;
  while (first < text.size() && std::isspace(static_cast<unsigned char>(text[first]))) ++first;
  return text.substr(first);
}

// The token: read from `path` (refused when group or others may read it), or created there.
std::string load_token(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) {
    unsigned char bytes[24];
    std::ifstream random("/dev/urandom", std::ios::binary);
    if (!random.read(reinterpret_cast<char*>(bytes), sizeof bytes)) {
      throw HostFailure(kExitFailure, "--http-token-file: cannot read /dev/urandom for a new token");
    }
    static const char* kHex = "0123456789abcdef";
    std::string token;
    for (unsigned char b : bytes) token += {kHex[b >> 4], kHex[b & 15]};
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) {
      throw HostFailure(kExitBadInput, path + ": cannot create the dashboard's token file: " + std::strerror(errno));
    }
    const std::string line = token + "\n";
    const bool written = ::write(fd, line.data(), line.size()) == static_cast<ssize_t>(line.size());
    ::close(fd);
    if (!written) throw HostFailure(kExitFailure, path + ": cannot write the dashboard's token");
    return token;
  }
  if (!S_ISREG(info.st_mode)) throw HostFailure(kExitBadInput, path + ": the token file is not a regular file");
  if (info.st_mode & 077) {
    throw HostFailure(kExitBadInput, path + ": the token file may be read by others (mode " +
                                         std::to_string((info.st_mode >> 6) & 7) +
                                         std::to_string((info.st_mode >> 3) & 7) + std::to_string(info.st_mode & 7) +
                                         "); chmod 600 it, owned by the service's user");
  }
  std::ifstream in(path);
  std::string token;
  std::getline(in, token);
  token = trim(token);
  if (token.size() < 16) throw HostFailure(kExitBadInput, path + ":1: the token is shorter than 16 characters");
  return token;
}

const char* content_type_of(const std::string& name) {
  const auto dot = name.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : name.substr(dot + 1);
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "js") return "text/javascript; charset=utf-8";
  if (ext == "css") return "text/css; charset=utf-8";
  if (ext == "png") return "image/png";
  if (ext == "svg") return "image/svg+xml";
  if (ext == "csv") return "text/csv; charset=utf-8";
  return "application/octet-stream";
}

bool plain_name(const std::string& name) {
  if (name.empty() || name[0] == '.' || name.size() > 200) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
  });
}

}  // namespace

void parse_http_address(const std::string& text, DashboardOptions& options) {
  const auto colon = text.rfind(':');
  std::string host = colon == std::string::npos ? "" : text.substr(0, colon);
  const std::string port = colon == std::string::npos ? text : text.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  char* end = nullptr;
  const long number = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || number < 0 || number > 65535) {
    throw HostFailure(kExitBadInput, "--http '" + text + "': expected ADDR:PORT, e.g. 127.0.0.1:8080");
  }
  options.address = host.empty() ? "127.0.0.1" : host;
  options.port = static_cast<int>(number);
}

std::string find_web_root() {
  if (const char* root = std::getenv("DELTACTL_WEB_ROOT"); root && *root) return root;
  // Beside the program (shipped_data.hpp): a build's links to the source tree's host/controller/web.
  return shipped_data_dir() + "/web";
}

struct Dashboard::Impl {
  DashboardOptions options;
  DashboardBackend backend;
  std::string token;
  httplib::Server server;
  std::thread listener, publisher;
  std::atomic<bool> stopping{false};
  std::atomic<int> streams{0};
  std::set<std::string> own_hosts;  // Host header values naming this server (loopback listener)
  bool loopback = true;

  // ---- telemetry in (on_telemetry) ----
  std::mutex incoming_mutex;
  std::vector<json> incoming;
  std::optional<std::uint32_t> last_kept_tick;
  std::optional<TelemetryRecord> newest;
  Clock::time_point newest_at{};

  // ---- out: the history (the kept minutes) and the event ring ----
  std::mutex out_mutex;
  std::condition_variable published;
  std::deque<std::string> history;  // the kept samples, each as its JSON text (dumped once)
  std::deque<std::pair<std::uint64_t, std::shared_ptr<const std::string>>> events;
  std::uint64_t sequence = 0;
  std::mutex plot_mutex;  // one gnuplot at a time

  json enriched_status() {
    json status = backend.status();
    std::optional<TelemetryRecord> last;
    Clock::time_point at;
    {
      std::lock_guard<std::mutex> lock(incoming_mutex);
      last = newest;
      at = newest_at;
    }
    status["homed"] = false;
    status["drives_enabled"] = false;
    status["fault"] = nullptr;
    status["data_age_ms"] = nullptr;
    if (last) {
      const link::TelemetryPayload& t = last->telemetry;
      status["homed"] = t.has(link::TelemetryFlag::kHomed);
      status["drives_enabled"] = t.has(link::TelemetryFlag::kDriveEnable);
      if (t.has(link::TelemetryFlag::kFault)) status["fault"] = link::describe_fault(t.fault_cause);
      status["board_time_s"] = t.tick / 1e4;
      status["data_age_ms"] = std::chrono::duration<double, std::milli>(Clock::now() - at).count();
      status["counters"]["underruns"] = t.underruns;
      if (status.value("state", std::string()) != "running" && status.value("state", std::string()) != "holding" &&
          status.value("connection", std::string()) == "connected") {
        status["state"] = state_name(state_of(t));
      }
    }
    if (status.contains("run") && status["run"].is_object()) {
      json& run = status["run"];
      const double played = run.value("played", 0.0), planned = run.value("planned", 0.0);
      run["seconds"] = played / static_cast<double>(board::kSetpointRateHz);
      run["total_s"] = planned / static_cast<double>(board::kSetpointRateHz);
      run["percent"] = planned > 0 ? std::round(1000.0 * played / planned) / 10.0 : 0.0;
    } else {
      status["run"] = nullptr;
    }
    return status;
  }

  void publish_loop() {
    auto next = Clock::now();
    const std::size_t keep = static_cast<std::size_t>(options.history_s * 1e4 / kKeepTicks);
    while (!stopping.load()) {
      next += std::chrono::milliseconds(kPublishMs);
      std::this_thread::sleep_until(next);
      if (Clock::now() - next > std::chrono::milliseconds(10 * kPublishMs)) next = Clock::now();  // no burst
      std::vector<json> fresh;
      {
        std::lock_guard<std::mutex> lock(incoming_mutex);
        fresh.swap(incoming);
      }
      // One event for all clients: its text is made here once and shared (a client only writes it).
      std::vector<std::string> texts;
      texts.reserve(fresh.size());
      for (const json& sample : fresh) texts.push_back(sample.dump());
      const std::string status = enriched_status().dump();
      std::lock_guard<std::mutex> lock(out_mutex);
      const std::string seq = std::to_string(++sequence);
      events.emplace_back(sequence, std::make_shared<const std::string>(
                                        "id: " + seq + "\ndata: {\"seq\":" + seq + ",\"status\":" + status +
                                        ",\"samples\":" + json_array(texts.begin(), texts.end()) + "}\n\n"));
      for (std::string& text : texts) history.push_back(std::move(text));
      while (history.size() > keep) history.pop_front();
      while (events.size() > kEventRing) events.pop_front();
      published.notify_all();
    }
    published.notify_all();
  }

  // ---- security ----
  // Empty when allowed; else the status to answer (401 or 403) and a reason in `why`.
  int refused(const httplib::Request& request, bool changes, std::string& why) const {
    const std::string origin = request.get_header_value("Origin");
    if (loopback) {
      const std::string host = request.get_header_value("Host");
      if (!own_hosts.count(host)) {
        why = "Host '" + host + "' is not this dashboard's (loopback only)";
        return 403;
      }
    }
    if (!origin.empty() && origin != "http://" + request.get_header_value("Host")) {
      why = "Origin '" + origin + "' is not this dashboard's";
      return 403;
    }
    if (!changes && is_loopback_address(request.remote_addr)) return 0;
    const std::string authorization = request.get_header_value("Authorization");
    const std::string prefix = "Bearer ";
    if (authorization.rfind(prefix, 0) != 0 || !equal_constant_time(trim(authorization.substr(prefix.size())), token)) {
      why = changes ? "a changing request needs 'Authorization: Bearer TOKEN' (the token file's content)"
                    : "reading from another host needs 'Authorization: Bearer TOKEN'";
      return 401;
    }
    return 0;
  }

  bool allow(const httplib::Request& request, httplib::Response& response, bool changes) const {
    std::string why;
    const int status = refused(request, changes, why);
    if (status == 0) return true;
    response.status = status;
    if (status == 401) response.set_header("WWW-Authenticate", "Bearer realm=\"deltactl\"");
    response.set_content(json{{"ok", false}, {"error", why}}.dump(), "application/json");
    return false;
  }

  static void reply(httplib::Response& response, const json& body) {
    const bool ok = body.value("ok", false);
    const int exit = body.value("exit", ok ? 0 : 3);
    response.status = ok ? 200 : exit == kExitBadInput ? 400 : 409;
    response.set_content(body.dump(), "application/json");
  }

  void routes() {
    server.set_default_headers(
        {{"X-Content-Type-Options", "nosniff"},
         {"X-Frame-Options", "DENY"},
         {"Referrer-Policy", "no-referrer"},
         {"Cache-Control", "no-store"},
         {"Content-Security-Policy",
          "default-src 'self'; img-src 'self' data: blob:; frame-ancestors 'none'; base-uri 'none'"}});
    auto asset = [this](const std::string& name, httplib::Response& response) {
      const std::string path = find_or(options.web_root) + "/" + name;
      std::ifstream in(path, std::ios::binary);
      if (!plain_name(name) || !in) {
        response.status = 404;
        response.set_content("not found: " + name + "\n", "text/plain");
        return;
      }
      std::ostringstream text;
      text << in.rdbuf();
      response.set_content(text.str(), content_type_of(name));
    };
    server.Get("/", [this, asset](const httplib::Request& request, httplib::Response& response) {
      if (allow(request, response, false) || response.status == 401) {
        response.status = 200;
        asset("index.html", response);  // the page asks for the token itself
      }
    });
    server.Get(R"(/web/([A-Za-z0-9_.-]+))", [asset](const httplib::Request& request, httplib::Response& response) {
      asset(request.matches[1], response);
    });
    server.Get("/api/status", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, false)) return;
      response.set_content(enriched_status().dump(), "application/json");
    });
    server.Get("/api/trajectories", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, false)) return;
      json list = json::array();
      for (const auto& [name, description] : trajectory_catalogue()) {
        list.push_back({{"name", name}, {"description", description}});
      }
      response.set_content(list.dump(), "application/json");
    });
    server.Get("/api/recordings", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, false)) return;
      response.set_content(recordings().dump(), "application/json");
    });
    server.Get(R"(/api/recordings/([A-Za-z0-9_.-]+)\.(csv|png))",
               [this](const httplib::Request& request, httplib::Response& response) {
                 if (!allow(request, response, false)) return;
                 recording_file(request.matches[1], request.matches[2], response);
               });
    server.Get("/api/telemetry", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, false)) return;
      stream(response);
    });
    // The commands take no body and are carried out before httplib reads one: a POST without
    // Content-Length (Debian 12's `curl -X POST` sends none, and httplib then waits for the end of
    // the stream and answers 400), chunked, or with a body past the payload limit is still an
    // e-stop once it is authenticated (else 401).
    static const std::map<std::string, std::string> kCommands = {
        {"/api/home", "home"}, {"/api/hold", "hold"},         {"/api/resume", "resume"},
        {"/api/stop", "stop"}, {"/api/clear", "clear-fault"}, {"/api/estop", "estop"}};
    server.set_pre_routing_handler([this](const httplib::Request& request, httplib::Response& response) {
      if (request.method != "POST") return httplib::Server::HandlerResponse::Unhandled;
      const auto command = kCommands.find(request.path);
      if (command != kCommands.end()) {
        if (allow(request, response, true)) reply(response, backend.dispatch(json{{"cmd", command->second}}));
        return httplib::Server::HandlerResponse::Handled;
      }
      if (!request.has_header("Content-Length") && !request.has_header("Transfer-Encoding")) {
        if (!allow(request, response, true)) return httplib::Server::HandlerResponse::Handled;
        response.status = 411;
        response.set_content(json{{"ok", false},
                                  {"error", request.path + ": a POST with a body needs Content-Length "
                                                           "(curl: -d '{...}' or --json '{...}')"}}
                                 .dump(),
                             "application/json");
        return httplib::Server::HandlerResponse::Handled;
      }
      return httplib::Server::HandlerResponse::Unhandled;
    });
    server.Post("/api/run", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, true)) return;
      json body;
      try {
        body = json::parse(request.body);
        json run = {{"cmd", "run"}, {"trajectory", body.at("trajectory").get<std::string>()}, {"wait", false}};
        if (body.contains("duration") && !body["duration"].is_null()) run["duration"] = body["duration"].get<double>();
        reply(response, backend.dispatch(run));
      } catch (const json::exception& error) {
        reply(response,
              json{{"ok", false},
                   {"exit", kExitBadInput},
                   {"error",
                    std::string("run: the body is {\"trajectory\": NAME_OR_FILE, \"duration\": S}: ") + error.what()}});
      }
    });
  }

  static std::string find_or(const std::string& root) { return root.empty() ? find_web_root() : root; }

  json recordings() const {
    json list = json::array();
    std::error_code error;
    std::vector<fs::directory_entry> files;
    for (const auto& entry : fs::directory_iterator(options.record_folder, error)) {
      const std::string name = entry.path().filename().string();
      if (entry.is_regular_file(error) && plain_name(name) && entry.path().extension() == ".csv") {
        files.push_back(entry);
      }
    }
    std::sort(files.begin(), files.end(),
              [](const auto& a, const auto& b) { return a.last_write_time() > b.last_write_time(); });
    for (const auto& entry : files) {
      const std::string stem = entry.path().stem().string();
      const auto modified =
          std::chrono::duration_cast<std::chrono::seconds>(entry.last_write_time() - fs::file_time_type::clock::now() +
                                                           std::chrono::system_clock::now().time_since_epoch());
      list.push_back({{"name", entry.path().filename().string()},
                      {"bytes", entry.file_size(error)},
                      {"modified_unix_s", modified.count()},
                      {"csv", "/api/recordings/" + stem + ".csv"},
                      {"plot", "/api/recordings/" + stem + ".png"}});
    }
    return list;
  }

  void recording_file(const std::string& stem, const std::string& kind, httplib::Response& response) {
    const std::string csv = options.record_folder + "/" + stem + ".csv";
    std::error_code error;
    if (!plain_name(stem + ".csv") || !fs::is_regular_file(csv, error)) {
      response.status = 404;
      response.set_content("no recording " + stem + ".csv\n", "text/plain");
      return;
    }
    std::string path = csv;
    if (kind == "png") {
      const std::string folder = options.record_folder + "/.plots";
      fs::create_directories(folder, error);
      path = folder + "/" + stem + ".png";
      std::lock_guard<std::mutex> lock(plot_mutex);
      if (!fs::is_regular_file(path, error) || fs::last_write_time(path, error) < fs::last_write_time(csv, error)) {
        try {
          plot_recording(csv, path);
        } catch (const std::exception& failure) {
          response.status = 422;
          response.set_content(std::string(failure.what()) + "\n", "text/plain");
          return;
        }
      }
    } else {
      response.set_header("Content-Disposition", "attachment; filename=\"" + stem + ".csv\"");
    }
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    response.set_content(text.str(), content_type_of(path));
  }

  // Server-Sent Events: the history first, then each published event; a client that falls more
  // than the ring behind skips to the newest (its socket's buffer full: its write times out).
  void stream(httplib::Response& response) {
    if (streams.fetch_add(1) >= options.max_streams) {
      streams.fetch_sub(1);
      response.status = 503;
      response.set_content(
          json{{"ok", false}, {"error", "too many telemetry clients (" + std::to_string(options.max_streams) + ")"}}
              .dump(),
          "application/json");
      return;
    }
    auto cursor = std::make_shared<std::optional<std::uint64_t>>();
    response.set_header("X-Accel-Buffering", "no");
    response.set_chunked_content_provider(
        "text/event-stream",
        [this, cursor](std::size_t, httplib::DataSink& sink) {
          if (stopping.load()) {
            sink.done();
            return true;
          }
          if (!*cursor) {
            std::string text;
            {
              std::lock_guard<std::mutex> lock(out_mutex);
              const json bits = {{"drive_enable", 1 << board::kFlagDriveEnable},
                                 {"homed", 1 << board::kFlagHomed},
                                 {"holding", 1 << board::kFlagHolding},
                                 {"fault", 1 << board::kFlagFault}};
              text = "event: history\ndata: {\"flag_bits\":" + bits.dump() +
                     ",\"samples\":" + json_array(history.begin(), history.end()) + "}\n\n";
              *cursor = sequence;
            }
            return sink.write(text.data(), text.size());
          }
          std::vector<std::shared_ptr<const std::string>> due;
          {
            std::unique_lock<std::mutex> lock(out_mutex);
            published.wait_for(lock, std::chrono::seconds(1), [&] { return sequence > **cursor || stopping.load(); });
            for (const auto& [seq, text] : events) {
              if (seq > **cursor) due.push_back(text);
            }
            *cursor = sequence;
          }
          if (due.empty()) {
            static const std::string kAlive = ": alive\n\n";
            return sink.write(kAlive.data(), kAlive.size());
          }
          for (const auto& text : due) {
            if (!sink.write(text->data(), text->size())) return false;
          }
          return true;
        },
        [this](bool) { streams.fetch_sub(1); });
  }
};

Dashboard::Dashboard(const DashboardOptions& options, DashboardBackend backend) : impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  d.options = options;
  d.backend = std::move(backend);
  if (d.options.web_root.empty()) d.options.web_root = find_web_root();
  std::error_code ignored;
  if (!fs::is_regular_file(d.options.web_root + "/index.html", ignored)) {
    throw HostFailure(kExitFailure, "the dashboard's page is not at " + d.options.web_root +
                                        "/index.html (set DELTACTL_WEB_ROOT or install the package)");
  }
  d.token = load_token(d.options.token_file);
  d.loopback = is_loopback_address(d.options.address);
  // Streaming clients each hold a pool thread: the pool has room for all of them and the API.
  const std::size_t threads = static_cast<std::size_t>(d.options.max_streams) + 8;
  d.server.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  d.server.set_keep_alive_max_count(1);  // an idle keep-alive connection would hold a thread
  d.server.set_read_timeout(5, 0);
  d.server.set_write_timeout(2, 0);  // a stuck browser's stream ends; others go on
  d.server.set_payload_max_length(64 * 1024);
  d.routes();
  int port = d.options.port;
  if (port == 0) {
    port = d.server.bind_to_any_port(d.options.address);
  } else if (!d.server.bind_to_port(d.options.address, port)) {
    port = -1;
  }
  if (port <= 0) {
    throw HostFailure(kExitFailure, "--http " + d.options.address + ":" + std::to_string(d.options.port) +
                                        ": cannot listen (in use, or not an address of this machine)");
  }
  d.options.port = port;
  const std::string p = std::to_string(port);
  d.own_hosts = {"127.0.0.1:" + p, "localhost:" + p, "[::1]:" + p, d.options.address + ":" + p};
}

Dashboard::~Dashboard() { stop(); }

void Dashboard::start() {
  Impl& d = *impl_;
  d.publisher = std::thread([&d] { d.publish_loop(); });
  d.listener = std::thread([&d] { d.server.listen_after_bind(); });
}

void Dashboard::stop() {
  Impl& d = *impl_;
  if (d.stopping.exchange(true)) return;
  d.published.notify_all();
  d.server.stop();
  if (d.listener.joinable()) d.listener.join();
  if (d.publisher.joinable()) d.publisher.join();
}

void Dashboard::on_telemetry(const TelemetryRecord& record) {
  Impl& d = *impl_;
  const std::uint32_t tick = record.telemetry.tick;
  std::lock_guard<std::mutex> lock(d.incoming_mutex);
  d.newest = record;
  d.newest_at = Clock::now();
  if (d.last_kept_tick && tick - *d.last_kept_tick < kKeepTicks && tick >= *d.last_kept_tick) return;
  d.last_kept_tick = tick;
  if (d.incoming.size() < 4096) d.incoming.push_back(sample_json(record));
}

std::string Dashboard::url() const {
  const std::string& a = impl_->options.address;
  return "http://" + (a.find(':') != std::string::npos ? "[" + a + "]" : a) + ":" + std::to_string(impl_->options.port);
}

}  // namespace delta::controller

// The operator's dashboard: HTTP API, telemetry events and the page's assets (see dashboard.hpp).
#include "delta/controller/dashboard.hpp"

#include <fcntl.h>
#include <ifaddrs.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
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
#include "delta/controller/http_front_door.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/exit_codes.hpp"
#include "delta/input_error.hpp"
#include "delta/recording_plot.hpp"
#include "delta/run_report.hpp"
#include "delta/shipped_data.hpp"
#include "delta/trajectory.hpp"
#include "delta/utf8_text.hpp"

namespace delta::controller {
namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;
constexpr int kPublishMs = 40;             // one telemetry event per 40 ms: 25 events per second
constexpr std::uint32_t kKeepTicks = 200;  // a sample kept per 20 ms of board time (ticks of 100 us)
constexpr std::size_t kEventRing = 64;     // events a client may lag behind before it skips ahead
constexpr int kMarkFeedHeld = 1;           // a sample's host marks (its last element): the operator's feed hold
constexpr int kMarkEstopLatched = 2;       //   and a latched e-stop

// One kept sample: [t_s, enc1..3 deg, ref1..3 deg, cur1..3 A, plate ref x,y,z mm (null: none),
// flags, fault cause, underruns]; the publisher adds the host's marks (kMark*).
json sample_json(const TelemetryRecord& r) {
  const link::TelemetryPayload& t = r.telemetry;
  json row = json::array();
  row.push_back(t.time_s());
  for (int k = 0; k < 3; ++k) row.push_back(std::round(t.count_deg(k) * 1e4) / 1e4);
  for (int k = 0; k < 3; ++k) row.push_back(std::round(t.reference_deg(k) * 1e4) / 1e4);
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

// A reply's JSON text whatever its strings hold (bytes that are not UTF-8 replaced): dump never
// throws, so no answer is an empty 500.
std::string json_text(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// "HOST:PORT" as a browser writes it in the Host header (an IPv6 address in brackets).
std::string host_and_port(const std::string& host, int port) {
  return (host.find(':') != std::string::npos ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

bool is_wildcard_address(const std::string& address) {
  return address.empty() || address == "0.0.0.0" || address == "::" || address == "0:0:0:0:0:0:0:0";
}

// The Host header values that name this server: the loopback's names, the --http address as
// given, this machine's name, and for a listener on every address (0.0.0.0, [::]) each address of
// each interface. Any other name is refused (DNS rebinding: a page of another site, its name
// pointed at this machine, would otherwise read the robot's state and recordings).
std::set<std::string> own_host_names(const std::string& address, int port) {
  std::set<std::string> names;
  auto add = [&](const std::string& host) {
    if (host.empty()) return;
    names.insert(lowercase(host_and_port(host, port)));
    if (port == 80) names.insert(lowercase(host.find(':') != std::string::npos ? "[" + host + "]" : host));
  };
  for (const char* loopback : {"127.0.0.1", "localhost", "::1"}) add(loopback);
  if (!is_wildcard_address(address)) add(address);
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) == 0) {
    const std::string host = name;
    add(host);
    if (host.find('.') == std::string::npos) add(host + ".local");  // its mDNS name
  }
  if (is_wildcard_address(address)) {
    ifaddrs* interfaces = nullptr;
    if (::getifaddrs(&interfaces) == 0) {
      for (const ifaddrs* i = interfaces; i; i = i->ifa_next) {
        if (!i->ifa_addr || (i->ifa_addr->sa_family != AF_INET && i->ifa_addr->sa_family != AF_INET6)) continue;
        const socklen_t size = i->ifa_addr->sa_family == AF_INET ? sizeof(sockaddr_in) : sizeof(sockaddr_in6);
        char text[NI_MAXHOST] = {};
        if (::getnameinfo(i->ifa_addr, size, text, sizeof text, nullptr, 0, NI_NUMERICHOST) != 0) continue;
        const std::string host = text;
        if (host.find('%') == std::string::npos) add(host);  // not a link-local address with its zone
      }
      ::freeifaddrs(interfaces);
    }
  }
  return names;
}

// One connection as httplib reads and writes it: first the bytes the front door read (the head and
// any of the body), then the socket (non-blocking), every read against one deadline for the rest
// of the request and every write against its own timeout.
class ConnectionStream final : public httplib::Stream {
 public:
  ConnectionStream(HttpConnection& connection, Clock::time_point read_deadline, std::chrono::milliseconds write_timeout)
      : c_(connection), read_deadline_(read_deadline), write_timeout_(write_timeout) {}

  bool is_readable() const override { return offset_ < c_.received.size() || wait(POLLIN, read_deadline_); }
  bool is_writable() const override { return wait(POLLOUT, Clock::now() + write_timeout_); }

  ssize_t read(char* ptr, std::size_t size) override {
    if (offset_ >= c_.received.size()) {
      c_.received.clear();
      offset_ = 0;
      if (!wait(POLLIN, read_deadline_)) return -1;
      char buffer[4096];
      const ssize_t n = ::recv(c_.fd, buffer, sizeof buffer, 0);
      if (n <= 0) return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) ? -1 : n;
      c_.received.assign(buffer, static_cast<std::size_t>(n));
    }
    const std::size_t n = std::min(size, c_.received.size() - offset_);
    std::memcpy(ptr, c_.received.data() + offset_, n);
    offset_ += n;
    return static_cast<ssize_t>(n);
  }

  // All of it or -1 (httplib writes a response's head in one call).
  ssize_t write(const char* ptr, std::size_t size) override {
    const Clock::time_point deadline = Clock::now() + write_timeout_;
    std::size_t done = 0;
    while (done < size) {
      if (!wait(POLLOUT, deadline)) return -1;
      const ssize_t n = ::send(c_.fd, ptr + done, size - done, MSG_NOSIGNAL);
      if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) continue;
      if (n <= 0) return -1;
      done += static_cast<std::size_t>(n);
    }
    return static_cast<ssize_t>(size);
  }

  void get_remote_ip_and_port(std::string& ip, int& port) const override { address_of(false, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { address_of(true, ip, port); }
  int socket() const override { return c_.fd; }

 private:
  bool wait(short events, Clock::time_point deadline) const {
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      pollfd p{c_.fd, events, 0};
      const int ready = ::poll(&p, 1, static_cast<int>(std::max<long long>(0, left)));
      if (ready < 0 && errno == EINTR) continue;
      return ready > 0 && (p.revents & events) && !(p.revents & (POLLERR | POLLNVAL)) &&
             !(events == POLLOUT && (p.revents & POLLHUP));
    }
  }

  void address_of(bool local, std::string& ip, int& port) const {
    sockaddr_storage address{};
    socklen_t size = sizeof address;
    const int got = local ? ::getsockname(c_.fd, reinterpret_cast<sockaddr*>(&address), &size)
                          : ::getpeername(c_.fd, reinterpret_cast<sockaddr*>(&address), &size);
    char host[NI_MAXHOST] = {}, service[NI_MAXSERV] = {};
    if (got != 0 || ::getnameinfo(reinterpret_cast<sockaddr*>(&address), size, host, sizeof host, service,
                                  sizeof service, NI_NUMERICHOST | NI_NUMERICSERV) != 0) {
      ip.clear();
      port = 0;
      return;
    }
    ip = host;
    port = std::atoi(service);
  }

  HttpConnection& c_;
  std::size_t offset_ = 0;
  Clock::time_point read_deadline_;
  std::chrono::milliseconds write_timeout_;
};

// httplib's routing and responses, on connections the front door accepted (its own accept loop is
// never run: it hands every connection to one pool before reading a byte of it).
class RoutedServer final : public httplib::Server {
 public:
  // Binds like httplib (port 0: any); the port, or -1.
  int bind(const std::string& address, int port) {
    if (port == 0) return bind_to_any_port(address);
    return bind_to_port(address, port) ? port : -1;
  }
  int listening_socket() const { return svr_sock_; }
  // One request on `stream`, answered with "Connection: close".
  void serve(httplib::Stream& stream) {
    bool closed = true;
    process_request(stream, true, closed, nullptr);
  }
  // Ends the streams being written (httplib's writers stop when the server's socket is gone).
  void close_listener() {
    const int fd = svr_sock_.exchange(INVALID_SOCKET);
    if (fd != INVALID_SOCKET) {
      ::shutdown(fd, SHUT_RDWR);
      ::close(fd);
    }
  }
};

}  // namespace

std::string recording_name_problem(const std::string& file_name) {
  if (file_name.size() < 5 || file_name.compare(file_name.size() - 4, 4, ".csv") != 0)
    return "a recording's name ends in .csv";
  if (file_name[0] == '.') return "a recording's name does not start with '.' (hidden files are not listed)";
  if (file_name.size() > 200) return "a recording's name has at most 200 characters";
  if (!plain_name(file_name)) return "a recording's name has only letters, digits, '-', '_' and '.'";
  return "";
}

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
  RoutedServer server;
  std::unique_ptr<HttpFrontDoor> door;
  std::thread publisher;
  std::atomic<bool> stopping{false};
  std::atomic<int> streams{0};
  std::set<std::string> own_hosts;  // Host header values naming this server, lowercase (own_host_names)

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
  // The recordings' reports, by name, while their files stay as they were (the page asks for every
  // listed one each time it lists them).
  struct CachedReport {
    fs::file_time_type written;
    std::uintmax_t bytes = 0;
    int status = 200;
    json body;
  };
  static constexpr std::size_t kReportsKept = 256;
  std::mutex report_mutex;
  std::map<std::string, CachedReport> reports;

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
      if (t.has(link::TelemetryFlag::kFault)) status["fault"] = link::describe_fault(t);
      status["board_time_s"] = t.time_s();
      status["data_age_ms"] = std::chrono::duration<double, std::milli>(Clock::now() - at).count();
      status["counters"]["underruns"] = t.underruns;
      // The controller's state as its board thread last read it, from the newest frame instead;
      // a state of the controller's own (e-stopped, homing, running, ...) stays.
      const std::string state = status.value("state", std::string());
      if ((state == "idle" || state == "homed" || state == "fault" || state == "unknown") &&
          status.value("connection", std::string()) == "connected") {
        status["state"] = state_name(state_of(t));
      }
    }
    if (status.contains("run") && status["run"].is_object()) {
      json& run = status["run"];
      const double played = run.value("played", 0.0), planned = run.value("planned", 0.0);
      run["seconds"] = played / static_cast<double>(board::kSetpointRateHz);
      // Held, slowing to rest or stopping, the plan ends at the rest point: no share of the run.
      const std::string feed = run.value("feed", std::string());
      const bool whole_plan = feed == "streaming" || feed == "resuming";
      run["total_s"] = whole_plan ? json(planned / static_cast<double>(board::kSetpointRateHz)) : json(nullptr);
      run["percent"] = whole_plan && planned > 0 ? json(std::round(1000.0 * played / planned) / 10.0) : json(nullptr);
    } else {
      status["run"] = nullptr;
    }
    return status;
  }

  // What the host knows of a sample and the board does not: the operator's feed hold (the board
  // also holds at every run's start and end) and a latched e-stop; kMark* bits.
  static int host_marks(const json& status) {
    int marks = 0;
    if (status.contains("run") && status["run"].is_object()) {
      const std::string feed = status["run"].value("feed", std::string());
      if (feed == "held" || feed.rfind("holding", 0) == 0) marks |= kMarkFeedHeld;
    }
    if (status.contains("estop") && status["estop"].is_object() && status["estop"].value("latched", false)) {
      marks |= kMarkEstopLatched;
    }
    return marks;
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
      const json now = enriched_status();
      const int marks = host_marks(now);
      std::vector<std::string> texts;
      texts.reserve(fresh.size());
      for (json& sample : fresh) {
        sample.push_back(marks);
        texts.push_back(json_text(sample));
      }
      const std::string status = json_text(now);
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

  // ---- connections: the front door's lanes ----
  // A command from a client with the token never waits for a read: the e-stop has a lane of its
  // own, the other commands another; reads, plots (a gnuplot each, one at a time) and telemetry
  // streams (each holds its thread) have theirs. A client without the token only reaches those.
  enum Lane : std::size_t { kEstopLane, kCommandLane, kReadLane, kPlotLane, kStreamLane };
  static constexpr auto kRequestDeadline = std::chrono::milliseconds(2000);  // the rest of a request after its head
  static constexpr auto kWriteTimeout = std::chrono::milliseconds(2000);     // a stuck browser's stream ends

  static std::string busy(const std::string& what) { return json_text(json{{"ok", false}, {"error", what}}); }

  void open_front_door() {
    std::vector<HttpLane> lanes(5);
    lanes[kEstopLane] = {"e-stop", 2, 16, busy("busy: e-stops are being answered")};
    lanes[kCommandLane] = {"commands", 3, 16, busy("busy: too many commands at once")};
    lanes[kReadLane] = {"reads", 6, 64, busy("busy: too many reads at once; try again")};
    lanes[kPlotLane] = {"plots", 1, 16, busy("busy: too many plots asked for at once; try again")};
    lanes[kStreamLane] = {"telemetry", options.max_streams, 0,
                          busy("too many telemetry clients (" + std::to_string(options.max_streams) + ")")};
    door = std::make_unique<HttpFrontDoor>(
        server.listening_socket(), std::move(lanes), [this](const HttpConnection& c) { return lane_of(c); },
        [this](HttpConnection& c) {
          ConnectionStream stream(c, Clock::now() + kRequestDeadline, kWriteTimeout);
          server.serve(stream);
        });
  }

  std::size_t lane_of(const HttpConnection& c) const {
    if (c.method == "POST" && carries_token(c.header("Authorization"))) {
      return c.path == "/api/estop" ? kEstopLane : kCommandLane;
    }
    if (c.method == "GET" && c.path == "/api/telemetry") return kStreamLane;
    // A plot, or a run's report (a whole recording read): the plots' lane, not the reads'.
    if (c.method == "GET" && c.path.rfind("/api/recordings/", 0) == 0 && c.path.size() > 7 &&
        (c.path.compare(c.path.size() - 4, 4, ".png") == 0 || c.path.compare(c.path.size() - 7, 7, "/report") == 0)) {
      return kPlotLane;
    }
    return kReadLane;
  }

  // "Bearer TOKEN", the scheme's name in any case (RFC 7235).
  bool carries_token(const std::string& authorization) const {
    const std::string prefix = "bearer ";
    return lowercase(authorization.substr(0, prefix.size())) == prefix &&
           equal_constant_time(trim(authorization.substr(prefix.size())), token);
  }

  // ---- security ----
  // Empty when allowed; else the status to answer (401 or 403) and a reason in `why`.
  int refused(const httplib::Request& request, bool changes, std::string& why) const {
    const std::string origin = lowercase(request.get_header_value("Origin"));
    const std::string host = lowercase(request.get_header_value("Host"));
    if (!own_hosts.count(host)) {
      std::string known;
      for (const std::string& name : own_hosts) known += (known.empty() ? "" : ", ") + name;
      why = "Host '" + escape_invalid_utf8(host) + "' is not one of this dashboard's names (" + known + ")";
      return 403;
    }
    if (!origin.empty() && origin != "http://" + host) {
      why = "Origin '" + escape_invalid_utf8(origin) + "' is not this dashboard's";
      return 403;
    }
    if (!changes && is_loopback_address(request.remote_addr)) return 0;
    if (!carries_token(request.get_header_value("Authorization"))) {
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
    response.set_content(json_text(json{{"ok", false}, {"error", why}}), "application/json");
    return false;
  }

  static void reply(httplib::Response& response, const json& body) {
    const bool ok = body.value("ok", false);
    const int exit = body.value("exit", ok ? 0 : 3);
    response.status = ok ? 200 : exit == kExitBadInput ? 400 : 409;
    response.set_content(json_text(body), "application/json");
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
      response.set_content(json_text(enriched_status()), "application/json");
    });
    server.Get("/api/trajectories", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, false)) return;
      json list = json::array();
      for (const auto& [name, description] : trajectory_catalogue()) {
        list.push_back({{"name", name}, {"description", description}});
      }
      response.set_content(json_text(list), "application/json");
    });
    server.Get("/api/recordings", [this](const httplib::Request& request, httplib::Response& response) {
      if (!allow(request, response, false)) return;
      response.set_content(json_text(recordings()), "application/json");
    });
    server.Get(R"(/api/recordings/([A-Za-z0-9_.-]+)\.(csv|png))",
               [this](const httplib::Request& request, httplib::Response& response) {
                 if (!allow(request, response, false)) return;
                 recording_file(request.matches[1], request.matches[2], response);
               });
    server.Get(R"(/api/recordings/([A-Za-z0-9_.-]+)\.csv/report)",
               [this](const httplib::Request& request, httplib::Response& response) {
                 if (!allow(request, response, false)) return;
                 recording_report(request.matches[1], response);
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
        response.set_content(
            json_text(json{{"ok", false},
                           {"error", escape_invalid_utf8(request.path) + ": a POST with a body needs Content-Length "
                                                                         "(curl: -d '{...}' or --json '{...}')"}}),
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
        reply(response, json{{"ok", false},
                             {"exit", kExitBadInput},
                             {"error", "run: the body is {\"trajectory\": NAME_OR_FILE, \"duration\": S}: " +
                                           escape_invalid_utf8(error.what())}});
      }
    });
    // Whatever a handler throws: an answer with a body, its text escaped.
    server.set_exception_handler([](const httplib::Request&, httplib::Response& response, std::exception_ptr failure) {
      std::string what = "unknown";
      try {
        std::rethrow_exception(failure);
      } catch (const std::exception& error) {
        what = error.what();
      } catch (...) {
      }
      response.status = 500;
      response.set_content(json_text(json{{"ok", false}, {"error", escape_invalid_utf8(what)}}), "application/json");
    });
  }

  static std::string find_or(const std::string& root) { return root.empty() ? find_web_root() : root; }

  // The recordings folder's regular files (not links, FIFOs or folders) named by the recording
  // name rule, newest first.
  json recordings() const {
    json list = json::array();
    std::error_code error;
    std::vector<std::pair<fs::path, fs::file_time_type>> files;
    for (const auto& entry : fs::directory_iterator(options.record_folder, error)) {
      const std::string name = entry.path().filename().string();
      std::error_code ignored;
      if (fs::is_regular_file(entry.symlink_status(ignored)) && recording_name_problem(name).empty()) {
        files.emplace_back(entry.path(), fs::last_write_time(entry.path(), ignored));
      }
    }
    std::sort(files.begin(), files.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
    for (const auto& [path, written] : files) {
      const std::string stem = path.stem().string();
      const auto modified = std::chrono::duration_cast<std::chrono::seconds>(
          written - fs::file_time_type::clock::now() + std::chrono::system_clock::now().time_since_epoch());
      std::error_code ignored;
      list.push_back({{"name", path.filename().string()},
                      {"bytes", fs::file_size(path, ignored)},
                      {"modified_unix_s", modified.count()},
                      {"csv", "/api/recordings/" + stem + ".csv"},
                      {"plot", "/api/recordings/" + stem + ".png"},
                      {"report", "/api/recordings/" + stem + ".csv/report"}});
    }
    return list;
  }

  // A regular file that is not a link.
  static bool is_plain_file(const std::string& path) {
    struct stat info {};
    return ::lstat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
  }

  // The content of a regular file, opened without following a link or waiting on a FIFO.
  static std::optional<std::string> read_plain_file(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return std::nullopt;
    struct stat info {};
    std::optional<std::string> text;
    if (::fstat(fd, &info) == 0 && S_ISREG(info.st_mode)) {
      text.emplace();
      char buffer[1 << 16];
      ssize_t n;
      while ((n = ::read(fd, buffer, sizeof buffer)) > 0) text->append(buffer, static_cast<std::size_t>(n));
      if (n < 0) text.reset();
    }
    ::close(fd);
    return text;
  }

  void recording_file(const std::string& stem, const std::string& kind, httplib::Response& response) {
    const std::string csv = options.record_folder + "/" + stem + ".csv";
    auto not_found = [&] {
      response.status = 404;
      response.set_content("no recording " + stem + ".csv\n", "text/plain");
    };
    if (!recording_name_problem(stem + ".csv").empty() || !is_plain_file(csv)) return not_found();
    std::string path = csv;
    if (kind == "png") {
      const std::string folder = options.record_folder + "/.plots";
      std::error_code error;
      if (!fs::exists(fs::symlink_status(folder, error))) fs::create_directory(folder, error);
      if (!fs::is_directory(fs::symlink_status(folder, error))) {
        response.status = 422;
        response.set_content(folder + " is not a folder (a link or a file): no plots are written there\n",
                             "text/plain");
        return;
      }
      path = folder + "/" + stem + ".png";
      std::lock_guard<std::mutex> lock(plot_mutex);
      if (!is_plain_file(path) || fs::last_write_time(path, error) < fs::last_write_time(csv, error)) {
        fs::remove(path, error);  // a link planted there is removed, never followed
        try {
          plot_recording(csv, path);
        } catch (const std::exception& failure) {
          response.status = 422;
          response.set_content(escape_invalid_utf8(failure.what()) + "\n", "text/plain");
          return;
        }
      }
    } else {
      response.set_header("Content-Disposition", "attachment; filename=\"" + stem + ".csv\"");
    }
    std::optional<std::string> text = read_plain_file(path);
    if (!text) return not_found();
    response.set_content(*text, content_type_of(path));
  }

  // run-report of a recording from its own columns (run_report.hpp: the joints, and the plate when
  // the recording has it), with its headline; kept while the file's size and time stay the same. A
  // recording that is no run (a drag with the drives off, a file cut short): 422 and why.
  void recording_report(const std::string& stem, httplib::Response& response) {
    const std::string csv = options.record_folder + "/" + stem + ".csv";
    if (!recording_name_problem(stem + ".csv").empty() || !is_plain_file(csv)) {
      response.status = 404;
      response.set_content(json_text(json{{"ok", false}, {"error", "no recording " + stem + ".csv"}}),
                           "application/json");
      return;
    }
    std::error_code error;
    const auto written = fs::last_write_time(csv, error);
    const auto bytes = fs::file_size(csv, error);
    std::lock_guard<std::mutex> lock(report_mutex);
    auto cached = reports.find(stem);
    if (cached == reports.end() || cached->second.written != written || cached->second.bytes != bytes) {
      CachedReport entry{written, bytes, 200, json()};
      try {
        const RunReport report = run_report_of_file(csv);
        entry.body = report_json(report);
        entry.body["run"] = stem + ".csv";  // not the server's path
        entry.body["headline"] = report_headline(report);
      } catch (const std::exception& failure) {
        std::string why = failure.what();
        if (why.rfind(options.record_folder + "/", 0) == 0) why = why.substr(options.record_folder.size() + 1);
        entry.status = 422;
        entry.body = json{{"ok", false}, {"error", why}};
      }
      if (reports.size() >= kReportsKept) reports.clear();
      cached = reports.insert_or_assign(stem, std::move(entry)).first;
    }
    response.status = cached->second.status;
    response.set_content(json_text(cached->second.body), "application/json");
  }

  // Server-Sent Events: the history first, then each published event; a client that falls more
  // than the ring behind skips to the newest (its socket's buffer full: its write times out).
  void stream(httplib::Response& response) {
    if (streams.fetch_add(1) >= options.max_streams) {
      streams.fetch_sub(1);
      response.status = 503;
      response.set_content(
          json_text(json{{"ok", false},
                         {"error", "too many telemetry clients (" + std::to_string(options.max_streams) + ")"}}),
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
                                 {"fault", 1 << board::kFlagFault},
                                 {"homing", 1 << board::kFlagHoming}};
              const json marks = {{"feed_held", kMarkFeedHeld}, {"estop_latched", kMarkEstopLatched}};
              text = "event: history\ndata: {\"flag_bits\":" + bits.dump() + ",\"mark_bits\":" + marks.dump() +
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
  d.server.set_payload_max_length(64 * 1024);
  d.routes();
  const int port = d.server.bind(d.options.address, d.options.port);
  if (port <= 0) {
    throw HostFailure(kExitFailure, "--http " + d.options.address + ":" + std::to_string(d.options.port) +
                                        ": cannot listen (in use, or not an address of this machine)");
  }
  d.options.port = port;
  d.own_hosts = own_host_names(d.options.address, port);
  d.open_front_door();
}

Dashboard::~Dashboard() { stop(); }

void Dashboard::start() {
  Impl& d = *impl_;
  d.publisher = std::thread([&d] { d.publish_loop(); });
  d.door->start();
}

void Dashboard::stop() {
  Impl& d = *impl_;
  if (d.stopping.exchange(true)) return;
  d.published.notify_all();
  d.door->stop();  // the streams see `stopping` within a second
  d.server.close_listener();
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

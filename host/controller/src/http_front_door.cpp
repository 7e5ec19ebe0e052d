// The dashboard's front door: heads read in one poll loop, connections served by lanes (see http_front_door.hpp).
#include "delta/controller/http_front_door.hpp"

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

namespace delta::controller {
namespace {

using Clock = std::chrono::steady_clock;

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string trimmed(const std::string& text) {
  std::size_t first = 0, last = text.size();
  while (first < last && std::isspace(static_cast<unsigned char>(text[first]))) ++first;
  while (last > first && std::isspace(static_cast<unsigned char>(text[last - 1]))) --last;
  return text.substr(first, last - first);
}

// A short answer written without waiting (the socket is non-blocking), then the connection closed:
// for a head that never completes, one too long, or a lane that is full.
void answer_and_close(int fd, int status, const char* reason, const std::string& json_body) {
  const std::string text = "HTTP/1.1 " + std::to_string(status) + " " + reason +
                           "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(json_body.size()) +
                           "\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n" + json_body;
  (void)::send(fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(fd, SHUT_WR);
  ::close(fd);
}

void close_connection(int fd) {
  ::shutdown(fd, SHUT_RDWR);
  ::close(fd);
}

// Where the head ends (after its blank line), or 0 while it has not.
std::size_t head_end(const std::string& received) {
  const std::size_t crlf = received.find("\r\n\r\n");
  const std::size_t lf = received.find("\n\n");
  if (crlf == std::string::npos && lf == std::string::npos) return 0;
  if (lf == std::string::npos || (crlf != std::string::npos && crlf + 2 < lf)) return crlf + 4;
  return lf + 2;
}

// One lane: its threads take connections from its queue, serve and close them.
class Lane {
 public:
  Lane(HttpLane spec, std::function<void(HttpConnection&)> serve) : spec_(std::move(spec)), serve_(std::move(serve)) {}

  void start() {
    for (int k = 0; k < std::max(1, spec_.threads); ++k) threads_.emplace_back([this] { work(); });
  }

  // False when the lane is full (or stopping): the caller answers 503.
  bool offer(HttpConnection&& connection) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_ || busy_ + waiting_.size() >= static_cast<std::size_t>(std::max(1, spec_.threads)) + spec_.queue) {
      return false;
    }
    waiting_.push_back(std::move(connection));
    wake_.notify_one();
    return true;
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
      for (HttpConnection& c : waiting_) close_connection(c.fd);
      waiting_.clear();
    }
    wake_.notify_all();
    for (std::thread& t : threads_) t.join();
    threads_.clear();
  }

  const HttpLane& spec() const { return spec_; }

 private:
  void work() {
    for (;;) {
      HttpConnection connection;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stopping_ || !waiting_.empty(); });
        if (stopping_) return;
        connection = std::move(waiting_.front());
        waiting_.pop_front();
        ++busy_;
      }
      try {
        serve_(connection);
      } catch (...) {  // the answer is lost, not the lane
      }
      close_connection(connection.fd);
      std::lock_guard<std::mutex> lock(mutex_);
      --busy_;
    }
  }

  HttpLane spec_;
  std::function<void(HttpConnection&)> serve_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<HttpConnection> waiting_;
  std::size_t busy_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace

std::string HttpConnection::header(const std::string& name) const {
  const std::string wanted = lowercase(name);
  std::size_t line = received.find('\n');  // past the request line
  while (line != std::string::npos && line + 1 < head_size) {
    const std::size_t start = line + 1;
    const std::size_t end = std::min(received.find('\n', start), head_size);
    const std::string text = received.substr(start, end - start);
    const std::size_t colon = text.find(':');
    if (colon != std::string::npos && lowercase(trimmed(text.substr(0, colon))) == wanted) {
      return trimmed(text.substr(colon + 1));
    }
    line = end < head_size ? end : std::string::npos;
  }
  return "";
}

struct HttpFrontDoor::Impl {
  int listen_fd = -1;
  int wake_fd = -1;
  std::vector<std::unique_ptr<Lane>> lanes;
  std::function<std::size_t(const HttpConnection&)> lane_of;
  HttpFrontDoorLimits limits;
  std::thread door;
  std::atomic<bool> stopping{false};
  bool started = false;

  struct Reading {
    int fd;
    Clock::time_point accepted;
    std::string received;
  };
  std::deque<Reading> reading;  // oldest first

  // The head is whole: parse its request line and hand it to its lane (or answer for it).
  void hand_over(Reading& r, std::size_t head_size) {
    HttpConnection c;
    c.fd = r.fd;
    c.received = std::move(r.received);
    c.head_size = head_size;
    c.accepted = r.accepted;
    const std::size_t line_end = c.received.find('\n');
    const std::string line = c.received.substr(0, line_end);
    const std::size_t first = line.find(' ');
    const std::size_t second = first == std::string::npos ? std::string::npos : line.find(' ', first + 1);
    c.method = line.substr(0, first);
    if (first != std::string::npos) {
      const std::string target =
          trimmed(line.substr(first + 1, second == std::string::npos ? second : second - first - 1));
      c.path = target.substr(0, target.find('?'));
    }
    const std::size_t lane = std::min(lane_of(c), lanes.size() - 1);
    const int fd = c.fd;
    if (!lanes[lane]->offer(std::move(c)))
      answer_and_close(fd, 503, "Service Unavailable", lanes[lane]->spec().busy_reply);
  }

  // Reads what arrived on `r`; true when it is done with (handed over or closed).
  bool read_some(Reading& r) {
    char buffer[4096];
    for (;;) {
      const ssize_t n = ::recv(r.fd, buffer, sizeof buffer, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        close_connection(r.fd);
        return true;
      }
      if (n < 0) return false;
      r.received.append(buffer, static_cast<std::size_t>(n));
      const std::size_t end = head_end(r.received);
      if (end != 0 && end <= limits.head_max_bytes) {
        hand_over(r, end);
        return true;
      }
      if (r.received.size() > limits.head_max_bytes) {
        answer_and_close(r.fd, 431, "Request Header Fields Too Large",
                         "{\"ok\":false,\"error\":\"the request's head is longer than " +
                             std::to_string(limits.head_max_bytes) + " bytes\"}");
        return true;
      }
    }
  }

  void accept_all() {
    for (;;) {
      const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) {
        if (errno == EINTR) continue;
        if ((errno == EMFILE || errno == ENFILE) && !reading.empty()) {  // make room: the oldest goes
          close_connection(reading.front().fd);
          reading.pop_front();
          continue;
        }
        return;  // EAGAIN: all taken
      }
      const int yes = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &yes, sizeof yes);
      if (reading.size() >= limits.max_reading) {
        close_connection(reading.front().fd);
        reading.pop_front();
      }
      reading.push_back(Reading{fd, Clock::now(), {}});
    }
  }

  void loop() {
    std::vector<pollfd> polled;
    while (!stopping.load()) {
      polled.clear();
      polled.push_back({wake_fd, POLLIN, 0});
      polled.push_back({listen_fd, POLLIN, 0});
      for (const Reading& r : reading) polled.push_back({r.fd, POLLIN, 0});
      int timeout_ms = -1;
      if (!reading.empty()) {
        const auto left = reading.front().accepted + limits.head_deadline - Clock::now();
        timeout_ms = static_cast<int>(
            std::max<long long>(0, std::chrono::duration_cast<std::chrono::milliseconds>(left).count() + 1));
      }
      const int ready = ::poll(polled.data(), polled.size(), timeout_ms);
      if (ready < 0 && errno != EINTR) break;
      if (polled[0].revents) break;
      // Reading first (the connections polled are reading[0..n)), then the deadline, then new ones.
      std::deque<Reading> still;
      for (std::size_t k = 0; k < reading.size(); ++k) {
        const short events = polled[k + 2].revents;
        if (events && read_some(reading[k])) continue;
        still.push_back(std::move(reading[k]));
      }
      reading.swap(still);
      const auto now = Clock::now();
      while (!reading.empty() && now - reading.front().accepted >= limits.head_deadline) {
        answer_and_close(reading.front().fd, 408, "Request Timeout",
                         "{\"ok\":false,\"error\":\"the request's head did not arrive within " +
                             std::to_string(limits.head_deadline.count()) + " ms\"}");
        reading.pop_front();
      }
      if (polled[1].revents & POLLIN) accept_all();
    }
    for (const Reading& r : reading) close_connection(r.fd);
    reading.clear();
  }
};

HttpFrontDoor::HttpFrontDoor(int listen_fd, std::vector<HttpLane> lanes,
                             std::function<std::size_t(const HttpConnection&)> lane_of,
                             std::function<void(HttpConnection&)> serve, HttpFrontDoorLimits limits)
    : impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  d.listen_fd = listen_fd;
  d.lane_of = std::move(lane_of);
  d.limits = limits;
  for (HttpLane& lane : lanes) d.lanes.push_back(std::make_unique<Lane>(std::move(lane), serve));
  if (d.lanes.empty()) d.lanes.push_back(std::make_unique<Lane>(HttpLane{"all", 4, 16, "{}"}, serve));
  ::listen(listen_fd, 512);  // a listening socket takes a new backlog
  const int flags = ::fcntl(listen_fd, F_GETFL);
  ::fcntl(listen_fd, F_SETFL, flags | O_NONBLOCK);
  d.wake_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
}

HttpFrontDoor::~HttpFrontDoor() {
  stop();
  if (impl_->wake_fd >= 0) ::close(impl_->wake_fd);
}

void HttpFrontDoor::start() {
  Impl& d = *impl_;
  if (d.started) return;
  d.started = true;
  for (auto& lane : d.lanes) lane->start();
  d.door = std::thread([&d] { d.loop(); });
}

void HttpFrontDoor::stop() {
  Impl& d = *impl_;
  if (d.stopping.exchange(true)) return;
  const std::uint64_t one = 1;
  (void)::write(d.wake_fd, &one, sizeof one);
  if (d.door.joinable()) d.door.join();
  for (auto& lane : d.lanes) lane->stop();
}

}  // namespace delta::controller

// The dashboard's front door: one thread accepts every HTTP connection and reads its request head
// against one deadline in a poll loop, then hands the connection to the lane its request belongs
// to (each lane its own threads and a bounded queue), so no client, idle, slow or busy, can take
// the threads another kind of request needs (docs/dashboard.md, "Real time").
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace delta::controller {

// One accepted connection whose request head has arrived whole.
struct HttpConnection {
  int fd = -1;
  std::string received;       // the head with its blank line, then whatever of the body came with it
  std::size_t head_size = 0;  // bytes of `received` up to and including the blank line
  std::string method;         // "GET", "POST", ...
  std::string path;           // the request target without its query
  std::chrono::steady_clock::time_point accepted;
  // The first value of a header (name case-insensitive, value trimmed); "" when absent.
  std::string header(const std::string& name) const;
};

struct HttpLane {
  std::string name;        // for the 503 when it is full
  int threads = 1;         // connections served at once
  std::size_t queue = 0;   // connections waiting beyond those; more are answered 503 at once
  std::string busy_reply;  // the 503's JSON body
};

struct HttpFrontDoorLimits {
  std::chrono::milliseconds head_deadline{2000};  // from accept to the head's blank line, in all
  std::size_t head_max_bytes = 16 * 1024;         // a longer head: 431
  std::size_t max_reading = 512;                  // heads being read at once; more: the oldest is dropped
};

class HttpFrontDoor {
 public:
  // `listen_fd` is bound and listening; the door makes it non-blocking with a backlog of 512 and
  // never closes it. `lane_of` picks a lane for each complete head; `serve` runs on that lane's
  // thread and answers the connection, which the lane then closes.
  HttpFrontDoor(int listen_fd, std::vector<HttpLane> lanes, std::function<std::size_t(const HttpConnection&)> lane_of,
                std::function<void(HttpConnection&)> serve, HttpFrontDoorLimits limits = {});
  ~HttpFrontDoor();
  void start();
  // No new connections; those waiting are closed; returns when every lane's `serve` has returned.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace delta::controller

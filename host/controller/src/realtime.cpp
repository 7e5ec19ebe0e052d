// Real-time support of the streaming thread (see realtime.hpp).
#include "delta/controller/realtime.hpp"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

namespace delta::controller {

std::string lock_memory() {
  if (::mlockall(MCL_CURRENT | MCL_FUTURE) == 0) return "";
  return std::string("mlockall: ") + std::strerror(errno);
}

std::string make_thread_realtime(int priority) {
  sched_param param{};
  param.sched_priority = priority;
  const int error = ::pthread_setschedparam(::pthread_self(), SCHED_FIFO, &param);
  if (error == 0) return "";
  return std::string("SCHED_FIFO ") + std::to_string(priority) + ": " + std::strerror(error);
}

timespec monotonic_now() {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return now;
}

std::int64_t to_ns(const timespec& t) { return static_cast<std::int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec; }

timespec from_ns(std::int64_t ns) {
  timespec t{};
  t.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  t.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  return t;
}

void sleep_until(std::int64_t deadline_ns) {
  const timespec deadline = from_ns(deadline_ns);
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
  }
}

void WakeLatency::record(std::int64_t late_ns) {
  late_ns = std::max<std::int64_t>(late_ns, 0);
  ++bins_[std::min<std::size_t>(static_cast<std::size_t>(late_ns / 1000), kBins)];
  ++count_;
  max_ns_ = std::max(max_ns_, late_ns);
}

double WakeLatency::percentile_us(double p) const {
  if (count_ == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(p / 100.0 * static_cast<double>(count_)));
  std::uint64_t seen = 0;
  for (std::size_t bin = 0; bin <= kBins; ++bin) {
    seen += bins_[bin];
    if (seen >= std::max<std::uint64_t>(rank, 1)) return bin == kBins ? max_us() : static_cast<double>(bin + 1);
  }
  return max_us();
}

}  // namespace delta::controller

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

WakeLatencyProbe measure_wake_latency(double seconds, int priority) {
  WakeLatencyProbe probe;
  int old_policy = 0;
  sched_param old_param{};
  ::pthread_getschedparam(::pthread_self(), &old_policy, &old_param);
  probe.realtime_note = priority > 0 ? make_thread_realtime(priority) : "not asked";
  constexpr std::int64_t kPeriodNs = 1'000'000;
  const auto total = std::max<std::int64_t>(1, std::llround(seconds * 1000.0));
  std::int64_t deadline = to_ns(monotonic_now());
  for (std::int64_t i = 0; i < total; ++i) {
    deadline += kPeriodNs;
    sleep_until(deadline);
    const std::int64_t late = to_ns(monotonic_now()) - deadline;
    probe.latency.record(late);
    if (late >= kPeriodNs) {  // keep the grid, as the streaming loop does
      probe.overruns += static_cast<std::uint64_t>(late / kPeriodNs);
      deadline += late / kPeriodNs * kPeriodNs;
    }
  }
  if (probe.realtime_note.empty()) ::pthread_setschedparam(::pthread_self(), old_policy, &old_param);
  return probe;
}

}  // namespace delta::controller

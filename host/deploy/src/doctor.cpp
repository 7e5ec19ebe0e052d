// deltactl doctor's measurements: the wake-latency probe and its LinuxCNC grading.
#include "delta/deploy/doctor.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>

namespace delta::deploy {

const char* verdict_name(Verdict verdict) {
  switch (verdict) {
    case Verdict::kOk:
      return "ok";
    case Verdict::kWarn:
      return "warn";
    case Verdict::kFail:
      return "FAIL";
    case Verdict::kSkip:
      return "skip";
  }
  return "?";
}

// LinuxCNC's latency-test: < 20 us very good, < 50 us good, < 100 us acceptable (servo), < 500 us
// poor (a base thread will not keep up), >= 500 us not acceptable.
std::string latency_band(double max_us) {
  if (max_us < 20) return "very good (< 20 us)";
  if (max_us < 50) return "good (< 50 us)";
  if (max_us < 100) return "acceptable (< 100 us)";
  if (max_us < 500) return "poor (< 500 us)";
  return "not acceptable (>= 500 us)";
}

Verdict latency_verdict(double max_us) {
  if (max_us < 100) return Verdict::kOk;
  if (max_us < 500) return Verdict::kWarn;
  return Verdict::kFail;
}

WakeLatency measure_wake_latency(double seconds) {
  WakeLatency result;
  sched_param param{};
  param.sched_priority = 80;
  int old_policy = 0;
  sched_param old_param{};
  pthread_getschedparam(pthread_self(), &old_policy, &old_param);
  result.realtime = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0;
  constexpr long kPeriodNs = 1000000;
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  const long total = std::max(1L, static_cast<long>(seconds * 1000.0));
  double sum = 0;
  for (long i = 0; i < total; ++i) {
    next.tv_nsec += kPeriodNs;
    if (next.tv_nsec >= 1000000000L) {
      next.tv_nsec -= 1000000000L;
      ++next.tv_sec;
    }
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) != 0) {
    }
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    const double late_us = ((now.tv_sec - next.tv_sec) * 1e9 + (now.tv_nsec - next.tv_nsec)) / 1e3;
    result.max_us = std::max(result.max_us, late_us);
    sum += late_us;
    ++result.samples;
  }
  result.mean_us = sum / static_cast<double>(result.samples);
  if (result.realtime) pthread_setschedparam(pthread_self(), old_policy, &old_param);
  return result;
}

}  // namespace delta::deploy

// deltactl doctor: the checks of a lab PC, each with a verdict and the fix for a failure.
#pragma once

#include <string>
#include <vector>

namespace delta::deploy {

enum class Verdict { kOk, kWarn, kFail, kSkip };  // skip: needs hardware or a file that is not there

struct Check {
  std::string name;
  Verdict verdict = Verdict::kSkip;
  std::string detail;  // what was measured
  std::string fix;     // what to do (empty when ok)
};

const char* verdict_name(Verdict verdict);

// LinuxCNC's latency-test bands for the worst wake-up latency (max jitter), microseconds.
std::string latency_band(double max_us);
Verdict latency_verdict(double max_us);

struct WakeLatency {
  double max_us = 0;
  double mean_us = 0;
  long samples = 0;
  bool realtime = false;  // ran as SCHED_FIFO
};
// Wakes at 1 kHz (absolute CLOCK_MONOTONIC deadlines) for `seconds`, SCHED_FIFO 80 if allowed.
WakeLatency measure_wake_latency(double seconds);

}  // namespace delta::deploy

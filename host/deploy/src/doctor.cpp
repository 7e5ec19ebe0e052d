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

}  // namespace delta::deploy

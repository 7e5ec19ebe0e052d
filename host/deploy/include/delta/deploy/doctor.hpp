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

// The worst wake-up latency (max jitter, microseconds) judged against the host's streaming budget.
std::string latency_band(double max_us);
Verdict latency_verdict(double max_us);

}  // namespace delta::deploy

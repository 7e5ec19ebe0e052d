// deltactl doctor's measurements: the wake-latency probe and its grading against the streaming budget.
#include "delta/deploy/doctor.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <string>

#include "delta/link/session.hpp"

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

// Against the host's streaming budget (docs/board_link.md, "Streaming budget"): the loop wakes
// every 1 ms and keeps link::kLinkTimeoutMs (200 ms) of setpoints ahead of the board, so a late
// wake-up costs nothing until it eats into that lead. Within a period: good; within a quarter of
// the budget: acceptable; within half: poor (little margin for a stall on top); beyond: the run may
// lose the link.
std::string latency_band(double max_us) {
  const double budget_us = link::kLinkTimeoutMs * 1e3;
  const std::string budget = std::to_string(link::kLinkTimeoutMs) + " ms streaming budget";
  if (max_us < 1000) return "good (< 1 ms, the loop's period)";
  if (max_us < budget_us / 4) return "acceptable (< 1/4 of the " + budget + ")";
  if (max_us < budget_us / 2) return "poor (< 1/2 of the " + budget + ")";
  return "not acceptable (>= 1/2 of the " + budget + ")";
}

Verdict latency_verdict(double max_us) {
  const double budget_us = link::kLinkTimeoutMs * 1e3;
  if (max_us < budget_us / 4) return Verdict::kOk;
  if (max_us < budget_us / 2) return Verdict::kWarn;
  return Verdict::kFail;
}

}  // namespace delta::deploy

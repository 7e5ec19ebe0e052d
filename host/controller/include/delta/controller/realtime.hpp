// Real-time support of the host's streaming thread: SCHED_FIFO and locked memory when the system
// permits them (a one-line warning otherwise: the loop still runs, with worse wake latency), an
// absolute-deadline sleep on CLOCK_MONOTONIC, and a wake-latency histogram (no allocation after
// construction; 1 us bins up to 10 ms, then one overflow bin).
#pragma once

#include <array>
#include <cstdint>
#include <ctime>
#include <string>

namespace delta::controller {

// mlockall(current and future); "" on success, else the reason (for the warning line).
std::string lock_memory();
// SCHED_FIFO at `priority` for the calling thread; "" on success, else the reason.
std::string make_thread_realtime(int priority);

timespec monotonic_now();
std::int64_t to_ns(const timespec& t);
timespec from_ns(std::int64_t ns);
// Sleeps until the absolute CLOCK_MONOTONIC time `deadline_ns` (restarted after signals).
void sleep_until(std::int64_t deadline_ns);

// The time a loop keeps its deadlines in: CLOCK_MONOTONIC for the lab's host (MonotonicClock), or
// another, e.g. the virtual board's board time in the co-simulation, where sleeping advances the
// board (cosim::BoardTimeClock). Nanoseconds.
class LoopClock {
 public:
  virtual ~LoopClock() = default;
  virtual std::int64_t now_ns() = 0;
  virtual void sleep_until_ns(std::int64_t deadline_ns) = 0;
};

class MonotonicClock final : public LoopClock {
 public:
  std::int64_t now_ns() override { return to_ns(monotonic_now()); }
  void sleep_until_ns(std::int64_t deadline_ns) override { sleep_until(deadline_ns); }
};

class WakeLatency {
 public:
  void record(std::int64_t late_ns);
  std::uint64_t count() const { return count_; }
  double percentile_us(double p) const;  // upper edge of the bin holding the p-th percentile
  double max_us() const { return static_cast<double>(max_ns_) / 1000.0; }

 private:
  static constexpr std::size_t kBins = 10000;  // 1 us each
  std::array<std::uint64_t, kBins + 1> bins_{};
  std::uint64_t count_ = 0;
  std::int64_t max_ns_ = 0;
};

// The wake latency of a 1 kHz loop with absolute deadlines run for `seconds` in the calling thread,
// as SCHED_FIFO at `priority` when permitted (0: normal scheduling); the thread's scheduling is
// restored after. What `deltactl host latency` and `deltactl doctor` report.
struct WakeLatencyProbe {
  WakeLatency latency;
  std::uint64_t overruns = 0;  // periods missed entirely
  std::string realtime_note;   // "" when SCHED_FIFO was granted, else why not (or "not asked")
};
WakeLatencyProbe measure_wake_latency(double seconds, int priority);

}  // namespace delta::controller

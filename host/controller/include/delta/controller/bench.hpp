// The bench bring-up checks (deltactl bench jog|switches|scale|soak, docs/bench.md): each a loop
// over a LinkSession that reads every telemetry frame with the drives off (jog: the board's own
// bounded open-loop jog) and prints what it sees, and the pure parts of each, fed telemetry
// frames, so that they are tested without a board. Every loop leaves the drives off on its way out
// (DrivesOff: a disable is sent on every path, a signal and a link loss included; the board's
// watchdog covers a host that dies). Nothing here enables the drives: the only command that turns
// them on is the board's jog (board::kCommandJogBase + 2 j + n), which the board bounds to
// board::kJogPeriods control periods at board::kJogCurrentCode and ends by itself.
#pragma once

#include <array>
#include <csignal>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/link/session.hpp"

namespace delta::controller::bench {

constexpr double kCountsPerDegree = 1e6 / board::kEncoderCountMicrodeg;      // the expected scale
constexpr std::uint8_t kSwitchBits = 0x7;                                    // the home byte's switch bits
constexpr std::uint16_t kRefusedMask = (1u << board::kBoardFaultShift) - 1;  // the refused counter's bits

// Where a bench command's lines go: `out` for what it reports (stdout), `note` for prompts and
// progress (stderr).
struct Output {
  std::string port;  // the board's, for the messages
  std::function<void(const std::string&)> out;
  std::function<void(const std::string&)> note;
};

// The outcome of a check: its exit code (0 passed, 1 the check failed, 3 the board faulted or is
// not ready, 4 the link was lost, 128 + N stopped by signal N) and, unless 0, one line saying why.
struct Outcome {
  int code = 0;
  std::string error;
};

// A board a bench check refuses: "" when it may start, else why not (exit 3): a latched fault
// (named), the drives on (another program?), a homing under way.
std::string refusal(const link::TelemetryPayload& telemetry, const std::string& port);

// A disable sent when this goes out of scope, whatever ended the check (a disable is always
// accepted; the board's jog ends with it). finish() sends it now and waits for a frame showing the
// drives off; the destructor only sends (the link may be gone).
class DrivesOff {
 public:
  explicit DrivesOff(link::LinkSession& session) : session_(session) {}
  ~DrivesOff();
  DrivesOff(const DrivesOff&) = delete;
  DrivesOff& operator=(const DrivesOff&) = delete;
  // The last frame, the drives off; throws link::LinkError when the board does not confirm.
  link::TelemetryPayload finish();

 private:
  link::LinkSession& session_;
  bool confirmed_ = false;
};

// ---- switches --------------------------------------------------------------------------------
struct SwitchEdge {
  double t_s = 0.0;  // board time since the watch began
  int joint = 0;     // 0-based
  bool closed = false;
  std::array<std::int16_t, 3> counts{};  // every joint's count at the frame that showed it
};

// The home switches' states, frame by frame: every change is an edge.
class SwitchWatch {
 public:
  struct Joint {
    bool seen_open = false, seen_closed = false;
    std::vector<std::int16_t> closing_counts, opening_counts;  // the joint's count at each edge
  };
  explicit SwitchWatch(const link::TelemetryPayload& first);
  std::vector<SwitchEdge> feed(const link::TelemetryPayload& telemetry);
  const std::array<Joint, 3>& joints() const { return joints_; }
  bool closed(int joint) const { return ((switches_ >> joint) & 1) != 0; }
  double seconds() const { return seconds_; }

 private:
  link::TelemetryPayload first_;
  std::uint8_t switches_;
  std::array<Joint, 3> joints_;
  double seconds_ = 0.0;
};

std::string describe_edge(const SwitchEdge& edge);
// One line per switch: open/closed seen, the count at each edge, the spread of the closing counts.
std::vector<std::string> switch_summary(const SwitchWatch& watch);
// "" when every switch was seen open and closed, else which were not and what to do.
std::string switch_problem(const SwitchWatch& watch);

struct SwitchesOptions {
  double duration_s = 0.0;  // board time; 0: until a signal
};
Outcome watch_switches(link::LinkSession& session, const SwitchesOptions& options,
                       const volatile std::sig_atomic_t& stop, const Output& output);

// ---- scale -----------------------------------------------------------------------------------
// Counts per degree between two fixture angles against the expected kCountsPerDegree.
struct ScaleResult {
  double counts_per_degree = 0.0;
  double error_percent = 0.0;  // (measured / expected - 1) * 100
  bool within = false;         // |error| <= tolerance
};
ScaleResult scale_result(double first_count, double second_count, double from_deg, double to_deg,
                         double tolerance_percent);

// A joint's count held still: the mean and spread over `frames` telemetry frames.
struct HeldReading {
  double mean = 0.0;
  int spread = 0;  // max - min, counts
};
HeldReading held_reading(const std::vector<link::TelemetryPayload>& frames, int joint);

struct ScaleOptions {
  int joint = 0;  // 0-based
  double from_deg = 0.0, to_deg = 0.0;
  double tolerance_percent = 0.5;
  double settle_s = -1.0;       // >= 0: wait this long (board time) at each fixture instead of Enter
  bool first_at_start = false;  // the joint is at the first fixture already: read it at once
  int input_fd = 0;             // where Enter comes from
  int reading_frames = 100;     // frames averaged per reading (100 ms)
  int max_spread_counts = 5;    // a reading that moved more: the joint was not held still
};
Outcome check_scale(link::LinkSession& session, const ScaleOptions& options, const volatile std::sig_atomic_t& stop,
                    const Output& output);

// ---- soak ------------------------------------------------------------------------------------
// One counter of the soak: its name, what it counted during the soak, and whether a count is a
// fault (the totals beside them are not).
struct SoakCounter {
  std::string name;
  std::uint64_t value = 0;
  bool fault = true;
};

// The soak's counters from the board's telemetry (their rise since the first frame) and the host's
// link statistics (their rise since `start`), plus the soak's own.
class SoakTally {
 public:
  SoakTally(const link::TelemetryPayload& first, const link::LinkStatistics& start);
  void feed(const link::TelemetryPayload& telemetry) { last_ = telemetry; }
  void count_unanswered() { ++unanswered_; }
  void count_late() { ++late_; }
  void count_request() { ++requests_; }
  std::vector<SoakCounter> counters(const link::LinkStatistics& now) const;
  // The board counters already saturated at the start (their rise cannot be seen), by name.
  std::vector<std::string> saturated_at_start() const;
  double seconds() const;

 private:
  link::TelemetryPayload first_, last_;
  link::LinkStatistics start_;
  std::uint64_t unanswered_ = 0, late_ = 0, requests_ = 0;
};

// "name value, ..." of the counters that counted a fault ("" when none).
std::string soak_faults(const std::vector<SoakCounter>& counters);

struct SoakOptions {
  double duration_s = 60.0;    // board time
  double progress_s = 10.0;    // a progress line every this much board time
  int commands_per_frame = 8;  // disable commands sent per telemetry frame (host -> board traffic)
  int late_ms = 100;           // a wall-clock gap between telemetry frames longer than this: late
  int answer_frames = 20;      // telemetry frames an identify request waits for its reply
};
Outcome soak(link::LinkSession& session, const SoakOptions& options, const volatile std::sig_atomic_t& stop,
             const Output& output);

// ---- jog -------------------------------------------------------------------------------------
// The command byte of the bench jog of joint j (0-based), n = 0 positive current, 1 negative.
constexpr std::uint8_t jog_command(int joint, bool negative) {
  return static_cast<std::uint8_t>(board::kCommandJogBase + 2 * joint + (negative ? 1 : 0));
}
bool jog_running(const link::TelemetryPayload& telemetry);

// A jog seen frame by frame: waiting for the board to start it, running, done.
class JogWatch {
 public:
  enum class Phase { kWaiting, kRunning, kDone };
  JogWatch(const link::TelemetryPayload& before, int joint);
  void feed(const link::TelemetryPayload& telemetry);
  Phase phase() const { return phase_; }
  int moved_counts() const { return end_count_ - start_count_; }  // start of the jog to its end
  int peak_counts() const { return peak_; }                       // the largest |moved| on the way
  int moved_so_far() const { return end_count_ - start_count_; }  // while it runs: from its start to now
  std::int16_t applied_current() const { return current_; }       // the joint's current while it ran
  int frames_running() const { return running_frames_; }
  bool other_joints_quiet() const { return others_quiet_; }  // the other joints' currents stayed 0
  bool refused() const { return refused_; }                  // the refused counter rose while waiting
  const link::TelemetryPayload& last() const { return last_; }

 private:
  link::TelemetryPayload before_, last_;
  int joint_;
  Phase phase_ = Phase::kWaiting;
  int start_count_, end_count_;
  int peak_ = 0, running_frames_ = 0;
  std::int16_t current_ = 0;
  bool others_quiet_ = true, refused_ = false;
};

struct JogOptions {
  int joint = 0;  // 0-based
  bool negative = false;
  int expect_sign = 0;    // +1 or -1: the count's expected direction; 0: either
  int min_counts = 5;     // fewer counts moved: the joint did not move
  int start_frames = 20;  // telemetry frames the board has to start the jog
  // The host's own bound on the jog's travel: once the joint has moved this far, a disable ends the
  // jog (the board bounds only its time and current; a free arm can turn far in 0.5 s).
  int max_move_counts = 500;
  double settle_s = 0.2;  // board time watched after the jog (the drives off) before the last count
};
// "" when the jog moved as expected, else why not (the joint did not move, moved the wrong way).
std::string jog_problem(const JogWatch& watch, const JogOptions& options);
Outcome jog(link::LinkSession& session, const JogOptions& options, const volatile std::sig_atomic_t& stop,
            const Output& output);

}  // namespace delta::controller::bench

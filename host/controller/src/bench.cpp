// The bench bring-up checks: switches, scale, soak and jog over a LinkSession (bench.hpp).
#include "delta/controller/bench.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>

#include "delta/controller/run_job.hpp"
#include "delta/table.hpp"

namespace delta::controller::bench {
namespace {

bool drives_on(const link::TelemetryPayload& t) { return t.has(link::TelemetryFlag::kDriveEnable); }

std::string joint_name(int joint) { return "joint " + std::to_string(joint + 1); }

std::string signed_counts(int counts) { return (counts > 0 ? "+" : "") + std::to_string(counts); }

std::string degrees(double counts) { return fixed(counts * board::kEncoderCountDeg, 2) + " deg"; }

Outcome stopped(int signal_number) {
  return {128 + signal_number, "stopped by signal " + std::to_string(signal_number) + " (drives off)"};
}

// The newest telemetry frame: the next one, then whatever else waits (older frames are stale).
link::TelemetryPayload newest(link::LinkSession& session) {
  link::TelemetryPayload t = session.next_telemetry();
  session.poll_frames();
  while (std::optional<link::TelemetryPayload> more = session.take_telemetry()) t = *more;
  return t;
}

}  // namespace

std::string refusal(const link::TelemetryPayload& t, const std::string& port) {
  if (t.has(link::TelemetryFlag::kFault)) {
    return port + ": the board has a fault latched (" + link::describe_state(t) +
           "): remove its cause, then clear it (deltactl host ctl clear-fault, or reset the board)";
  }
  if (jog_running(t)) return port + ": a bench jog is running (another program?); the drives are turned off";
  if (drives_on(t)) {
    return port +
           ": the drives are on (another program drives the board?); the bench checks start with the drives "
           "off: they are turned off";
  }
  return "";
}

DrivesOff::~DrivesOff() {
  if (confirmed_) return;
  try {
    session_.send_command(link::Command::kDisable);
  } catch (const std::exception&) {  // the link is gone: the board's watchdog and the jog's bound stop the drives
  }
}

link::TelemetryPayload DrivesOff::finish() {
  const link::TelemetryPayload t = session_.disable();
  confirmed_ = true;
  return t;
}

// ---- switches --------------------------------------------------------------------------------
SwitchWatch::SwitchWatch(const link::TelemetryPayload& first)
    : first_(first), switches_(static_cast<std::uint8_t>(first.home & kSwitchBits)) {
  for (int j = 0; j < 3; ++j) (closed(j) ? joints_[j].seen_closed : joints_[j].seen_open) = true;
}

std::vector<SwitchEdge> SwitchWatch::feed(const link::TelemetryPayload& t) {
  seconds_ = board_seconds_between(first_, t);
  std::vector<SwitchEdge> edges;
  const auto now = static_cast<std::uint8_t>(t.home & kSwitchBits);
  for (int j = 0; j < 3; ++j) {
    const bool was = ((switches_ >> j) & 1) != 0, is = ((now >> j) & 1) != 0;
    if (was == is) continue;
    SwitchEdge edge{seconds_, j, is, t.counts};
    (is ? joints_[j].seen_closed : joints_[j].seen_open) = true;
    (is ? joints_[j].closing_counts : joints_[j].opening_counts).push_back(t.counts[j]);
    edges.push_back(edge);
  }
  switches_ = now;
  return edges;
}

std::string describe_edge(const SwitchEdge& e) {
  return fixed(e.t_s, 3) + " s: switch " + std::to_string(e.joint + 1) + (e.closed ? " closed" : " opened") +
         " at count " + std::to_string(e.counts[e.joint]) + " (" + degrees(e.counts[e.joint]) + "); counts " +
         std::to_string(e.counts[0]) + ", " + std::to_string(e.counts[1]) + ", " + std::to_string(e.counts[2]);
}

namespace {
std::string count_list(const std::vector<std::int16_t>& counts) {
  constexpr std::size_t kShown = 8;
  std::string text;
  for (std::size_t i = 0; i < counts.size() && i < kShown; ++i) text += (i ? ", " : "") + std::to_string(counts[i]);
  if (counts.size() > kShown) text += ", ... (" + std::to_string(counts.size()) + " edges)";
  return text;
}
}  // namespace

std::vector<std::string> switch_summary(const SwitchWatch& watch) {
  std::vector<std::string> lines;
  for (int j = 0; j < 3; ++j) {
    const SwitchWatch::Joint& s = watch.joints()[j];
    std::string line = "switch " + std::to_string(j + 1) + ": " +
                       (s.seen_open && s.seen_closed ? "seen open and closed"
                        : s.seen_closed              ? "seen closed only"
                                                     : "seen open only");
    if (!s.closing_counts.empty()) {
      const auto [low, high] = std::minmax_element(s.closing_counts.begin(), s.closing_counts.end());
      line += "; closed at " + count_list(s.closing_counts) + " (spread " + std::to_string(*high - *low) +
              " counts = " + degrees(*high - *low) + ")";
    }
    if (!s.opening_counts.empty()) line += "; opened at " + count_list(s.opening_counts);
    if (s.closing_counts.empty() && s.opening_counts.empty()) line += "; no edge";
    lines.push_back(line);
  }
  return lines;
}

std::string switch_problem(const SwitchWatch& watch) {
  std::string missing;
  for (int j = 0; j < 3; ++j) {
    const SwitchWatch::Joint& s = watch.joints()[j];
    if (s.seen_open && s.seen_closed) continue;
    missing += (missing.empty() ? "" : ", ") + std::string("switch ") + std::to_string(j + 1) + " never seen " +
               (s.seen_open ? "closed" : "open");
  }
  if (missing.empty()) return "";
  return missing +
         ": move each arm by hand up through its switch and back (it closes at and above the home angle); a switch "
         "that never changes: check its wiring";
}

Outcome watch_switches(link::LinkSession& session, const SwitchesOptions& options,
                       const volatile std::sig_atomic_t& stop, const Output& output) {
  const link::TelemetryPayload first = newest(session);
  SwitchWatch watch(first);
  std::string start = "switches at the start:";
  for (int j = 0; j < 3; ++j) {
    start += std::string(j ? "," : "") + " " + std::to_string(j + 1) + (watch.closed(j) ? " closed" : " open") +
             " (count " + std::to_string(first.counts[j]) + ")";
  }
  output.out(start);
  output.note("bench switches: drives off; move each arm by hand up through its home switch and back" +
              (options.duration_s > 0 ? " (" + fixed(options.duration_s, 1) + " s)" : std::string(" (Ctrl-C ends)")));
  while (stop == 0 && (options.duration_s <= 0 || watch.seconds() < options.duration_s)) {
    const link::TelemetryPayload t = session.next_telemetry();
    const std::string why = refusal(t, output.port);
    if (!why.empty()) return {3, why};
    for (const SwitchEdge& edge : watch.feed(t)) output.out(describe_edge(edge));
  }
  output.out("summary after " + fixed(watch.seconds(), 1) + " s:");
  for (const std::string& line : switch_summary(watch)) output.out(line);
  const std::string problem = switch_problem(watch);
  if (!problem.empty()) return {1, problem};
  return {};
}

// ---- scale -----------------------------------------------------------------------------------
ScaleResult scale_result(double first_count, double second_count, double from_deg, double to_deg,
                         double tolerance_percent) {
  ScaleResult r;
  r.counts_per_degree = (second_count - first_count) / (to_deg - from_deg);
  r.error_percent = (r.counts_per_degree / kCountsPerDegree - 1.0) * 100.0;
  r.within = std::abs(r.error_percent) <= tolerance_percent;
  return r;
}

HeldReading held_reading(const std::vector<link::TelemetryPayload>& frames, int joint) {
  HeldReading r;
  if (frames.empty()) return r;
  double sum = 0.0;
  int low = frames.front().counts[joint], high = low;
  for (const link::TelemetryPayload& t : frames) {
    sum += t.counts[joint];
    low = std::min<int>(low, t.counts[joint]);
    high = std::max<int>(high, t.counts[joint]);
  }
  r.mean = sum / static_cast<double>(frames.size());
  r.spread = high - low;
  return r;
}

namespace {

// Waits for Enter on `fd` while reading telemetry: true when a line came, false at end of input.
// The refusal and the stop are checked at every frame (their outcome in `ended`).
bool wait_enter(link::LinkSession& session, int fd, const volatile std::sig_atomic_t& stop, const Output& output,
                std::optional<Outcome>& ended) {
  for (;;) {
    const link::TelemetryPayload t = session.next_telemetry();
    if (const std::string why = refusal(t, output.port); !why.empty()) {
      ended = Outcome{3, why};
      return true;
    }
    if (stop != 0) {
      ended = stopped(stop);
      return true;
    }
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 0) <= 0) continue;
    char c = 0;
    for (;;) {
      const ssize_t n = ::read(fd, &c, 1);
      if (n <= 0) return false;
      if (c == '\n') return true;
    }
  }
}

}  // namespace

Outcome check_scale(link::LinkSession& session, const ScaleOptions& options, const volatile std::sig_atomic_t& stop,
                    const Output& output) {
  const std::string joint = joint_name(options.joint);
  std::array<HeldReading, 2> readings;
  const std::array<double, 2> angles = {options.from_deg, options.to_deg};
  for (int k = 0; k < 2; ++k) {
    const std::string fixture = (k == 0 ? "first fixture, " : "second fixture, ") + fixed(angles[k], 2) + " deg";
    std::optional<Outcome> ended;
    if (k == 0 && options.first_at_start) {
      output.note("bench scale: reading " + joint + " at the " + fixture + " now");
    } else if (options.settle_s >= 0.0) {
      output.note("bench scale: hold " + joint + " at the " + fixture + "; reading in " + fixed(options.settle_s, 1) +
                  " s");
      const link::TelemetryPayload from = newest(session);
      for (link::TelemetryPayload t = from; board_seconds_between(from, t) < options.settle_s;) {
        t = session.next_telemetry();
        if (const std::string why = refusal(t, output.port); !why.empty()) return {3, why};
        if (stop != 0) return stopped(stop);
      }
    } else {
      output.note("bench scale: hold " + joint + " at the " + fixture + ", then press Enter");
      if (!wait_enter(session, options.input_fd, stop, output, ended)) {
        return {2, "the input ended before Enter: give --settle S to read at each fixture after S seconds"};
      }
      if (ended) return *ended;
    }
    std::vector<link::TelemetryPayload> frames;
    newest(session);  // frames older than the reading's start are not the fixture's
    while (static_cast<int>(frames.size()) < options.reading_frames) {
      frames.push_back(session.next_telemetry());
      if (const std::string why = refusal(frames.back(), output.port); !why.empty()) return {3, why};
      if (stop != 0) return stopped(stop);
    }
    readings[k] = held_reading(frames, options.joint);
    output.out(fixture + ": count " + fixed(readings[k].mean, 2) + " (" + degrees(readings[k].mean) + "), spread " +
               std::to_string(readings[k].spread) + " counts over " + std::to_string(frames.size()) + " frames");
    if (readings[k].spread > options.max_spread_counts) {
      return {1, joint + " moved " + std::to_string(readings[k].spread) + " counts while it was read at the " +
                     fixture + ": hold it still against the fixture and try again"};
    }
  }
  const ScaleResult r =
      scale_result(readings[0].mean, readings[1].mean, options.from_deg, options.to_deg, options.tolerance_percent);
  const std::string line = joint + ": " + fixed(readings[1].mean - readings[0].mean, 2) + " counts over " +
                           fixed(options.to_deg - options.from_deg, 2) + " deg: " + fixed(r.counts_per_degree, 3) +
                           " counts/deg measured, " + fixed(kCountsPerDegree, 3) +
                           " expected (0.01 deg a count): error " + (r.error_percent >= 0 ? "+" : "") +
                           fixed(r.error_percent, 3) + " % (tolerance " + fixed(options.tolerance_percent, 3) + " %)";
  output.out("scale: " + line);
  if (!r.within) {
    return {1, joint + "'s scale is " + fixed(r.error_percent, 3) + " % off (tolerance " +
                   fixed(options.tolerance_percent, 3) +
                   " %): check the encoder's lines per revolution and the gear ratio against the board's 0.01 deg a "
                   "count, and the fixture angles"};
  }
  return {};
}

// ---- soak ------------------------------------------------------------------------------------
SoakTally::SoakTally(const link::TelemetryPayload& first, const link::LinkStatistics& start)
    : first_(first), last_(first), start_(start) {}

double SoakTally::seconds() const { return board_seconds_between(first_, last_); }

namespace {
constexpr std::uint16_t kSaturated = 4095;  // the board's counters saturate there (docs/board_link.md)
std::uint64_t rise(std::uint16_t from, std::uint16_t to) { return to > from ? to - from : 0; }
}  // namespace

std::vector<SoakCounter> SoakTally::counters(const link::LinkStatistics& now) const {
  const link::DecoderCounters& d = now.decoder;
  const link::DecoderCounters& d0 = start_.decoder;
  return {
      {"board bad frames", rise(first_.bad_frames, last_.bad_frames)},
      {"board underruns", rise(first_.underruns, last_.underruns)},
      {"board saturations", rise(first_.saturations, last_.saturations)},
      {"board slew limits", rise(first_.slew_limits, last_.slew_limits)},
      {"board refused", rise(first_.rejected & kRefusedMask, last_.rejected & kRefusedMask)},
      {"host CRC errors", d.bad_crc - d0.bad_crc},
      {"host bad lengths", d.bad_length - d0.bad_length},
      {"host unknown types", d.unknown_type - d0.unknown_type},
      {"host bytes outside frames", d.skipped_bytes - d0.skipped_bytes},
      {"lost telemetry frames", now.lost_telemetry - start_.lost_telemetry},
      {"missed telemetry periods", now.skipped_telemetry - start_.skipped_telemetry},
      {"late telemetry frames", late_},
      {"unanswered identify requests", unanswered_},
      {"telemetry frames", now.telemetry_frames - start_.telemetry_frames, false},
      {"identify requests", requests_, false},
      {"identify replies", now.identify_frames - start_.identify_frames, false},
      {"frames sent", now.frames_sent - start_.frames_sent, false},
      {"bytes sent", now.bytes_sent - start_.bytes_sent, false},
      {"bytes received", now.bytes_received - start_.bytes_received, false},
  };
}

std::vector<std::string> SoakTally::saturated_at_start() const {
  std::vector<std::string> names;
  const std::pair<const char*, std::uint16_t> board[] = {{"board bad frames", first_.bad_frames},
                                                         {"board underruns", first_.underruns},
                                                         {"board saturations", first_.saturations},
                                                         {"board slew limits", first_.slew_limits},
                                                         {"board refused", first_.rejected & kRefusedMask}};
  for (const auto& [name, value] : board) {
    if (value >= kSaturated) names.push_back(name);
  }
  return names;
}

std::string soak_faults(const std::vector<SoakCounter>& counters) {
  std::string text;
  for (const SoakCounter& c : counters) {
    if (c.fault && c.value != 0) text += (text.empty() ? "" : ", ") + c.name + " " + std::to_string(c.value);
  }
  return text;
}

Outcome soak(link::LinkSession& session, const SoakOptions& options, const volatile std::sig_atomic_t& stop,
             const Output& output) {
  using Clock = std::chrono::steady_clock;
  link::TelemetryPayload previous = newest(session);
  SoakTally tally(previous, session.statistics());
  const std::vector<std::string> saturated = tally.saturated_at_start();
  if (!saturated.empty()) {
    std::string names;
    for (const std::string& n : saturated) names += (names.empty() ? "" : ", ") + n;
    return {3, "the board's counters " + names +
                   " are saturated (4095) already: a rise cannot be seen; reset the board, then soak"};
  }
  output.note("bench soak: " + fixed(options.duration_s, 0) +
              " s of board time, drives off: every telemetry frame read, identify requests answered one after "
              "another, " +
              std::to_string(options.commands_per_frame) + " disable commands per frame");
  // One identify request on its way at a time (the board answers each; two at once would share a reply).
  bool waiting = false;
  std::uint64_t replies_before = 0;
  int frames_waited = 0;
  const auto request = [&] {
    replies_before = session.statistics().identify_frames;
    session.send_identify_request();
    tally.count_request();
    waiting = true;
    frames_waited = 0;
  };
  request();
  const std::uint64_t frames_before = session.statistics().telemetry_frames;
  auto last_frame_at = Clock::now();
  double next_progress = options.progress_s;
  bool ending = false;
  Outcome outcome;
  for (;;) {
    const link::TelemetryPayload newest_frame = session.next_telemetry();
    const auto now = Clock::now();
    if (now - last_frame_at > std::chrono::milliseconds(options.late_ms)) tally.count_late();
    last_frame_at = now;
    std::vector<link::TelemetryPayload> frames = {newest_frame};
    while (std::optional<link::TelemetryPayload> more = session.take_telemetry()) frames.push_back(*more);
    for (const link::TelemetryPayload& t : frames) {
      if (static_cast<std::int32_t>(t.tick - previous.tick) < 0) {
        return {3, "the board restarted during the soak (its tick went back from " + std::to_string(previous.tick) +
                       " to " + std::to_string(t.tick) + ")"};
      }
      previous = t;
      tally.feed(t);
      if (const std::string why = refusal(t, output.port); !why.empty()) return {3, why};
      if (waiting) {
        if (session.statistics().identify_frames > replies_before) {
          waiting = false;
        } else if (++frames_waited > options.answer_frames) {
          tally.count_unanswered();
          waiting = false;
        }
      }
    }
    if (stop != 0) {
      outcome = stopped(stop);
      break;
    }
    if (!ending && tally.seconds() >= options.duration_s) ending = true;
    if (ending && !waiting) break;
    if (!ending) {
      if (!waiting) request();
      for (int k = 0; k < options.commands_per_frame; ++k) session.send_command(link::Command::kDisable);
    }
    if (tally.seconds() >= next_progress && !ending) {
      const std::string faults = soak_faults(tally.counters(session.statistics()));
      const double percent = 100.0 * tally.seconds() / options.duration_s;
      output.note("bench soak: " + fixed(tally.seconds(), 0) + " s of " + fixed(options.duration_s, 0) + " s (" +
                  fixed(percent, 0) + " %): " + std::to_string(session.statistics().telemetry_frames - frames_before) +
                  " telemetry frames; " + (faults.empty() ? "no fault counted" : "faults so far: " + faults));
      next_progress += options.progress_s;
    }
  }
  const std::vector<SoakCounter> counters = tally.counters(session.statistics());
  output.out("soak: " + fixed(tally.seconds(), 3) + " s of board time, drives off");
  for (const SoakCounter& c : counters) {
    output.out("  " + c.name + ": " + std::to_string(c.value) + (c.fault ? "" : " (total)"));
  }
  if (outcome.code != 0) return outcome;
  const std::string faults = soak_faults(counters);
  if (!faults.empty()) return {1, "the link counted faults: " + faults};
  output.out("soak: ok, no counter counted a fault");
  return {};
}

// ---- jog -------------------------------------------------------------------------------------
bool jog_running(const link::TelemetryPayload& t) { return ((t.home >> board::kTelemetryJogBit) & 1) != 0; }

JogWatch::JogWatch(const link::TelemetryPayload& before, int joint)
    : before_(before), last_(before), joint_(joint), start_count_(before.counts[joint]), end_count_(start_count_) {}

void JogWatch::feed(const link::TelemetryPayload& t) {
  switch (phase_) {
    case Phase::kWaiting:
      if (!jog_running(t)) {
        start_count_ = end_count_ = t.counts[joint_];
        if ((t.rejected & kRefusedMask) != (before_.rejected & kRefusedMask)) refused_ = true;
        break;
      }
      phase_ = Phase::kRunning;
      [[fallthrough]];
    case Phase::kRunning:
      if (!jog_running(t)) {
        phase_ = Phase::kDone;
        end_count_ = t.counts[joint_];
        break;
      }
      ++running_frames_;
      end_count_ = t.counts[joint_];
      if (std::abs(end_count_ - start_count_) > std::abs(peak_)) peak_ = end_count_ - start_count_;
      if (std::abs(t.currents[joint_]) > std::abs(current_)) current_ = t.currents[joint_];
      for (int j = 0; j < 3; ++j) {
        if (j != joint_ && t.currents[j] != 0) others_quiet_ = false;
      }
      break;
    case Phase::kDone:
      break;
  }
  last_ = t;
}

std::string jog_problem(const JogWatch& watch, const JogOptions& options) {
  const std::string joint = joint_name(options.joint);
  const int moved = watch.moved_counts();
  const std::string current =
      std::string(options.negative ? "-" : "+") + fixed(board::kJogCurrentCode * kCurrentCodeA, 3) + " A";
  if (std::abs(moved) < options.min_counts) {
    return joint + " did not move: " + signed_counts(moved) + " counts in the jog at " + current + " (fewer than " +
           std::to_string(options.min_counts) +
           "): check the motor's wiring, its drive (enable, current limit, fault) and that the arm is free";
  }
  if (options.expect_sign != 0 && (moved > 0 ? 1 : -1) != options.expect_sign) {
    return joint + " moved the wrong way: " + signed_counts(moved) + " counts for a jog at " + current +
           ", expected the count to " + (options.expect_sign > 0 ? "rise" : "fall") +
           ": the motor's or the encoder's direction is reversed (swap the motor's leads or the encoder's A and B)";
  }
  return "";
}

Outcome jog(link::LinkSession& session, const JogOptions& options, const volatile std::sig_atomic_t& stop,
            const Output& output) {
  const std::string joint = joint_name(options.joint);
  const link::TelemetryPayload before = newest(session);
  if (before.has(link::TelemetryFlag::kHoming)) {
    return {3,
            "the board is homing (a homing that did not finish): home it ('deltactl host home') or reset it, "
            "then jog"};
  }
  const std::string current =
      std::string(options.negative ? "-" : "+") + fixed(board::kJogCurrentCode * kCurrentCodeA, 3) + " A";
  const double jog_s = static_cast<double>(board::kJogPeriods) / board::kControlRateHz;
  JogWatch watch(before, options.joint);
  session.send_command(static_cast<link::Command>(jog_command(options.joint, options.negative)));
  output.note("bench jog: " + joint + " at " + current + " open loop for " + fixed(jog_s, 2) +
              " s (the board ends it and turns the drives off)");
  // The jog's bound on the board, with a margin of the host's: then the host turns the drives off.
  const int longest_frames = static_cast<int>(board::kJogPeriods / board::kPeriodsPerSetpoint) + 100;
  bool ended_by_host = false;
  for (int frames = 0; watch.phase() != JogWatch::Phase::kDone; ++frames) {
    const link::TelemetryPayload t = session.next_telemetry();
    watch.feed(t);
    if (t.has(link::TelemetryFlag::kFault)) {
      return {3, "the jog ended with a fault: " + link::describe_state(t)};
    }
    if (stop != 0) return stopped(stop);
    if (watch.phase() == JogWatch::Phase::kWaiting && frames >= options.start_frames) {
      if (watch.refused()) {
        return {3, "the board refused the jog (its refused counter rose; " + link::describe_state(t) + ")"};
      }
      return {3, "the board did not start the jog in " + std::to_string(options.start_frames) +
                     " telemetry frames (its gateware has no bench jog? deltactl host status names it)"};
    }
    if (watch.phase() == JogWatch::Phase::kRunning && !ended_by_host &&
        std::abs(watch.moved_so_far()) >= options.max_move_counts) {
      session.send_command(link::Command::kDisable);  // ends the jog at once
      ended_by_host = true;
      output.note("bench jog: " + joint + " moved " + signed_counts(watch.moved_so_far()) +
                  " counts: the host ended the jog (--max-move-deg " +
                  fixed(options.max_move_counts * board::kEncoderCountDeg, 2) + ")");
    }
    if (watch.phase() == JogWatch::Phase::kRunning && frames >= longest_frames) {
      return {3, "the jog did not end after " + std::to_string(frames) + " ms; the host turned the drives off"};
    }
  }
  const int moved = watch.moved_counts();
  if (drives_on(watch.last())) return {3, "the drives stayed on after the jog; the host turned them off"};
  // The arm after the jog, the drives off (it may coast, or fall).
  link::TelemetryPayload after = watch.last();
  while (board_seconds_between(watch.last(), after) < options.settle_s) {
    after = session.next_telemetry();
    if (const std::string why = refusal(after, output.port); !why.empty()) return {3, why};
    if (stop != 0) return stopped(stop);
  }
  const int coasted = after.counts[options.joint] - watch.last().counts[options.joint];
  output.out("jog: " + joint + " moved " + signed_counts(moved) + " counts (" + (moved > 0 ? "+" : "") +
             degrees(moved) + ") in " + std::to_string(watch.frames_running()) + " ms at " + current + " (applied " +
             fixed(watch.applied_current() * kCurrentCodeA, 3) + " A; largest excursion " +
             signed_counts(watch.peak_counts()) + " counts); direction seen: " +
             (moved > 0   ? "count rising"
              : moved < 0 ? "count falling"
                          : "none") +
             "; " + signed_counts(coasted) + " counts in the " + fixed(options.settle_s, 1) + " s after, drives off");
  if (!watch.other_joints_quiet()) output.note("bench jog: another joint's current was not 0 during the jog");
  const std::string problem = jog_problem(watch, options);
  if (!problem.empty()) return {1, problem};
  output.out("jog: ok");
  return {};
}

}  // namespace delta::controller::bench

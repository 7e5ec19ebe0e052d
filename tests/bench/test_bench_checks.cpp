// The bench checks (delta/controller/bench.hpp) without a board: the switch watch, the scale, the
// soak's counters and the jog's watch fed telemetry frames, and the jog and soak loops against a
// scripted board in line time that keeps the bench jog's rules (docs/bench.md: accepted with the
// drives off and no fault, the drives on for board::kJogPeriods, the jog bit in the home byte) and
// records every command it takes, so that the drives-off guarantee is checked on every way out.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "delta/board_facts.hpp"
#include "delta/controller/bench.hpp"
#include "delta/io/byte_stream.hpp"
#include "delta/link/frame_codec.hpp"
#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"
#include "support/line_time_board.hpp"

namespace delta {
namespace {

using controller::bench::JogWatch;
using controller::bench::SwitchWatch;
namespace bench = controller::bench;

link::TelemetryPayload frame_at(std::uint32_t ms, std::uint8_t switches = 0, std::array<std::int16_t, 3> counts = {}) {
  link::TelemetryPayload t;
  t.tick = ms * static_cast<std::uint32_t>(board::kPeriodsPerSetpoint);
  t.home = switches;
  t.counts = counts;
  return t;
}

TEST(BenchSwitches, EveryChangeIsAnEdgeWithItsCountAndTheSummaryNamesWhatWasNotSeen) {
  SwitchWatch watch(frame_at(0, 0b010, {2500, 3000, 2600}));
  EXPECT_TRUE(watch.closed(1));
  EXPECT_FALSE(watch.closed(0));
  EXPECT_TRUE(watch.feed(frame_at(1, 0b010, {2600, 3000, 2600})).empty());
  // Joint 1 closes at 3001 while joint 2 opens at 2999: two edges in one frame.
  const auto edges = watch.feed(frame_at(2, 0b001, {3001, 2999, 2600}));
  ASSERT_EQ(edges.size(), 2u);
  EXPECT_EQ(edges[0].joint, 0);
  EXPECT_TRUE(edges[0].closed);
  EXPECT_EQ(edges[0].counts[0], 3001);
  EXPECT_EQ(edges[1].joint, 1);
  EXPECT_FALSE(edges[1].closed);
  EXPECT_DOUBLE_EQ(edges[0].t_s, 0.002);
  EXPECT_NE(bench::describe_edge(edges[0]).find("switch 1 closed at count 3001 (30.01 deg)"), std::string::npos);
  watch.feed(frame_at(3, 0b000, {2990, 2999, 2600}));
  watch.feed(frame_at(4, 0b001, {3004, 2999, 2600}));
  // Bits above the switches (referenced, jog) are no switch.
  EXPECT_TRUE(watch.feed(frame_at(5, 0b1111001, {3004, 2999, 2600})).empty());
  EXPECT_EQ(watch.joints()[0].closing_counts, (std::vector<std::int16_t>{3001, 3004}));
  EXPECT_EQ(watch.joints()[0].opening_counts, (std::vector<std::int16_t>{2990}));
  const std::vector<std::string> summary = bench::switch_summary(watch);
  EXPECT_NE(summary[0].find("seen open and closed; closed at 3001, 3004 (spread 3 counts = 0.03 deg)"),
            std::string::npos)
      << summary[0];
  EXPECT_NE(summary[2].find("seen open only; no edge"), std::string::npos) << summary[2];
  const std::string problem = bench::switch_problem(watch);
  EXPECT_NE(problem.find("switch 3 never seen closed"), std::string::npos) << problem;
  EXPECT_EQ(problem.find("switch 1"), std::string::npos) << problem;
  EXPECT_EQ(problem.find("switch 2"), std::string::npos) << problem;
}

TEST(BenchScale, CountsPerDegreeAgainstTheBoardsHundred) {
  const bench::ScaleResult exact = bench::scale_result(1000.0, 3000.0, 10.0, 30.0, 0.5);
  EXPECT_DOUBLE_EQ(exact.counts_per_degree, 100.0);
  EXPECT_NEAR(exact.error_percent, 0.0, 1e-12);
  EXPECT_TRUE(exact.within);
  // 1 % more counts: outside 0.5 %, inside 2 %; the sign of the travel does not matter.
  const bench::ScaleResult more = bench::scale_result(3000.0, 980.0, 30.0, 10.0, 0.5);
  EXPECT_NEAR(more.error_percent, 1.0, 1e-9);
  EXPECT_FALSE(more.within);
  EXPECT_TRUE(bench::scale_result(3000.0, 980.0, 30.0, 10.0, 2.0).within);
  // An encoder counting down where the angle rises: -200 %.
  EXPECT_NEAR(bench::scale_result(3000.0, 1000.0, 10.0, 30.0, 0.5).error_percent, -200.0, 1e-9);
  const std::vector<link::TelemetryPayload> held = {frame_at(0, 0, {0, 100, 0}), frame_at(1, 0, {0, 103, 0}),
                                                    frame_at(2, 0, {0, 101, 0})};
  const bench::HeldReading r = bench::held_reading(held, 1);
  EXPECT_NEAR(r.mean, 304.0 / 3.0, 1e-12);
  EXPECT_EQ(r.spread, 3);
}

TEST(BenchSoak, CountersAreTheRiseSinceTheStartAndTheBoardCausesAreNoRefusals) {
  link::TelemetryPayload first = frame_at(0);
  first.bad_frames = 7;  // before the soak: not the soak's
  first.rejected = 2;
  link::LinkStatistics start;
  start.decoder.bad_crc = 1;
  start.lost_telemetry = 3;
  bench::SoakTally tally(first, start);
  EXPECT_TRUE(tally.saturated_at_start().empty());
  link::TelemetryPayload last = frame_at(10000);
  last.bad_frames = 7;
  last.rejected = static_cast<std::uint16_t>(2 | (1u << board::kBoardFaultShift));  // a board cause: bits 12-15
  tally.feed(last);
  link::LinkStatistics now = start;
  now.telemetry_frames = 10000;
  EXPECT_EQ(bench::soak_faults(tally.counters(now)), "");
  EXPECT_DOUBLE_EQ(tally.seconds(), 10.0);
  last.bad_frames = 9;
  last.underruns = 1;
  tally.feed(last);
  now.decoder.bad_crc = 5;
  now.lost_telemetry = 4;
  tally.count_unanswered();
  EXPECT_EQ(bench::soak_faults(tally.counters(now)),
            "board bad frames 2, board underruns 1, host CRC errors 4, lost telemetry frames 1, unanswered identify "
            "requests 1");
  // The totals are no faults, however large.
  for (const bench::SoakCounter& c : tally.counters(now)) {
    if (c.name == "telemetry frames") {
      EXPECT_FALSE(c.fault);
    }
  }
  link::TelemetryPayload saturated = frame_at(0);
  saturated.underruns = 4095;
  EXPECT_EQ(bench::SoakTally(saturated, start).saturated_at_start(), (std::vector<std::string>{"board underruns"}));
}

link::TelemetryPayload jogging(std::uint32_t ms, std::int16_t count, std::int16_t current) {
  link::TelemetryPayload t = frame_at(ms, 1u << board::kTelemetryJogBit, {3000, count, 3000});
  t.set(link::TelemetryFlag::kDriveEnable, true);
  t.currents[1] = current;
  return t;
}

TEST(BenchJog, TheWatchMeasuresFromTheJogsStartToItsEndAndNamesAStillOrReversedJoint) {
  JogWatch watch(frame_at(0, 0, {3000, 2000, 3000}), 1);
  watch.feed(frame_at(1, 0, {3000, 2002, 3000}));  // the arm drifted before the jog: not the jog's
  EXPECT_EQ(watch.phase(), JogWatch::Phase::kWaiting);
  for (std::uint32_t ms = 2; ms < 502; ++ms) {
    watch.feed(jogging(ms, static_cast<std::int16_t>(2002 + (ms - 1) / 10),
                       static_cast<std::int16_t>(board::kJogCurrentCode)));
  }
  EXPECT_EQ(watch.phase(), JogWatch::Phase::kRunning);
  watch.feed(frame_at(502, 0, {3000, 2052, 3000}));
  EXPECT_EQ(watch.phase(), JogWatch::Phase::kDone);
  EXPECT_EQ(watch.moved_counts(), 50);
  EXPECT_EQ(watch.frames_running(), 500);
  EXPECT_EQ(watch.applied_current(), board::kJogCurrentCode);
  EXPECT_TRUE(watch.other_joints_quiet());
  bench::JogOptions options;
  options.joint = 1;
  options.expect_sign = 1;
  EXPECT_EQ(bench::jog_problem(watch, options), "");
  options.expect_sign = -1;
  EXPECT_NE(bench::jog_problem(watch, options).find("joint 2 moved the wrong way: +50 counts"), std::string::npos);
  options.expect_sign = 0;
  EXPECT_EQ(bench::jog_problem(watch, options), "");

  JogWatch still(frame_at(0, 0, {3000, 2000, 3000}), 1);
  still.feed(jogging(1, 2001, static_cast<std::int16_t>(board::kJogCurrentCode)));
  still.feed(frame_at(2, 0, {3000, 2003, 3000}));
  EXPECT_NE(bench::jog_problem(still, options).find("joint 2 did not move: +3 counts"), std::string::npos);
}

// ---- a scripted board ------------------------------------------------------------------------
// In line time: the host's bytes reach it at 10 us a byte, every 1 ms it sends telemetry; it answers
// identify requests, takes disable (drives off, a jog ended) and the bench jog (drives off and no
// fault: the drives on for kJogPeriods, the joint's count moving `counts_per_ms` a millisecond with
// the current's sign), refuses any other command and every setpoint (the drives off).
class ScriptedBenchBoard : public test::LineTimeBoard {
 public:
  int counts_per_ms = 1;               // the jogged joint's motion (negative: a reversed motor)
  bool knows_jog = true;               // false: a gateware without the bench jog (the command byte refused)
  bool fault = false;                  // a latched fault (watchdog)
  std::size_t corrupt_every = 0;       // every Nth byte to the host flipped (0: none)
  std::vector<std::uint8_t> commands;  // every command byte the board took, in order
  volatile std::sig_atomic_t* stop_at_jog_ms = nullptr;  // set to SIGINT 100 ms into a jog (a Ctrl-C)
  int jog_ms_left_at_disable = -1;                       // the jog's milliseconds left when a disable came
  int identify_requests = 0;
  bool drives_on() const { return jog_ms_ > 0; }
  // The line delivers what the host sent last (nobody reading).
  void run_ms(int ms) {
    for (int k = 0; k < 100 * ms; ++k) step();
  }

  void write_all(const std::uint8_t* data, std::size_t size, int) override {
    line_.insert(line_.end(), data, data + size);
  }

 private:
  void step() override {  // one byte time, 10 us
    ++time_;
    if (!line_.empty()) {
      const std::uint8_t byte = line_.front();
      line_.pop_front();
      for (const link::Frame& frame : decoder_.feed(&byte, 1)) take(frame);
    }
    if (time_ % 100 == 0) tick_ms();
  }
  void take(const link::Frame& frame) {
    last_sequence_ = frame.sequence;
    if (frame.type == link::FrameType::kIdentifyRequest) {
      ++identify_requests;
      send(link::make_frame(frame.sequence, link::board_identify(0, 0)));
      return;
    }
    if (frame.type != link::FrameType::kCommand) {
      ++rejected_;
      return;
    }
    const std::uint8_t byte = frame.payload.at(0);
    commands.push_back(byte);
    if (byte == board::kCommandDisable) {
      if (jog_ms_ > 0) jog_ms_left_at_disable = jog_ms_;
      jog_ms_ = 0;
      return;
    }
    const int jog = byte - static_cast<int>(board::kCommandJogBase);
    if (knows_jog && jog >= 0 && jog < 6 && jog_ms_ == 0 && !fault) {
      jog_joint_ = jog / 2;
      jog_sign_ = jog % 2 == 0 ? 1 : -1;
      jog_ms_ = static_cast<int>(board::kJogPeriods / board::kPeriodsPerSetpoint);
      return;
    }
    ++rejected_;
  }
  void tick_ms() {
    ++ms_;
    link::TelemetryPayload t;
    t.tick = static_cast<std::uint32_t>(ms_ * board::kPeriodsPerSetpoint);
    if (jog_ms_ > 0) {
      counts_[jog_joint_] = static_cast<std::int16_t>(counts_[jog_joint_] + jog_sign_ * counts_per_ms);
      --jog_ms_;
      if (stop_at_jog_ms && jog_ms_ == board::kJogPeriods / board::kPeriodsPerSetpoint - 100) *stop_at_jog_ms = SIGINT;
    }
    t.counts = counts_;
    if (jog_ms_ > 0) {
      t.set(link::TelemetryFlag::kDriveEnable, true);
      t.home = static_cast<std::uint8_t>(1u << board::kTelemetryJogBit);
      t.currents[jog_joint_] = static_cast<std::int16_t>(jog_sign_ * board::kJogCurrentCode);
    }
    if (fault) {
      t.set(link::TelemetryFlag::kFault, true);
      t.set(link::FaultCause::kWatchdog, true);
    }
    t.rejected = rejected_;
    t.sequence = last_sequence_;
    send(link::make_frame(telemetry_sequence_++, t));
  }
  void send(const link::Frame& frame) {
    for (std::uint8_t byte : link::encode_frame(frame)) {
      ++sent_bytes_;
      to_host_.push_back(corrupt_every != 0 && sent_bytes_ % corrupt_every == 0 ? static_cast<std::uint8_t>(byte ^ 0x04)
                                                                                : byte);
    }
  }

  link::FrameDecoder decoder_{link::Receiver::kBoard};
  std::deque<std::uint8_t> line_;
  std::uint64_t time_ = 0, ms_ = 0, sent_bytes_ = 0;
  std::array<std::int16_t, 3> counts_ = {3000, 3000, 3000};
  int jog_ms_ = 0, jog_joint_ = 0, jog_sign_ = 1;
  std::uint16_t rejected_ = 0;
  std::uint8_t last_sequence_ = 0, telemetry_sequence_ = 0;
};

struct Captured {
  std::vector<std::string> out, note;
  bench::Output output() {
    return {"scripted", [this](const std::string& l) { out.push_back(l); },
            [this](const std::string& l) { note.push_back(l); }};
  }
  bool out_has(const std::string& text) const {
    return std::any_of(out.begin(), out.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; });
  }
};

const volatile std::sig_atomic_t kNoStop = 0;

bench::Outcome jog_on(ScriptedBenchBoard& board, bench::JogOptions options, Captured& captured) {
  link::LinkSession session(board);
  bench::Outcome outcome;
  {
    bench::DrivesOff off(session);
    outcome = bench::jog(session, options, kNoStop, captured.output());
    if (outcome.code == 0) off.finish();
  }
  board.run_ms(2);
  return outcome;
}

TEST(BenchJog, AJogOnTheScriptedBoardIsMeasuredAndEndsWithADisable) {
  ScriptedBenchBoard board;
  board.counts_per_ms = 2;
  bench::JogOptions options;
  options.joint = 2;
  options.negative = true;
  options.expect_sign = -1;
  options.max_move_counts = 10000;  // the whole jog
  Captured captured;
  const bench::Outcome outcome = jog_on(board, options, captured);
  EXPECT_EQ(outcome.code, 0) << outcome.error;
  // The board moved the joint 2 counts for each millisecond of its jog.
  const int ms = static_cast<int>(board::kJogPeriods / board::kPeriodsPerSetpoint);
  EXPECT_TRUE(captured.out_has("joint 3 moved " + std::to_string(-2 * ms) + " counts")) << captured.out.at(0);
  EXPECT_TRUE(captured.out_has("count falling"));
  ASSERT_GE(board.commands.size(), 2u);
  EXPECT_EQ(board.commands.front(), board::kCommandJogBase + 2 * 2 + 1);
  EXPECT_EQ(board.commands.back(), board::kCommandDisable);
  EXPECT_FALSE(board.drives_on());
}

TEST(BenchJog, TheHostEndsAJogThatHasMovedTheJointItsMaximum) {
  ScriptedBenchBoard board;
  board.counts_per_ms = 5;
  bench::JogOptions options;
  options.max_move_counts = 100;
  Captured captured;
  const bench::Outcome outcome = jog_on(board, options, captured);
  EXPECT_EQ(outcome.code, 0) << outcome.error;
  // The disable went out at the frame that showed 100 counts; the board took it with most of the jog to run.
  const int jog_ms = static_cast<int>(board::kJogPeriods / board::kPeriodsPerSetpoint);
  EXPECT_GT(board.jog_ms_left_at_disable, jog_ms - 100 / 5 - 3);
  EXPECT_TRUE(captured.out_has("joint 1 moved +1")) << captured.out.at(0);
  EXPECT_FALSE(board.drives_on());
}

TEST(BenchJog, AReversedMotorAndAStuckJointFailAndTheDrivesEndOff) {
  ScriptedBenchBoard reversed;
  reversed.counts_per_ms = -1;
  bench::JogOptions options;
  options.joint = 0;
  options.expect_sign = 1;
  Captured a;
  const bench::Outcome wrong = jog_on(reversed, options, a);
  EXPECT_EQ(wrong.code, 1);
  EXPECT_NE(wrong.error.find("moved the wrong way"), std::string::npos) << wrong.error;
  EXPECT_EQ(reversed.commands.back(), board::kCommandDisable);

  ScriptedBenchBoard stuck;
  stuck.counts_per_ms = 0;
  Captured b;
  const bench::Outcome still = jog_on(stuck, options, b);
  EXPECT_EQ(still.code, 1);
  EXPECT_NE(still.error.find("joint 1 did not move: 0 counts"), std::string::npos) << still.error;
  EXPECT_EQ(stuck.commands.back(), board::kCommandDisable);
}

TEST(BenchJog, ACtrlCInTheJogTurnsTheDrivesOffAtOnce) {
  ScriptedBenchBoard board;
  volatile std::sig_atomic_t stop = 0;
  board.stop_at_jog_ms = &stop;
  link::LinkSession session(board);
  Captured captured;
  bench::Outcome outcome;
  {
    bench::DrivesOff off(session);
    outcome = bench::jog(session, bench::JogOptions{}, stop, captured.output());
  }
  board.run_ms(2);
  EXPECT_EQ(outcome.code, 128 + SIGINT);
  EXPECT_FALSE(board.drives_on());
  // The disable came within a few frames of the signal, most of the jog still to run.
  const int jog_ms = static_cast<int>(board::kJogPeriods / board::kPeriodsPerSetpoint);
  EXPECT_GT(board.jog_ms_left_at_disable, jog_ms - 100 - 5);
  EXPECT_EQ(board.commands.back(), board::kCommandDisable);
}

TEST(BenchJog, ABoardWithoutTheJogRefusesItAndNothingIsSentAgain) {
  ScriptedBenchBoard old;
  old.knows_jog = false;
  bench::JogOptions options;
  Captured captured;
  const bench::Outcome outcome = jog_on(old, options, captured);
  EXPECT_EQ(outcome.code, 3);
  EXPECT_NE(outcome.error.find("the board refused the jog"), std::string::npos) << outcome.error;
  // One jog byte only (a jog is never resent: a second might start a second jog), then the disable.
  EXPECT_EQ(std::count(old.commands.begin(), old.commands.end(), board::kCommandJogBase), 1);
  EXPECT_EQ(old.commands.back(), board::kCommandDisable);
}

TEST(BenchSoak, ACleanLinkCountsNothingAndACorruptedOneNamesTheHostsCrcErrors) {
  bench::SoakOptions options;
  options.duration_s = 2.0;
  options.progress_s = 1.0;
  {
    ScriptedBenchBoard board;
    link::LinkSession session(board);
    Captured captured;
    const bench::Outcome outcome = bench::soak(session, options, kNoStop, captured.output());
    EXPECT_EQ(outcome.code, 0) << outcome.error;
    EXPECT_TRUE(captured.out_has("board bad frames: 0"));
    EXPECT_TRUE(captured.out_has("host CRC errors: 0"));
    EXPECT_TRUE(captured.out_has("soak: ok"));
    // About one request a frame, each answered before the next; 8 disables a frame.
    EXPECT_GT(board.identify_requests, 1000);
    EXPECT_GT(std::count(board.commands.begin(), board.commands.end(), board::kCommandDisable), 8 * 1500);
    EXPECT_EQ(captured.note.size(), 2u);  // the start, one progress line at 1 s
  }
  {
    ScriptedBenchBoard board;
    board.corrupt_every = 5000;
    link::LinkSession session(board);
    Captured captured;
    const bench::Outcome outcome = bench::soak(session, options, kNoStop, captured.output());
    EXPECT_EQ(outcome.code, 1);
    EXPECT_NE(outcome.error.find("host CRC errors"), std::string::npos) << outcome.error;
  }
}

TEST(BenchChecks, AFaultedBoardIsRefusedNamingTheCause) {
  link::TelemetryPayload t = frame_at(5);
  EXPECT_EQ(bench::refusal(t, "tty"), "");
  t.set(link::TelemetryFlag::kFault, true);
  t.set(link::FaultCause::kWatchdog, true);
  EXPECT_NE(bench::refusal(t, "tty").find("tty: the board has a fault latched"), std::string::npos);
  EXPECT_NE(bench::refusal(t, "tty").find("watchdog"), std::string::npos) << bench::refusal(t, "tty");
  // A fault mid-soak ends it with exit 3.
  ScriptedBenchBoard board;
  board.fault = true;
  link::LinkSession session(board);
  Captured captured;
  bench::SoakOptions options;
  options.duration_s = 1.0;
  EXPECT_EQ(bench::soak(session, options, kNoStop, captured.output()).code, 3);
}

}  // namespace
}  // namespace delta

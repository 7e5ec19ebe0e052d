// The model board (host/cosim/include/delta/cosim/model_board.hpp) against the RTL board: the same host session
// (experiment 1 with the paper-like robot over link v2) through both virtual boards must give the
// same board: every telemetry frame equal in every field, and at every 10 kHz control period the
// same drive currents the world applies, encoder lines, plant angles and status pins.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <iostream>
#include <string>
#include <vector>

#include "../support/stream_with_the_lab_loop.hpp"
#include "delta/controller/homing.hpp"
#include "delta/cosim/board_cosim.hpp"
#include "delta/effect_file.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/golden/model_image.hpp"
#include "delta/io/byte_stream.hpp"
#include "delta/link/payloads.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/trajectory.hpp"
#include "rtl_fixture.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

// The deployed model: its backlash compensation (half_play.mem) runs in both boards' interpolators.
const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";
golden::QuantisedNetwork deployed_network() {
  golden::QuantisedNetwork q = golden::quantise_file(kWeights, nn::read_weights_file(kWeights));
  EXPECT_TRUE(q.compensation.any());
  return q;
}
const std::string kEffects = std::string(DELTA_SOURCE_DIR) + "/sim/paper_like_effects.json";

struct PeriodRecord {
  std::uint64_t clocks = 0;
  Vec3 current_a = Vec3::Zero();
  Vec3 encoder_deg = Vec3::Zero();
  Vec3 true_alpha_deg = Vec3::Zero();
  cosim::BoardPins pins;
};

// Every control period of b equals a's: its clock, the currents the world applied (the PWM it
// averaged, exactly), the encoder lines, the plant angles and the status pins.
void expect_same_periods(const std::vector<PeriodRecord>& a, const std::vector<PeriodRecord>& b) {
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(b[i].clocks, a[i].clocks) << "period " << i;
    ASSERT_EQ(b[i].current_a, a[i].current_a) << "period " << i;
    ASSERT_EQ(b[i].encoder_deg, a[i].encoder_deg) << "period " << i;
    ASSERT_EQ(b[i].true_alpha_deg, a[i].true_alpha_deg) << "period " << i;
    ASSERT_EQ(b[i].pins.drive_enable, a[i].pins.drive_enable) << "period " << i;
    ASSERT_EQ(b[i].pins.fault_cause_bits, a[i].pins.fault_cause_bits) << "period " << i;
    ASSERT_EQ(b[i].pins.encoder_error_bits, a[i].pins.encoder_error_bits) << "period " << i;
    ASSERT_EQ(b[i].pins.joint_limited, a[i].pins.joint_limited) << "period " << i;
  }
}

// Every telemetry frame and every period of run b equal run a's (a run with `telemetry` and `periods`).
template <typename Run>
void expect_same_session(const Run& a, const Run& b) {
  ASSERT_EQ(b.telemetry.size(), a.telemetry.size());
  for (std::size_t i = 0; i < a.telemetry.size(); ++i) {
    ASSERT_EQ(link::encode(b.telemetry[i]), link::encode(a.telemetry[i])) << "telemetry frame " << i;
  }
  expect_same_periods(a.periods, b.periods);
}

struct BoardRun {
  cosim::CosimResult result;
  std::vector<PeriodRecord> periods;
};

BoardRun run_board(cosim::BoardFidelity fidelity, const golden::QuantisedNetwork& q, const std::string& mem_dir) {
  BoardRun out;
  cosim::CosimOptions options;
  options.fidelity = fidelity;
  options.mem_dir = mem_dir;
  options.network = &q;
  options.effects = read_effect_file(kEffects);
  options.trajectory = "experiment1";
  options.duration_s = 2.0;
  options.period_observer = [&out](std::uint64_t clocks, const cosim::BoardPins& pins, const RobotWorld& world) {
    out.periods.push_back({clocks, world.current_a(), world.encoder_deg(), world.true_alpha_deg(), pins});
  };
  out.result = cosim::run_cosim(options);
  return out;
}

TEST(ModelBoard, EqualsTheRtlBoardFrameForFrameAndPeriodForPeriodOverExperimentOne) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_mem");
  golden::write_export(q, mem_dir);
  auto seconds_since = [](std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  auto start = std::chrono::steady_clock::now();
  const BoardRun rtl = run_board(cosim::BoardFidelity::kRtl, q, mem_dir);
  const double rtl_s = seconds_since(start);
  start = std::chrono::steady_clock::now();
  const BoardRun model = run_board(cosim::BoardFidelity::kModel, q, mem_dir);
  const double model_s = seconds_since(start);
  std::cout << "RTL: " << rtl.result.telemetry.size() << " telemetry frames, " << rtl.periods.size() << " periods in "
            << rtl_s << " s; model: " << model.result.telemetry.size() << ", " << model.periods.size() << " in "
            << model_s << " s\n";

  // The session completed on both (a real trajectory: it moved the joints, drew current).
  ASSERT_EQ(rtl.result.stream.outcome, controller::StreamingResult::Outcome::kCompleted);
  ASSERT_GT(rtl.result.telemetry.size(), 2000u);
  EXPECT_EQ(model.result.identify.weights_crc, rtl.result.identify.weights_crc);
  EXPECT_EQ(model.result.identify.build_id, rtl.result.identify.build_id);

  ASSERT_EQ(model.result.telemetry.size(), rtl.result.telemetry.size());
  std::size_t moving = 0;
  for (std::size_t i = 0; i < rtl.result.telemetry.size(); ++i) {
    const link::TelemetryPayload& a = rtl.result.telemetry[i];
    const link::TelemetryPayload& b = model.result.telemetry[i];
    ASSERT_EQ(link::encode(b), link::encode(a))
        << "telemetry frame " << i << " (tick " << a.tick << " vs " << b.tick << "): sample " << a.sample_index << "/"
        << b.sample_index << " counts " << a.counts[0] << "/" << b.counts[0] << " currents " << a.currents[0] << "/"
        << b.currents[0] << " references " << a.references[0] << "/" << b.references[0] << " flags " << int(a.flags)
        << "/" << int(b.flags) << " fill " << a.fill << "/" << b.fill;
    if (a.currents[0] != 0 || a.currents[1] != 0 || a.currents[2] != 0) ++moving;
  }
  EXPECT_GT(moving, 1000u);

  expect_same_periods(rtl.periods, model.periods);
}

// A host session with a fault and a recovery, on either board: identify, set home, enable, stream
// 300 setpoints circling 2 mm around where the plate starts; from board time 0.25 s joint 1's
// encoder skips a quadrature state (the virtual board's fault injection): the board latches fault
// cause 0 and stops the torque; the host clears the fault, enables again, streams 300 more, disables.
struct FaultRun {
  std::vector<link::TelemetryPayload> telemetry;
  std::vector<PeriodRecord> periods;
  LabStream first, second;
  link::TelemetryPayload cleared, reenabled;
};

// The host's bytes to the board with one bit flipped in every `every`-th byte (0: none): the
// board's receiver drops frames and rescans its ring.
class CorruptingStream : public io::ByteStream {
 public:
  CorruptingStream(io::ByteStream& inner, std::size_t every) : inner_(inner), every_(every) {}
  std::size_t read_some(std::uint8_t* data, std::size_t capacity) override { return inner_.read_some(data, capacity); }
  void write_all(const std::uint8_t* data, std::size_t size, int timeout_ms) override {
    std::vector<std::uint8_t> bytes(data, data + size);
    for (std::uint8_t& byte : bytes) {
      if (every_ != 0 && ++written_ % every_ == 0) byte ^= static_cast<std::uint8_t>(1u << (written_ / every_ % 8));
    }
    inner_.write_all(bytes.data(), bytes.size(), timeout_ms);
  }
  bool wait_readable(int timeout_ms) override { return inner_.wait_readable(timeout_ms); }
  bool wait_readable(int timeout_ms, std::size_t bytes) override { return inner_.wait_readable(timeout_ms, bytes); }
  int fd() const override { return inner_.fd(); }
  const std::string& name() const override { return inner_.name(); }

 private:
  io::ByteStream& inner_;
  std::size_t every_;
  std::size_t written_ = 0;
};

// The board's bytes reach the host `delay` bytes late (a USB adapter's batching, a loaded PC): when
// the host sends a request, the frames already on their way were sent before the board had it.
class DelayLineStream : public io::ByteStream {
 public:
  DelayLineStream(io::ByteStream& inner, std::size_t delay) : inner_(inner), delay_(delay) {}
  std::size_t read_some(std::uint8_t* data, std::size_t capacity) override {
    pull();
    const std::size_t n = held_.size() > delay_ ? std::min(capacity, held_.size() - delay_) : 0;
    std::copy(held_.begin(), held_.begin() + static_cast<std::ptrdiff_t>(n), data);
    held_.erase(held_.begin(), held_.begin() + static_cast<std::ptrdiff_t>(n));
    return n;
  }
  void write_all(const std::uint8_t* data, std::size_t size, int timeout_ms) override {
    inner_.write_all(data, size, timeout_ms);
  }
  bool wait_readable(int timeout_ms) override {
    for (;;) {
      pull();
      if (held_.size() > delay_) return true;
      if (!inner_.wait_readable(timeout_ms)) return false;
    }
  }
  bool wait_readable(int timeout_ms, std::size_t) override { return wait_readable(timeout_ms); }
  int fd() const override { return inner_.fd(); }
  const std::string& name() const override { return inner_.name(); }

 private:
  void pull() {
    std::uint8_t buffer[4096];
    for (std::size_t got; (got = inner_.read_some(buffer, sizeof buffer)) > 0;) {
      held_.insert(held_.end(), buffer, buffer + got);
    }
  }
  io::ByteStream& inner_;
  std::size_t delay_;
  std::deque<std::uint8_t> held_;
};

FaultRun run_fault_session(cosim::BoardFidelity fidelity, const golden::QuantisedNetwork& q, const std::string& mem_dir,
                           bool skip_idle_network = true, std::uint64_t* idle_network_clocks = nullptr,
                           std::uint64_t* clocks = nullptr, bool check_model_runs = false,
                           std::size_t corrupt_every = 0) {
  FaultRun out;
  cosim::VirtualBoardOptions options;
  options.fidelity = fidelity;
  options.skip_idle_network = skip_idle_network;
  options.check_model_runs = check_model_runs;
  options.network = &q;
  options.mem_dir = mem_dir;
  options.effects = read_effect_file(kEffects);
  options.inject_encoder_skip_at_s = 0.25;
  cosim::VirtualBoard board(options);
  board.observe_periods([&out](std::uint64_t clocks, const cosim::BoardPins& pins, const RobotWorld& world) {
    out.periods.push_back({clocks, world.current_a(), world.encoder_deg(), world.true_alpha_deg(), pins});
  });
  cosim::VirtualBoardStream board_stream(board);
  CorruptingStream stream(board_stream, corrupt_every);
  link::LinkSession session(stream);
  session.identify();
  session.set_home();
  const link::TelemetryPayload enabled = session.enable();
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = enabled.count_deg(j);
  const Vec3 start = cosim::locate_plate(q, Geometry::nominal(), counts_deg);
  auto circle = [](const Vec3& centre) {
    std::vector<Vec3> points;
    for (std::size_t k = 0; k < 300; ++k) {
      const double phase = 2.0 * M_PI * static_cast<double>(k) / 300.0;
      points.push_back(centre + 2e-3 * Vec3(std::sin(phase), std::cos(phase) - 1.0, 0.0) * std::min(1.0, k / 100.0));
    }
    return points;
  };
  cosim::BoardTimeClock clock(board);
  out.first = stream_with_the_lab_loop(session, q, circle(start), &clock);
  out.cleared = session.clear_fault();
  out.reenabled = session.enable();
  // From where the arms are now (they fell with the torque off), as a host plans a run.
  for (int j = 0; j < 3; ++j) counts_deg[j] = out.reenabled.count_deg(j);
  out.second =
      stream_with_the_lab_loop(session, q, circle(cosim::locate_plate(q, Geometry::nominal(), counts_deg)), &clock);
  session.disable();
  out.telemetry = session.telemetry();
  if (idle_network_clocks != nullptr) *idle_network_clocks = board.idle_network_clocks();
  if (clocks != nullptr) *clocks = board.clocks();
  return out;
}

// Every telemetry frame and every control period's currents, encoder lines, plant angles and
// status pins of run b equal run a's.
void expect_same_runs(const FaultRun& a, const FaultRun& b) {
  EXPECT_EQ(b.first.result.outcome, a.first.result.outcome);
  EXPECT_EQ(b.second.result.outcome, a.second.result.outcome);
  ASSERT_EQ(b.telemetry.size(), a.telemetry.size());
  for (std::size_t i = 0; i < a.telemetry.size(); ++i) {
    ASSERT_EQ(link::encode(b.telemetry[i]), link::encode(a.telemetry[i]))
        << "telemetry frame " << i << " (tick " << a.telemetry[i].tick << ")";
  }
  expect_same_periods(a.periods, b.periods);
}

TEST(ModelBoard, EqualsTheRtlBoardThroughAnEncoderSkipFaultAndItsRecovery) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_fault_mem");
  golden::write_export(q, mem_dir);
  const FaultRun rtl = run_fault_session(cosim::BoardFidelity::kRtl, q, mem_dir);
  const FaultRun model = run_fault_session(cosim::BoardFidelity::kModel, q, mem_dir);
  std::cout << "RTL: " << rtl.telemetry.size() << " telemetry frames, " << rtl.periods.size() << " periods\n";

  // The scenario happened: the skip faulted the first stream, the clear and the enable were taken,
  // the second stream completed.
  EXPECT_EQ(rtl.first.result.outcome, controller::StreamingResult::Outcome::kFault);
  EXPECT_TRUE(rtl.first.result.last.fault_cause & (1 << board::kFaultEncoderSkip));
  EXPECT_EQ(rtl.cleared.fault_cause, 0);
  EXPECT_TRUE(rtl.reenabled.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_EQ(rtl.second.result.outcome, controller::StreamingResult::Outcome::kCompleted) << rtl.second.result.cause;
  expect_same_runs(rtl, model);
}

// The model board's speed comes from taking clocks in runs (quiet clocks that only count, and
// micro clocks that do one frequent kind of work): the fault session with every run checked
// against as many full clocks, register by register, block RAM by block RAM and drive pin by
// drive pin (ModelBoard::check_runs throws at the first difference); the checked session is the
// unchecked one.
// A host that reads the board's bytes about 40 telemetry frames late (more than identify's wait of
// 20 frames): identify counts only the frames the board sent after it had the request (telemetry
// names the last frame it accepted), not the ones already on their way.
TEST(ModelBoard, IdentifyWaitsOnlyOnTelemetrySentAfterTheBoardHadTheRequest) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_late_mem");
  golden::write_export(q, mem_dir);
  cosim::VirtualBoardOptions options;
  options.fidelity = cosim::BoardFidelity::kModel;
  options.network = &q;
  options.mem_dir = mem_dir;
  options.effects = read_effect_file(kEffects);
  cosim::VirtualBoard board(options);
  cosim::VirtualBoardStream board_stream(board);
  const std::size_t late_bytes = 40 * (board::kTelemetryPayloadBytes + 8);  // a frame: payload + at least 8
  DelayLineStream late(board_stream, late_bytes);
  link::LinkSession session(late);
  for (int i = 0; i < 5; ++i) session.next_telemetry();
  const std::uint64_t before = session.statistics().telemetry_frames;
  link::IdentifyPayload identify;
  ASSERT_NO_THROW(identify = session.identify());
  EXPECT_EQ(identify.protocol_version, board::kProtocolVersion);
  EXPECT_GT(session.statistics().telemetry_frames - before, 30u) << "the reply came behind the frames on their way";
}

TEST(ModelBoard, ItsRunsOfClocksAreExactlyItsFullClocks) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_runs_mem");
  golden::write_export(q, mem_dir);
  FaultRun checked;
  std::uint64_t clocks = 0;
  ASSERT_NO_THROW(checked = run_fault_session(cosim::BoardFidelity::kModel, q, mem_dir, true, nullptr, &clocks, true));
  const FaultRun model = run_fault_session(cosim::BoardFidelity::kModel, q, mem_dir);
  std::cout << "board clocks checked: " << clocks << "\n";
  EXPECT_GT(clocks, 10'000'000u);  // the whole session (about 0.55 s of board time)
  EXPECT_EQ(checked.second.result.outcome, controller::StreamingResult::Outcome::kCompleted);
  expect_same_runs(model, checked);
}

// The same session with one bit flipped in every 97th byte the host sends (after the identify
// and set-home, which go first through clean bytes; then frames are dropped, setpoints refused and
// streamed again, the receiver rescans its ring): both boards identical, and the model's runs
// checked against its full clocks on it.
TEST(ModelBoard, EqualsTheRtlBoardWithCorruptedBytesToTheBoard) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_corrupt_mem");
  golden::write_export(q, mem_dir);
  FaultRun rtl, model, checked;
  const std::size_t every = 97;
  try {
    rtl = run_fault_session(cosim::BoardFidelity::kRtl, q, mem_dir, true, nullptr, nullptr, false, every);
  } catch (const std::exception& error) {
    FAIL() << "RTL session: " << error.what();
  }
  ASSERT_NO_THROW(
      model = run_fault_session(cosim::BoardFidelity::kModel, q, mem_dir, true, nullptr, nullptr, false, every));
  ASSERT_NO_THROW(checked =
                      run_fault_session(cosim::BoardFidelity::kModel, q, mem_dir, true, nullptr, nullptr, true, every));
  ASSERT_FALSE(rtl.telemetry.empty());
  const link::TelemetryPayload& last = rtl.telemetry.back();
  std::cout << "RTL: " << rtl.telemetry.size() << " telemetry frames; board counters: bad frames " << last.bad_frames
            << ", refused " << last.rejected << "\n";
  EXPECT_GT(last.bad_frames, 10u);  // the corruption reached the receiver
  expect_same_runs(rtl, model);
  expect_same_runs(model, checked);
}

// Setpoints sent while the drives are off (any program on the port can leave them) are never
// played: identify, set home, 64 setpoints 8 mm away from the plate (indices 0..63, the drives
// off), then enable and 30 ms in which the host sends nothing. The board refused them all (fill 0,
// the refused counter up by 64), the enable starts on an empty buffer, the references and the
// joints stay where they were; the RTL board and the model board identical throughout.
struct StaleRun {
  std::vector<link::TelemetryPayload> telemetry;
  std::vector<PeriodRecord> periods;
  link::TelemetryPayload before, enabled;
};

StaleRun run_stale_setpoints(cosim::BoardFidelity fidelity, const golden::QuantisedNetwork& q,
                             const std::string& mem_dir) {
  StaleRun out;
  cosim::VirtualBoardOptions options;
  options.fidelity = fidelity;
  options.network = &q;
  options.mem_dir = mem_dir;
  options.effects = read_effect_file(kEffects);
  cosim::VirtualBoard board(options);
  board.observe_periods([&out](std::uint64_t clocks, const cosim::BoardPins& pins, const RobotWorld& world) {
    out.periods.push_back({clocks, world.current_a(), world.encoder_deg(), world.true_alpha_deg(), pins});
  });
  cosim::VirtualBoardStream stream(board);
  link::LinkSession session(stream);
  session.identify();
  const link::TelemetryPayload homed = session.set_home();
  const auto code = golden::encode_position(q.formats, Vec3(0.006, 0.0055, -0.0706));
  for (std::uint32_t i = 0; i < 64; ++i) {
    session.send_setpoint(homed.sample_index + i, golden::setpoint_input(q, code));
  }
  for (int i = 0; i < 30; ++i) out.before = session.next_telemetry();  // the line carries them in 15 ms
  out.enabled = session.enable();
  for (int i = 0; i < 30; ++i) session.next_telemetry();
  session.disable();
  out.telemetry = session.telemetry();
  return out;
}

TEST(ModelBoard, NeitherBoardPlaysSetpointsSentWhileTheDrivesWereOff) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_stale_mem");
  golden::write_export(q, mem_dir);
  const StaleRun rtl = run_stale_setpoints(cosim::BoardFidelity::kRtl, q, mem_dir);
  const StaleRun model = run_stale_setpoints(cosim::BoardFidelity::kModel, q, mem_dir);
  for (const StaleRun* run : {&rtl, &model}) {
    const char* name = run == &rtl ? "RTL" : "model";
    EXPECT_EQ(run->before.fill, 0) << name << ": setpoints taken with the drives off";
    EXPECT_GE(run->before.rejected, 64) << name << ": the 64 setpoints refused";
    EXPECT_TRUE(run->enabled.has(link::TelemetryFlag::kDriveEnable)) << name;
    EXPECT_EQ(run->enabled.fill, 0) << name;
    // From the enable on: nothing played, the references and the joints where they were.
    bool after_enable = false;
    for (const link::TelemetryPayload& t : run->telemetry) {
      if (t.tick == run->enabled.tick) after_enable = true;
      if (!after_enable || !t.has(link::TelemetryFlag::kDriveEnable)) continue;
      ASSERT_EQ(t.sample_index, run->enabled.sample_index) << name << " tick " << t.tick << ": a setpoint played";
      ASSERT_EQ(t.references, run->enabled.references) << name << " tick " << t.tick << ": the reference moved";
    }
    // The joints from the enable (the first period with the drives on) to the disable.
    std::size_t on = 0;
    while (on < run->periods.size() && !run->periods[on].pins.drive_enable) ++on;
    ASSERT_LT(on, run->periods.size()) << name << ": the drives never came on";
    const Vec3 first = run->periods[on].true_alpha_deg;
    double moved_deg = 0.0;
    for (std::size_t i = on; i < run->periods.size() && run->periods[i].pins.drive_enable; ++i) {
      moved_deg = std::max(moved_deg, (run->periods[i].true_alpha_deg - first).cwiseAbs().maxCoeff());
    }
    std::cout << name << ": joints moved at most " << moved_deg << " deg; refused " << run->before.rejected << "\n";
    EXPECT_LT(moved_deg, 0.5) << name << ": motion the host did not command";
  }
  expect_same_session(rtl, model);
}

// The model as data (docs/board_link.md, "The model") on both boards: a board with no model
// (--no-model) refuses the enable; a load with one word corrupted (the commit carries the image's
// CRC) leaves it with no model; the good load gives flag 7 and identify's CRC; the drives come
// on and the lab loop streams a circle; a load begun with the drives on is refused and changes
// nothing; after the disable a second load replaces the model with itself. Every telemetry frame
// and every period equal.
struct LoadRun {
  std::vector<link::TelemetryPayload> telemetry;
  std::vector<PeriodRecord> periods;
  std::uint32_t crc_before = 1, crc_corrupted = 1, crc_loaded = 0, crc_after_refused = 0, crc_reloaded = 0;
  link::TelemetryPayload refused_enable, after_corrupted, loaded, refused_load;
  bool enable_refused = false;
  LabStream stream;
};

// The frames of a load (golden::model_frames, word `corrupt` with bit 0 flipped unless < 0) as a
// host sends them, then telemetry until the board has taken them all.
link::TelemetryPayload send_load(cosim::VirtualBoard& board, link::LinkSession& session,
                                 const golden::QuantisedNetwork& q, int corrupt, std::uint8_t& sequence) {
  std::vector<link::ModelPayload> frames = golden::model_frames(q);
  if (corrupt >= 0) frames[static_cast<std::size_t>(corrupt)].word[0] ^= 1;
  std::vector<std::uint8_t> bytes;
  for (const link::ModelPayload& frame : frames) {
    const std::vector<std::uint8_t> encoded = link::encode_frame(link::make_frame(sequence++, frame));
    bytes.insert(bytes.end(), encoded.begin(), encoded.end());
  }
  board.write(bytes.data(), bytes.size());
  link::TelemetryPayload t = session.next_telemetry();
  while (board.bytes_to_board() != 0) t = session.next_telemetry();
  for (int i = 0; i < 3; ++i) t = session.next_telemetry();
  return t;
}

LoadRun run_load_session(cosim::BoardFidelity fidelity, const golden::QuantisedNetwork& q, const std::string& mem_dir) {
  LoadRun out;
  cosim::VirtualBoardOptions options;
  options.fidelity = fidelity;
  options.network = nullptr;  // no model
  options.mem_dir = mem_dir;
  options.effects = read_effect_file(kEffects);
  cosim::VirtualBoard board(options);
  board.observe_periods([&out](std::uint64_t clocks, const cosim::BoardPins& pins, const RobotWorld& world) {
    out.periods.push_back({clocks, world.current_a(), world.encoder_deg(), world.true_alpha_deg(), pins});
  });
  cosim::VirtualBoardStream stream(board);
  link::LinkSession session(stream);
  std::uint8_t sequence = 128;  // the model frames' own sequence numbers (the session's count from 0)
  out.crc_before = session.identify().weights_crc;
  session.set_home();
  try {
    session.enable();
  } catch (const link::LinkError& error) {
    out.enable_refused = error.kind() == link::LinkError::Kind::kRefused;
  }
  out.refused_enable = *session.last_telemetry();
  out.after_corrupted = send_load(board, session, q, 40, sequence);
  out.crc_corrupted = session.identify().weights_crc;
  out.loaded = send_load(board, session, q, -1, sequence);
  out.crc_loaded = session.identify().weights_crc;
  const link::TelemetryPayload enabled = session.enable();
  // A load begun with the drives on: its first frame is refused.
  const std::vector<std::uint8_t> first =
      link::encode_frame(link::make_frame(sequence++, golden::model_frames(q).front()));
  board.write(first.data(), first.size());
  Vec3 counts_deg;
  for (int j = 0; j < 3; ++j) counts_deg[j] = enabled.count_deg(j);
  const Vec3 start = cosim::locate_plate(q, Geometry::nominal(), counts_deg);
  std::vector<Vec3> points;
  for (std::size_t k = 0; k < 200; ++k) {
    const double phase = 2.0 * M_PI * static_cast<double>(k) / 200.0;
    points.push_back(start + 1e-3 * Vec3(std::sin(phase), std::cos(phase) - 1.0, 0.0) * std::min(1.0, k / 50.0));
  }
  cosim::BoardTimeClock clock(board);
  out.stream = stream_with_the_lab_loop(session, q, points, &clock);
  out.refused_load = *session.last_telemetry();
  out.crc_after_refused = session.identify().weights_crc;
  session.disable();
  send_load(board, session, q, -1, sequence);
  out.crc_reloaded = session.identify().weights_crc;
  for (int i = 0; i < 5; ++i) session.next_telemetry();
  out.telemetry = session.telemetry();
  return out;
}

TEST(ModelBoard, EqualsTheRtlBoardThroughARefusedEnableACorruptedLoadALoadAndARun) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_load_mem");
  golden::write_export(q, mem_dir);
  const LoadRun rtl = run_load_session(cosim::BoardFidelity::kRtl, q, mem_dir);
  const LoadRun model = run_load_session(cosim::BoardFidelity::kModel, q, mem_dir);
  const std::uint32_t crc = weights_crc(q);
  std::cout << "RTL: " << rtl.telemetry.size() << " telemetry frames, " << rtl.periods.size() << " periods\n";
  for (const LoadRun* run : {&rtl, &model}) {
    const char* name = run == &rtl ? "RTL" : "model";
    EXPECT_EQ(run->crc_before, 0u) << name << ": a board starts with no model";
    EXPECT_TRUE(run->enable_refused) << name;
    EXPECT_FALSE(run->refused_enable.has(link::TelemetryFlag::kDriveEnable)) << name;
    EXPECT_FALSE(run->refused_enable.has(link::TelemetryFlag::kModel)) << name;
    EXPECT_GT(run->refused_enable.rejected, 0) << name;
    EXPECT_FALSE(run->after_corrupted.has(link::TelemetryFlag::kModel)) << name << ": a corrupted word loaded";
    EXPECT_EQ(run->crc_corrupted, 0u) << name;
    EXPECT_TRUE(run->loaded.has(link::TelemetryFlag::kModel)) << name;
    EXPECT_EQ(run->loaded.rejected, run->refused_enable.rejected) << name << ": a frame of a load refused";
    EXPECT_EQ(run->crc_loaded, crc) << name;
    EXPECT_EQ(run->stream.result.outcome, controller::StreamingResult::Outcome::kCompleted)
        << name << ": " << run->stream.result.cause;
    EXPECT_TRUE(run->refused_load.has(link::TelemetryFlag::kModel)) << name << ": the model went with the drives on";
    EXPECT_GT(run->refused_load.rejected, run->loaded.rejected) << name << ": the frame with the drives on was taken";
    EXPECT_EQ(run->crc_after_refused, crc) << name;
    EXPECT_EQ(run->crc_reloaded, crc) << name;
  }
  expect_same_session(rtl, model);
}

// Homing at the switches (docs/homing.md) on both boards, a host script that depends on nothing
// but the telemetry (keep-alive frames every 20 frames, not by the wall clock): home start, then
// per jog set home, the jog's setpoint, the drives on until a switch's rising edge references its
// joint and turns them off. The arms start 0.2-0.9 deg below their switches. Every telemetry frame
// and every period equal; the model's runs of clocks checked against its full clocks (the switch
// edges end runs); every joint referenced at the end, its count the robot's encoder reading.
struct HomingRun {
  std::vector<link::TelemetryPayload> telemetry;
  std::vector<PeriodRecord> periods;
  Vec3 switches_deg = Vec3::Zero();
  int jogs = 0;
};

HomingRun run_homing(cosim::BoardFidelity fidelity, const golden::QuantisedNetwork& q, const std::string& mem_dir) {
  HomingRun out;
  cosim::VirtualBoardOptions options;
  options.fidelity = fidelity;
  options.check_model_runs = fidelity == cosim::BoardFidelity::kModel;
  options.network = &q;
  options.mem_dir = mem_dir;
  options.effects = read_effect_file(kEffects);
  {
    // Where the switches are (a world of this robot at the home pose), then the start below them.
    BoardInterface probe;
    probe.board_clock_hz = 1e6;
    probe.pwm_period_cycles = 1024;
    probe.current_full_scale_a = 0.5;
    probe.home_count = static_cast<int>(board::kHomeCount);
    const RobotWorld world(probe, options.effects, Geometry::nominal(), JointPlantParameters{});
    out.switches_deg = world.switch_true_alpha_deg();
  }
  options.start_true_alpha_deg = out.switches_deg - Vec3(0.2, 0.9, 0.5);
  cosim::VirtualBoard board(options);
  board.observe_periods([&out](std::uint64_t clocks, const cosim::BoardPins& pins, const RobotWorld& world) {
    out.periods.push_back({clocks, world.current_a(), world.encoder_deg(), world.true_alpha_deg(), pins});
  });
  cosim::VirtualBoardStream stream(board);
  link::LinkSession session(stream);
  session.identify();
  session.command(link::Command::kHomeStart, [](const link::TelemetryPayload& t) {
    return t.has(link::TelemetryFlag::kHoming) && (t.home >> 3) == 0;
  });
  golden::BoardWeights weights;
  weights.network = q;
  const std::int32_t search = 26;  // Q.8 counts per ms: 1 deg/s
  for (int jog = 0; jog < 3 && ((session.last_telemetry()->home >> 3) & 7) != 7; ++jog) {
    const link::TelemetryPayload off = session.command(link::Command::kSetHome, [](const link::TelemetryPayload& t) {
      for (int j = 0; j < 3; ++j) {
        if (!t.referenced(j) && t.counts[j] != board::kHomeCount) return false;
      }
      return t.has(link::TelemetryFlag::kHomed);
    });
    std::array<std::int32_t, 3> delta{}, actual{};
    for (int j = 0; j < 3; ++j) delta[j] = off.referenced(j) ? 0 : search;
    const std::array<std::int32_t, 3> code = controller::jog_setpoint(weights, off.references, delta, &actual);
    const link::TelemetryPayload on = session.enable();
    session.send_setpoint(on.sample_index + on.fill,
                          golden::setpoint_input(weights.network, {code[0], code[1], code[2]}));
    ++out.jogs;
    for (int frame = 1; frame < 4000; ++frame) {
      const link::TelemetryPayload t = session.next_telemetry();
      if (!t.has(link::TelemetryFlag::kDriveEnable)) break;
      if (frame % 20 == 0) session.send_identify_request();
    }
  }
  for (int i = 0; i < 30; ++i) session.next_telemetry();
  out.telemetry = session.telemetry();
  return out;
}

TEST(ModelBoard, EqualsTheRtlBoardThroughAHomingAtTheSwitches) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("model_board_homing_mem");
  golden::write_export(q, mem_dir);
  const HomingRun rtl = run_homing(cosim::BoardFidelity::kRtl, q, mem_dir);
  const HomingRun model = run_homing(cosim::BoardFidelity::kModel, q, mem_dir);
  std::cout << "RTL: " << rtl.telemetry.size() << " telemetry frames, " << rtl.jogs << " jogs\n";
  ASSERT_FALSE(rtl.telemetry.empty());
  const link::TelemetryPayload& last = rtl.telemetry.back();
  EXPECT_TRUE(last.has(link::TelemetryFlag::kReferenced)) << link::describe_state(last);
  EXPECT_FALSE(last.has(link::TelemetryFlag::kHoming));
  EXPECT_FALSE(last.has(link::TelemetryFlag::kDriveEnable));
  // Each joint's count is the robot's own reading (the world's encoder) at rest at the end.
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(last.count_deg(j), rtl.periods.back().encoder_deg[j], 1e-9) << "joint " << j + 1;
  }
  expect_same_session(rtl, model);
}

// The RTL board's idle-network skip (rtl::IdleNetworkSkip: board clocks without the network
// clock's edges while the network is idle and provably stays so) against the same board clocked
// on every edge: the fault session above, every telemetry frame and every period identical. The
// skip must have taken most clocks (the network works about 60 of every 23,250).
TEST(RtlBoard, SkippingAnIdleNetworksClockEdgesChangesNothing) {
  const golden::QuantisedNetwork q = deployed_network();
  const std::string mem_dir = fresh_directory("idle_network_mem");
  golden::write_export(q, mem_dir);
  std::uint64_t skipped = 0, clocks = 0, unskipped = 0;
  const FaultRun every_edge = run_fault_session(cosim::BoardFidelity::kRtl, q, mem_dir, false, &unskipped);
  const FaultRun skipping = run_fault_session(cosim::BoardFidelity::kRtl, q, mem_dir, true, &skipped, &clocks);
  std::cout << "board clocks " << clocks << ", without the network's edges " << skipped << "\n";
  EXPECT_EQ(unskipped, 0u);
  EXPECT_GT(skipped, clocks * 9 / 10);
  EXPECT_EQ(every_edge.second.result.outcome, controller::StreamingResult::Outcome::kCompleted);
  expect_same_runs(every_edge, skipping);
}

}  // namespace
}  // namespace delta::test

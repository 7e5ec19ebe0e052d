// The model board's safety inputs, its e-stop command and its bench jog (design: docs/bench.md,
// rtl/board/delta_board_pkg.sv), in process through the virtual board at model fidelity with
// every run of clocks checked against as many full clocks (ModelBoard::check_runs): a stop level
// shorter than the filter never latches, one as long as it always does and turns the drives off;
// the clear-fault is refused while the input stays at stop; CommandEstop latches in any state;
// a bench jog drives one joint open loop for JogPeriods periods. Seeded random windows print their
// seed (DELTA_TEST_SEED replays it).
#include <gtest/gtest.h>

#include <unistd.h>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <random>
#include <string>

#include "delta/board_facts.hpp"
#include "delta/cosim/board_inputs.hpp"
#include "delta/cosim/virtual_board.hpp"
#include "delta/golden/export.hpp"
#include "delta/link/payloads.hpp"
#include "delta/link/session.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";
constexpr double kPeriodS = 1.0 / board::kControlRateHz;
constexpr std::uint64_t kPeriodClocks = cosim::kClocksPerTick;

std::uint64_t test_seed() {
  static const std::uint64_t seed = [] {
    const char* env = std::getenv("DELTA_TEST_SEED");
    return env != nullptr ? std::strtoull(env, nullptr, 0) : std::random_device{}();
  }();
  return seed;
}

// The gateware's .mem files once per test binary.
const std::string& mem_dir() {
  static const std::string dir = [] {
    const std::string d = ::testing::TempDir() + "board_safety_inputs_" + std::to_string(::getpid());
    std::filesystem::create_directories(d);
    golden::write_export(cosim::read_board_network(kWeights), d);
    return d;
  }();
  return dir;
}

// A model-fidelity virtual board (runs checked) with these safety input windows, holding the model.
std::unique_ptr<cosim::VirtualBoard> make_board(const std::vector<cosim::SafetyInputWindow>& windows,
                                                bool with_model = true) {
  static const golden::QuantisedNetwork network = cosim::read_board_network(kWeights);
  cosim::VirtualBoardOptions options;
  options.fidelity = cosim::BoardFidelity::kModel;
  options.mem_dir = mem_dir();
  options.network = with_model ? &network : nullptr;
  options.check_model_runs = true;
  options.safety_inputs = windows;
  return std::make_unique<cosim::VirtualBoard>(options);
}

// Steps the board a clock at a time until its drive enable pin shows `on` (at most max_clocks).
void step_until_drives(cosim::VirtualBoard& board, bool on, std::uint64_t max_clocks) {
  for (std::uint64_t i = 0; i < max_clocks && board.pins().drive_enable != on; ++i) board.step(1);
  ASSERT_EQ(board.pins().drive_enable, on) << "within " << max_clocks << " clocks";
}

// Steps the board to board time t_s.
void step_to(cosim::VirtualBoard& board, double t_s) {
  const auto clocks = static_cast<std::uint64_t>(t_s * cosim::kBoardClockHz);
  if (clocks > board.clocks()) board.step(clocks - board.clocks());
}

TEST(ModelBoardSafetyInputs, AStopShorterThanTheFilterNeverLatchesOneAsLongAlwaysDoes) {
  std::cout << "seed " << test_seed() << " (DELTA_TEST_SEED)\n";
  std::mt19937_64 random(test_seed());
  const int filter = static_cast<int>(board::kBoardInputFilterPeriods);
  for (int trial = 0; trial < 8; ++trial) {
    const int input = trial % 4;  // the e-stop chain, drives 1-3
    const double start_s = 0.05 + std::uniform_real_distribution<double>(0.0, 0.01)(random);
    // Shorter than BoardInputFilterPeriods - 1 periods: at most that many samples at stop.
    const std::uint64_t glitch_clocks =
        std::uniform_int_distribution<std::uint64_t>(1, (filter - 1) * kPeriodClocks - 1)(random);
    const double glitch_s = static_cast<double>(glitch_clocks) / cosim::kBoardClockHz;
    SCOPED_TRACE("input " + std::to_string(input) + " at " + std::to_string(start_s) + " s for " +
                 std::to_string(glitch_clocks) + " clocks");
    {
      auto board = make_board({{input, start_s, start_s + glitch_s}});
      step_to(*board, start_s + glitch_s + 10 * kPeriodS);
      EXPECT_EQ(board->pins().board_fault_bits, 0);
      EXPECT_EQ(board->pins().fault_cause_bits, 0);
    }
    // As long as the filter (BoardInputFilterPeriods periods): latched, its cause alone.
    {
      const double held_s = filter * kPeriodS;
      auto board = make_board({{input, start_s, start_s + held_s}});
      step_to(*board, start_s + held_s + 10 * kPeriodS);
      EXPECT_EQ(board->pins().board_fault_bits, 1 << input);
      EXPECT_FALSE(board->pins().drive_enable);
    }
  }
}

// A host session over the in-process board.
struct Session {
  std::unique_ptr<cosim::VirtualBoard> board;
  cosim::VirtualBoardStream stream;
  link::LinkSession session;
  explicit Session(std::unique_ptr<cosim::VirtualBoard> b)
      : board(std::move(b)), stream(*board), session(stream, link::SessionOptions{}) {}
  // A frame whose snapshot came after this call (the one on the line may be older).
  link::TelemetryPayload now() {
    session.poll_frames();
    while (session.take_telemetry()) {
    }
    session.next_telemetry();
    return session.next_telemetry();
  }
};

TEST(ModelBoardSafetyInputs, AnOpenEstopInputTurnsTheDrivesOffLatchesAndRefusesTheClearUntilItCloses) {
  const double open_s = 0.2, close_s = 0.4;
  Session s(make_board({{0, open_s, close_s}}));
  s.session.set_home();
  link::TelemetryPayload t = s.session.enable();
  ASSERT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  // The drives go off within BoardInputFilterPeriods + 1 periods of the chain opening (and a few clocks).
  step_to(*s.board, open_s + (board::kBoardInputFilterPeriods + 1) * kPeriodS + 8e-6);
  EXPECT_FALSE(s.board->pins().drive_enable);
  t = s.now();
  EXPECT_TRUE(t.has(link::TelemetryFlag::kFault));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_TRUE(t.has(link::BoardFault::kEstopInput));
  EXPECT_EQ(link::describe_fault(t), "e-stop input open");
  // Refused while the chain stays open (counted), the enable too; nothing turns the drives on.
  const std::uint16_t refused = t.rejected;
  try {
    s.session.clear_fault();
    ADD_FAILURE() << "the clear-fault was taken with the e-stop chain open";
  } catch (const link::LinkError& error) {
    EXPECT_EQ(error.kind(), link::LinkError::Kind::kRefused);
    EXPECT_NE(std::string(error.what()).find("e-stop input is still open"), std::string::npos) << error.what();
  }
  EXPECT_THROW(s.session.enable(), link::LinkError);
  t = s.now();
  EXPECT_GT(t.rejected, refused);
  EXPECT_TRUE(t.has(link::BoardFault::kEstopInput));
  EXPECT_FALSE(s.board->pins().drive_enable);
  // Closed: the cause stays latched (nothing clears itself), the clear is taken, the drives stay off.
  step_to(*s.board, close_s + 5 * kPeriodS);
  t = s.now();
  EXPECT_TRUE(t.has(link::BoardFault::kEstopInput));
  t = s.session.clear_fault();
  EXPECT_FALSE(t.has(link::TelemetryFlag::kFault));
  EXPECT_EQ(t.board_fault, 0);
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
  t = s.session.enable();
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
}

TEST(ModelBoardEstop, TheEstopCommandLatchesInEveryStateUntilAClearFault) {
  Session s(make_board({}));
  // Drives off and not homed.
  link::TelemetryPayload t = s.session.estop();
  EXPECT_TRUE(t.estop);
  EXPECT_TRUE(t.has(link::TelemetryFlag::kFault));
  EXPECT_EQ(link::describe_fault(t), "e-stop command");
  s.session.clear_fault();
  // Drives on: off at once, the enable refused until the clear.
  s.session.set_home();
  s.session.enable();
  s.session.send_command(link::Command::kEstop);
  const std::uint64_t sent = s.board->clocks();
  step_until_drives(*s.board, false, 100 * kPeriodClocks);
  // The command's frame on the line (5 bytes + CRC at 10 bits of LinkClocksPerBit) and a few clocks.
  EXPECT_LT(s.board->clocks() - sent, 8 * 10 * cosim::kClocksPerBit + 8);
  EXPECT_THROW(s.session.enable(), link::LinkError);
  t = s.now();
  EXPECT_TRUE(t.estop);
  EXPECT_FALSE(s.board->pins().drive_enable);
  t = s.session.clear_fault();
  EXPECT_FALSE(t.estop);
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));  // nothing re-enables by itself
}

TEST(ModelBoardJog, AJogDrivesOneJointOpenLoopForJogPeriodsThenTurnsTheDrivesOff) {
  Session s(make_board({}, false));  // no model, not homed: a jog needs neither
  const int joint = 1;
  link::Frame frame;
  frame.type = link::FrameType::kCommand;
  frame.payload = {link::jog_command_byte(joint, true)};
  const std::vector<std::uint8_t> bytes = link::encode_frame(frame);
  s.board->write(bytes.data(), bytes.size());
  step_until_drives(*s.board, true, 100 * kPeriodClocks);
  const std::uint64_t on = s.board->clocks();
  s.board->step(100 * kPeriodClocks);
  link::TelemetryPayload t = s.now();
  EXPECT_TRUE(t.jogging());
  EXPECT_TRUE(t.has(link::TelemetryFlag::kDriveEnable));
  for (int j = 0; j < 3; ++j) EXPECT_EQ(t.currents[j], j == joint ? -board::kJogCurrentCode : 0) << "joint " << j;
  EXPECT_LT(s.board->world().current_a()[joint], 0.0);
  EXPECT_EQ(s.board->world().current_a()[0], 0.0);
  EXPECT_EQ(s.board->world().current_a()[2], 0.0);
  for (int i = 0; i < 8 * board::kJogPeriods && s.board->pins().drive_enable; ++i) s.board->step(kPeriodClocks / 4);
  const double ran = static_cast<double>(s.board->clocks() - on) / kPeriodClocks;
  EXPECT_GT(ran, board::kJogPeriods - 1.5);
  EXPECT_LT(ran, board::kJogPeriods + 0.5);
  t = s.now();
  EXPECT_FALSE(t.jogging());
  EXPECT_FALSE(t.has(link::TelemetryFlag::kDriveEnable));
  EXPECT_FALSE(t.has(link::TelemetryFlag::kFault));
  // An e-stop ends one at once.
  s.board->write(bytes.data(), bytes.size());
  step_until_drives(*s.board, true, 100 * kPeriodClocks);
  s.board->step(10 * kPeriodClocks);
  t = s.session.estop();
  EXPECT_FALSE(t.jogging());
  EXPECT_FALSE(s.board->pins().drive_enable);
}

}  // namespace
}  // namespace delta::test

// RobotWorld::advance (runs of held-duty cycles at once, the model board's path) against step()
// cycle by cycle (the RTL board's path): the same world after every run, to the bit.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <iostream>
#include <random>

#include "delta/robot_world.hpp"

namespace delta {
namespace {

BoardInterface board_interface() {
  BoardInterface board;  // the iCEBreaker board's figures (delta_board_pkg.sv)
  board.board_clock_hz = 23.25e6;
  board.pwm_period_cycles = 1024;
  board.current_full_scale_a = 0.5;
  board.home_count = 3000;
  board.count_deg = 0.01;
  board.plant_divider = 2325;  // the control period, as the virtual board steps the plants
  board.plant_lead = 35;
  return board;
}

EffectSet sensor_effects() {
  EffectSet effects;  // the sensor chain's stateful and transcendental parts
  effects.backlash_deg = Vec3(0.15, 0.03, 0.03);
  effects.transmission_error = TransmissionError{Vec3(0.02, 0.01, 0.01), Vec3(7.5, 7.5, 7.5), Vec3(0.3, 1.1, 2.0)};
  effects.encoder_scale = Vec3(0.000148, -0.006482, -0.001651);
  return effects;
}

TEST(RobotWorld, AdvanceEqualsSteppingCycleByCycle) {
  const std::uint64_t seed = 16;
  std::cout << "seed " << seed << '\n';
  std::mt19937_64 random(seed);
  const BoardInterface board = board_interface();
  RobotWorld bulk(board, sensor_effects(), Geometry::nominal(), JointPlantParameters{});
  RobotWorld stepped(board, sensor_effects(), Geometry::nominal(), JointPlantParameters{});

  DrivePattern pattern;
  std::uniform_int_distribution<int> duty(0, 1100), phase(0, 1023), bits(0, 7);
  std::size_t moves = 0;
  int last_lines = bulk.encoder_a() | (bulk.encoder_b() << 3);
  for (int run = 0; run < 200000; ++run) {
    if (run % 500 == 0) {  // new duties now and then (a control period's store)
      for (int j = 0; j < 3; ++j) pattern.duty[j] = duty(random);
      pattern.direction = bits(random);
      pattern.enable = run % 20000 < 18000;
    }
    pattern.phase = phase(random);
    const std::uint64_t cycles = std::uniform_int_distribution<std::uint64_t>(1, bulk.cycles_to_event())(random);
    bulk.advance(cycles, pattern);
    for (std::uint64_t i = 0; i < cycles; ++i) stepped.step(pattern.pins(i, board.pwm_period_cycles));

    ASSERT_EQ(bulk.cycle(), stepped.cycle()) << "run " << run;
    ASSERT_EQ(bulk.current_a(), stepped.current_a()) << "run " << run;
    ASSERT_EQ(bulk.true_alpha_deg(), stepped.true_alpha_deg()) << "run " << run;
    ASSERT_EQ(bulk.encoder_a(), stepped.encoder_a()) << "run " << run;
    ASSERT_EQ(bulk.encoder_b(), stepped.encoder_b()) << "run " << run;
    ASSERT_EQ(bulk.cycles_to_event(), stepped.cycles_to_event()) << "run " << run;
    const int lines = bulk.encoder_a() | (bulk.encoder_b() << 3);
    if (lines != last_lines) ++moves;
    last_lines = lines;
  }
  // The runs moved the joints: the encoder lines changed.
  EXPECT_GT(moves, 500u);  // 716 with this seed
  EXPECT_NE(bulk.true_alpha_deg(), bulk.home_true_alpha_deg());
}

}  // namespace
}  // namespace delta

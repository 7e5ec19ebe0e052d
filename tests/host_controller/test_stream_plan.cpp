// The host's plan under feed holds: a hold slows the plate to rest on the path within
// the checked limits, a resume brings it back to speed and on to the path's end, a run with holds
// covers the same path as one without, the plan never outgrows the capacity reserved for holds
// (the streaming thread does not allocate), and a stop during a hold ends the plan where it rests.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <random>

#include "delta/controller/run_job.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "support/tree_paths.hpp"

namespace delta::controller {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

// Largest position step between consecutive samples, metres.
double largest_step(const StreamPlan& plan, std::size_t from, std::size_t to) {
  double step = 0.0;
  for (std::size_t k = from + 1; k < to; ++k) step = std::max(step, (plan.position(k) - plan.position(k - 1)).norm());
  return step;
}

TEST(StreamPlan, HoldComesToRestOnThePathAndResumeFinishesItWithinTheLimits) {
  const golden::BoardWeights weights = golden::read_board_weights(kWeights);
  const Path path = load_path("experiment1", 3.0);
  const StreamLimits limits;
  const Vec3 start = path.samples.front().position_m + Vec3(0.002, 0.0, 0.0);
  const StreamPlan reference(path, start, limits);
  StreamPlan plan(path, start, limits);
  const std::size_t capacity = plan.capacity();
  ASSERT_GE(capacity, plan.size() + kHoldReserveSamples);

  const std::size_t hold_at = plan.approach_samples() + 1200;  // at full speed on the path
  const double tau_at = plan.tau(hold_at);
  const std::size_t held = plan.hold_from(hold_at);
  ASSERT_LT(held, reference.size());
  // At rest on the path: the last samples do not move, and it is a point of the path.
  EXPECT_LT((plan.position(held - 1) - plan.position(held - 2)).norm(), 1e-9);
  EXPECT_GT(plan.tau(held - 1), tau_at);
  EXPECT_LT(plan.tau(held - 1), tau_at + 0.5);
  EXPECT_LT((plan.position(held - 1) - path.at(plan.tau(held - 1))).norm(), 1e-12);
  EXPECT_TRUE(plan.resumable());
  EXPECT_FALSE(check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits))
      << *check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits);

  const std::size_t resumed = plan.resume();
  ASSERT_GT(resumed, held);
  EXPECT_LE(resumed, capacity);
  // Whole: no step, the limits held through hold and resume, the same end as without the hold.
  EXPECT_FALSE(check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits))
      << *check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits);
  EXPECT_NEAR(plan.tau(plan.size() - 1), path.duration_s(), 1e-9);
  EXPECT_LT((plan.position(plan.size() - 1) - reference.position(reference.size() - 1)).norm(), 1e-12);
  EXPECT_LE(largest_step(plan, 0, plan.size()), largest_step(reference, 0, reference.size()) + 1e-9);
  // Path time never goes back.
  for (std::size_t k = plan.approach_samples() + 1; k < plan.size(); ++k) ASSERT_GE(plan.tau(k), plan.tau(k - 1)) << k;
  // About the two ramps' extra time longer than without the hold.
  const double extra_s = static_cast<double>(plan.size() - reference.size()) / kStreamRateHz;
  std::cout << "hold at path time " << tau_at << " s, at rest at " << plan.tau(held - 1) << " s; the plan " << extra_s
            << " s longer\n";
  EXPECT_GT(extra_s, 0.05);
  EXPECT_LT(extra_s, 1.0);
}

TEST(StreamPlan, ManyRandomHoldsStayInsideTheReserveAndTheLimits) {
  const golden::BoardWeights weights = golden::read_board_weights(kWeights);
  const Path path = load_path("experiment1", 4.0);
  const StreamLimits limits;
  StreamPlan plan(path, path.samples.front().position_m, limits);
  const unsigned seed = 1313;
  std::cout << "seed " << seed << "\n";
  std::mt19937 random(seed);
  std::size_t next = plan.approach_samples();
  int holds = 0;
  while (holds < 40) {
    std::uniform_int_distribution<std::size_t> draw(1, 400);  // including holds during ramps
    next += draw(random);
    if (next >= plan.size()) break;
    const std::size_t before = plan.size();
    const std::size_t held = plan.hold_from(next);
    if (held == before) break;  // in the final ramp: already stopping
    ++holds;
    ASSERT_GT(plan.resume(), 0u) << "hold " << holds;
    ASSERT_LE(plan.size(), plan.capacity());
    next = held;
  }
  std::cout << holds << " holds; plan " << plan.size() << " samples of a capacity of " << plan.capacity() << "\n";
  EXPECT_GE(holds, 10);
  EXPECT_FALSE(check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits))
      << *check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits);
  EXPECT_NEAR(plan.tau(plan.size() - 1), path.duration_s(), 1e-9);
}

TEST(StreamPlan, HoldDuringTheApproachFinishesItAndResumeStartsThePath) {
  const Path path = load_path("experiment1", 1.0);
  const StreamLimits limits;
  StreamPlan plan(path, path.samples.front().position_m + Vec3(0.0, 0.003, 0.0), limits);
  ASSERT_GT(plan.approach_samples(), 10u);
  const std::size_t full = plan.size();
  EXPECT_EQ(plan.hold_from(3), plan.approach_samples());
  EXPECT_LT((plan.position(plan.size() - 1) - path.samples.front().position_m).norm(), 1e-12);
  EXPECT_EQ(plan.resume(), full);  // the path as planned at first
  EXPECT_NEAR(plan.tau(plan.size() - 1), path.duration_s(), 1e-9);
}

TEST(StreamPlan, StopDuringALongApproachComesToRestWithinHalfASecond) {
  // From a corner of the trained range: the straight move alone lasts most of a second. A stop in
  // it (a signal, ctl stop) must not wait for its end: the plate comes to rest on the line.
  const golden::BoardWeights weights = golden::read_board_weights(kWeights);
  const Path path = load_path("experiment1", 1.0);
  const StreamLimits limits;
  const Vec3 start = weights.trained_min_m + Vec3::Constant(0.0005);
  StreamPlan plan(path, start, limits);
  const StreamPlan reference(path, start, limits);
  ASSERT_GT(plan.approach_samples(), 600u);
  const std::size_t k = plan.approach_samples() / 3;
  const std::size_t stopped = plan.stop_from(k);
  std::cout << "approach " << plan.approach_samples() << " samples; stopped at sample " << k << ", at rest after "
            << stopped - k << " more\n";
  EXPECT_LE(stopped - k, 400u);
  EXPECT_LT(stopped, plan.approach_samples());
  EXPECT_FALSE(plan.resumable());
  EXPECT_EQ(plan.resume(), 0u);
  // The samples before k unchanged; at rest at the end; on the line, never beyond the unstopped move.
  for (std::size_t i = 0; i <= k; ++i) ASSERT_EQ(plan.position(i), reference.position(i)) << i;
  EXPECT_LT((plan.position(stopped - 1) - plan.position(stopped - 2)).norm(), 1e-9);
  EXPECT_LE(largest_step(plan, 0, stopped), largest_step(reference, 0, reference.size()) + 1e-12);
  EXPECT_FALSE(check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits))
      << *check_plan(plan, "experiment1", weights.trained_min_m, weights.trained_max_m, limits);
}

TEST(StreamPlan, RunsBeyondTheLongestAreRefusedBeforeAllocating) {
  // A named trajectory's duration, a move's length: refused before the samples are made.
  EXPECT_THROW(load_path("experiment1", kMaxRunSeconds + 1.0), std::invalid_argument);
  EXPECT_THROW(load_path("experiment1", 1e300), std::invalid_argument);
  EXPECT_THROW(load_path("move:0,0,-0.075;1e300,0,-0.075", 0.0), InputError);
  EXPECT_NO_THROW(load_path("experiment1", 2.0));
}

TEST(StreamPlan, RunSummaryBoardTimeSurvivesTheTickWrapAndAnEarlierFrame) {
  // The summary's board time: the u32 tick wraps after 4.97 days; a frame that shows an earlier
  // tick (taken from the queue after a newer one, or a restarted board) is 0 s, not 429496.7 s.
  link::TelemetryPayload first, last;
  first.tick = 0xFFFFFF00u;
  last.tick = 0x00000100u;
  EXPECT_NEAR(board_seconds_between(first, last), 512 / 1e4, 1e-12);
  first.tick = 20'000;
  last.tick = 19'990;
  EXPECT_EQ(board_seconds_between(first, last), 0.0);
  last.tick = 30'000;
  EXPECT_NEAR(board_seconds_between(first, last), 1.0, 1e-12);
}

TEST(StreamPlan, AtTheEndOfThePathThereIsNothingToResume) {
  const Path path = load_path("experiment1", 1.0);
  StreamPlan plan(path, path.samples.front().position_m, StreamLimits{});
  EXPECT_FALSE(plan.resumable());
  EXPECT_EQ(plan.resume(), 0u);
  // A hold in the final ramp changes nothing (already slowing to the end).
  const std::size_t size = plan.size();
  EXPECT_EQ(plan.hold_from(size - 5), size);
}

TEST(StreamPlan, PointToPointMovesAreJerkLimitedRestToRestThroughTheWaypoints) {
  const golden::BoardWeights weights = golden::read_board_weights(kWeights);
  const Path path = load_path("move:0,0,-0.075;0.006,0,-0.075;0.006,0.004,-0.08", 0.0);
  const Vec3 last(0.006, 0.004, -0.08);
  EXPECT_LT((path.samples.back().position_m - last).norm(), 1e-12);
  // At rest at each waypoint: the middle one is passed with zero speed.
  std::size_t at_middle = 0;
  for (std::size_t k = 1; k + 1 < path.samples.size(); ++k) {
    if ((path.samples[k].position_m - Vec3(0.006, 0, -0.075)).norm() < 1e-12) ++at_middle;
  }
  EXPECT_GE(at_middle, 1u);
  const StreamLimits limits;
  const StreamPlan plan(path, Vec3(0.001, 0, -0.074), limits);
  EXPECT_FALSE(check_plan(plan, path.source, weights.trained_min_m, weights.trained_max_m, limits))
      << *check_plan(plan, path.source, weights.trained_min_m, weights.trained_max_m, limits);
  EXPECT_LT((plan.position(plan.size() - 1) - last).norm(), 1e-12);
  // A bad waypoint is named by its number.
  try {
    load_path("move:0,0,-0.075;0.006,x,-0.075", 0.0);
    FAIL() << "accepted a bad waypoint";
  } catch (const InputError& error) {
    EXPECT_EQ(error.line(), 2u);
    std::cout << error.what() << "\n";
  }
  // An unreachable waypoint is refused by the plan's check, naming it.
  const Path far = load_path("move:0,0,-0.075;0,0,-0.3", 0.0);
  const StreamPlan far_plan(far, Vec3(0, 0, -0.075), limits);
  const auto violation = check_plan(far_plan, far.source, weights.trained_min_m, weights.trained_max_m, limits);
  ASSERT_TRUE(violation);
  EXPECT_NE(violation->find(":2: "), std::string::npos) << *violation;
}

// A model with a joint ripple table shapes the setpoints it sends: a path to a point on the box's
// face whose shaped setpoint falls outside the box passes the check of the positions alone and is
// refused by the run's check (the model given), naming the shaped setpoints, the axis and the box.
TEST(StreamPlan, TheShapedSetpointsOfARippleTableAreCheckedAgainstTheBox) {
  const golden::BoardWeights weights =
      golden::read_board_weights(std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_calibration_deployed.json");
  ASSERT_FALSE(weights.model.joint_ripple.empty());
  const Vec3 centre = 0.5 * (weights.trained_min_m + weights.trained_max_m);
  // On the face x = max: the first grid point whose shaped setpoint lies beyond it.
  std::optional<Vec3> edge;
  for (int i = 1; i < 20 && !edge; ++i) {
    for (int k = 1; k < 20 && !edge; ++k) {
      const Vec3 s(1.0, i / 20.0, k / 20.0);
      const Vec3 p = weights.trained_min_m + s.cwiseProduct(weights.trained_max_m - weights.trained_min_m);
      if (nn::shape_setpoint(weights.model, p).x() > weights.trained_max_m.x()) edge = p;
    }
  }
  ASSERT_TRUE(edge) << "no point of the face x = max shaped beyond it";
  char move[160];
  std::snprintf(move, sizeof move, "move:%.12f,%.12f,%.12f;%.12f,%.12f,%.12f", centre.x(), centre.y(), centre.z(),
                edge->x(), edge->y(), edge->z());
  const Path path = load_path(move, 0.0);
  const StreamLimits limits;
  const StreamPlan plan(path, centre, limits);
  EXPECT_FALSE(check_plan(plan, "move", weights.trained_min_m, weights.trained_max_m, limits));
  const auto refused = check_plan(plan, "move", weights.trained_min_m, weights.trained_max_m, limits, &weights.model);
  ASSERT_TRUE(refused);
  std::cout << *refused << "\n";
  EXPECT_NE(refused->find("shaped setpoints"), std::string::npos) << *refused;
  EXPECT_NE(refused->find("x reaches"), std::string::npos) << *refused;
  EXPECT_NE(refused->find("the box x"), std::string::npos) << *refused;
  RunRequest request;
  request.trajectory = move;
  EXPECT_EQ(check_run(weights, request).size(), 1u);
}

// A deployed model's joint ripple table moves every joint by the table's entry on top of the path
// (nn::shape_setpoint): the plan check checks the joints so shaped too. A table within the reader's
// bounds that zig-zags every 0.1 deg makes the shaped joints jerk beyond the limit on a path the
// check passes unshaped: refused, naming the shaping; the shipped calibration model's table passes.
TEST(StreamPlan, TheCheckSeesTheJointsAsTheRippleTableShapesThem) {
  const golden::BoardWeights shipped =
      golden::read_board_weights(std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_calibration_deployed.json");
  ASSERT_FALSE(shipped.model.joint_ripple.empty());
  const Path path = load_path("experiment1", 3.0);
  const StreamLimits limits;
  const StreamPlan plan(path, path.samples.front().position_m, limits);
  EXPECT_FALSE(check_plan(plan, "experiment1", shipped.trained_min_m, shipped.trained_max_m, limits, &shipped.model));
  golden::BoardWeights zigzag = shipped;
  nn::JointRippleTable& table = zigzag.model.joint_ripple;
  table.bin_deg = 0.01;
  table.first_deg = Vec3::Constant(10.0);
  for (auto& values : table.values_deg) {
    values.clear();
    for (std::size_t k = 0; k < nn::kMaxJointRippleEntries; ++k) {  // a triangle of 0.1 deg, as steep as allowed
      const double phase = static_cast<double>(k % 10);
      values.push_back(nn::kMaxJointRippleSlope * table.bin_deg * (phase < 5 ? phase : 10 - phase));
    }
  }
  EXPECT_NO_THROW(nn::parse_weights_file(nn::weights_file_text(zigzag.model), "zigzag.json"));
  EXPECT_FALSE(check_plan(plan, "experiment1", zigzag.trained_min_m, zigzag.trained_max_m, limits));
  const auto refused =
      check_plan(plan, "experiment1", zigzag.trained_min_m, zigzag.trained_max_m, limits, &zigzag.model);
  ASSERT_TRUE(refused);
  EXPECT_NE(refused->find("joint ripple table"), std::string::npos) << *refused;
  EXPECT_NE(refused->find("above the limit"), std::string::npos) << *refused;
}

}  // namespace
}  // namespace delta::controller

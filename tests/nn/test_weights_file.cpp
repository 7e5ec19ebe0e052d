// W.json: exact round trip, the loader's rejections (exit code 2 through deltactl, no output file),
// and the float back end of `deltactl ik` against Network::evaluate.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>

#include "../support/run_command.hpp"
#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/trained_model.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/output_file.hpp"
#include "support/tree_paths.hpp"

namespace delta::nn {
namespace {

using delta::test::file_exists;
using delta::test::run_deltactl;
using delta::test::write_text;

// A seeded random 3-5-3 network with realistic scaling (the 10 mm cube, angles about 30 deg).
WeightsFile random_weights(std::uint64_t seed, int hidden = 5) {
  std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
  std::mt19937_64 generator(seed);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  WeightsFile weights;
  Network& n = weights.network;
  n.input_min = Vec3(-0.005, -0.005, -0.081);
  n.input_max = Vec3(0.005, 0.005, -0.0708);
  n.output_min = Vec3(14.1, 15.2, 16.3);
  n.output_max = Vec3(45.5, 44.4, 43.3);
  n.input_weights = Eigen::MatrixXd::NullaryExpr(hidden, 3, [&] { return uniform(generator); });
  n.hidden_bias = Eigen::VectorXd::NullaryExpr(hidden, [&] { return uniform(generator); });
  n.output_weights = Eigen::MatrixXd::NullaryExpr(3, hidden, [&] { return uniform(generator) / 3.0; });
  n.output_bias = Vec3(uniform(generator), uniform(generator), uniform(generator)) / 3.0;
  weights.provenance = {{"tool", "test"}, {"seed", seed}};
  return weights;
}

std::string temp(const std::string& name) { return ::testing::TempDir() + "nn_weights_" + name; }

TEST(WeightsFile, RoundTripIsExactAndTheTextDeterministic) {
  const WeightsFile weights = random_weights(11);
  const std::string text = weights_file_text(weights);
  const WeightsFile back = parse_weights_file(text, "memory");
  EXPECT_EQ(back.network.input_weights, weights.network.input_weights);
  EXPECT_EQ(back.network.hidden_bias, weights.network.hidden_bias);
  EXPECT_EQ(back.network.output_weights, weights.network.output_weights);
  EXPECT_EQ(back.network.output_bias, weights.network.output_bias);
  EXPECT_EQ(back.network.input_min, weights.network.input_min);
  EXPECT_EQ(back.network.output_max, weights.network.output_max);
  EXPECT_EQ(back.provenance, weights.provenance);
  EXPECT_EQ(weights_file_text(back), text);
}

TEST(WeightsFile, HybridKeepsItsEffectsAndRefusesBacklash) {
  WeightsFile weights = random_weights(12);
  weights.model = "hybrid";
  weights.effects.joint_offset_deg = Vec3(0.1, -0.2, 0.3);
  weights.effects.chain_angle_deg = Vec3(-0.5, 0.25, 0.125);
  const WeightsFile back = parse_weights_file(weights_file_text(weights), "memory");
  ASSERT_TRUE(back.hybrid());
  EXPECT_EQ(*back.effects.joint_offset_deg, *weights.effects.joint_offset_deg);
  EXPECT_EQ(*back.effects.chain_angle_deg, *weights.effects.chain_angle_deg);
  weights.effects.backlash_deg = Vec3(0.1, 0, 0);
  EXPECT_THROW(parse_weights_file(weights_file_text(weights), "memory"), InputError);
}

// A deployed model with a joint ripple table of `entries` per joint (a 6 deg sinusoid of 0.03 deg).
WeightsFile rippled_weights(std::uint64_t seed, int hidden, std::size_t entries = 120) {
  WeightsFile weights = random_weights(seed, hidden);
  weights.model = "deployed";
  weights.backlash_half_play_deg = Vec3(0.01, 0.0, 0.02);
  weights.joint_ripple.bin_deg = 0.25;
  weights.joint_ripple.first_deg = Vec3(14.0, 15.0, 16.0);
  for (std::size_t j = 0; j < 3; ++j) {
    for (std::size_t k = 0; k < entries; ++k) {
      weights.joint_ripple.values_deg[j].push_back(0.03 * std::sin(2.0 * M_PI * (0.25 * k + j) / 6.0));
    }
  }
  return weights;
}

TEST(WeightsFile, JointRippleTableRoundTripsAsVersion3AndIsChecked) {
  const WeightsFile weights = rippled_weights(15, 5);
  const std::string text = weights_file_text(weights);
  EXPECT_NE(text.find("\"version\": 3"), std::string::npos);
  const WeightsFile back = parse_weights_file(text, "memory");
  EXPECT_EQ(back.joint_ripple.bin_deg, weights.joint_ripple.bin_deg);
  EXPECT_EQ(back.joint_ripple.first_deg, weights.joint_ripple.first_deg);
  for (std::size_t j = 0; j < 3; ++j) EXPECT_EQ(back.joint_ripple.values_deg[j], weights.joint_ripple.values_deg[j]);
  EXPECT_EQ(weights_file_text(back), text);
  // Between entries the table is linear, beyond them it holds its end entries.
  const JointRippleTable& table = back.joint_ripple;
  EXPECT_DOUBLE_EQ(table.at(1, 15.125), 0.5 * (table.values_deg[1][0] + table.values_deg[1][1]));
  EXPECT_EQ(table.at(2, 3.0), table.values_deg[2].front());
  EXPECT_EQ(table.at(0, 90.0), table.values_deg[0].back());
  // Without a table a deployed model stays version 2, byte for byte as before.
  WeightsFile plain = weights;
  plain.joint_ripple = {};
  EXPECT_NE(weights_file_text(plain).find("\"version\": 2"), std::string::npos);
  EXPECT_EQ(weights_file_text(plain).find("joint_ripple"), std::string::npos);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"\"version\": 3", "\"version\": 2"},  // a version 2 reader would not apply the table
      {"\"bin_deg\": 0.25", "\"bin_deg\": 0"},
      {"\"bin_deg\": 0.25", "\"bin_deg\": 0.25, \"phase\": 1"},
      {"\"first_deg\": [14", "\"first_deg\": [14, 1"},
      {"\"values_deg\": [\n    [", "\"values_deg\": [\n    [0.75, "},
      {"\"values_deg\": [\n    [", "\"values_deg\": [\n    [null, "}};
  for (const auto& [from, to] : bad) {
    SCOPED_TRACE(to);
    std::string broken = text;
    const std::size_t at = broken.find(from);
    ASSERT_NE(at, std::string::npos);
    broken.replace(at, from.size(), to);
    EXPECT_THROW(parse_weights_file(broken, "memory"), InputError);
  }
}

// A table whose shaping could move the joints beyond what the plan check saw is refused: a steep
// one (entries changing by more than kMaxJointRippleSlope per degree: it chatters, or moves the
// joints faster than the path) or a large one; every shipped model still loads.
TEST(WeightsFile, JointRippleTablesThatWouldMoveTheJointsFarBeyondThePathAreRefused) {
  const std::string text = weights_file_text(rippled_weights(17, 5));
  auto with_table = [&](double bin_deg, const std::function<double(std::size_t)>& value, std::size_t entries) {
    std::string table = "\"joint_ripple\": {\"bin_deg\": " + format_number(bin_deg) +
                        ", \"first_deg\": [20, 20, 20], \"values_deg\": [";
    for (int j = 0; j < 3; ++j) {
      table += j ? ", [" : "[";
      for (std::size_t k = 0; k < entries; ++k) table += (k ? ", " : "") + format_number(value(k));
      table += "]";
    }
    std::string changed = text;
    const std::size_t at = changed.find("\"joint_ripple\"");
    const std::size_t end = changed.find("]]}", at) + 3;
    changed.replace(at, end - at, table + "]}");
    return changed;
  };
  struct Case {
    std::string name;
    std::string text;
    std::string reason;
  };
  const std::vector<Case> refused = {// +-0.5 deg every 0.01 deg: joint references stepping by degrees per setpoint.
                                     {"chatter",
                                      with_table(
                                          0.01, [](std::size_t k) { return k % 2 ? -0.5 : 0.5; }, 2000),
                                      "beyond +-0.25"},
                                     {"fine chatter",
                                      with_table(
                                          0.01, [](std::size_t k) { return k % 2 ? -0.1 : 0.1; }, 2000),
                                      "steeper than 0.25"},
                                     {"step",
                                      with_table(
                                          0.25, [](std::size_t k) { return k < 50 ? 0.0 : 0.1; }, 100),
                                      "steeper than 0.25"},
                                     {"constant shift",
                                      with_table(
                                          0.25, [](std::size_t) { return 0.5; }, 100),
                                      "beyond +-0.25"}};
  for (const Case& c : refused) {
    SCOPED_TRACE(c.name);
    try {
      parse_weights_file(c.text, "W.json");
      ADD_FAILURE() << "accepted";
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find(c.reason), std::string::npos) << error.what();
      EXPECT_NE(std::string(error.what()).find("values_deg"), std::string::npos) << error.what();
    }
  }
  // A real transmission ripple passes: 0.05 deg over a 2 deg period (slope 0.16 deg per deg).
  EXPECT_NO_THROW(
      parse_weights_file(with_table(
                             0.25, [](std::size_t k) { return 0.05 * std::sin(2.0 * M_PI * 0.25 * k / 2.0); }, 200),
                         "W.json"));
  int shipped = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(DELTA_SOURCE_DIR) + "/weights")) {
    if (entry.path().extension() != ".json") continue;
    SCOPED_TRACE(entry.path().string());
    EXPECT_NO_THROW(read_weights_file(entry.path().string()));
    ++shipped;
  }
  EXPECT_GE(shipped, 3);
}

// The shipped board network (an inverse kinematics, as every trained model is) with the table above.
TEST(SetpointShaping, TheShapedSetpointMakesTheNetworkAnswerWithTheTable) {
  WeightsFile weights = rippled_weights(16, 2);
  weights.network = read_weights_file(std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json").network;
  std::mt19937_64 generator(16);
  std::printf("positions seed 16\n");
  std::uniform_real_distribution<double> xy(-0.005, 0.005), z(-0.081, -0.071);
  double largest_shift_m = 0.0;
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(xy(generator), xy(generator), z(generator));
    const Vec3 answer = weights.network.evaluate(p);
    const Vec3 shaped = shape_setpoint(weights, p);
    largest_shift_m = std::max(largest_shift_m, (shaped - p).norm());
    const Vec3 error = weights.network.evaluate(shaped) - (answer + weights.joint_ripple.at(answer));
    EXPECT_LT(error.cwiseAbs().maxCoeff(), 1e-9) << "pose " << i;
    // Unshaped back to within a nanometre (the board's input LSB is 3.7 nm).
    EXPECT_LT((unshape_setpoint(weights, shaped) - p).cwiseAbs().maxCoeff(), 1e-9) << "pose " << i;
    // The float model is the network at the shaped setpoint.
    const IkSolution model = evaluate_model(weights, p);
    EXPECT_EQ(model.alpha_deg, weights.network.evaluate(shaped));
  }
  std::printf("largest shift %.3f um\n", largest_shift_m * 1e6);
  EXPECT_GT(largest_shift_m, 1e-6);  // 0.03 deg of ripple: microns at the plate
  WeightsFile plain = weights;
  plain.joint_ripple = {};
  const Vec3 p(0.001, -0.002, -0.075);
  EXPECT_EQ(shape_setpoint(plain, p), p);
  EXPECT_EQ(unshape_setpoint(plain, p), p);
}

struct BadCase {
  std::string name;
  std::string from;
  std::string to;
  std::string reason;  // part of the expected message
};

TEST(WeightsFile, DeltactlRejectsBrokenFilesWithFileLineReasonAndExitCode2) {
  const std::string good = weights_file_text(random_weights(13, 2));
  const std::string in = temp("in.csv");
  write_text(in, "x_m,y_m,z_m\n0,0,-0.075\n");
  const std::vector<BadCase> cases = {
      {"version", "\"version\": 1", "\"version\": 4", "unsupported weights file version 4"},
      {"shape", "\"hidden\": 2", "\"hidden\": 3", "input_weights: expected 3 rows"},
      {"row", "\"output_bias\": [", "\"output_bias\": [1, ", "output_bias: expected an array of 3"},
      {"infinite", "\"hidden_bias\": [", "\"hidden_bias\": [1e999, ", "not finite"},
      {"null", "\"hidden_bias\": [", "\"hidden_bias\": [null, ", "hidden_bias: expected a number"},
      {"model", "\"model\": \"network\"", "\"model\": \"table\"", "model must be"},
      {"range", "\"input_max\": [0.005", "\"input_max\": [-0.005", "input_max must exceed"},
      {"json", "\"format\"", "format\"", "invalid JSON"}};
  for (const BadCase& c : cases) {
    SCOPED_TRACE(c.name);
    std::string text = good;
    const std::size_t at = text.find(c.from);
    ASSERT_NE(at, std::string::npos);
    text.replace(at, c.from.size(), c.to);
    if (c.name == "infinite" || c.name == "null") {  // keep the length: drop the original first value
      const std::size_t value = at + c.to.size();
      text.erase(value, text.find(',', value) + 2 - value);
    }
    const std::string path = temp(c.name + ".json");
    write_text(path, text);
    EXPECT_THROW(read_weights_file(path), InputError);
    const std::string out = temp(c.name + "_out.csv");
    std::remove(out.c_str());
    const auto result = run_deltactl("ik --weights " + path + " --in " + in + " --out " + out);
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_NE(result.err.find(path + ":"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find(c.reason), std::string::npos) << result.err;
    EXPECT_FALSE(file_exists(out));
  }
}

TEST(FloatBackend, DeltactlIkEqualsNetworkEvaluateExactly) {
  const WeightsFile weights = random_weights(14, 25);
  const std::string path = temp("float.json");
  write_weights_file(path, weights);
  std::mt19937_64 generator(14);
  std::uniform_real_distribution<double> xy(-0.006, 0.006), z(-0.082, -0.070);
  std::string text = "t_s,x_m,y_m,z_m\n";
  std::vector<Vec3> positions;
  for (int i = 0; i < 200; ++i) {
    positions.emplace_back(xy(generator), xy(generator), z(generator));
    text += std::to_string(i) + "," + format_number(positions.back()[0]) + "," + format_number(positions.back()[1]) +
            "," + format_number(positions.back()[2]) + "\n";
  }
  const std::string in = temp("float_in.csv"), out = temp("float_out.csv");
  write_text(in, text);
  const auto result = run_deltactl("ik --weights " + path + " --in " + in + " --out " + out + " --backend float");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const CsvTable table = read_csv(out, {"alpha1_deg", "alpha2_deg", "alpha3_deg"});
  ASSERT_EQ(table.rows.size(), positions.size());
  const WeightsFile loaded = read_weights_file(path);
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const Vec3 expected = weights.network.evaluate(positions[i]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(table.rows[i][k], expected[k]) << "row " << i << " joint " << k;
  }
  // The default back end is the float one.
  const auto fallback = run_deltactl("ik --weights " + path + " --in " + in + " --out " + out + "_default");
  ASSERT_EQ(fallback.exit_code, 0) << fallback.err;
  EXPECT_EQ(delta::test::read_text(out), delta::test::read_text(out + "_default"));
}

}  // namespace
}  // namespace delta::nn

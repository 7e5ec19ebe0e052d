// MATLAB exchange: export then import gives the same network (outputs equal to 1e-12; in fact the
// same bits), for .mat and CSV; an import names what is wrong.
#include <gtest/gtest.h>

#include <random>

#include "../support/run_command.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/matlab_exchange.hpp"
#include "delta/nn/training.hpp"
#include "delta/nn/weights_file.hpp"
#include "nn_test_data.hpp"

namespace delta::nn {
namespace {

Network trained_network() {
  std::vector<Vec3> inputs, targets;
  for (const Sample& s : test::record("validation", test::paper_like_effects(), 800)) {
    inputs.push_back(s.position_m);
    targets.push_back(s.alpha_deg);
  }
  TrainingOptions options;
  options.max_epochs = 5;
  return train_network(inputs, targets, options).network;
}

void expect_same_outputs(const Network& a, const Network& b) {
  std::mt19937_64 generator(21);
  std::printf("seed 21\n");
  std::uniform_real_distribution<double> xy(-0.005, 0.005), z(-0.081, -0.071);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(xy(generator), xy(generator), z(generator));
    EXPECT_LE((a.evaluate(p) - b.evaluate(p)).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_EQ(network_parameters(a), network_parameters(b));  // stronger: identical weights
  EXPECT_EQ(a.input_min, b.input_min);
  EXPECT_EQ(a.input_max, b.input_max);
  EXPECT_EQ(a.output_min, b.output_min);
  EXPECT_EQ(a.output_max, b.output_max);
}

TEST(MatlabExchange, MatFileRoundTrip) {
  const Network network = trained_network();
  const std::string path = ::testing::TempDir() + "nn_round_trip.mat";
  export_matlab(path, network);
  expect_same_outputs(network, import_matlab(path));
}

TEST(MatlabExchange, CsvRoundTrip) {
  const Network network = trained_network();
  const std::string path = ::testing::TempDir() + "nn_round_trip.csv";
  export_matlab(path, network);
  expect_same_outputs(network, import_matlab(path));
}

TEST(MatlabExchange, DeltactlExportImportRoundTrip) {
  WeightsFile weights;
  weights.network = trained_network();
  const std::string stem = ::testing::TempDir() + "nn_cli_round_trip";
  write_weights_file(stem + ".json", weights);
  auto result = delta::test::run_deltactl("export-matlab --weights " + stem + ".json --out " + stem + ".mat");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  result = delta::test::run_deltactl("import-matlab --in " + stem + ".mat --out " + stem + "_back.json");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  expect_same_outputs(weights.network, read_weights_file(stem + "_back.json").network);
}

TEST(MatlabExchange, ImportNamesTheWrongVariable) {
  const std::string path = ::testing::TempDir() + "nn_bad.csv";
  WeightsFile weights;
  weights.network = trained_network();
  export_matlab(path, weights.network);
  std::string text = delta::test::read_text(path);
  text.replace(text.find("\nb2,3,1,"), 8, "\nb2,2,1,");
  delta::test::write_text(path, text);
  try {
    import_matlab(path);
    FAIL() << "accepted a broken b2";
  } catch (const InputError& error) {
    EXPECT_EQ(error.line(), 5u);
    EXPECT_NE(error.reason().find("b2"), std::string::npos) << error.what();
  }
  const auto result = delta::test::run_deltactl("import-matlab --in " + path + " --out " + path + ".json");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_FALSE(delta::test::file_exists(path + ".json"));
}

}  // namespace
}  // namespace delta::nn

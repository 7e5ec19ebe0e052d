// deltactl ik --backend fixed|hls, quantise and accuracy on the shipped weights: raw codes identical
// across back ends and equal to the golden model, deterministic export, refusals, bad input.
#include <gtest/gtest.h>

#include <cstdio>
#include <sstream>

#include "delta/csv.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/nn/weights_file.hpp"
#include "support/run_command.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like.json";

std::string temp_path(const std::string& name) {
  return ::testing::TempDir() + "fixed_cli_" + std::to_string(::getpid()) + "_" + name;
}

// Positions inside the cube, beyond it, and far outside (input saturation).
std::string write_positions() {
  const std::string path = temp_path("positions.csv");
  std::ostringstream text;
  text << "t_s,x_m,y_m,z_m\n";
  for (int i = 0; i < 60; ++i) {
    const double s = i / 59.0;
    text << i << ',' << -0.007 + 0.014 * s << ',' << 0.004 - 0.009 * s * s << ',' << -0.082 + 0.013 * s << '\n';
  }
  text << "60,0.03,-0.03,-0.05\n";
  write_text(path, text.str());
  return path;
}

TEST(FixedCli, FixedAndHlsGiveIdenticalRawCodesEqualToGolden) {
  const std::string in = write_positions();
  const std::string fixed_out = temp_path("fixed.csv");
  const std::string hls_out = temp_path("hls.csv");
  const CommandResult fixed =
      run_deltactl("ik --weights " + kWeights + " --backend fixed --in " + in + " --out " + fixed_out);
  ASSERT_EQ(fixed.exit_code, 0) << fixed.err;
  const CommandResult hls =
      run_deltactl("ik --weights " + kWeights + " --backend hls --in " + in + " --out " + hls_out);
  ASSERT_EQ(hls.exit_code, 0) << hls.err;
  EXPECT_NE(hls.err.find("saturations: scaled input 1"), std::string::npos) << hls.err;  // the far position
  const std::vector<std::string> columns = {"alpha1_deg", "alpha2_deg", "alpha3_deg",
                                            "alpha1_raw", "alpha2_raw", "alpha3_raw"};
  const CsvTable a = read_csv(fixed_out, columns);
  const CsvTable b = read_csv(hls_out, columns);
  const CsvTable positions = read_csv(in, {"x_m", "y_m", "z_m"});
  ASSERT_EQ(a.rows.size(), positions.rows.size());
  ASSERT_EQ(b.rows.size(), positions.rows.size());
  const golden::QuantisedNetwork q = golden::quantise(nn::read_weights_file(kWeights).network);
  for (std::size_t i = 0; i < a.rows.size(); ++i) {
    const auto& p = positions.rows[i];
    const golden::RawOutput golden =
        golden::evaluate_raw(q, golden::encode_position(q.formats, Vec3(p[0], p[1], p[2])));
    for (int o = 0; o < 3; ++o) {
      EXPECT_EQ(static_cast<std::int64_t>(a.rows[i][3 + o]), golden.alpha[o]) << "row " << i;
      EXPECT_EQ(b.rows[i][3 + o], a.rows[i][3 + o]) << "row " << i;
      EXPECT_EQ(a.rows[i][o], a.rows[i][3 + o] / 16384.0) << "row " << i;  // Q10.14 degrees
    }
  }
}

TEST(FixedCli, QuantiseIsDeterministicAndMatchesTheLibrary) {
  const std::string dir_a = temp_path("export_a");
  const std::string dir_b = temp_path("export_b");
  ASSERT_EQ(std::system(("mkdir -p " + dir_a + " " + dir_b).c_str()), 0);
  for (const std::string& dir : {dir_a, dir_b}) {
    const CommandResult result = run_deltactl("quantise --weights " + kWeights + " --out-dir " + dir + " --vectors 50");
    ASSERT_EQ(result.exit_code, 0) << result.err;
  }
  const golden::QuantisedNetwork q = golden::quantise(nn::read_weights_file(kWeights).network);
  for (const golden::ExportFile& file : golden::export_files(q)) {
    EXPECT_EQ(read_text(dir_a + "/" + file.name), file.text) << file.name;
    EXPECT_EQ(read_text(dir_b + "/" + file.name), file.text) << file.name;
  }
  EXPECT_EQ(read_text(dir_a + "/golden_vectors.txt"), read_text(dir_b + "/golden_vectors.txt"));
  // Spot-check the $readmemh layout: header comments, then one masked hex word per line.
  std::istringstream weights(read_text(dir_a + "/input_weights.mem"));
  std::string line;
  std::getline(weights, line);
  EXPECT_EQ(line.rfind("// ", 0), 0u);
  int words = 0;
  while (std::getline(weights, line)) {
    if (line.rfind("//", 0) == 0) continue;
    EXPECT_EQ(line, golden::hex_word(q.input_weights[words], q.formats.input_weight_bits));
    ++words;
  }
  EXPECT_EQ(words, 3 * q.hidden);
}

TEST(FixedCli, RefusesWeightsThatSaturateWithoutWritingFiles) {
  nn::WeightsFile weights = nn::read_weights_file(kWeights);
  weights.network.output_weights(1, 3) = 500.0;  // LW' far beyond Q7.17
  const std::string path = temp_path("saturating.json");
  nn::write_weights_file(path, weights);
  const std::string dir = temp_path("export_refused");
  ASSERT_EQ(std::system(("mkdir -p " + dir).c_str()), 0);
  const CommandResult result = run_deltactl("quantise --weights " + path + " --out-dir " + dir);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("LW'(2,4)"), std::string::npos) << result.err;
  EXPECT_FALSE(file_exists(dir + "/input_weights.mem"));
  const CommandResult ik = run_deltactl("ik --weights " + path + " --backend fixed --in " + write_positions() +
                                        " --out " + temp_path("never.csv"));
  EXPECT_EQ(ik.exit_code, 2);
  EXPECT_FALSE(file_exists(temp_path("never.csv")));
}

TEST(FixedCli, AccuracyReportsTheBoundOnASmallGrid) {
  const CommandResult result = run_deltactl("accuracy --weights " + kWeights + " --grid-points 21 --no-sweep");
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("| grid, all"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("trajectory experiment2"), std::string::npos);
  EXPECT_NE(result.out.find("Bound 0.001 deg on the whole grid with no saturation inside the trained range: met"),
            std::string::npos);
  // An impossible bound must fail with exit code 1, so the check above can fail too.
  const CommandResult strict =
      run_deltactl("accuracy --weights " + kWeights + " --grid-points 5 --no-sweep --bound-deg 1e-9");
  EXPECT_EQ(strict.exit_code, 1);
}

TEST(FixedCli, AccuracyRefusesAPlotWithoutTheSweep) {
  // The plot draws the word-length sweep: asked without it, refused (exit 2), no file written.
  const std::string png = temp_path("no_sweep.png");
  std::remove(png.c_str());
  const CommandResult result =
      run_deltactl("accuracy --weights " + kWeights + " --grid-points 5 --no-sweep --plot " + png);
  EXPECT_EQ(result.exit_code, 2) << result.out << result.err;
  EXPECT_NE(result.err.find("--plot"), std::string::npos) << result.err;
  EXPECT_FALSE(file_exists(png));
}

TEST(FixedCli, HelpTeachesWithAnExample) {
  for (const char* command : {"quantise", "accuracy"}) {
    const CommandResult result = run_deltactl(std::string(command) + " --help");
    EXPECT_EQ(result.exit_code, 0);
    EXPECT_NE(result.out.find("Example: deltactl " + std::string(command)), std::string::npos) << result.out;
  }
}

}  // namespace
}  // namespace delta::test

// deltactl diagnose: the SPEC contract (outputs, bad input) and a quick subset of the blind suite.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "../support/run_command.hpp"
#include "blind_suite.hpp"
#include "delta/csv.hpp"
#include "delta/diagnosis/report.hpp"
#include "delta/recording.hpp"
#include "support/tree_paths.hpp"

namespace delta::test {
namespace {

std::string temp(const std::string& name) { return ::testing::TempDir() + "diagnose_" + name; }

TEST(DiagnoseCli, HelpTeachesWithAnExample) {
  const CommandResult result = run_deltactl("diagnose --help");
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_NE(result.out.find("Example"), std::string::npos);
  EXPECT_NE(result.out.find("--holdout"), std::string::npos);
}

// One recording pair with a known effect, shared by the contract tests.
struct Pair {
  std::string fit = temp("fit.csv"), check = temp("check.csv");
  Pair() {
    EffectSet effects;
    effects.joint_offset_deg = Vec3(0.2, -0.1, 0.3);
    RecordingOptions options;
    options.samples = 2000;
    const VirtualRobot robot(effects);
    write_recording(fit, robot.record(make_trajectory("sweep", 11), options).samples);
    options.samples = 700;
    write_recording(check, robot.record(make_trajectory("sweep", 12), options).samples);
  }
};

TEST(DiagnoseCli, WritesTheSpecOutputs) {
  const Pair pair;
  const std::string json = temp("out.json"), predictions = temp("pred.csv"), report = temp("report/r.md");
  const CommandResult result = run_deltactl("diagnose --data " + pair.fit + " --holdout " + pair.check + " --json " +
                                            json + " --predictions " + predictions + " --report " + report);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  nlohmann::json document;
  std::ifstream(json) >> document;
  EXPECT_NEAR(document.at("noise_floor_deg").get<double>(), 0.01 / std::sqrt(12.0), 1e-12);
  EXPECT_TRUE(document.at("explained").get<bool>());
  ASSERT_FALSE(document.at("effects").empty());
  EXPECT_EQ(document["effects"][0].at("name"), "joint_offset");
  EXPECT_TRUE(document["effects"][0].at("significant").get<bool>());
  EXPECT_NEAR(document["effects"][0]["parameters"]["o_deg"][2].get<double>(), 0.3, 2e-3);
  for (int j = 0; j < 3; ++j) {
    EXPECT_GT(document["holdout"]["rmse_nominal_deg"][j].get<double>(), 0.09);
    EXPECT_LT(document["holdout"]["rmse_after_deg"][j].get<double>(), 0.0032);
  }
  const Recording check = read_recording(pair.check);
  const CsvTable rows = read_csv(predictions, {"t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg"});
  ASSERT_EQ(rows.rows.size(), check.samples.size());
  for (std::size_t i = 0; i < rows.rows.size(); ++i) ASSERT_EQ(rows.rows[i][0], check.samples[i].t_s);
  EXPECT_TRUE(file_exists(report));
  EXPECT_TRUE(file_exists(temp("report/r_map.png")));
}

TEST(DiagnoseCli, BadInputNamesFileAndLineAndWritesNothing) {
  const Pair pair;
  std::string text = read_text(pair.check);
  // Time going backwards on the 4th data line.
  std::vector<std::string> lines;
  std::istringstream stream(text);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  std::size_t header = 0;
  while (lines[header][0] == '#') ++header;
  lines[header + 4] = "0" + lines[header + 4].substr(lines[header + 4].find(','));
  std::string broken;
  for (const std::string& line : lines) broken += line + "\n";
  const std::string bad = temp("bad.csv");
  write_text(bad, broken);
  const std::string json = temp("bad.json"), predictions = temp("bad_pred.csv");
  std::filesystem::remove(json);
  std::filesystem::remove(predictions);
  const CommandResult result = run_deltactl("diagnose --data " + pair.fit + " --holdout " + bad + " --json " + json +
                                            " --predictions " + predictions);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find(bad + ":" + std::to_string(header + 5) + ": time goes backwards"), std::string::npos)
      << result.err;
  EXPECT_FALSE(file_exists(json));
  EXPECT_FALSE(file_exists(predictions));
  // A position the nominal robot cannot reach.
  write_text(bad, "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m\n0,30,30,30,0,0,-0.5\n");
  const CommandResult unreachable = run_deltactl("diagnose --data " + bad + " --holdout " + pair.check + " --json " +
                                                 json + " --predictions " + predictions);
  EXPECT_EQ(unreachable.exit_code, 2);
  EXPECT_NE(unreachable.err.find(bad + ": has 1 rows"), std::string::npos) << unreachable.err;
  EXPECT_FALSE(file_exists(json));
}

// The report reads in one order: the selection trace's models, the "gap shrinks" table's rows and
// the summary's significant set all name the effects in the order forward selection added them
// (here backlash, the larger effect, before joint_offset, which the vocabulary lists first). The
// summary states how long the recordings are, not only how long the diagnosis took.
TEST(DiagnoseReport, TraceGapTableAndSummaryFollowTheOrderEffectsWereAdded) {
  EffectSet effects;
  effects.backlash_deg = Vec3(0.4, 0.3, 0.35);
  effects.joint_offset_deg = Vec3(0.04, -0.03, 0.05);
  const VirtualRobot robot(effects);
  RecordingOptions options;
  options.samples = 2000;
  const std::string fit = temp("order_fit.csv"), check = temp("order_check.csv");
  const std::vector<Sample> fit_rows = robot.record(make_trajectory("sweep", 21), options).samples;
  write_recording(fit, fit_rows);
  options.samples = 700;
  write_recording(check, robot.record(make_trajectory("sweep", 22), options).samples);
  const std::string report = temp("order/report.md");
  const CommandResult result =
      run_deltactl("diagnose --data " + fit + " --holdout " + check + " --json " + temp("order.json") +
                   " --predictions " + temp("order_pred.csv") + " --report " + report);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::string text = read_text(report);
  // The gap table: "| + name ..." rows after the heading.
  std::vector<std::string> gap;
  std::istringstream lines(text.substr(text.find("## How far the gap shrinks")));
  for (std::string line; std::getline(lines, line) && line.rfind("## Effects", 0) != 0;) {
    if (line.rfind("| + ", 0) == 0) gap.push_back(line.substr(4, line.find(' ', 4) - 4));
  }
  ASSERT_EQ(gap.size(), 2u) << text;
  EXPECT_EQ(gap[0], "backlash");
  EXPECT_EQ(gap[1], "joint_offset");
  // The trace: "- from **MODEL**: ... -> added NAME".
  std::vector<std::pair<std::string, std::string>> trace;
  std::istringstream steps(text.substr(text.find("## Selection trace")));
  for (std::string line; std::getline(steps, line);) {
    if (line.rfind("- from **", 0) != 0) continue;
    const std::size_t end = line.find("**", 9), added = line.find("-> added ");
    trace.push_back({line.substr(9, end - 9), added == std::string::npos ? "" : line.substr(added + 9)});
  }
  ASSERT_EQ(trace.size(), 3u) << text;
  std::string model = "nominal";
  for (std::size_t k = 0; k < trace.size(); ++k) {
    EXPECT_EQ(trace[k].first, model) << "step " << k + 1;
    if (k < gap.size()) {
      EXPECT_EQ(trace[k].second, gap[k]) << "step " << k + 1;
      model = k == 0 ? gap[k] : model + " + " + gap[k];
    }
  }
  EXPECT_NE(result.out.find("significant: backlash + joint_offset;"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("verdict: backlash + joint_offset"), std::string::npos) << result.out;
  // The recordings' lengths: FIT spans its first to its last t_s.
  std::ostringstream span;
  span.setf(std::ios::fixed);
  span.precision(1);
  span << "FIT " << fit_rows.back().t_s - fit_rows.front().t_s << " s (" << fit_rows.size() << " rows)";
  EXPECT_NE(result.out.find(span.str()), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("computed in "), std::string::npos) << result.out;
}

// The example: chain angles plus radius offsets, which a frame misalignment plus radius
// offsets imitates to within a few hundredths of the floor. The diagnosis must name the injected
// set, or name an equivalent one and list the injected set among its alternatives; the verdict
// names every equivalent set; the floor test gives its figure and threshold; the fitted values lie
// within their intervals (taken twice as wide: neighbouring rows are correlated).
TEST(DiagnoseCli, NamesEquivalentExplanationsAndIntervals) {
  EffectSet effects;
  effects.chain_angle_deg = Vec3(0.35, 0.35, 0.92);
  effects.radius_offset_m = Vec3(0.3e-3, -0.2e-3, 0.1e-3);
  const VirtualRobot robot(effects);
  RecordingOptions options;
  options.samples = 5000;
  const std::string fit = temp("equivalent_fit.csv"), check = temp("equivalent_check.csv");
  const std::vector<Sample> fit_rows = robot.record(make_trajectory("validation"), options).samples;
  write_recording(fit, fit_rows);
  options.samples = 2500;
  write_recording(check, robot.record(make_trajectory("sweep", 2), options).samples);
  const std::string json = temp("equivalent.json"), predictions = temp("equivalent_pred.csv");
  const CommandResult result = run_deltactl("diagnose --data " + fit + " --holdout " + check + " --json " + json +
                                            " --predictions " + predictions);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  nlohmann::json document;
  std::ifstream(json) >> document;
  const std::set<std::string> injected = {"chain_angle", "radius_offset"};
  std::set<std::string> chosen;
  for (const auto& effect : document.at("effects")) {
    if (effect.at("significant").get<bool>()) chosen.insert(effect.at("name").get<std::string>());
  }
  bool listed = false;
  for (const auto& alternative : document.at("alternatives")) {
    const auto names = alternative.at("effects").get<std::vector<std::string>>();
    listed |= std::set<std::string>(names.begin(), names.end()) == injected;
    EXPECT_NE(document.at("verdict").get<std::string>().find("or equivalently"), std::string::npos);
    EXPECT_FALSE(alternative.at("separate_by").get<std::string>().empty());
  }
  EXPECT_TRUE(chosen == injected || listed) << document.at("verdict");
  // How far each joint travels on FIT, as the report states it (no outliers here: every row).
  for (int j = 0; j < 3; ++j) {
    double low = 1e9, high = -1e9;
    for (const Sample& row : fit_rows) {
      low = std::min(low, row.alpha_deg[j]);
      high = std::max(high, row.alpha_deg[j]);
    }
    EXPECT_DOUBLE_EQ(document.at("fit_joint_travel_deg")[j].get<double>(), high - low) << "joint " << j + 1;
  }
  EXPECT_TRUE(document.at("explained").get<bool>()) << document.at("floor_test");
  EXPECT_LE(document["floor_test"].at("statistic_z").get<double>(),
            document["floor_test"].at("threshold_z").get<double>());
  if (chosen != injected) return;
  for (const auto& effect : document.at("effects")) {
    if (!effect.at("significant").get<bool>()) continue;
    const bool angle = effect.at("name") == "chain_angle";
    const auto& value = effect["final_parameters"][angle ? "dphi_deg" : "dr_m"];
    const auto& half = effect["confidence_95_half_width"][angle ? "dphi_deg" : "dr_m"];
    const Vec3 truth = angle ? *effects.chain_angle_deg : *effects.radius_offset_m;
    for (int j = 0; j < 3; ++j) {
      EXPECT_GT(half[j].get<double>(), 0.0);
      EXPECT_LE(std::abs(value[j].get<double>() - truth[j]), 2.0 * half[j].get<double>())
          << effect.at("name") << " joint " << j + 1;
    }
  }
}

// A residual above the floor on a FIT whose joints travel less than a long gear ripple's period
// (the validation trajectory's 16-20 deg) may be effects of the vocabulary that this FIT cannot
// separate: the verdict says so, with the travel and the drag that turns the joints further; on a
// FIT that travels 30 deg or more it names an effect outside the vocabulary alone.
// A recording whose header says its counts were not referenced at the home switches ("# referenced:
// hand" or "none": host record --unreferenced) is refused by diagnose and train (exit 2, one line
// naming the file and --unreferenced, nothing written) unless --unreferenced; "home switches" and a
// recording that does not say are taken; a header that says something else is refused naming its line.
TEST(DiagnoseCli, ARecordingWhoseCountsWereNotReferencedIsRefusedUnlessTold) {
  EffectSet effects;
  effects.joint_offset_deg = Vec3(0.2, -0.1, 0.3);
  RecordingOptions options;
  options.samples = 2000;
  const VirtualRobot robot(effects);
  const std::vector<Sample> fit_rows = robot.record(make_trajectory("sweep", 11), options).samples;
  options.samples = 700;
  const std::string check = temp("ref_check.csv");
  write_recording(check, robot.record(make_trajectory("sweep", 12), options).samples,
                  {referencing_comment(Referencing::kHomeSwitches)});
  const std::string json = temp("ref.json"), predictions = temp("ref_pred.csv"), weights = temp("ref_w.json");
  for (const Referencing referencing : {Referencing::kHand, Referencing::kNone}) {
    const std::string fit = temp(std::string("ref_fit_") + referencing_name(referencing) + ".csv");
    write_recording(fit, fit_rows, {"deltactl host record", referencing_comment(referencing)});
    std::filesystem::remove(json);
    std::filesystem::remove(weights);
    const std::string diagnose =
        "diagnose --data " + fit + " --holdout " + check + " --json " + json + " --predictions " + predictions;
    const CommandResult refused = run_deltactl(diagnose);
    EXPECT_EQ(refused.exit_code, 2) << refused.err;
    EXPECT_EQ(std::count(refused.err.begin(), refused.err.end(), '\n'), 1) << refused.err;
    EXPECT_NE(refused.err.find(fit + ":2:"), std::string::npos) << refused.err;  // the file and its line
    EXPECT_NE(refused.err.find("--unreferenced"), std::string::npos) << refused.err;
    EXPECT_NE(refused.err.find("host home"), std::string::npos) << refused.err;
    EXPECT_FALSE(std::filesystem::exists(json));
    // The held-out recording is held to the same rule.
    const CommandResult swapped = run_deltactl("diagnose --data " + check + " --holdout " + fit + " --json " + json +
                                               " --predictions " + predictions);
    EXPECT_EQ(swapped.exit_code, 2) << swapped.err;
    const CommandResult train = run_deltactl("train --data " + fit + " --out " + weights);
    EXPECT_EQ(train.exit_code, 2) << train.err;
    EXPECT_NE(train.err.find(fit), std::string::npos) << train.err;
    EXPECT_FALSE(std::filesystem::exists(weights));
    if (referencing == Referencing::kNone) {
      const CommandResult told = run_deltactl(diagnose + " --unreferenced");
      EXPECT_EQ(told.exit_code, 0) << told.err;
      const CommandResult trained =
          run_deltactl("train --data " + fit + " --out " + weights + " --unreferenced --max-epochs 2 --threads 1");
      EXPECT_EQ(trained.exit_code, 0) << trained.err;
    }
  }
  const std::string odd = temp("ref_odd.csv");
  write_recording(odd, fit_rows, {"referenced: somewhere"});
  const CommandResult bad = run_deltactl("diagnose --data " + odd + " --holdout " + check + " --json " + json +
                                         " --predictions " + predictions);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find(odd + ":1:"), std::string::npos) << bad.err;
}

// simulate's recordings say they are referenced at the home switches (the virtual robot's encoders
// read the home count there).
TEST(DiagnoseCli, SimulateSaysItsCountsAreReferencedAtTheHomeSwitches) {
  const std::string out = temp("simulated.csv");
  const CommandResult simulate = run_deltactl("simulate --experiment sweep --samples 200 --out " + out);
  ASSERT_EQ(simulate.exit_code, 0) << simulate.err;
  EXPECT_NE(read_text(out).find("\n# referenced: home switches\n"), std::string::npos) << read_text(out).substr(0, 400);
}

// A joint offset no assembled robot has (beyond 2 deg: counts not referenced at the home switches)
// is a warning naming the joint and homing, in the summary and the JSON's "warnings"; the
// paper-like sizes (tenths of a degree) are not.
TEST(DiagnoseCli, WarnsOfAJointOffsetNoAssembledRobotHasNamingHoming) {
  for (const double offset : {3.5, 0.3}) {
    EffectSet effects;
    effects.joint_offset_deg = Vec3(offset, -0.1, 0.2);
    RecordingOptions options;
    options.samples = 2000;
    const VirtualRobot robot(effects);
    const std::string fit = temp("offset_fit.csv"), check = temp("offset_check.csv");
    write_recording(fit, robot.record(make_trajectory("sweep", 11), options).samples);
    options.samples = 700;
    write_recording(check, robot.record(make_trajectory("sweep", 12), options).samples);
    const std::string json = temp("offset.json");
    const CommandResult result = run_deltactl("diagnose --data " + fit + " --holdout " + check + " --json " + json +
                                              " --predictions " + temp("offset_pred.csv"));
    ASSERT_EQ(result.exit_code, 0) << result.err;
    nlohmann::json document;
    std::ifstream(json) >> document;
    ASSERT_TRUE(document.contains("warnings")) << "offset " << offset;
    if (offset > diagnosis::kPlausibleJointOffsetDeg) {
      ASSERT_EQ(document["warnings"].size(), 1u) << document["warnings"].dump();
      const std::string warning = document["warnings"][0].get<std::string>();
      EXPECT_NE(warning.find("joint 1's offset 3.50 deg"), std::string::npos) << warning;
      EXPECT_NE(warning.find("host home"), std::string::npos) << warning;
      EXPECT_NE(result.out.find("warning: joint 1's offset"), std::string::npos) << result.out;
    } else {
      EXPECT_TRUE(document["warnings"].empty()) << document["warnings"].dump();
      EXPECT_EQ(result.out.find("warning:"), std::string::npos) << result.out;
    }
  }
}

TEST(DiagnoseReport, ANotExplainedVerdictSaysWhenTheFitTravelsTooLittleToSeparateARipple) {
  diagnosis::Diagnosis d;
  d.explained = false;
  d.floor_test.z = 6.4;
  d.floor_test.threshold = 4.0;
  d.unexplained.joint = 2;
  d.unexplained.region = "x+ y- z-";
  d.fit_joint_travel_deg = Vec3(16.1, 19.7, 19.2);
  std::ostringstream short_travel;
  diagnosis::print_summary(short_travel, d);
  EXPECT_NE(short_travel.str().find("outside the vocabulary, or effects the FIT recording cannot separate (its "
                                    "joints travel 16.1 / 19.7 / 19.2 deg"),
            std::string::npos)
      << short_travel.str();
  EXPECT_NE(short_travel.str().find("calibration trajectory"), std::string::npos);
  d.fit_joint_travel_deg = Vec3(38.0, 41.5, 30.0);
  std::ostringstream long_travel;
  diagnosis::print_summary(long_travel, d);
  EXPECT_NE(long_travel.str().find("an effect outside the vocabulary; its excess"), std::string::npos)
      << long_travel.str();
  EXPECT_EQ(long_travel.str().find("cannot separate"), std::string::npos);
  d.explained = true;
  d.fit_joint_travel_deg = Vec3(16.1, 19.7, 19.2);
  std::ostringstream explained;
  diagnosis::print_summary(explained, d);
  EXPECT_EQ(explained.str().find("cannot separate"), std::string::npos) << explained.str();
}

// A model above the floor by one joint alone (the three joints together within the threshold) or
// by a joint's held-out RMSE above the cap: the verdict and the summary name that part of the floor
// test, never "z = 3.58 > 4.0".
TEST(DiagnoseReport, ANotExplainedVerdictNamesThePartOfTheFloorTestMissed) {
  diagnosis::Diagnosis d;
  d.explained = false;
  d.floor_test.threshold = 4.0;
  d.floor_test.rmse_cap_floors = 1.5;
  d.floor_test.z = 6.91;
  d.floor_test.joint_z = Vec3(5.6, 3.2, 4.5);
  d.floor_test.joint_rmse_floors = Vec3(1.07, 1.05, 1.05);
  d.fit_joint_travel_deg = Vec3(38.0, 41.5, 30.0);
  const auto summary = [&d] {
    std::ostringstream out;
    diagnosis::print_summary(out, d);
    return out.str();
  };
  std::string text = summary();
  EXPECT_NE(text.find("(floor test z = 6.91 > 4.0, held-out"), std::string::npos) << text;
  d.floor_test.z = 3.58;
  d.floor_test.joint_z = Vec3(1.7, 1.2, 4.67);
  text = summary();
  EXPECT_NE(text.find("(joint 3's floor test z = 4.67 > 4.5, the three joints' z = 3.58, held-out"), std::string::npos)
      << text;
  EXPECT_NE(text.find("explained: no (joint 3's floor test z"), std::string::npos) << text;
  EXPECT_EQ(text.find("> 4.0"), std::string::npos) << text;
  d.floor_test.joint_z = Vec3(1.7, 1.2, 2.0);
  d.floor_test.joint_rmse_floors = Vec3(1.07, 1.62, 1.05);
  text = summary();
  EXPECT_NE(text.find("(joint 2 at 1.62 floors held out, above the cap of 1.5, held-out"), std::string::npos) << text;
}

// Quick blind subset: none, chain angle, backlash, transmission error, three pairs (10 needs the
// transmission restart, 15 the swap search) and the unequal-rods robot; outlier cases also require
// every glitch row listed (CaseScore::set_ok).
class BlindSubset : public ::testing::TestWithParam<int> {};

TEST_P(BlindSubset, DiagnosisFindsTheInjectedSet) {
  const blind::BlindCase blind_case = blind::make_case(GetParam(), true);
  std::cout << "blind case " << GetParam() << ": " << blind_case.description << '\n';
  const blind::CaseScore score = blind::run_case(blind_case, DELTACTL_PATH, ::testing::TempDir() + "blind_subset");
  ASSERT_TRUE(score.error.empty()) << score.error;
  std::string reported;
  for (const std::string& name : score.reported) reported += name + " ";
  EXPECT_TRUE(score.set_ok) << "injected " << blind_case.description << ", reported " << reported;
  EXPECT_TRUE(score.rmse_ok) << "held-out RMSE " << score.rmse_after_over_floor << " noise floors";
}

INSTANTIATE_TEST_SUITE_P(Quick, BlindSubset, ::testing::Values(0, 5, 7, 8, 10, 12, 15, 17));
// Extended kinds: a trading pair, small effect, glitches without effect, glitches and a gap under
// backlash, stage scale errors outside the vocabulary (all axes: measuring_scale named; x alone:
// not imitated, explained false; y alone, -0.30 %: imitated by the vocabulary, measuring_scale per axis named).
INSTANTIATE_TEST_SUITE_P(Extended, BlindSubset, ::testing::Values(100, 104, 106, 107, 108, 109, 139));

}  // namespace
}  // namespace delta::test

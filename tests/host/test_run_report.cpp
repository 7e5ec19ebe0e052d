// deltactl run-report's library on a run of known errors: a move out, a dwell, a move back through
// a reversal, with the plate a known offset (and one spike) from its reference; the dwells, the
// reversals and every figure as constructed; the truth read at other instants than the run's; and
// the command's refusals of bad input (exit 2, one line, no JSON left).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "delta/input_error.hpp"
#include "delta/run_report.hpp"
#include "support/run_command.hpp"

namespace delta::test {
namespace {

constexpr double kPi = 3.14159265358979323846;
const Vec3 kOffsetM(3e-6, -4e-6, 0.0);  // the plate's error everywhere: 5 um
constexpr double kSpikeAtS = 1.0;       // and 12 um in z at this row (moving)

// x of the reference: rest at 0 until 0.5 s, out to 5 mm by 1.5 s, rest until 2 s, back to 0 by
// 3 s, rest until 3.3 s.
double x_reference(double t) {
  if (t < 0.5) return 0.0;
  if (t < 1.5) return 2.5e-3 * (1.0 - std::cos(kPi * (t - 0.5)));
  if (t < 2.0) return 5e-3;
  if (t < 3.0) return 2.5e-3 * (1.0 + std::cos(kPi * (t - 2.0)));
  return 0.0;
}
Vec3 reference(double t) { return Vec3(x_reference(t), 0.0, -0.075); }
// With `settling`, the plate also overshoots by 20 um in y for the first 30 ms of the dwell at 5 mm
// (1.5 .. 1.53 s: inside the 50 ms a dwell is given to settle).
constexpr double kSettlingFromS = 1.5, kSettlingToS = 1.53;
Vec3 plate(double t, bool settling) {
  Vec3 p = reference(t) + kOffsetM;
  if (std::abs(t - kSpikeAtS) < 1e-9) p.z() += 12e-6;
  if (settling && t >= kSettlingFromS - 1e-9 && t < kSettlingToS - 1e-9) p.y() += 20e-6;
  return p;
}

// 1 kHz rows 0 .. 3.3 s; the drives on from row 5; joint 1's reference follows x (1 deg per mm),
// joint 2's encoder 0.01 deg behind.
std::string run_csv(bool with_plate, bool settling = false) {
  std::ostringstream out;
  out << std::setprecision(17) << "# a run of known errors\n"
      << "t_s,x_ref_m,y_ref_m,z_ref_m,alpha1_ref_deg,alpha2_ref_deg,alpha3_ref_deg,alpha1_deg,alpha2_deg,alpha3_deg,"
      << "drives_enabled" << (with_plate ? ",x_m,y_m,z_m" : "") << "\n";
  for (int k = 0; k <= 3300; ++k) {
    const double t = k * 1e-3;
    const Vec3 r = reference(t);
    const double a1 = 30.0 + r.x() * 1e3;
    out << t << ',' << r.x() << ',' << r.y() << ',' << r.z() << ',' << a1 << ",31,32," << a1 << ",30.99,32,"
        << (k >= 5 ? 1 : 0);
    if (with_plate) {
      const Vec3 p = plate(t, settling);
      out << ',' << p.x() << ',' << p.y() << ',' << p.z();
    }
    out << '\n';
  }
  return out.str();
}

std::string folder() {
  const std::string dir = ::testing::TempDir() + "run_report_" + std::to_string(::getpid()) + "/";
  std::system(("mkdir -p " + dir).c_str());
  return dir;
}

TEST(RunReport, FiguresDwellsAndReversalsOfARunOfKnownErrors) {
  const std::string dir = folder();
  write_text(dir + "run.csv", run_csv(true));
  const RunReport r = run_report_of_file(dir + "run.csv");
  std::cout << report_text(r);
  EXPECT_EQ(r.rows, 3301u);
  EXPECT_EQ(r.driven_rows, 3296u);
  ASSERT_TRUE(r.plate_measured);
  EXPECT_EQ(r.plate_rows, 3296u);
  // Everywhere 5 um (3, -4, 0) but one row of 12 um more in z.
  const PlateFigures& all = r.plate[kAllRows];
  EXPECT_NEAR(all.rms_m.x(), 3e-6, 1e-12);
  EXPECT_NEAR(all.rms_m.y(), 4e-6, 1e-12);
  EXPECT_NEAR(all.rms_m.z(), std::sqrt(144e-12 / 3296.0), 1e-12);
  EXPECT_NEAR(all.max_abs_m.z(), 12e-6, 1e-12);
  EXPECT_NEAR(all.max_distance_m, std::sqrt(9 + 16 + 144) * 1e-6, 1e-12);
  EXPECT_NEAR(all.max_at_s, kSpikeAtS, 1e-9);
  EXPECT_NEAR(r.plate[kMoving].max_distance_m, all.max_distance_m, 1e-15);  // the spike is mid-move
  EXPECT_NEAR(r.plate[kAtRest].max_distance_m, 5e-6, 1e-12);
  EXPECT_EQ(r.plate[kMoving].rows + r.plate[kAtRest].rows + r.plate[kReversals].rows, r.plate_rows);

  // Three dwells: from the enable to 0.5 s, 1.5 .. 2 s at 5 mm, 3 .. 3.3 s; each within the few ms
  // the cosine ramp spends within 1 um of where the dwell starts (up to 2 um of its end: 13 ms).
  ASSERT_EQ(r.dwells.size(), 3u);
  const double starts[] = {0.005, 1.49, 2.99}, ends[] = {0.51, 2.0, 3.3};
  for (std::size_t d = 0; d < 3; ++d) {
    EXPECT_NEAR(r.dwells[d].start_s, starts[d], 0.013) << d;
    EXPECT_NEAR(r.dwells[d].start_s + r.dwells[d].duration_s, ends[d], 0.013) << d;
    EXPECT_NEAR(r.dwells[d].mean_distance_m, 5e-6, 1e-12) << d;
    EXPECT_NEAR(r.dwells[d].max_distance_m, 5e-6, 1e-12) << d;
    EXPECT_NEAR(r.dwells[d].settled_mean_distance_m, 5e-6, 1e-12) << d;
    EXPECT_EQ(r.dwells[d].settled_rows + 50u, r.dwells[d].rows) << d;  // 1 kHz rows
  }
  EXPECT_NEAR(r.dwells[1].reference_m.x(), 5e-3, 1e-6);
  // One reversal, of x and of joint 1 (which follows it), as the dwell at 5 mm ends; none where
  // the motion starts from rest or comes to rest.
  ASSERT_EQ(r.reversals.size(), 2u);
  for (const Reversal& v : r.reversals) {
    EXPECT_NEAR(v.t_s, 2.0, 1.5e-3) << v.signal;
    EXPECT_TRUE(v.signal == "x" || v.signal == "alpha1") << v.signal;
  }
  // Its window's rows not at rest: the 100 ms after it, less the few ms the dwell lasts beyond it
  // (the ramp back within 1 um of 5 mm).
  EXPECT_GT(r.plate[kReversals].rows, 85u);
  EXPECT_LE(r.plate[kReversals].rows, 100u);
  // Joint tracking: joint 2 0.01 deg behind, the others exact.
  EXPECT_NEAR(r.joints[kAllRows].rms_deg[1], 0.01, 1e-9);
  EXPECT_NEAR(r.joints[kAllRows].max_abs_deg[1], 0.01, 1e-9);
  EXPECT_NEAR(r.joints[kAllRows].rms_deg[0], 0.0, 1e-9);
  EXPECT_NEAR(r.joints[kAllRows].rms_deg[2], 0.0, 1e-9);
  // The JSON carries the same.
  const nlohmann::json j = report_json(r);
  EXPECT_NEAR(j["plate"]["all"]["max_distance_um"].get<double>(), std::sqrt(169.0), 1e-6);
  EXPECT_EQ(j["dwells"].size(), 3u);
  EXPECT_EQ(j["reversals"].size(), 2u);
  EXPECT_NE(report_headline(r).find("plate - reference: rms"), std::string::npos) << report_headline(r);
  std::system(("rm -rf " + dir).c_str());
}

// Where a part is set down: a dwell's settled figures leave out its first 50 ms (an overshoot of
// 20 um there), its figures over the whole dwell do not; the headline names the worst settled dwell.
TEST(RunReport, ADwellsSettledFiguresLeaveOutItsFirst50Ms) {
  const std::string dir = folder();
  write_text(dir + "run.csv", run_csv(true, true));
  const RunReport r = run_report_of_file(dir + "run.csv");
  std::cout << dwells_text(r);
  ASSERT_EQ(r.dwells.size(), 3u);
  const Dwell& d = r.dwells[1];
  ASSERT_LE(d.start_s, kSettlingFromS);  // the overshoot lies inside the dwell's first 50 ms
  ASSERT_GE(d.start_s + kDwellSettleS, kSettlingToS);
  const double overshoot = Vec3(3e-6, 16e-6, 0.0).norm();  // kOffsetM + 20 um in y
  EXPECT_NEAR(d.max_distance_m, overshoot, 1e-12);
  const double n = static_cast<double>(d.measured_rows);
  const double overshoot_rows = std::round((kSettlingToS - kSettlingFromS) * 1e3);
  EXPECT_NEAR(d.mean_distance_m, ((n - overshoot_rows) * 5e-6 + overshoot_rows * overshoot) / n, 1e-12);
  EXPECT_NEAR(d.settled_mean_distance_m, 5e-6, 1e-12);
  EXPECT_NEAR(d.settled_max_distance_m, 5e-6, 1e-12);
  ASSERT_NE(worst_dwell(r), nullptr);  // all settle to 5 um
  EXPECT_NEAR(worst_dwell(r)->settled_mean_distance_m, 5e-6, 1e-12);
  const nlohmann::json j = report_json(r);
  EXPECT_NEAR(j["dwells"][1]["settled_mean_um"].get<double>(), 5.0, 1e-6);
  EXPECT_NEAR(j["dwells"][1]["max_um"].get<double>(), overshoot * 1e6, 1e-6);
  const std::string headline = report_headline(r);
  EXPECT_NE(headline.find("where it rests (3 dwells, from 50 ms after each stop): worst mean 5.00 um"),
            std::string::npos)
      << headline;
  std::system(("rm -rf " + dir).c_str());
}

// A co-simulation's recording (`cosim --out`) names the references otherwise (net1..3_deg,
// ref_x_m..): read the same, the same figures.
TEST(RunReport, ACosimulationsRecordingGivesTheSameReport) {
  const std::string dir = folder();
  std::string text = run_csv(true);
  const std::string host_header =
      "t_s,x_ref_m,y_ref_m,z_ref_m,alpha1_ref_deg,alpha2_ref_deg,alpha3_ref_deg,alpha1_deg,alpha2_deg,alpha3_deg";
  const std::string cosim_header =
      "t_s,ref_x_m,ref_y_m,ref_z_m,net1_deg,net2_deg,net3_deg,alpha1_deg,alpha2_deg,alpha3_deg";
  ASSERT_NE(text.find(host_header), std::string::npos);
  write_text(dir + "run.csv", text);
  write_text(dir + "cosim.csv", text.replace(text.find(host_header), host_header.size(), cosim_header));
  const RunReport host = run_report_of_file(dir + "run.csv");
  const RunReport cosim = run_report_of_file(dir + "cosim.csv");
  ASSERT_TRUE(cosim.plate_measured);
  EXPECT_EQ(cosim.dwells.size(), host.dwells.size());
  EXPECT_EQ(cosim.reversals.size(), host.reversals.size());
  for (int s = 0; s < kRunSegments; ++s) {
    EXPECT_EQ(cosim.plate[s].rows, host.plate[s].rows) << segment_name(s);
    EXPECT_DOUBLE_EQ(cosim.plate[s].rms_distance_m, host.plate[s].rms_distance_m) << segment_name(s);
    EXPECT_EQ(cosim.joints[s].rms_deg, host.joints[s].rms_deg) << segment_name(s);
  }
  std::system(("rm -rf " + dir).c_str());
}

TEST(RunReport, TheTruthAtOtherInstantsAndARunWithoutAPlate) {
  const std::string dir = folder();
  write_text(dir + "run.csv", run_csv(false));
  // The truth half a millisecond off the run's rows: linear between them, within 0.01 um.
  std::ostringstream truth;
  truth << std::setprecision(17) << "t_s,x_m,y_m,z_m,drives_enabled\n";
  for (int k = 0; k <= 3400; ++k) {
    const double t = k * 1e-3 - 0.5e-3;
    const Vec3 p = reference(t) + kOffsetM;
    truth << t << ',' << p.x() << ',' << p.y() << ',' << p.z() << ",1\n";
  }
  write_text(dir + "truth.csv", truth.str());
  const RunColumns run = read_run_columns(dir + "run.csv");
  const PlateTrack track = plate_from_truth(run, dir + "truth.csv");
  const RunReport r = make_run_report(run, &track);
  ASSERT_TRUE(r.plate_measured);
  EXPECT_EQ(r.plate_rows, 3296u);
  EXPECT_NEAR(r.plate[kAllRows].rms_distance_m, 5e-6, 0.01e-6);
  EXPECT_NEAR(r.plate[kAllRows].max_distance_m, 5e-6, 0.01e-6);

  // Without a plate: the joints and the segments, the plate said not measured.
  const RunReport joints_only = run_report_of_file(dir + "run.csv");
  EXPECT_FALSE(joints_only.plate_measured);
  EXPECT_NE(joints_only.plate_source.find("not measured"), std::string::npos);
  EXPECT_EQ(joints_only.dwells.size(), 3u);
  EXPECT_NEAR(joints_only.joints[kAllRows].rms_deg[1], 0.01, 1e-9);
  const std::string headline = report_headline(joints_only);
  EXPECT_NE(headline.find("joint tracking"), std::string::npos) << headline;
  EXPECT_NE(headline.find("plate: not measured"), std::string::npos) << headline;
  EXPECT_TRUE(report_json(joints_only)["plate"].is_null());
  std::system(("rm -rf " + dir).c_str());
}

TEST(RunReport, TheCommandPrintsTheTablesAndRefusesBadInputWithOneLine) {
  const std::string dir = folder();
  write_text(dir + "run.csv", run_csv(true));
  const CommandResult good = run_deltactl("run-report --run " + dir + "run.csv --json " + dir + "report.json");
  std::cout << good.out << good.err;
  ASSERT_EQ(good.exit_code, 0) << good.err;
  EXPECT_NE(good.out.find("| plate - reference |"), std::string::npos) << good.out;
  EXPECT_NE(good.out.find("| joint reference - encoder |"), std::string::npos) << good.out;
  EXPECT_NE(good.out.find("| dwell |"), std::string::npos) << good.out;
  const nlohmann::json j = nlohmann::json::parse(read_text(dir + "report.json"));
  EXPECT_NEAR(j["plate"]["at_rest"]["max_distance_um"].get<double>(), 5.0, 1e-6);

  // Bad input: exit 2, one line naming the file, no JSON written.
  const std::string text = run_csv(true);
  std::string backwards;  // the row of t = 1.5 s at 0.2 s
  std::istringstream lines(text);
  int number = 0;
  for (std::string line; std::getline(lines, line); ++number) {
    if (number == 2 + 1500) line = "0.2" + line.substr(line.find(','));
    backwards += line + '\n';
  }
  write_text(dir + "backwards.csv", backwards);
  std::string off = run_csv(false);
  for (std::size_t at = off.find(",1\n"); at != std::string::npos; at = off.find(",1\n", at))
    off.replace(at, 3, ",0\n");
  write_text(dir + "off.csv", off);
  write_text(dir + "columns.csv", "t_s,alpha1_deg\n0,1\n");
  write_text(dir + "truth.csv", "t_s,x_m,y_m\n0,0,0\n");
  struct Case {
    std::string arguments, names;
  };
  const std::vector<Case> cases = {
      {"--run " + dir + "backwards.csv", dir + "backwards.csv:"},
      {"--run " + dir + "off.csv", dir + "off.csv"},
      {"--run " + dir + "columns.csv", dir + "columns.csv"},
      {"--run " + dir + "run.csv --truth " + dir + "truth.csv", dir + "truth.csv"},
      {"--run " + dir + "run.csv --truth " + dir + "truth.csv --stage " + dir + "run.csv", "excludes"},
      {"--run " + dir + "missing.csv", dir + "missing.csv"},
  };
  for (const Case& c : cases) {
    std::system(("rm -f " + dir + "bad.json").c_str());
    const CommandResult bad = run_deltactl("run-report " + c.arguments + " --json " + dir + "bad.json");
    std::cout << c.arguments << ": exit " << bad.exit_code << ": " << bad.err;
    EXPECT_EQ(bad.exit_code, 2) << c.arguments;
    EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
    EXPECT_NE(bad.err.find(c.names), std::string::npos) << bad.err;
    EXPECT_TRUE(bad.out.empty()) << bad.out;
    EXPECT_FALSE(file_exists(dir + "bad.json")) << c.arguments;
  }
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace
}  // namespace delta::test

// deltactl limits: what the host allows a model: the box of plate positions (the network's trained
// range, W.json input_min/input_max), the joints' travel and the joint angles the box spans, and the
// motion limits every streamed sample is checked against (controller/stream_plan.hpp).
#include <algorithm>
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/kinematics.hpp"
#include "delta/motion/trajectory_check.hpp"
#include "delta/output_file.hpp"
#include "delta/table.hpp"

namespace delta {
namespace {

constexpr int kGrid = 20;  // the box sampled on a 21 x 21 x 21 grid for the joint angles it spans

struct LimitsOptions {
  std::string weights;
  bool json = false;
};

void run_limits(const LimitsOptions& options) {
  const golden::BoardWeights weights = golden::read_board_weights(options.weights);
  const controller::JointTravel travel = controller::joint_travel();
  const controller::StreamLimits motion;
  // The nominal model's joint angles over the box (what the check compares with the travel).
  Vec3 low = Vec3::Constant(1e9), high = Vec3::Constant(-1e9);
  std::size_t unreachable = 0;
  for (int i = 0; i <= kGrid; ++i) {
    for (int j = 0; j <= kGrid; ++j) {
      for (int k = 0; k <= kGrid; ++k) {
        const Vec3 s(i / double(kGrid), j / double(kGrid), k / double(kGrid));
        const Vec3 p = weights.trained_min_m + s.cwiseProduct(weights.trained_max_m - weights.trained_min_m);
        const IkSolution ik = inverse_kinematics(Geometry::nominal(), p);
        if (!ik.ok()) {
          ++unreachable;
          continue;
        }
        low = low.cwiseMin(ik.alpha_deg);
        high = high.cwiseMax(ik.alpha_deg);
      }
    }
  }
  if (options.json) {
    nlohmann::json box, spans = nlohmann::json::array();
    const char* axis[] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) box[axis[a]] = {weights.trained_min_m[a] * 1e3, weights.trained_max_m[a] * 1e3};
    for (int j = 0; j < 3; ++j) spans.push_back({low[j], high[j]});
    const nlohmann::json out = {{"weights", options.weights},
                                {"box_mm", box},
                                {"joint_travel_deg", {travel.min_deg, travel.max_deg}},
                                {"box_joint_span_deg", unreachable == 0 ? spans : nlohmann::json(nullptr)},
                                {"box_unreachable_points", unreachable},
                                {"joint_velocity_deg_s", motion.joint_velocity_deg_s},
                                {"joint_acceleration_deg_s2", motion.joint_acceleration_deg_s2},
                                {"joint_jerk_deg_s3", motion.joint_jerk_deg_s3}};
    std::cout << out.dump(2) << '\n';
    return;
  }
  std::cout << "limits of " << options.weights << " (what 'host run' and 'host run --check' allow):\n\n";
  Table box({"axis", "min [mm]", "max [mm]", "span [mm]"});
  const char* axis = "xyz";
  for (int a = 0; a < 3; ++a) {
    box.add_row({std::string(1, axis[a]), fixed(weights.trained_min_m[a] * 1e3, 3),
                 fixed(weights.trained_max_m[a] * 1e3, 3),
                 fixed((weights.trained_max_m[a] - weights.trained_min_m[a]) * 1e3, 3)});
  }
  box.print(std::cout);
  std::cout << '\n';
  Table joints({"joint", "travel [deg]", "the box spans [deg] (nominal model)"});
  for (int j = 0; j < 3; ++j) {
    joints.add_row({std::to_string(j + 1), fixed(travel.min_deg, 2) + " .. " + fixed(travel.max_deg, 2),
                    unreachable == 0 ? fixed(low[j], 2) + " .. " + fixed(high[j], 2) : "-"});
  }
  joints.print(std::cout);
  if (unreachable > 0) {
    std::cout << "\n"
              << unreachable << " of " << (kGrid + 1) * (kGrid + 1) * (kGrid + 1)
              << " points of the box are beyond the nominal robot's reach (refused as unreachable)\n";
  }
  std::cout << "\nmotion: joint velocity <= " << fixed(motion.joint_velocity_deg_s, 0)
            << " deg/s, acceleration <= " << format_number(motion.joint_acceleration_deg_s2)
            << " deg/s^2, jerk <= " << format_number(motion.joint_jerk_deg_s3)
            << " deg/s^3 (1 kHz differences of the nominal model)\n";
}

const RegisterCommand command("limits", 74, [](CLI::App& root) {
  auto options = std::make_shared<LimitsOptions>();
  CLI::App* sub = root.add_subcommand("limits", "The box of plate positions and the joint travel a model allows");
  sub->footer(
      "\nThe allowed box is W.json's trained range (input_min, input_max): 'host run' refuses any sample\n"
      "of a plan outside it (naming every axis it leaves it on, with the box), as it refuses a joint\n"
      "beyond the board's travel (its travel blocks, the same for every joint) or moving faster than\n"
      "the motion limits. The joint angles the box spans are the nominal model's over a 21 x 21 x 21\n"
      "grid of it (the network's answers differ by about a degree). 'host run --check' checks a whole\n"
      "trajectory against all of it without a board.\n"
      "Example: deltactl limits --weights weights/paper_like_deployed.json");
  sub->add_option("--weights", options->weights, "W.json: the model")->required();
  sub->add_flag("--json", options->json, "print JSON instead of tables (millimetres, degrees)");
  sub->callback([options] { run_limits(*options); });
});

}  // namespace
}  // namespace delta

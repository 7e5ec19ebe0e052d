// Blind suite of the sim-to-real diagnosis: seeded cases whose effects the diagnosis never sees,
// run through `deltactl diagnose` and scored from its JSON and predictions file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "delta/effects.hpp"
#include "delta/virtual_robot.hpp"

namespace delta::blind {

enum class CaseKind { none, single, pair, outside, trading, triple, small, outliers, stage_scale };
const char* kind_name(CaseKind kind);

struct BlindCase {
  int id = 0;
  CaseKind kind = CaseKind::none;
  EffectSet effects;            // injected library effects (empty for none and outside)
  double unequal_rods_m = 0.0;  // outside: rod length difference in one parallelogram
  int unequal_chain = 0;
  std::string fit_trajectory;  // "validation" or "sweep:<seed>"
  std::size_t fit_samples = 0;
  std::uint64_t check_seed = 1;  // CHECK is a sweep with this seed
  std::size_t check_samples = 0;
  // stage_scale: the measuring stage reads (1 + s) x the position along stage_axis (0-2), or along
  // every axis (-1). The vocabulary imitates an all-axes scale exactly (every robot length scaled by
  // 1 / (1 + s)), so there the diagnosis must name the new effect; one axis it cannot imitate.
  double stage_scale = 0.0;
  int stage_axis = -1;
  std::size_t glitches = 0;  // outliers: FIT rows whose position jumps by 0.05-0.5 mm
  std::size_t gap_rows = 0;  // FIT rows missing in the middle (a gap in time)
  std::string description;   // the injected effects, for the score table
};

// Case `id` of the suite (deterministic in id). quick: smaller recordings for CTest.
// Cases 0-99 cycle: none, every family alone, pairs, outside-library (unequal rods). Cases from
// 100 on are the extended kinds, cycling every 10: two trading pairs (effects the data can hardly
// tell from another set), two three-effect sets, two small effects near the detection limit, two
// outlier cases (stage glitches and a gap; one without any effect) and two scale errors of the
// measuring stage (outside the vocabulary): all axes, and one axis.
constexpr int kExtendedFirst = 100;
BlindCase make_case(int id, bool quick);

// Records FIT and CHECK of a case (the generator's robot, including effects outside the library).
struct CaseRecordings {
  std::vector<Sample> fit;
  std::vector<Sample> check;
  std::vector<std::size_t> glitch_rows;  // 1-based FIT data rows made outliers
};
CaseRecordings record_case(const BlindCase& blind_case);

// Rows of the "unequal rods" robot: chain `chain`'s parallelogram has rods of L_B +- difference/2,
// rod pairs 2 * kRodHalfSpacingM apart; the plate is carried by the stage at its centre but free
// to tilt, so the angles and plate tilt solve the six rod constraints (Newton).
constexpr double kRodHalfSpacingM = 0.006;
std::vector<Sample> record_unequal_rods(const std::string& trajectory, std::uint64_t seed, std::size_t samples,
                                        double difference_m, int chain);

struct CaseScore {
  BlindCase blind_case;
  std::vector<std::string> reported;  // significant effect names
  bool explained = false;
  double rmse_after_over_floor = 0.0;                  // worst joint, computed from PRED.csv by the suite
  std::vector<std::vector<std::string>> alternatives;  // the equivalent sets the diagnosis listed
  bool via_alternative = false;                        // the injected set is not the chosen one but an alternative
  std::size_t glitches_found = 0;                      // injected glitch rows listed among the outliers
  bool set_ok = false;                                 // reported set (or an alternative) == injected set (outside:
                                                       // explained false or a new name); outliers: every glitch listed
  bool rmse_ok = false;                                // in-library: <= 1.5 floor
  double seconds = 0.0;
  std::string error;  // non-empty when deltactl failed
  bool pass() const { return error.empty() && set_ok && rmse_ok; }
};

// Writes the recordings into `folder`, runs `deltactl diagnose` and scores the outputs.
CaseScore run_case(const BlindCase& blind_case, const std::string& deltactl, const std::string& folder);

}  // namespace delta::blind

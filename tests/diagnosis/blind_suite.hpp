// Blind suite of the sim-to-real diagnosis: seeded cases whose effects the diagnosis never sees,
// run through `deltactl diagnose` and scored from its JSON and predictions file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "delta/effects.hpp"
#include "delta/virtual_robot.hpp"

namespace delta::blind {

enum class CaseKind { none, single, pair, outside };
const char* kind_name(CaseKind kind);

struct BlindCase {
  int id = 0;
  CaseKind kind = CaseKind::none;
  EffectSet effects;                 // injected library effects (empty for none and outside)
  double unequal_rods_m = 0.0;       // outside: rod length difference in one parallelogram
  int unequal_chain = 0;
  std::string fit_trajectory;        // "validation" or "sweep:<seed>"
  std::size_t fit_samples = 0;
  std::uint64_t check_seed = 1;      // CHECK is a sweep with this seed
  std::size_t check_samples = 0;
  std::string description;           // the injected effects, for the score table
};

// Case `id` of the suite (deterministic in id). quick: smaller recordings for CTest.
// The kinds cycle: none, every family alone, pairs, outside-library (unequal rods).
BlindCase make_case(int id, bool quick);

// Records FIT and CHECK of a case (the generator's robot, including effects outside the library).
struct CaseRecordings {
  std::vector<Sample> fit;
  std::vector<Sample> check;
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
  double rmse_after_over_floor = 0.0;  // worst joint, computed from PRED.csv by the suite
  bool set_ok = false;                 // reported set == injected set (outside: explained false or a new name)
  bool rmse_ok = false;                // in-library: <= 1.5 floor
  double seconds = 0.0;
  std::string error;                   // non-empty when deltactl failed
  bool pass() const { return error.empty() && set_ok && rmse_ok; }
};

// Writes the recordings into `folder`, runs `deltactl diagnose` and scores the outputs.
CaseScore run_case(const BlindCase& blind_case, const std::string& deltactl, const std::string& folder);

}  // namespace delta::blind

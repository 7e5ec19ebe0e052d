// The clocks from the board's stage sync output as the stage logged it (merge.hpp). The board
// drives stage_sync_o with a bit of its control periods since reset (delta_board_pkg::StageSyncBit),
// the same count its telemetry's board time is made of: the level changes at every multiple of
// level_s of board time and is 1 after the odd ones. A stage that samples it beside its positions
// sees each change between two of its samples, a and b on its clock:
//   a < offset + (1 + rate) T_n <= b,   T_n = n level_s,
// a strip in (offset, rate) per change. The alignment is the centre of the region all of them
// leave (a change every 0.41 s falls at every phase of the stage's samples: on a few minutes the
// region is a few microseconds wide); n comes from the data's alignment, its offset corrected by
// the changes' phase (a change to 1 at an odd multiple, to 0 at an even one: unambiguous to within
// level_s either way).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace delta::diagnosis {

// The longest step between two stage samples that merge interpolates or times a change across:
// 3 x the median spacing of `stage_t` (0 for fewer than two samples). Longer steps are gaps.
double max_stage_gap(const std::vector<double>& stage_t);

struct SyncAlignment {
  std::size_t changes = 0;  // of the level, between two stage samples no further apart than max_stage_gap
  double offset_s = 0.0, offset_sd_s = 0.0;
  double rate = 0.0, rate_sd = 0.0;  // relative (ppm 1e-6)
  bool consistent = false;           // every change inside the region (else a least-squares line)
  double shift_s = 0.0;              // the changes' phase: the given alignment's error (board time)
  // The shift is beyond what the matching of the changes tolerates (a quarter of the level): the
  // given alignment had lost the clocks and the phase corrected it.
  bool corrected_lost_alignment = false;
};

// stage_t, sync: the stage's times and logged levels (0 or 1). offset_s, rate: the alignment from
// the data, to within 3/4 level_s (its offset is corrected by the changes' phase, shift_s; the
// caller checks a corrected alignment against the data). A shift beyond 3/4 level_s reads as an
// inverted input: InputError. Returns changes = 0 when the level never changes
// (the input not wired). InputError (exit 2) naming stage_path when the changes do not follow the
// board's output at the corrected alignment: more than 2 % of them further than level_s / 4 from
// one, or the wrong way.
SyncAlignment align_on_sync(const std::string& stage_path, const std::vector<double>& stage_t,
                            const std::vector<int>& sync, double offset_s, double rate, double level_s);

}  // namespace delta::diagnosis

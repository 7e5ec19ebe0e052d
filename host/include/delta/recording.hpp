// Recordings of the robot (docs/contracts.md): t_s, alpha1..3_deg, x_m, y_m, z_m, in time order.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "delta/virtual_robot.hpp"

namespace delta {

// How a recording's joint angles (the board's counts) were referenced, as its header says in a
// comment line "# referenced: home switches|hand|none" (docs/lab_loop.md): at the robot's home
// switches (`host home`; simulate's recordings by construction), by hand (`host home --by-hand`:
// the counts set where the arms stood) or not at all (the power-up count, 30.00 deg wherever the
// arms were). Counts not referenced at the switches carry the arms' pose then as joint offsets.
enum class Referencing { kHomeSwitches, kHand, kNone };
const char* referencing_name(Referencing referencing);  // "home switches", "hand", "none"
// The header comment, without its '#': "referenced: home switches".
std::string referencing_comment(Referencing referencing);

struct CsvTable;

// The "# referenced: ..." line among a table's header comments (nothing: the file does not say).
// Throws InputError naming the line when it names something else.
std::optional<Referencing> referencing_of(const CsvTable& table);

struct Recording {
  std::string path;
  std::vector<Sample> samples;
  std::vector<std::size_t> line_numbers;   // file line of each sample
  std::optional<Referencing> referencing;  // as the header says (nothing: it does not)
  std::size_t referencing_line = 0;        // the file line that says it
};

// For the commands that fit a robot to a recording (diagnose, train): throws InputError (exit 2)
// naming the file and its "# referenced:" line when that says the counts were not referenced at
// the home switches, unless `allow` (their --unreferenced). A recording that does not say is taken
// as it is (older recordings; every deltactl command that writes one says).
void check_referenced(const Recording& recording, bool allow);

// Throws InputError naming the file and line when row `row`'s time (column `column`, seconds) is
// before the previous row's: SPEC recordings are in time order.
void check_time_order(const CsvTable& table, std::size_t row, std::size_t column);

// Throw InputError naming the file, line and column when a value of row `row` in columns [first,
// first + count) is not a measurement of this robot: a joint angle beyond one turn, a plate
// position beyond 1 m (a corrupt row or a unit mix-up; one such row would dominate any fit). Every
// reader of recordings applies them: diagnose, train, compare, ik, merge.
void check_plausible_angles(const CsvTable& table, std::size_t row, std::size_t first, std::size_t count);
void check_plausible_positions(const CsvTable& table, std::size_t row, std::size_t first, std::size_t count);

// Throws InputError (file, line, reason) on any SPEC violation, including time going backwards.
Recording read_recording(const std::string& path);

// Writes atomically (no partial file on failure); header comment lines go first, each prefixed '#'.
void write_recording(const std::string& path, const std::vector<Sample>& samples,
                     const std::vector<std::string>& comments = {});

// Plate positions of any CSV with x_m, y_m, z_m columns (the input of `deltactl ik`).
std::vector<Vec3> read_positions(const std::string& path);

}  // namespace delta

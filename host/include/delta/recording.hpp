// Recordings of the robot (docs/contracts.md): t_s, alpha1..3_deg, x_m, y_m, z_m, in time order.
#pragma once

#include <string>
#include <vector>

#include "delta/virtual_robot.hpp"

namespace delta {

struct Recording {
  std::string path;
  std::vector<Sample> samples;
  std::vector<std::size_t> line_numbers;  // file line of each sample
};

struct CsvTable;

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

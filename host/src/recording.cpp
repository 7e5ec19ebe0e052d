// Recording reader and writer in the SPEC CSV format.
#include "delta/recording.hpp"

#include <cmath>

#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"

namespace delta {
namespace {

// A Delta robot of 0.1 m arms: a plate position beyond 1 m or a joint angle beyond one turn is a
// corrupt row (or a unit mix-up), not a measurement; one such row would dominate any fit.
constexpr double kMaxPlausiblePositionM = 1.0;
constexpr double kMaxPlausibleAngleDeg = 360.0;

constexpr const char* kReferencedKey = "referenced:";

void check_plausible(const CsvTable& table, std::size_t row, std::size_t first, std::size_t count, double limit,
                     const char* unit) {
  for (std::size_t k = first; k < first + count; ++k) {
    const double value = table.rows[row][k];
    if (std::fabs(value) > limit) {
      throw InputError(table.path, table.line_numbers[row],
                       "column '" + table.columns[k] + "': " + format_number(value) + " is not plausible (beyond " +
                           format_number(limit) + " " + unit + ")");
    }
  }
}

}  // namespace

void check_plausible_angles(const CsvTable& table, std::size_t row, std::size_t first, std::size_t count) {
  check_plausible(table, row, first, count, kMaxPlausibleAngleDeg, "deg");
}

void check_plausible_positions(const CsvTable& table, std::size_t row, std::size_t first, std::size_t count) {
  check_plausible(table, row, first, count, kMaxPlausiblePositionM, "m");
}

void check_time_order(const CsvTable& table, std::size_t row, std::size_t column) {
  if (row == 0 || !(table.rows[row][column] < table.rows[row - 1][column])) return;
  throw InputError(table.path, table.line_numbers[row],
                   "time goes backwards (t_s " + format_number(table.rows[row][column]) + " after " +
                       format_number(table.rows[row - 1][column]) + ")");
}

const char* referencing_name(Referencing referencing) {
  switch (referencing) {
    case Referencing::kHomeSwitches:
      return "home switches";
    case Referencing::kHand:
      return "hand";
    case Referencing::kNone:
      break;
  }
  return "none";
}

std::string referencing_comment(Referencing referencing) {
  return std::string(kReferencedKey) + " " + referencing_name(referencing);
}

std::optional<Referencing> referencing_of(const CsvTable& table) {
  std::optional<Referencing> found;
  for (std::size_t k = 0; k < table.comments.size(); ++k) {
    const std::string& comment = table.comments[k];
    if (comment.rfind(kReferencedKey, 0) != 0) continue;
    const std::string value = comment.substr(std::string(kReferencedKey).size());
    std::optional<Referencing> here;
    for (const Referencing r : {Referencing::kHomeSwitches, Referencing::kHand, Referencing::kNone}) {
      const std::string name = std::string(" ") + referencing_name(r);
      // The name, then the end or an explanation after a space ("none (the power-up count)").
      if (value.rfind(name, 0) == 0 && (value.size() == name.size() || value[name.size()] == ' ')) here = r;
    }
    if (!here) {
      throw InputError(table.path, table.comment_lines[k],
                       "'# " + comment.substr(0, 80) + "': the referencing is home switches, hand or none");
    }
    if (found && *found != *here) {
      throw InputError(table.path, table.comment_lines[k], "a second '# referenced:' line that says otherwise");
    }
    found = here;
  }
  return found;
}

void check_referenced(const Recording& recording, bool allow) {
  if (allow || !recording.referencing || *recording.referencing == Referencing::kHomeSwitches) return;
  throw InputError(recording.path, recording.referencing_line,
                   std::string("its counts were not referenced at the home switches (referenced: ") +
                       referencing_name(*recording.referencing) +
                       "): the arms' pose when the counts were set would be taken for joint offsets; home the board "
                       "(deltactl host home) and record again, or pass --unreferenced");
}

Recording read_recording(const std::string& path) {
  const CsvTable table = read_csv(path, {"t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg", "x_m", "y_m", "z_m"});
  Recording recording;
  recording.path = path;
  recording.line_numbers = table.line_numbers;
  recording.referencing = referencing_of(table);
  for (std::size_t k = 0; k < table.comments.size(); ++k) {
    if (table.comments[k].rfind(kReferencedKey, 0) == 0) recording.referencing_line = table.comment_lines[k];
  }
  recording.samples.reserve(table.rows.size());
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    const std::vector<double>& row = table.rows[i];
    check_time_order(table, i, 0);
    check_plausible_angles(table, i, 1, 3);
    check_plausible_positions(table, i, 4, 3);
    Sample sample;
    sample.t_s = row[0];
    sample.alpha_deg = Vec3(row[1], row[2], row[3]);
    sample.position_m = Vec3(row[4], row[5], row[6]);
    recording.samples.push_back(sample);
  }
  return recording;
}

void write_recording(const std::string& path, const std::vector<Sample>& samples,
                     const std::vector<std::string>& comments) {
  OutputFile file(path);
  std::ostream& out = file.stream();
  for (const std::string& comment : comments) out << "# " << comment << '\n';
  out << "t_s,alpha1_deg,alpha2_deg,alpha3_deg,x_m,y_m,z_m\n";
  for (const Sample& sample : samples) {
    out << format_number(sample.t_s);
    for (int j = 0; j < 3; ++j) out << ',' << format_number(sample.alpha_deg[j]);
    for (int k = 0; k < 3; ++k) out << ',' << format_number(sample.position_m[k]);
    out << '\n';
  }
  file.commit();
}

std::vector<Vec3> read_positions(const std::string& path) {
  const CsvTable table = read_csv(path, {"x_m", "y_m", "z_m"});
  std::vector<Vec3> positions;
  positions.reserve(table.rows.size());
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    check_plausible_positions(table, i, 0, 3);
    positions.emplace_back(table.rows[i][0], table.rows[i][1], table.rows[i][2]);
  }
  return positions;
}

}  // namespace delta

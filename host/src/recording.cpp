// Recording reader and writer in the SPEC CSV format.
#include "delta/recording.hpp"

#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/output_file.hpp"

namespace delta {

Recording read_recording(const std::string& path) {
  const CsvTable table = read_csv(path, {"t_s", "alpha1_deg", "alpha2_deg", "alpha3_deg", "x_m", "y_m", "z_m"});
  Recording recording;
  recording.path = path;
  recording.line_numbers = table.line_numbers;
  recording.samples.reserve(table.rows.size());
  for (std::size_t i = 0; i < table.rows.size(); ++i) {
    const std::vector<double>& row = table.rows[i];
    if (i > 0 && row[0] < recording.samples.back().t_s) {
      throw InputError(path, table.line_numbers[i], "time goes backwards (t_s " + format_number(row[0]) +
                                                        " after " + format_number(recording.samples.back().t_s) + ")");
    }
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
  for (const std::vector<double>& row : table.rows) positions.emplace_back(row[0], row[1], row[2]);
  return positions;
}

}  // namespace delta

// MATLAB exchange of the network: .mat through libmatio, or the line-per-variable CSV.
#include "delta/nn/matlab_exchange.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <matio.h>
#include <zlib.h>

#include "delta/csv.hpp"
#include "delta/input_error.hpp"
#include "delta/input_file.hpp"
#include "delta/nn/weights_file.hpp"
#include "delta/output_file.hpp"

namespace delta::nn {
namespace {

struct Variable {
  Eigen::MatrixXd value;
  std::size_t line = 0;  // CSV line (0 for .mat)
};
using Variables = std::map<std::string, Variable>;

bool ends_with(const std::string& text, const std::string& suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

Variables variables_of(const Network& network) {
  return {{"IW", {network.input_weights}},       {"b1", {network.hidden_bias}},
          {"LW", {network.output_weights}},      {"b2", {network.output_bias}},
          {"input_xmin", {network.input_min}},   {"input_xmax", {network.input_max}},
          {"output_xmin", {network.output_min}}, {"output_xmax", {network.output_max}}};
}

Variables read_mat(const std::string& path);

// Most values one variable may hold: W.json allows 10000 hidden neurons, so IW has 30000.
constexpr std::size_t kMaxMatElements = 3 * kMaxHiddenNeurons;

const char* const kOrder[] = {"IW", "b1", "LW", "b2", "input_xmin", "input_xmax", "output_xmin", "output_xmax"};

void write_mat(const std::string& path, const Variables& variables) {
  OutputFile output(path);
  mat_t* file = Mat_CreateVer(output.writing_path().c_str(), nullptr, MAT_FT_MAT5);
  if (!file) throw InputError(path, 0, "cannot write here (does the folder exist?)");
  bool written = true;
  for (const char* name : kOrder) {
    Eigen::MatrixXd value = variables.at(name).value;  // column-major, as MATLAB stores it
    std::size_t dims[2] = {static_cast<std::size_t>(value.rows()), static_cast<std::size_t>(value.cols())};
    matvar_t* variable = Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, value.data(), 0);
    written = written && variable && Mat_VarWrite(file, variable, MAT_COMPRESSION_NONE) == 0;
    if (variable) Mat_VarFree(variable);
  }
  written = Mat_Close(file) == 0 && written;
  // matio does not report every failed write (a full disk leaves a short file): read it back.
  if (written) {
    try {
      written = read_mat(output.writing_path()).size() == variables.size();
    } catch (const InputError&) {
      written = false;
    }
  }
  if (!written) throw InputError(path, 0, "could not be written completely (disk full?); nothing written");
  output.commit();
}

void write_csv(const std::string& path, const Variables& variables) {
  OutputFile file(path);
  std::ostream& out = file.stream();
  out << "# Network for MATLAB: name,rows,columns,values in column-major (:) order (delta::nn matlab_exchange.hpp)\n";
  for (const char* name : kOrder) {
    const Eigen::MatrixXd& value = variables.at(name).value;
    out << name << ',' << value.rows() << ',' << value.cols();
    for (Eigen::Index i = 0; i < value.size(); ++i) out << ',' << format_number(value.data()[i]);
    out << '\n';
  }
  file.commit();
}

// libmatio trusts the sizes in a file and allocates them before reading (the fuzzer found 1.6 GB
// and 8.5 GB from 2 kB files): the MAT5 layout is walked first. A 128-byte header, then data
// elements, each an 8-byte tag (type, byte count) whose count must fit in what holds it; a
// compressed element is inflated here, at most kMaxInflatedBytes, and walked the same way.
class Mat5Layout {
 public:
  Mat5Layout(const std::string& path, bool swapped) : path_(path), swapped_(swapped) {}

  std::uint32_t word(const std::string& bytes, std::size_t at) const {
    std::uint32_t value = 0;
    for (int b = 0; b < 4; ++b) {
      const auto byte = static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[at + static_cast<std::size_t>(b)]));
      value |= swapped_ ? byte << (8 * (3 - b)) : byte << (8 * b);
    }
    return value;
  }

  // Elements of bytes[from, to); returns nothing, throws InputError on the first inconsistency.
  void check_elements(const std::string& bytes, std::size_t from, std::size_t to, bool top_level) const {
    for (std::size_t at = from; at < to;) {
      if (to - at < 8) fail("a data element is cut short");
      const std::uint32_t type = word(bytes, at), count = word(bytes, at + 4);
      if (type == 15 && top_level) {  // miCOMPRESSED
        if (count > to - at - 8) fail("a compressed element claims more bytes than the file holds");
        const std::string inflated = inflate(bytes.substr(at + 8, count));
        check_elements(inflated, 0, inflated.size(), false);
        at += 8 + count;
      } else if (type == 14) {  // miMATRIX
        if (count > to - at - 8) fail("a matrix claims more bytes than the file holds");
        check_matrix(bytes, at + 8, at + 8 + count);
        at += 8 + count + (8 - count % 8) % 8;
      } else {
        fail("unexpected data element type " + std::to_string(type));
      }
    }
  }

 private:
  static constexpr std::size_t kMaxInflatedBytes = 8 * kMaxMatElements + 4096;

  [[noreturn]] void fail(const std::string& reason) const { throw InputError(path_, 0, reason); }

  // Sub-elements of a real double matrix: flags, dimensions, name, real part; each must fit.
  void check_matrix(const std::string& bytes, std::size_t from, std::size_t to) const {
    std::size_t elements = 1;
    int index = 0;
    for (std::size_t at = from; at < to; ++index) {
      if (to - at < 8) fail("a matrix sub-element is cut short");
      const std::uint32_t first = word(bytes, at);
      const bool small = (first >> 16) != 0;  // small data element: count in the upper half, data in 4 bytes
      const std::uint32_t count = small ? first >> 16 : word(bytes, at + 4);
      const std::size_t data = small ? at + 4 : at + 8;
      if (count > to - data) fail("a matrix sub-element claims more bytes than the matrix holds");
      const std::uint32_t type = small ? first & 0xffff : first;
      // libmatio takes the flags as 8 bytes and the dimensions right after them, whatever the
      // tags claim: a longer flags element would hide dimensions it then reads.
      if (index == 0 && (type != 6 || count != 8 || (word(bytes, data) & 0xff) != 6)) {
        fail("a variable is not a real double matrix");
      }
      if (index == 1 && (type != 5 || count < 8 || count % 4 != 0)) fail("a variable's dimensions are malformed");
      if (index == 1) {
        for (std::size_t d = 0; d + 4 <= count; d += 4)
          elements *= std::min<std::size_t>(word(bytes, data + d), kMaxMatElements + 1);
        if (elements > kMaxMatElements) {
          fail("a variable of more than " + std::to_string(kMaxMatElements) + " values (at most 10000 hidden neurons)");
        }
      }
      at = small ? at + 8 : data + count + (8 - count % 8) % 8;
    }
  }

  std::string inflate(const std::string& compressed) const {
    z_stream stream{};
    if (inflateInit(&stream) != Z_OK) fail("cannot inflate");
    std::string out(kMaxInflatedBytes + 1, '\0');
    stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data()));
    stream.avail_in = static_cast<uInt>(compressed.size());
    stream.next_out = reinterpret_cast<Bytef*>(out.data());
    stream.avail_out = static_cast<uInt>(out.size());
    const int status = ::inflate(&stream, Z_FINISH);
    const std::size_t produced = stream.total_out;
    inflateEnd(&stream);
    if (produced > kMaxInflatedBytes)
      fail("a compressed variable inflates beyond " + std::to_string(kMaxInflatedBytes) + " bytes");
    if (status != Z_STREAM_END) fail("a compressed variable is damaged");
    out.resize(produced);
    return out;
  }

  const std::string& path_;
  bool swapped_;
};

void check_mat5_layout(const std::string& path, std::ifstream& input) {
  const std::string bytes((std::istreambuf_iterator<char>(input)), std::istreambuf_iterator<char>());
  if (bytes.size() > kMaxInputBytes) throw InputError(path, 0, "too large for a network's .mat file");
  if (bytes.size() < 136) throw InputError(path, 0, "not a MATLAB 5/7 .mat file (too short)");
  const bool swapped = bytes[126] == 'M' && bytes[127] == 'I';
  if (!swapped && !(bytes[126] == 'I' && bytes[127] == 'M')) {
    throw InputError(path, 0, "not a MATLAB 5/7 .mat file (a v4 or v7.3/HDF5 file? save with -v7)");
  }
  Mat5Layout(path, swapped).check_elements(bytes, 128, bytes.size(), true);
}

Variables read_mat(const std::string& path) {
  std::ifstream input = open_input_file(path);  // a folder or a missing file named; noted as an input
  check_mat5_layout(path, input);
  mat_t* file = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (!file) throw InputError(path, 0, "cannot open as a MATLAB .mat file");
  std::unique_ptr<mat_t, int (*)(mat_t*)> closer(file, Mat_Close);
  Variables variables;
  for (const char* name : kOrder) {
    // Sizes first: a small compressed file may inflate to gigabytes.
    matvar_t* info = Mat_VarReadInfo(file, name);
    if (!info) continue;  // reported as missing below
    std::size_t elements = 1;
    for (int d = 0; d < info->rank; ++d) elements *= std::min<std::size_t>(info->dims[d], kMaxMatElements + 1);
    Mat_VarFree(info);
    if (elements > kMaxMatElements) {
      throw InputError(path, 0,
                       std::string(name) + ": more than " + std::to_string(kMaxMatElements) +
                           " values (a network of at most 10000 hidden neurons)");
    }
    matvar_t* variable = Mat_VarRead(file, name);
    if (!variable) continue;
    std::unique_ptr<matvar_t, void (*)(matvar_t*)> freer(variable, Mat_VarFree);
    if (variable->class_type != MAT_C_DOUBLE || variable->isComplex || variable->rank != 2 || !variable->data) {
      throw InputError(path, 0, std::string(name) + ": expected a real double matrix");
    }
    const auto rows = static_cast<Eigen::Index>(variable->dims[0]);
    const auto columns = static_cast<Eigen::Index>(variable->dims[1]);
    variables[name].value =
        Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(variable->data), rows, columns);
  }
  return variables;
}

Variables read_csv_variables(const std::string& path) {
  std::ifstream input = open_input_file(path);
  Variables variables;
  std::string line;
  std::size_t line_number = 0;
  while (std::getline(input, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream stream(line);
    std::string field;
    while (std::getline(stream, field, ',')) fields.push_back(field);
    if (fields.size() < 3) throw InputError(path, line_number, "expected name,rows,columns,values...");
    auto count = [&](const std::string& text, const char* what) {
      std::size_t used = 0;
      long value = -1;
      try {
        value = std::stol(text, &used);
      } catch (const std::exception&) {
      }
      if (used != text.size() || value < 0 || value > 100000) {
        throw InputError(path, line_number, std::string(what) + " must be a whole number, got '" + text + "'");
      }
      return static_cast<Eigen::Index>(value);
    };
    const Eigen::Index rows = count(fields[1], "rows");
    const Eigen::Index columns = count(fields[2], "columns");
    if (static_cast<Eigen::Index>(fields.size()) != 3 + rows * columns) {
      throw InputError(path, line_number,
                       fields[0] + ": " + std::to_string(rows) + " x " + std::to_string(columns) + " needs " +
                           std::to_string(rows * columns) + " values, got " + std::to_string(fields.size() - 3));
    }
    Variable variable{Eigen::MatrixXd(rows, columns), line_number};
    for (Eigen::Index i = 0; i < rows * columns; ++i) {
      const std::string& text = fields[static_cast<std::size_t>(3 + i)];
      const std::optional<double> value = parse_decimal(text);
      if (!value) throw InputError(path, line_number, fields[0] + ": '" + text + "' is not a number");
      variable.value.data()[i] = *value;
    }
    variables[fields[0]] = variable;
  }
  return variables;
}

}  // namespace

void export_matlab(const std::string& path, const Network& network) {
  if (ends_with(path, ".mat"))
    write_mat(path, variables_of(network));
  else if (ends_with(path, ".csv"))
    write_csv(path, variables_of(network));
  else
    throw std::invalid_argument("'" + path + "': the MATLAB export is a .mat or a .csv file");
}

Network import_matlab(const std::string& path) {
  Variables variables;
  if (ends_with(path, ".mat"))
    variables = read_mat(path);
  else if (ends_with(path, ".csv"))
    variables = read_csv_variables(path);
  else
    throw std::invalid_argument("'" + path + "': the MATLAB import reads a .mat or a .csv file");
  auto get = [&](const char* name, Eigen::Index rows, Eigen::Index columns) {
    const auto found = variables.find(name);
    if (found == variables.end()) throw InputError(path, 0, std::string("missing variable ") + name);
    const Variable& variable = found->second;
    if (variable.value.rows() != rows || variable.value.cols() != columns) {
      throw InputError(path, variable.line,
                       std::string(name) + ": expected " + std::to_string(rows) + " x " + std::to_string(columns) +
                           ", got " + std::to_string(variable.value.rows()) + " x " +
                           std::to_string(variable.value.cols()));
    }
    if (!variable.value.allFinite())
      throw InputError(path, variable.line, std::string(name) + ": a value is not finite");
    return variable.value;
  };
  const auto iw = variables.find("IW");
  if (iw == variables.end()) throw InputError(path, 0, "missing variable IW");
  const Eigen::Index hidden = iw->second.value.rows();
  if (hidden < 1 || hidden > kMaxHiddenNeurons) {
    throw InputError(path, iw->second.line,
                     "IW: expected H x 3 with 1 <= H <= " + std::to_string(kMaxHiddenNeurons) +
                         " (the weights file limit), got H = " + std::to_string(hidden));
  }
  Network network;
  network.input_weights = get("IW", hidden, 3);
  network.hidden_bias = get("b1", hidden, 1);
  network.output_weights = get("LW", 3, hidden);
  network.output_bias = get("b2", 3, 1);
  network.input_min = get("input_xmin", 3, 1);
  network.input_max = get("input_xmax", 3, 1);
  network.output_min = get("output_xmin", 3, 1);
  network.output_max = get("output_xmax", 3, 1);
  for (int k = 0; k < 3; ++k) {
    if (!(network.input_max[k] > network.input_min[k]) || !(network.output_max[k] > network.output_min[k])) {
      throw InputError(path, 0, "mapminmax settings: every xmax must exceed its xmin");
    }
  }
  return network;
}

}  // namespace delta::nn

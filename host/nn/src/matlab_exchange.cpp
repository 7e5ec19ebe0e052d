// MATLAB exchange of the network: .mat through libmatio, or the line-per-variable CSV.
#include "delta/nn/matlab_exchange.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <matio.h>

#include "delta/input_error.hpp"
#include "delta/input_file.hpp"
#include "delta/output_file.hpp"
#include "delta/nn/weights_file.hpp"

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
  return {{"IW", {network.input_weights}},        {"b1", {network.hidden_bias}},
          {"LW", {network.output_weights}},       {"b2", {network.output_bias}},
          {"input_xmin", {network.input_min}},    {"input_xmax", {network.input_max}},
          {"output_xmin", {network.output_min}},  {"output_xmax", {network.output_max}}};
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

Variables read_mat(const std::string& path) {
  open_input_file(path);  // a clear message for a folder or a missing file; noted as an input
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
      throw InputError(path, 0, std::string(name) + ": more than " + std::to_string(kMaxMatElements) +
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
    variables[name].value = Eigen::Map<const Eigen::MatrixXd>(static_cast<const double*>(variable->data), rows, columns);
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
      throw InputError(path, line_number, fields[0] + ": " + std::to_string(rows) + " x " + std::to_string(columns) +
                                              " needs " + std::to_string(rows * columns) + " values, got " +
                                              std::to_string(fields.size() - 3));
    }
    Variable variable{Eigen::MatrixXd(rows, columns), line_number};
    for (Eigen::Index i = 0; i < rows * columns; ++i) {
      const std::string& text = fields[static_cast<std::size_t>(3 + i)];
      char* end = nullptr;
      const double value = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0') throw InputError(path, line_number, fields[0] + ": '" + text + "' is not a number");
      variable.value.data()[i] = value;
    }
    variables[fields[0]] = variable;
  }
  return variables;
}

}  // namespace

void export_matlab(const std::string& path, const Network& network) {
  if (ends_with(path, ".mat")) write_mat(path, variables_of(network));
  else if (ends_with(path, ".csv")) write_csv(path, variables_of(network));
  else throw std::invalid_argument("'" + path + "': the MATLAB export is a .mat or a .csv file");
}

Network import_matlab(const std::string& path) {
  Variables variables;
  if (ends_with(path, ".mat")) variables = read_mat(path);
  else if (ends_with(path, ".csv")) variables = read_csv_variables(path);
  else throw std::invalid_argument("'" + path + "': the MATLAB import reads a .mat or a .csv file");
  auto get = [&](const char* name, Eigen::Index rows, Eigen::Index columns) {
    const auto found = variables.find(name);
    if (found == variables.end()) throw InputError(path, 0, std::string("missing variable ") + name);
    const Variable& variable = found->second;
    if (variable.value.rows() != rows || variable.value.cols() != columns) {
      throw InputError(path, variable.line, std::string(name) + ": expected " + std::to_string(rows) + " x " +
                                                std::to_string(columns) + ", got " + std::to_string(variable.value.rows()) +
                                                " x " + std::to_string(variable.value.cols()));
    }
    if (!variable.value.allFinite()) throw InputError(path, variable.line, std::string(name) + ": a value is not finite");
    return variable.value;
  };
  const auto iw = variables.find("IW");
  if (iw == variables.end()) throw InputError(path, 0, "missing variable IW");
  const Eigen::Index hidden = iw->second.value.rows();
  if (hidden < 1 || hidden > kMaxHiddenNeurons) {
    throw InputError(path, iw->second.line, "IW: expected H x 3 with 1 <= H <= " + std::to_string(kMaxHiddenNeurons) +
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

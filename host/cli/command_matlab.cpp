// deltactl export-matlab / import-matlab: the network to and from MATLAB (.mat or CSV).
#include <iostream>
#include <memory>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/nn/matlab_exchange.hpp"
#include "delta/nn/weights_file.hpp"

namespace delta::nn {
namespace {

const char* const kVariables =
    "\nVariables (MATLAB network object fields): IW (H x 3) = net.IW{1,1}, b1 (H x 1) = net.b{1},\n"
    "LW (3 x H) = net.LW{2,1}, b2 (3 x 1) = net.b{2}, input_xmin/input_xmax (3 x 1, metres) =\n"
    "net.inputs{1}.processSettings{1}.xmin/xmax, output_xmin/output_xmax (3 x 1, degrees) =\n"
    "net.outputs{2}.processSettings{1}.xmin/xmax (mapminmax to [-1, 1]). A .csv holds one line per\n"
    "variable: name,rows,columns,values in column-major order.\n";

struct ExchangeOptions {
  std::string weights;
  std::string in;
  std::string out;
};

const RegisterCommand export_command("export-matlab", 50, [](CLI::App& root) {
  auto options = std::make_shared<ExchangeOptions>();
  CLI::App* sub = root.add_subcommand("export-matlab", "Write the network of W.json for MATLAB (.mat or .csv)");
  sub->footer(std::string(kVariables) +
              "A hybrid W.json exports its network only (the residual on top of its math model).\n"
              "Example: deltactl export-matlab --weights weights/paper_like.json --out net.mat");
  sub->add_option("--weights", options->weights, "weights file (W.json)")->required();
  sub->add_option("--out", options->out, "MATLAB file to write (.mat or .csv)")->required();
  sub->callback([options] {
    const WeightsFile weights = read_weights_file(options->weights);
    export_matlab(options->out, weights.network);
    std::cerr << "export-matlab: 3-" << weights.network.hidden() << "-3 network -> " << options->out
              << (weights.hybrid() ? " (network part of a hybrid: the residual in degrees)" : "")
              << (weights.deployed() ? " (the network of a deployed model: its play and any joint ripple table are "
                                       "not exported)"
                                     : "")
              << '\n';
  });
});

const RegisterCommand import_command("import-matlab", 51, [](CLI::App& root) {
  auto options = std::make_shared<ExchangeOptions>();
  CLI::App* sub = root.add_subcommand("import-matlab", "Make a W.json from a network trained in MATLAB (.mat or .csv)");
  sub->footer(std::string(kVariables) +
              "In MATLAB: IW = net.IW{1,1}; b1 = net.b{1}; LW = net.LW{2,1}; b2 = net.b{2};\n"
              "  input_xmin = net.inputs{1}.processSettings{1}.xmin; (and xmax, and the outputs{2} pair)\n"
              "  save('net.mat', 'IW', 'b1', 'LW', 'b2', 'input_xmin', 'input_xmax', 'output_xmin', 'output_xmax')\n"
              "Example: deltactl import-matlab --in net.mat --out W.json");
  sub->add_option("--in", options->in, "MATLAB file (.mat or .csv)")->required();
  sub->add_option("--out", options->out, "weights file to write (W.json)")->required();
  sub->callback([options] {
    WeightsFile weights;
    weights.network = import_matlab(options->in);
    weights.provenance = {{"tool", "deltactl import-matlab"}, {"matlab_file", options->in}};
    write_weights_file(options->out, weights);
    std::cerr << "import-matlab: 3-" << weights.network.hidden() << "-3 network -> " << options->out << '\n';
  });
});

}  // namespace
}  // namespace delta::nn

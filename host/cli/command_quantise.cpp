// deltactl quantise: W.json -> the $readmemh files and C++ header of the fixed-point network.
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/golden/test_vectors.hpp"
#include "delta/input_error.hpp"
#include "delta/nn/weights_file.hpp"
#include "options.hpp"

namespace delta::golden {
namespace {

struct QuantiseOptions {
  std::string weights;
  std::string out_dir;
  std::size_t vectors = 0;
};

// golden_vectors.txt: raw input codes and the golden model's raw output codes, one vector a line.
std::string golden_vectors_text(const QuantisedNetwork& q, const nn::Network& network, std::size_t count) {
  std::ostringstream out;
  out << "# Golden vectors of the fixed-point network (hls/README.md): x_0 x_1 x_2 (raw input codes,\n"
         "# metres * 2^"
      << q.formats.input_fraction_bits << ") y_0 y_1 y_2 (raw output codes, degrees * 2^"
      << q.formats.output_fraction_bits << "), decimal; saturation corners, grid, random (seed 1).\n";
  for (const RawInput& x : csim_vectors(q, network.input_min, network.input_max, count, 1)) {
    const RawOutput y = evaluate_raw(q, x);
    out << x[0] << ' ' << x[1] << ' ' << x[2] << ' ' << y.alpha[0] << ' ' << y.alpha[1] << ' ' << y.alpha[2] << '\n';
  }
  return out.str();
}

void run_quantise(const QuantiseOptions& options) {
  const nn::WeightsFile weights = nn::read_weights_file(options.weights);
  const QuantisedNetwork q = quantise_file(options.weights, weights);  // a deployed model's half-plays too
  std::vector<ExportFile> files;
  try {
    files = export_files(q);
  } catch (const std::invalid_argument& error) {
    throw InputError(options.weights, 0, std::string("cannot be quantised: ") + error.what());
  }
  if (!std::filesystem::is_directory(options.out_dir)) throw InputError(options.out_dir, 0, "is not a folder");
  const std::uint32_t crc = weights_crc(q);
  files.push_back(board_identify_file(q));
  if (options.vectors > 0)
    files.push_back({"golden_vectors.txt", golden_vectors_text(q, weights.network, options.vectors)});
  write_export_files(files, options.out_dir);
  for (const ExportFile& file : files) std::cout << options.out_dir << "/" << file.name << '\n';
  std::cerr << "quantise: 3-" << q.hidden << "-3 network, input shifts " << q.input_shift[0] << ' ' << q.input_shift[1]
            << ' ' << q.input_shift[2] << (weights.hybrid() ? "; hybrid model: the network part (residual)" : "")
            << (weights.deployed()
                    ? "; deployed model: backlash half-plays " + std::to_string(q.compensation.half_play[0]) + " " +
                          std::to_string(q.compensation.half_play[1]) + " " +
                          std::to_string(q.compensation.half_play[2]) + " output LSBs (half_play.mem)"
                    : "")
            << (weights.joint_ripple.empty()
                    ? ""
                    : "; its joint ripple table stays with the host (it shapes the setpoints: run the board with "
                      "this W.json)")
            << "; weights CRC-32 " << hex_word(crc, 32) << ", gateware build id " << hex_word(kGatewareBuildId, 32)
            << '\n';
}

const RegisterCommand command("quantise", 45, [](CLI::App& root) {
  auto options = std::make_shared<QuantiseOptions>();
  CLI::App* sub = root.add_subcommand("quantise", "Quantise W.json for the FPGA: $readmemh files and a C++ header");
  sub->footer(
      "\nWrites input_centre, input_shift, input_weights, hidden_bias, tanh_table, tanh_slope,\n"
      "output_weights, output_bias, half_play (the deployed model's backlash half-plays in the board's\n"
      "reference units; zero for a plain network) (.mem, one hex word per line, format in each file's header),\n"
      "fixed_network_weights.hpp, and identify.mem: the board link's identify payload (docs/board_link.md:\n"
      "protocol, gateware build id, CRC-32 of the codes above, clocks, rates) as 16-bit words for the\n"
      "board's block RAM. Formats: hls/README.md. Weights that would saturate a format are refused\n"
      "(exit 2, nothing written). The output is the same bytes for the same W.json and RTL sources.\n"
      "--vectors N adds golden_vectors.txt (raw codes in and out) for the HLS and RTL testbenches.\n"
      "Example: deltactl quantise --weights weights/paper_like.json --out-dir build/network_mem");
  sub->add_option("--weights", options->weights, "network weights (W.json)")->required();
  sub->add_option("--out-dir", options->out_dir, "existing folder for the files")->required();
  sub->add_option("--vectors", options->vectors, "also write golden_vectors.txt with this many test vectors")
      ->check(options::whole_number(0, 1000000));
  sub->callback([options] { run_quantise(*options); });
});

}  // namespace
}  // namespace delta::golden

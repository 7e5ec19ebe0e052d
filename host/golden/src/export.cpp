// $readmemh files and the C++ weights header of a quantised network.
#include "delta/golden/export.hpp"
#include "delta/golden/model_image.hpp"

#include <cmath>
#include <memory>
#include <sstream>

#include "delta/crc32.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/output_file.hpp"

namespace delta::golden {
namespace {

struct MemSpec {
  std::string name;
  std::string content;  // what the words are, with their order
  std::string format;   // e.g. "signed Q5.19"
  int bits;
  std::vector<std::int64_t> words;
  std::string cpp_name;
};

std::vector<std::int64_t> half_play_words(const QuantisedNetwork& q) {
  const std::array<std::int32_t, 3> counts = interpolation::half_play_counts(q.compensation);
  return {counts.begin(), counts.end()};
}

std::vector<MemSpec> mem_specs(const QuantisedNetwork& q) {
  const Formats& f = q.formats;
  const int acc1 = f.hidden_accumulator_fraction_bits();
  const int acc2 = f.output_accumulator_fraction_bits();
  const int bias1_bits = f.tanh_input_bits + acc1 - f.tanh_input_fraction_bits;
  const int bias2_bits = f.output_bits + acc2 - f.output_fraction_bits;
  auto q_format = [](const char* sign, int bits, int fraction) {
    if (bits < fraction) return std::string(sign) + ", LSB 2^-" + std::to_string(fraction);  // no integer bits
    return std::string(sign) + " Q" + std::to_string(bits - fraction) + "." + std::to_string(fraction);
  };
  const std::vector<std::int64_t> shifts(q.input_shift.begin(), q.input_shift.end());
  const std::string h = std::to_string(q.hidden);
  return {
      {"input_centre.mem",
       "centre_j of the trained input range, raw input code (metres * 2^" + std::to_string(f.input_fraction_bits) +
           "), j = 0..2 (x, y, z)",
       q_format("signed", f.input_bits, f.input_fraction_bits), f.input_bits,
       std::vector<std::int64_t>(q.input_centre.begin(), q.input_centre.end()), "kInputCentre"},
      {"input_shift.mem", "shift_j: u_j = sat(round_shift(x_j - centre_j, shift_j)), j = 0..2", "unsigned integer", 8,
       shifts, "kInputShift"},
      {"input_weights.mem", "IW'_kj, " + h + " x 3 neuron-major: word 3k + j",
       q_format("signed", f.input_weight_bits, f.input_weight_fraction_bits), f.input_weight_bits, q.input_weights,
       "kInputWeights"},
      {"hidden_bias.mem", "b1'_k, k = 0.." + std::to_string(q.hidden - 1), q_format("signed", bias1_bits, acc1),
       bias1_bits, q.hidden_bias, "kHiddenBias"},
      {"tanh_table.mem",
       "T[i] = node of tanh at n = i 2^-" + std::to_string(f.tanh_segments_per_unit_log2) + ", i = 0.." +
           std::to_string(f.tanh_segments() - 1),
       q_format("unsigned", f.tanh_entry_fraction_bits(), f.tanh_entry_fraction_bits()), f.tanh_entry_fraction_bits(),
       q.tanh_table, "kTanhTable"},
      {"tanh_slope.mem", "D[i] = T[i+1] - T[i] (0 <= D <= 2^(20-7)), i = 0.." + std::to_string(f.tanh_segments() - 1),
       q_format("unsigned", f.tanh_entry_fraction_bits() - f.tanh_segments_per_unit_log2 + 1,
                f.tanh_entry_fraction_bits()),
       f.tanh_entry_fraction_bits() - f.tanh_segments_per_unit_log2 + 1, q.tanh_slope, "kTanhSlope"},
      {"output_weights.mem", "LW'_ok (degrees per unit h), 3 x " + h + " output-major: word " + h + " o + k",
       q_format("signed", f.output_weight_bits, f.output_weight_fraction_bits), f.output_weight_bits, q.output_weights,
       "kOutputWeights"},
      {"output_bias.mem", "b2'_o (degrees), o = 0..2", q_format("signed", bias2_bits, acc2), bias2_bits,
       std::vector<std::int64_t>(q.output_bias.begin(), q.output_bias.end()), "kOutputBias"},
      {"half_play.mem",
       "H_j = 25 h_j / 16: the deployed model's backlash half-play of joint j as the board's reference "
       "shift (reference_interpolator.sv), 0 for the plain network, j = 0..2",
       "unsigned Q" + std::to_string(board::kHalfPlayBits - interpolation::kReferenceFractionBits) + "." +
           std::to_string(interpolation::kReferenceFractionBits) + " encoder counts",
       static_cast<int>(board::kHalfPlayBits), half_play_words(q), "kHalfPlay"},
  };
}

// Brace initialiser of delta_hls::NetworkWeights<Config> (hls/network/network.hpp): every constant
// as the shortest decimal that reads back as the exact double code * 2^-fraction, which the
// fixed-point types then hold exactly.
std::string hls_initialiser(const QuantisedNetwork& q) {
  const Formats& f = q.formats;
  std::ostringstream out;
  auto list = [&out](const std::vector<std::int64_t>& codes, std::size_t begin, std::size_t count, int fraction) {
    out << "{";
    for (std::size_t i = 0; i < count; ++i) {
      out << (i ? ", " : "") << format_number(std::ldexp(static_cast<double>(codes[begin + i]), -fraction));
    }
    out << "}";
  };
  const std::vector<std::int64_t> centre(q.input_centre.begin(), q.input_centre.end());
  const std::vector<std::int64_t> bias2(q.output_bias.begin(), q.output_bias.end());
  std::vector<std::int64_t> gain;
  for (int e : q.input_exponent) gain.push_back(std::int64_t{1} << (16 - e));  // 2^-e as a code with 16 fraction bits
  const std::size_t h = static_cast<std::size_t>(q.hidden);
  out << "// Initialiser of delta_hls::NetworkWeights<DefaultNetworkConfig> for the synthesis top.\n"
         "#define DELTA_NETWORK_WEIGHTS_INIT \\\n  { ";
  list(centre, 0, 3, f.input_fraction_bits);
  out << ", ";
  list(gain, 0, 3, 16);
  out << ", \\\n    {";
  for (std::size_t k = 0; k < h; ++k) {
    out << (k ? ", " : "");
    list(q.input_weights, 3 * k, 3, f.input_weight_fraction_bits);
  }
  out << "}, \\\n    ";
  list(q.hidden_bias, 0, h, f.hidden_accumulator_fraction_bits());
  out << ", \\\n    ";
  list(q.tanh_table, 0, q.tanh_table.size(), f.tanh_entry_fraction_bits());
  out << ", \\\n    ";
  list(q.tanh_slope, 0, q.tanh_slope.size(), f.tanh_entry_fraction_bits());
  out << ", \\\n    {";
  for (std::size_t o = 0; o < 3; ++o) {
    out << (o ? ", " : "");
    list(q.output_weights, h * o, h, f.output_weight_fraction_bits);
  }
  out << "}, \\\n    ";
  list(bias2, 0, 3, f.output_accumulator_fraction_bits());
  out << " }\n";
  return out.str();
}

}  // namespace

std::string hex_word(std::int64_t value, int bits) {
  const std::uint64_t mask = bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
  const std::uint64_t word = static_cast<std::uint64_t>(value) & mask;
  static const char* digits = "0123456789abcdef";
  std::string text((bits + 3) / 4, '0');
  for (std::size_t i = 0; i < text.size(); ++i) text[text.size() - 1 - i] = digits[(word >> (4 * i)) & 0xF];
  return text;
}

std::vector<ExportFile> export_files(const QuantisedNetwork& q) {
  for (const MemSpec& spec : mem_specs(q)) {
    for (std::int64_t word : spec.words) {
      bool clamped = false;
      if (spec.format.rfind("unsigned", 0) == 0 ? (word < 0 || word >= (std::int64_t{1} << spec.bits))
                                                : (saturate(word, spec.bits, &clamped), clamped)) {
        throw std::invalid_argument(spec.name + ": word " + std::to_string(word) + " does not fit " + spec.format);
      }
    }
  }
  std::vector<ExportFile> files;
  std::ostringstream header;
  header << "// Quantised weights of the fixed-point 3-" << q.hidden
         << "-3 network, generated by `deltactl quantise` (hls/README.md, spec version 1).\n"
            "// Codes are two's complement integers; the formats are given beside each array.\n"
            "#pragma once\n\n#include <cstdint>\n\nnamespace delta_network_weights {\n\n"
         << "constexpr int kHidden = " << q.hidden << ";\n"
         << "constexpr int kTanhSegments = " << q.formats.tanh_segments() << ";\n\n";
  for (const MemSpec& spec : mem_specs(q)) {
    std::ostringstream mem;
    mem << "// delta fixed-point network, spec version 1 (hls/README.md): " << spec.name << "\n"
        << "// " << spec.content << "\n"
        << "// " << spec.words.size() << " words, " << spec.format << " in " << spec.bits << " bits, "
        << (spec.format.rfind("signed", 0) == 0 ? "two's complement, " : "") << (spec.bits + 3) / 4
        << " hex digits per word\n";
    for (std::int64_t word : spec.words) mem << hex_word(word, spec.bits) << '\n';
    files.push_back({spec.name, mem.str()});
    header << "// " << spec.content << "; " << spec.format << " in " << spec.bits << " bits\n"
           << "constexpr std::int64_t " << spec.cpp_name << "[" << spec.words.size() << "] = {";
    for (std::size_t i = 0; i < spec.words.size(); ++i) {
      header << (i % 8 == 0 ? "\n    " : " ") << spec.words[i] << (i + 1 < spec.words.size() ? "," : "");
    }
    header << "};\n\n";
  }
  header << "}  // namespace delta_network_weights\n\n" << hls_initialiser(q);
  files.push_back({"fixed_network_weights.hpp", header.str()});
  return files;
}

std::vector<std::uint8_t> weights_crc_bytes(const QuantisedNetwork& q) { return model_crc_bytes(q); }

ExportFile identify_mem_file(const link::IdentifyPayload& identify) {
  static_assert(board::kIdentifyPayloadBytes % 2 == 0, "identify.mem holds 16-bit words");
  const std::vector<std::uint8_t> payload = link::encode(identify);
  std::ostringstream mem;
  mem << "// delta board link v3 (docs/board_link.md): identify.mem, the identify payload ("
      << board::kIdentifyPayloadBytes << " bytes)\n"
      << "// protocol " << identify.protocol_version << ", setpoint depth " << identify.setpoint_depth
      << ", gateware build id " << hex_word(identify.build_id, 32) << ", weights CRC-32 "
      << hex_word(identify.weights_crc, 32) << ",\n"
      << "// network clock " << identify.network_clock_hz << " Hz, board clock " << identify.board_clock_hz
      << " Hz, control rate " << identify.control_rate_hz << " Hz, setpoint rate " << identify.setpoint_rate_hz
      << " Hz\n"
      << "// " << payload.size() / 2
      << " words, unsigned in 16 bits, 4 hex digits per word; word w = byte 2w | byte 2w+1 << 8\n";
  for (std::size_t w = 0; w < payload.size() / 2; ++w)
    mem << hex_word(payload[2 * w] | payload[2 * w + 1] << 8, 16) << '\n';
  return {"identify.mem", mem.str()};
}

void write_export_files(const std::vector<ExportFile>& files, const std::string& directory) {
  std::vector<std::unique_ptr<OutputFile>> outputs;
  for (const ExportFile& file : files) {
    outputs.push_back(std::make_unique<OutputFile>(directory + "/" + file.name));
    outputs.back()->stream() << file.text;
    outputs.back()->finish();
  }
  for (const auto& output : outputs) output->commit();
}

void write_export(const QuantisedNetwork& q, const std::string& directory) {
  std::vector<ExportFile> files = export_files(q);
  files.push_back(board_identify_file(q));
  write_export_files(files, directory);  // all checks before the first file is written
}

ExportFile board_identify_file(const QuantisedNetwork& q) {
  // The model is data the board loads over the link: the gateware's identify words hold no model
  // (CRC 0); the board writes the loaded model's CRC into them.
  static_cast<void>(q);
  return identify_mem_file(link::board_identify(kGatewareBuildId, 0));
}

}  // namespace delta::golden

namespace delta {

std::uint32_t weights_crc(const golden::QuantisedNetwork& q) { return crc32(golden::weights_crc_bytes(q)); }

}  // namespace delta

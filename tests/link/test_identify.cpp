// The identify payload's two ids: the weights CRC over the model's load image (delta::weights_crc)
// and the gateware build id (cmake/GatewareId.cmake), and identify.mem as `deltactl quantise`
// writes it: decoded through IdentifyPayload, it holds the package's facts and both ids.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "delta/crc32.hpp"
#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/fixed_point_backend.hpp"
#include "delta/link/payloads.hpp"
#include "delta/nn/weights_file.hpp"
#include "support/run_command.hpp"
#include "support/tree_paths.hpp"

namespace delta {
namespace {

// The board's shipped model: the deployed one (network + backlash half-plays, half_play.mem).
const std::string kWeights = std::string(DELTA_SOURCE_DIR) + "/weights/paper_like_deployed.json";

golden::QuantisedNetwork shipped_network() {
  golden::QuantisedNetwork q = golden::quantise_file(kWeights, nn::read_weights_file(kWeights));
  EXPECT_TRUE(q.compensation.any());
  return q;
}

std::string out_dir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "link_identify_" + name;
  std::filesystem::create_directories(dir);
  return dir;
}

// The hex words of a .mem file, with the width its header states ("... in N bits").
struct MemWords {
  int bits = 0;
  std::vector<std::uint64_t> words;
};

MemWords read_mem(const std::string& path) {
  std::istringstream text(test::read_text(path));
  MemWords mem;
  std::string line;
  const std::regex width(" in ([0-9]+) bits");
  while (std::getline(text, line)) {
    std::smatch match;
    if (line.rfind("//", 0) == 0) {
      if (mem.bits == 0 && std::regex_search(line, match, width)) mem.bits = std::stoi(match[1]);
      continue;
    }
    mem.words.push_back(std::stoull(line, nullptr, 16));
  }
  return mem;
}

TEST(WeightsCrc, ChangesWhenAnyOneCodeChangesByOneLsb) {
  const golden::QuantisedNetwork q = shipped_network();
  const std::uint32_t crc = weights_crc(q);
  std::cout << "weights CRC-32 of paper_like.json: " << golden::hex_word(crc, 32) << "\n";
  EXPECT_EQ(weights_crc(q), crc);  // deterministic
  const std::uint64_t seed = 8;
  std::cout << "seed " << seed << "\n";
  std::mt19937_64 random(seed);
  auto changed = [&](auto mutate) {
    golden::QuantisedNetwork other = q;
    mutate(other);
    return weights_crc(other) != crc;
  };
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t i = random() % q.input_weights.size(), k = random() % q.hidden_bias.size();
    const std::size_t t = random() % q.tanh_table.size(), o = random() % q.output_weights.size();
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.input_weights[i] += 1; })) << i;
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.hidden_bias[k] -= 1; })) << k;
    // The tanh table is the gateware's, not the model's: a network with another one cannot load.
    EXPECT_THROW(changed([&](golden::QuantisedNetwork& n) { n.tanh_table[t] ^= 1; }), std::invalid_argument) << t;
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.output_weights[o] += 1; })) << o;
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.input_centre[j] += 1; })) << j;
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.input_shift[j] += 1; })) << j;
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.output_bias[j] -= 1; })) << j;
    EXPECT_TRUE(changed([&](golden::QuantisedNetwork& n) { n.compensation.half_play[j] += 16; })) << j;
  }
  EXPECT_THROW(changed([&](golden::QuantisedNetwork& n) { n.tanh_slope.back() += 1; }), std::invalid_argument);
}

TEST(WeightsCrc, IsTheCrcOfTheLoadImageBuiltFromTheMemFiles) {
  // An independent reading of docs/board_link.md "The model": the quantise output files, parsed
  // as text, laid out as the load's 48-bit words, each as 6 little-endian bytes.
  const std::string dir = out_dir("crc");
  const test::CommandResult result = test::run_deltactl("quantise --weights " + kWeights + " --out-dir " + dir);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  auto words_of = [&](const char* name) {
    const MemWords mem = read_mem(dir + "/" + name + ".mem");
    EXPECT_FALSE(mem.words.empty()) << name;
    return mem;
  };
  auto sign_extend = [](std::uint64_t word, int bits) {
    const std::uint64_t sign = std::uint64_t{1} << (bits - 1);
    return static_cast<std::int64_t>((word ^ sign) - sign);
  };
  std::vector<std::uint64_t> image;
  for (const char* name : {"input_weights", "hidden_bias", "output_weights"}) {
    for (std::uint64_t w : words_of(name).words) image.push_back(w);
  }
  const MemWords bias2 = words_of("output_bias");
  for (std::uint64_t w : bias2.words) {
    image.push_back(static_cast<std::uint64_t>(sign_extend(w, bias2.bits) + (1 << 19)) &
                    ((std::uint64_t{1} << 47) - 1));
  }
  for (std::uint64_t h : words_of("half_play").words) {  // H in Q.8 counts
    const bool rounds = ((h >> 7) & 1) == ((h >> 6) & 1);
    const std::int64_t g = rounds ? 128 : 0;
    const std::int64_t above = (static_cast<std::int64_t>(h) + g) >> 8, below = (g - static_cast<std::int64_t>(h)) >> 8;
    image.push_back(h | (static_cast<std::uint64_t>(above) & 0x3FF) << 17 |
                    (static_cast<std::uint64_t>(below) & 0x3FF) << 27 | std::uint64_t{rounds} << 37);
  }
  const MemWords centre = words_of("input_centre"), shift = words_of("input_shift");
  for (int j = 0; j < 3; ++j) image.push_back(centre.words[j] | shift.words[j] << 32);
  ASSERT_EQ(image.size(), static_cast<std::size_t>(board::kModelCommitFrame));
  std::vector<std::uint8_t> bytes;
  for (std::uint64_t w : image) {
    for (int i = 0; i < 6; ++i) bytes.push_back(static_cast<std::uint8_t>(w >> (8 * i)));
  }
  const golden::QuantisedNetwork q = shipped_network();
  EXPECT_EQ(bytes, golden::weights_crc_bytes(q));
  EXPECT_EQ(crc32(bytes), weights_crc(q));
  EXPECT_NE(result.err.find(golden::hex_word(weights_crc(q), 32)), std::string::npos) << result.err;
}

TEST(IdentifyMem, QuantiseWritesTheIdentifyPayloadAsLittleEndianWords) {
  const std::string dir = out_dir("mem");
  const test::CommandResult result = test::run_deltactl("quantise --weights " + kWeights + " --out-dir " + dir);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find(dir + "/identify.mem"), std::string::npos) << result.out;
  const MemWords mem = read_mem(dir + "/identify.mem");
  EXPECT_EQ(mem.bits, 16);
  ASSERT_EQ(mem.words.size(), static_cast<std::size_t>(board::kIdentifyPayloadBytes / 2));
  std::vector<std::uint8_t> payload;
  for (std::uint64_t word : mem.words) {
    ASSERT_LE(word, 0xFFFFu);
    payload.push_back(static_cast<std::uint8_t>(word & 0xFF));  // word w: byte 2w low, 2w+1 high
    payload.push_back(static_cast<std::uint8_t>(word >> 8));
  }
  const link::IdentifyPayload identify = link::decode_identify(payload);
  EXPECT_EQ(identify.protocol_version, board::kProtocolVersion);
  EXPECT_EQ(identify.setpoint_depth, board::kSetpointDepth);
  EXPECT_EQ(identify.build_id, kGatewareBuildId);
  EXPECT_EQ(identify.weights_crc, 0u);  // the gateware holds no model: the board reports the loaded one's
  EXPECT_EQ(identify.network_clock_hz, board::kNetworkClockHz);
  EXPECT_EQ(identify.board_clock_hz, board::kBoardClockHz);
  EXPECT_EQ(identify.control_rate_hz, board::kControlRateHz);
  EXPECT_EQ(identify.setpoint_rate_hz, board::kSetpointRateHz);
  // Every line is a comment or exactly four hex digits ($readmemh into 16-bit words).
  std::istringstream text(test::read_text(dir + "/identify.mem"));
  std::string line;
  while (std::getline(text, line)) {
    if (line.rfind("//", 0) == 0) continue;
    EXPECT_TRUE(std::regex_match(line, std::regex("[0-9a-f]{4}"))) << line;
  }
}

TEST(GatewareId, IsTheSha256OfTheRtlSourcesInSortedOrder) {
  // The same rule through coreutils, independent of CMake: sorted paths, contents concatenated.
  const std::string command = std::string("cd '") + DELTA_SOURCE_DIR +
                              "' && find rtl -name '*.sv' -type f | LC_ALL=C sort | xargs cat | sha256sum";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  char digest[65] = {};
  ASSERT_EQ(std::fread(digest, 1, 64, pipe), 64u);
  pclose(pipe);
  std::cout << "sha256 " << digest << "\n";
  EXPECT_EQ(golden::hex_word(kGatewareBuildId, 32), std::string(digest, 8));
}

}  // namespace
}  // namespace delta

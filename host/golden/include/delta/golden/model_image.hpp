// The model as the board takes it over the link (docs/board_link.md, "The model"): the frames of a
// load, one 48-bit word each, from a quantised network. One home for the image's layout (frame
// numbers and word formats from rtl/board/delta_board_pkg.sv through delta/board_facts.hpp): the
// host's `host load`, the virtual boards' `--weights` and the weights CRC all read it.
#pragma once

#include <cstdint>
#include <vector>

#include "delta/golden/fixed_network.hpp"
#include "delta/link/payloads.hpp"

namespace delta::golden {

// The 48-bit word of frame n (0 .. board::kModelCommitFrame - 1), as the board stores it:
//   IW'_kj (word 3k + j), b1'_k, LW'_ok (word 25o + k): the code masked to its width;
//   b2'_o + 2^19 (the output cast's rounding half), 47 bits;
//   joint j's play: H_j = 25 h_j / 16 (bits 0-16), above_j = (H_j + g_j) >> 8 (bits 17-26),
//   below_j = (g_j - H_j) >> 8 (bits 27-36, two's complement), rounds_j = H_j[7] == H_j[6] (bit 37),
//   g_j = 128 when rounds_j else 0 (reference_interpolator.sv, golden interpolation::play_shift);
//   input j's scaling, which the host applies (the board never uses it, the CRC covers it):
//   centre_j (bits 0-31, two's complement), shift_j (bits 32-39).
// Throws std::invalid_argument when q is not in the board's formats (the spec's defaults, 25 hidden
// neurons, the tanh table of those formats) or a code does not fit its word.
std::vector<std::uint64_t> model_words(const QuantisedNetwork& q);

// The frames of a load: model_words(q) as frames 0 .. board::kModelCommitFrame - 1, then the commit
// frame with weights_crc(q) in bits 0-31.
std::vector<link::ModelPayload> model_frames(const QuantisedNetwork& q);

// The bytes the CRC-32 covers: each word of model_words(q) as 6 little-endian bytes, in frame order.
std::vector<std::uint8_t> model_crc_bytes(const QuantisedNetwork& q);

// Inverse of model_words for what the board keeps (network codes and half-plays): the network a
// board holding `words` runs, with the scaling frames' centre and shift. Throws
// std::invalid_argument when `words` has the wrong count.
QuantisedNetwork network_of_model_words(const std::vector<std::uint64_t>& words);

}  // namespace delta::golden

// Loading the model onto a board over the link (docs/board_link.md, "The model"): `deltactl host
// load`, and `host serve` when it connects to a board without its configured model. The gateware
// is the same for every model; the board takes the network's words, the deployed model's half-plays
// and the input scaling as golden::model_frames, checks their CRC-32 and only then enables.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "delta/controller/run_job.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/link/session.hpp"

namespace delta::controller {

// The board holds a complete model whose CRC checked (the telemetry's model flag).
bool board_has_model(const link::TelemetryPayload& telemetry);

struct ModelLoaded {
  std::uint32_t crc = 0;             // delta::weights_crc(q): what the board's identify reports now
  std::size_t frames = 0;            // frames sent (both attempts)
  int attempts = 0;                  // 1, or 2 after a retry from frame 0
  std::string retry_reason;          // why the first attempt failed ("" when it did not)
  double seconds = 0.0;              // wall time from the first frame to the check
  link::TelemetryPayload telemetry;  // the newest after the load
};

// On an identified board `c` (connect_board): HostFailure exit 5 naming both build ids unless it
// runs this checkout's gateware; exit 3 "the drives are on: disable first" when they are (nothing
// sent). Then sends golden::model_frames(q) (LinkSession::load_model, paced by the board's
// acceptance) and confirms: the telemetry's model flag and identify's weights CRC ==
// delta::weights_crc(q). A refusal, a stall or a mismatch: once more from frame 0; failing again,
// HostFailure exit 3 naming what failed (the frame refused, the board's CRC against the file's).
// Link loss: exit 4. std::invalid_argument when q is not in the board's formats (check before).
ModelLoaded load_board_model(link::LinkSession& session, const Connected& c, const golden::QuantisedNetwork& q,
                             const std::string& port_name);

}  // namespace delta::controller

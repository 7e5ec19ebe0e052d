// Loading the model onto a board (see model_load.hpp).
#include "delta/controller/model_load.hpp"

#include <chrono>
#include <vector>

#include "delta/gateware.hpp"
#include "delta/golden/export.hpp"
#include "delta/golden/model_image.hpp"

namespace delta::controller {
namespace {

std::string hex(std::uint32_t value) { return golden::hex_word(value, 32); }

int link_error_code(const link::LinkError& error) {
  return error.kind() == link::LinkError::Kind::kLinkLost   ? kExitLinkLost
         : error.kind() == link::LinkError::Kind::kProtocol ? kExitMismatch
                                                            : kExitFault;
}

}  // namespace

bool board_has_model(const link::TelemetryPayload& telemetry) { return telemetry.has(link::TelemetryFlag::kModel); }

ModelLoaded load_board_model(link::LinkSession& session, const Connected& c, const golden::QuantisedNetwork& q,
                             const std::string& port_name) {
  const std::vector<link::ModelPayload> frames = golden::model_frames(q);
  const std::uint32_t crc = weights_crc(q);
  if (c.identify.build_id != kGatewareBuildId) {
    throw HostFailure(kExitMismatch, port_name + ": the board runs gateware " + hex(c.identify.build_id) +
                                         ", this host's is " + hex(kGatewareBuildId) +
                                         " (flash this checkout's: deltactl flash); no model sent");
  }
  if (c.telemetry.has(link::TelemetryFlag::kDriveEnable)) {
    throw HostFailure(kExitFault, port_name +
                                      ": the drives are on: disable first (a model is taken only with the "
                                      "drives off); nothing sent");
  }
  ModelLoaded out;
  out.crc = crc;
  std::string failure;
  const auto start = std::chrono::steady_clock::now();
  try {
    for (int attempt = 1; attempt <= 2; ++attempt) {
      out.attempts = attempt;
      const link::ModelLoadReport report = session.load_model(frames);
      out.frames += report.sent;
      out.telemetry = report.telemetry;
      std::string problem = report.problem;
      if (problem.empty()) {
        const link::IdentifyPayload identify = session.identify();
        if (identify.weights_crc != crc) {
          problem = "the board reports model CRC " + hex(identify.weights_crc) + ", the file's is " + hex(crc);
        }
        if (session.last_telemetry()) out.telemetry = *session.last_telemetry();
      }
      if (problem.empty()) {
        out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return out;
      }
      if (attempt == 1) out.retry_reason = problem;
      failure = problem;
    }
  } catch (const link::LinkError& error) {
    throw HostFailure(link_error_code(error), error.what());
  }
  throw HostFailure(kExitFault, port_name + ": the model was not loaded, twice from frame 0: " + failure +
                                    (board_has_model(out.telemetry) ? " (the board keeps the model it had)"
                                                                    : " (the board has no model now)"));
}

}  // namespace delta::controller

// Streams a 1 kHz list of plate positions the way `deltactl host run` streams its plan: a
// controller::StreamPlan of them (no approach when the first is where the plate is; the rate ramped
// in and out), the lab's controller::StreamingLoop on an enabled session, on the wall clock (a
// board behind a pty) or another clock (cosim::BoardTimeClock for a board in this process), primed as
// RunJob primes it (hold, the lead sent, enable).
#pragma once

#include <csignal>
#include <cstddef>
#include <vector>

#include "delta/controller/host_run.hpp"
#include "delta/controller/stream_plan.hpp"
#include "delta/golden/board_network.hpp"
#include "delta/golden/fixed_network.hpp"
#include "delta/link/session.hpp"

namespace delta::test {

struct LabStream {
  controller::StreamingResult result;
  std::size_t planned = 0;  // samples in the plan (the positions with the ramps' extra time)
};

inline LabStream stream_with_the_lab_loop(link::LinkSession& session, const golden::QuantisedNetwork& network,
                                          const std::vector<Vec3>& positions, controller::LoopClock* clock = nullptr) {
  controller::Path path;
  path.source = "test positions";
  for (std::size_t k = 0; k < positions.size(); ++k) {
    path.samples.push_back({static_cast<double>(k) / controller::kStreamRateHz, positions[k], 0});
  }
  controller::StreamPlan plan(path, positions.front(), controller::StreamLimits{});
  session.hold();  // as RunJob starts: the loop sends the lead while the board holds, then enables
  controller::RecordQueue queue(plan.capacity() + 4096);
  controller::StreamingOptions options;
  options.session = session.options();
  options.link_timeout_ms = session.options().frame_timeout_ms;  // a slow board behind a pty: the session's bound
  options.clock = clock;
  options.priority = 0;
  static const volatile std::sig_atomic_t kNoStop = 0;
  golden::BoardWeights weights;  // the network alone: the positions are sent as they are (no shaping)
  weights.network = network;
  controller::StreamingLoop loop(session, plan, weights, positions.front(), queue, options, kNoStop);
  loop.run();
  return {loop.result(), plan.size()};
}

}  // namespace delta::test

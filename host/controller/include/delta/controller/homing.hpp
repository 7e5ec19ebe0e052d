// Homing against the robot's references (docs/homing.md): each upper arm closes its home switch at
// and above its reference angle; the board sets a joint's count to the home count on the switch's
// rising edge while homing with the drives on, marks the joint referenced and turns the drives off
// (board_core.sv). The host moves the arms with the board's jog: one setpoint sets each joint's
// reference change per millisecond, which persists while homing (a hold ends homing and the jog;
// a disable keeps homing on).
//
//   1. home start (drives off): the board forgets the references and starts homing;
//   2. clear: every joint not referenced moves down until its switch has been open over
//      `clear_margin_deg` of its own motion (so each approach comes from below, the backlash's play
//      taken up the same way every time); the drives stop as each joint gets there, and it is held
//      while the others go on, so no joint goes lower than that margin below its start or switch;
//      a joint the board references meanwhile (kicked up into its switch by an enable, at the
//      kick's speed) is no reference: the references are forgotten and the clear starts again
//      (at most `max_restarts` times);
//   3. search: every joint not referenced moves up at `search_deg_s` until its switch closes: the
//      board references it and stops the drives; the others go on after the next enable.
//
// Before every enable, set home gives the joints not referenced the home count (the network's
// range: the jog's setpoint is the network's answer at the arms' pose, located by
// locate_plate), and the host watches every telemetry frame: a fault, a joint that moves
// `max_travel_deg` one way without its switch, or the time running out stops the drives and ends
// homing with HostFailure (exit 3) naming the joint and the cause. Provisional counts never leave
// the network's range by more than `recentre_deg`: the drives stop, the counts are set again, and
// the motion goes on.
#pragma once

#include <array>
#include <csignal>
#include <functional>
#include <optional>
#include <string>

#include "delta/golden/board_network.hpp"
#include "delta/link/session.hpp"
#include "delta/recording.hpp"

namespace delta::controller {

struct HomingOptions {
  double search_deg_s = 4.0;      // up toward the switches
  double clear_deg_s = 8.0;       // down off a closed switch
  double clear_margin_deg = 0.5;  // below the switch before the approach
  double recentre_deg = 15.0;     // provisional motion before the counts are set again
  double max_travel_deg = 102.4;  // one way without the switch (the board's travel): no reference
  double timeout_s = 120.0;       // the whole homing
  // A reference the board takes while the joints clear (a joint kicked up into its switch by an
  // enable) is forgotten and the homing starts again, at most this many times.
  int max_restarts = 3;
  int keep_alive_ms = 20;  // a frame to the board at least this often (its watchdog: 250 ms)
  // Polled on every telemetry frame homing reads (empty: never): true ends homing at once, the
  // drives off, with HostFailure (kExitFault, "home: homing stopped on request; ..."). The service's
  // e-stop, stop and shutdown.
  std::function<bool()> stop_requested;
  // Called with every telemetry frame homing reads (empty: none), before stop_requested is polled:
  // the service feeds its watchdog and the dashboard from it. A hung homing reads no frames, so it
  // stops calling this.
  std::function<void(const link::TelemetryPayload&)> on_telemetry;
};

struct HomingReport {
  link::TelemetryPayload final;           // drives off, every joint referenced
  std::array<double, 3> travelled_deg{};  // each joint's motion (sum of |steps|)
  int enables = 0;                        // jogs started
  double seconds = 0.0;                   // wall time
};

// Homes the board; the drives are off and every joint referenced when it returns. `log` gets one
// line per step (may be empty); a stop signal (non-zero *stop, read on every telemetry frame) ends
// homing with the drives off (HostFailure, exit 128 + signal), as options.stop_requested does
// (exit 3). HostFailure with kExitFault or kExitLinkLost otherwise.
HomingReport home_at_references(link::LinkSession& session, const golden::BoardWeights& weights,
                                const HomingOptions& options, const std::function<void(const std::string&)>& log,
                                const volatile std::sig_atomic_t* stop = nullptr);

// How the board's counts are referenced now: at the home switches (every joint referenced), by hand
// (set home outside homing: 'host home --by-hand'), or not at all: never homed, or a homing that did
// not finish (stopped, failed: the board stays homing, its provisional counts set at each jog, until
// a hold or the next homing), or counts set by hand or at a homing's jog and then a fault (the board
// forgets a homing at a fault: the two look alike; neither is a reference).
Referencing board_referencing(const link::TelemetryPayload& telemetry);
// One line of why counts that are not referenced at the home switches are not ("" when they are).
std::string unreferenced_reason(const link::TelemetryPayload& telemetry);
// Not referenced because a homing did not finish: the board still homing (stopped, failed), or a
// fault ended it (TelemetryPayload::homing_ended_by_fault). Status's `homing_unfinished`.
bool homing_unfinished(const link::TelemetryPayload& telemetry);

// Reads telemetry until the counts have been still for 30 frames (the arms at rest with the drives
// off), at most 2000 frames: that last frame, or nothing if they never came to rest. `each` (may be
// empty) sees every frame read. LinkError propagates.
std::optional<link::TelemetryPayload> arms_at_rest(link::LinkSession& session,
                                                   const std::function<void(const link::TelemetryPayload&)>& each = {});

// The setpoint whose network answer moves each joint's reference by delta_q8[j] (Q24.8 counts per
// setpoint period) from `references` (Q24.8), through the deployed model's play (half_plays,
// Q24.8): the position codes, and in *actual the change the board will make.
std::array<std::int32_t, 3> jog_setpoint(const golden::BoardWeights& weights,
                                         const std::array<std::int32_t, 3>& references,
                                         const std::array<std::int32_t, 3>& delta_q8,
                                         std::array<std::int32_t, 3>* actual);

}  // namespace delta::controller

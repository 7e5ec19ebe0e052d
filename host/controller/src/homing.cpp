// Homing against the robot's references (see homing.hpp and docs/homing.md).
#include "delta/controller/homing.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>

#include <Eigen/Dense>

#include "delta/board_facts.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/golden/setpoint_interpolation.hpp"
#include "delta/table.hpp"

namespace delta::controller {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kQ8 = 256.0;

std::string joint_name(int j) { return "joint " + std::to_string(j + 1); }

int link_code(const link::LinkError& error) {
  return error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault;
}

// Q24.8 counts per setpoint period for a speed in deg/s.
std::int32_t q8_per_setpoint(double deg_s) {
  return static_cast<std::int32_t>(std::lround(deg_s / board::kSetpointRateHz / board::kEncoderCountDeg * kQ8));
}

// How far a jog's change d (Q.8 counts per ms) misses delta, in units of home_at_references' bound:
// a held joint within 16, a moving one its way (d != 0, delta's sign) within 20 % (at least 3).
// At most 1: that check passes.
double jog_miss(std::int32_t delta, std::int32_t d) {
  if (delta == 0) return std::abs(d) / 16.0;
  if (d == 0 || (d > 0) != (delta > 0)) return 1e3;  // the wrong way, or inside the play
  return std::abs(d - delta) / static_cast<double>(std::max(3, std::abs(delta) / 5));
}

// A stop asked while homing (a signal, or HomingOptions::stop_requested), seen on a telemetry frame:
// home_at_references turns it into HostFailure with the drives off.
struct StopRequested {
  int code;
  std::string why;
};

}  // namespace

Referencing board_referencing(const link::TelemetryPayload& telemetry) {
  if (telemetry.has(link::TelemetryFlag::kReferenced)) return Referencing::kHomeSwitches;
  if (telemetry.has(link::TelemetryFlag::kHoming)) return Referencing::kNone;
  // A fault ends the board's homing (it forgets it was homing) and keeps the homed flag of the
  // set-home at each jog: counts set by hand and a homing a fault ended look alike. Neither is a
  // reference; say not homed (a clear-fault through the service starts homing again, drives off).
  if (telemetry.has(link::TelemetryFlag::kFault)) return Referencing::kNone;
  return telemetry.has(link::TelemetryFlag::kHomed) ? Referencing::kHand : Referencing::kNone;
}

bool homing_unfinished(const link::TelemetryPayload& telemetry) {
  return board_referencing(telemetry) == Referencing::kNone &&
         (telemetry.has(link::TelemetryFlag::kHoming) || telemetry.homing_ended_by_fault());
}

std::string unreferenced_reason(const link::TelemetryPayload& telemetry) {
  switch (board_referencing(telemetry)) {
    case Referencing::kHomeSwitches:
      return "";
    case Referencing::kHand:
      return "homed by hand, not at its home switches: the counts were set where the arms stood";
    case Referencing::kNone:
      break;
  }
  if (telemetry.has(link::TelemetryFlag::kHoming))
    return "a homing that did not finish (stopped or failed): the counts are provisional";
  if (telemetry.homing_ended_by_fault())
    return "a homing that did not finish (a fault ended it), or counts set by hand before the fault: the counts are "
           "provisional";
  return "never homed: the counts started at 30.00 deg wherever the arms were at power-up";
}

std::optional<link::TelemetryPayload> arms_at_rest(link::LinkSession& session,
                                                   const std::function<void(const link::TelemetryPayload&)>& each) {
  const auto next = [&] {
    const link::TelemetryPayload f = session.next_telemetry();
    if (each) each(f);
    return f;
  };
  link::TelemetryPayload before = next();
  int still = 0;
  for (int frames = 0; still < 30 && frames < 2000; ++frames) {
    const link::TelemetryPayload f = next();
    still = f.counts == before.counts ? still + 1 : 0;
    before = f;
  }
  if (still < 30) return std::nullopt;
  return before;
}

std::array<std::int32_t, 3> jog_setpoint(const golden::BoardWeights& weights,
                                         const std::array<std::int32_t, 3>& references,
                                         const std::array<std::int32_t, 3>& delta_q8,
                                         std::array<std::int32_t, 3>* actual) {
  const auto half_plays = golden::interpolation::half_play_counts(weights.network.compensation);
  // The answer c the board turns into D = play(c - r, H): c = r + D + sign(D) H (D = 0: c = r, the
  // play's middle).
  Eigen::Vector3d target;
  Vec3 target_deg;
  for (int j = 0; j < 3; ++j) {
    const std::int64_t sign = delta_q8[j] > 0 ? 1 : delta_q8[j] < 0 ? -1 : 0;
    target[j] = static_cast<double>(std::int64_t{references[j]} + delta_q8[j] + sign * half_plays[j]);
    target_deg[j] = target[j] / kQ8 * board::kEncoderCountDeg;
  }
  // The nominal model's inverse of the network, then Newton on the input codes themselves with the
  // golden network (its answer in Q.8 counts, 25 y / 16 unrounded, as the function to zero).
  const Vec3 p = golden::locate_plate(weights.network, Geometry::nominal(), target_deg);
  std::array<std::int64_t, 3> codes = golden::encode_position(weights.network.formats, p);
  const auto answer = [&](const std::array<std::int64_t, 3>& at) {
    const golden::RawOutput raw = golden::evaluate_raw(weights.network, at);
    Eigen::Vector3d c;
    for (int j = 0; j < 3; ++j) c[j] = 25.0 * static_cast<double>(raw.alpha[j]) / 16.0;
    return c;
  };
  constexpr std::int64_t kProbe = 1 << 12;  // input LSBs for the Jacobian (a few nanometres... micrometres)
  for (int iteration = 0; iteration < 8; ++iteration) {
    const Eigen::Vector3d c = answer(codes);
    const Eigen::Vector3d error = c - target;
    if (error.cwiseAbs().maxCoeff() < 0.5) break;
    Eigen::Matrix3d jacobian;
    for (int k = 0; k < 3; ++k) {
      std::array<std::int64_t, 3> probe = codes;
      probe[k] += kProbe;
      jacobian.col(k) = (answer(probe) - c) / static_cast<double>(kProbe);
    }
    const Eigen::Vector3d step = jacobian.colPivHouseholderQr().solve(-error);
    for (int k = 0; k < 3; ++k) codes[k] += static_cast<std::int64_t>(std::llround(step[k]));
  }
  // The network sees the position only through its scaled input u = (x - centre) / 2^shift, a 16-bit
  // code: an LSB of u moves the answer by 3-7 Q.8 counts on the paper's 10 mm cube and by 13-24 on a
  // calibration drag's range (+-12 mm: 2^shift = 256 input codes, 0.95 um), as much as a jog's
  // bound. The best point of u's neighbourhood (+-2 LSBs of u on each axis): the smallest miss of
  // the homing check's bounds (jog_miss), then a held joint's change weighing 100 times a moving
  // joint's error.
  const auto changes = [&](const std::array<std::int64_t, 3>& at) {
    const golden::RawOutput raw = golden::evaluate_raw(weights.network, at);
    std::array<std::int32_t, 3> d{};
    for (int j = 0; j < 3; ++j) {
      const std::int64_t c = golden::interpolation::reference_counts(static_cast<std::int32_t>(raw.alpha[j]));
      d[j] = static_cast<std::int32_t>(std::clamp<std::int64_t>(golden::play(c - references[j], half_plays[j]),
                                                                golden::interpolation::kDeltaMin,
                                                                golden::interpolation::kDeltaMax));
    }
    return d;
  };
  // Among the points within the bounds, the least downward creep of the held joints comes first:
  // a held joint creeps for as long as the others move (a joint that has cleared its switch, or a
  // referenced one, while another searches for seconds), and down is toward the end of its travel.
  const auto cost = [&](const std::array<std::int32_t, 3>& d) {
    double worst = 0.0;
    double sum = 0.0;
    double held_down = 0.0;
    for (int j = 0; j < 3; ++j) {
      worst = std::max(worst, jog_miss(delta_q8[j], d[j]));
      sum += (delta_q8[j] == 0 ? 100.0 : 1.0) * std::abs(d[j] - delta_q8[j]);
      if (delta_q8[j] == 0) held_down += std::max(0, -d[j]);
    }
    return std::make_tuple(std::max(worst, 1.0), held_down, worst, sum);
  };
  std::array<std::int64_t, 3> lsb{};
  for (int k = 0; k < 3; ++k) lsb[k] = std::int64_t{1} << std::max(0, weights.network.input_shift[k]);
  std::array<std::int64_t, 3> best = codes;
  auto best_cost = cost(changes(codes));
  constexpr int kRadius = 2;
  for (int a = -kRadius; a <= kRadius; ++a) {
    for (int b = -kRadius; b <= kRadius; ++b) {
      for (int e = -kRadius; e <= kRadius; ++e) {
        const std::array<std::int64_t, 3> at = {codes[0] + a * lsb[0], codes[1] + b * lsb[1], codes[2] + e * lsb[2]};
        const auto c = cost(changes(at));
        if (c < best_cost) {
          best_cost = c;
          best = at;
        }
      }
    }
  }
  *actual = changes(best);
  std::array<std::int32_t, 3> code{};
  for (int j = 0; j < 3; ++j) code[j] = static_cast<std::int32_t>(best[j]);
  return code;
}

HomingReport home_at_references(link::LinkSession& session, const golden::BoardWeights& weights,
                                const HomingOptions& options, const std::function<void(const std::string&)>& log,
                                const volatile std::sig_atomic_t* stop) {
  const auto say = [&](const std::string& line) {
    if (log) log(line);
  };
  const std::string port = "the board";
  const Clock::time_point start = Clock::now();
  HomingReport report;
  const auto drives_off = [&] {
    try {
      session.send_command(link::Command::kDisable);
      session.disable();
    } catch (const link::LinkError&) {
    }
  };
  const auto fail = [&](int code, const std::string& why) {
    drives_off();
    throw HostFailure(code, "home: " + why + "; drives off, the board not referenced");
  };
  const auto checked = [&](auto&& body) {
    try {
      return body();
    } catch (const link::LinkError& error) {
      drives_off();
      throw HostFailure(link_code(error), std::string("home: ") + error.what());
    }
  };
  // Every telemetry frame homing reads passes here: the observer first, then the stop requests.
  const auto observe = [&](const link::TelemetryPayload& f) {
    if (options.on_telemetry) options.on_telemetry(f);
    if (stop != nullptr && *stop != 0) {
      const int signal_number = static_cast<int>(*stop);
      throw StopRequested{128 + signal_number, "stopped by signal " + std::to_string(signal_number)};
    }
    if (options.stop_requested && options.stop_requested())
      throw StopRequested{kExitFault, "homing stopped on request"};
  };
  const auto next = [&] {
    const link::TelemetryPayload f = session.next_telemetry();
    observe(f);
    return f;
  };
  // A command and the frames that answer it, observed (those already in the device's buffer too).
  const auto command = [&](link::Command c, const std::function<bool(const link::TelemetryPayload&)>& done) {
    session.poll_frames();
    while (const std::optional<link::TelemetryPayload> f = session.take_telemetry()) observe(*f);
    return session.command(c, [&](const link::TelemetryPayload& f) {
      observe(f);
      return done(f);
    });
  };
  const auto disable = [&] {
    return command(link::Command::kDisable,
                   [](const link::TelemetryPayload& f) { return !f.has(link::TelemetryFlag::kDriveEnable); });
  };

  try {
    link::TelemetryPayload t = checked([&] { return next(); });
    if (t.has(link::TelemetryFlag::kFault)) {
      throw HostFailure(kExitFault, "home: the board has a latched fault: " + link::describe_fault(t) +
                                        " (clear it deliberately first)");
    }
    if (t.has(link::TelemetryFlag::kDriveEnable)) {
      throw HostFailure(kExitFault, "home: the drives are on (another controller?); homing starts with the drives off");
    }
    const auto home_start = [&] {
      return checked([&] {
        return command(link::Command::kHomeStart, [](const link::TelemetryPayload& frame) {
          return frame.has(link::TelemetryFlag::kHoming) && (frame.home >> 3) == 0;
        });
      });
    };
    t = home_start();
    say("homing: references forgotten; switches " + std::to_string(t.home & 7) + " (bit j: joint j+1 closed)");

    const std::int32_t search = q8_per_setpoint(options.search_deg_s);
    const std::int32_t clear = q8_per_setpoint(options.clear_deg_s);
    std::array<bool, 3> clear_first = {true, true, true};  // the joint moves down off its switch first
    std::array<double, 3> open_run{};                      // degrees moved down with the switch open (clear phase)
    std::array<double, 3> one_way{};                       // degrees moved the present way without the switch
    bool clearing = true;
    int kicked = 0;    // joints the board referenced while clearing (bit j: joint j+1)
    int restarts = 0;  // homings started again for such a reference
    while (true) {
      // At rest first (a jog ends at speed, and a switch read in motion may still change).
      {
        const std::optional<link::TelemetryPayload> rest = checked([&] { return arms_at_rest(session, observe); });
        if (!rest) fail(kExitFault, "the arms do not come to rest with the drives off");
        t = *rest;
      }
      if (t.has(link::TelemetryFlag::kFault)) fail(kExitFault, "fault: " + link::describe_fault(t));
      // A reference the board took while the joints were clearing is not one: a joint that powered
      // up just below its switch, kicked up into it by an enable (the play's side unknown), closes it
      // at the kick's speed, not the search's, counts off. Forget every reference and clear again.
      if (kicked != 0) {
        if (++restarts > options.max_restarts) {
          fail(kExitFault, "a joint closed its switch while clearing " + std::to_string(restarts) +
                               " times (kicked up into it at each enable?)");
        }
        for (int j = 0; j < 3; ++j) {
          if (((kicked >> j) & 1) != 0)
            say("homing: " + joint_name(j) + " closed its switch while clearing (a kick, not a search); " +
                "references forgotten, clearing again");
        }
        t = home_start();
        kicked = 0;
        clearing = true;
        clear_first = {true, true, true};
        open_run = {};
        continue;
      }
      const int referenced = (t.home >> 3) & 7;
      if (referenced == 7) break;
      if (!t.has(link::TelemetryFlag::kHoming))
        fail(kExitFault, "the board left homing (" + link::describe_state(t) + ")");
      // A joint not referenced whose switch is closed at rest passed its switch with the drives off
      // (coasting after another joint's reference stopped them): the board takes a reference only on
      // an edge with the drives on, so that joint goes down off its switch again.
      if (!clearing) {
        for (int j = 0; j < 3; ++j) {
          if (((referenced >> j) & 1) == 0 && t.home_switch(j)) {
            say("homing: " + joint_name(j) + " passed its switch with the drives off; clearing it again");
            clear_first[j] = true;
            open_run[j] = 0.0;
            clearing = true;
          }
        }
      }
      std::array<std::int32_t, 3> delta{};
      if (clearing) {
        bool any = false;
        for (int j = 0; j < 3; ++j) {
          const bool done = ((referenced >> j) & 1) != 0 || !clear_first[j] || open_run[j] >= options.clear_margin_deg;
          delta[j] = done ? 0 : -clear;
          any = any || !done;
        }
        if (!any) {
          clearing = false;
          clear_first = {false, false, false};
          one_way = {};
          say("homing: every arm below its switch; searching up at " + fixed(options.search_deg_s, 1) + " deg/s");
          continue;
        }
      } else {
        for (int j = 0; j < 3; ++j) delta[j] = ((referenced >> j) & 1) != 0 ? 0 : search;
      }

      // Counts set again (the joints not referenced); the jog's setpoint from the references the
      // drives will start from (with the drives off they follow the counts); drives on; the setpoint.
      // (Done when the telemetry shows it: the counts of the joints not referenced at the home count
      // and the references following them; the homed flag may be there from before.)
      const link::TelemetryPayload off = checked([&] {
        return command(link::Command::kSetHome, [](const link::TelemetryPayload& f) {
          for (int j = 0; j < 3; ++j) {
            if (!f.referenced(j) && f.counts[j] != board::kHomeCount) return false;
            if (f.references[j] != f.counts[j] * 256) return false;
          }
          return f.has(link::TelemetryFlag::kHomed);
        });
      });
      std::array<std::int32_t, 3> actual{};
      std::array<std::int32_t, 3> code{};
      try {
        code = jog_setpoint(weights, off.references, delta, &actual);
      } catch (const std::runtime_error& error) {
        fail(kExitFault, std::string("no jog setpoint at the arms' pose: ") + error.what());
      }
      for (int j = 0; j < 3; ++j) {
        // A joint held may creep by a few Q.8 counts per millisecond (an input code's LSB moves the
        // answer by up to tens of them; a referenced joint's encoder keeps counting, so its count
        // stays right): at most 16, 0.63 deg/s. A moving one goes its way at about its speed: within
        // 20 % (far below the trained range, at 7 deg, the input lattice's nearest point moves joint 1
        // at 113 for 102). jog_miss holds these bounds.
        if (jog_miss(delta[j], actual[j]) > 1.0) {
          fail(kExitFault, joint_name(j) + ": the network cannot move it as asked (" + std::to_string(actual[j]) +
                               " instead of " + std::to_string(delta[j]) + " Q.8 counts per ms)");
        }
      }
      const link::TelemetryPayload on = checked([&] {
        return command(link::Command::kEnable, [&](const link::TelemetryPayload& f) {
          if (f.has(link::TelemetryFlag::kFault)) {
            throw link::LinkError(link::LinkError::Kind::kFault, port + ": enable: " + link::describe_state(f));
          }
          return f.has(link::TelemetryFlag::kDriveEnable) && !f.has(link::TelemetryFlag::kHolding);
        });
      });
      ++report.enables;
      for (int j = 0; j < 3; ++j) {
        if (on.references[j] != off.references[j]) fail(kExitFault, joint_name(j) + " moved with the drives off");
      }
      checked([&] {
        session.send_setpoint(on.sample_index + on.fill,
                              golden::setpoint_input(weights.network, {code[0], code[1], code[2]}));
        return 0;
      });

      // Watch until the drives stop (a switch), the phase's goal, a limit or a fault.
      std::array<std::int16_t, 3> last = on.counts;
      std::array<double, 3> lag{};  // |reference - count| [deg] in the last frame with the drives on
      Clock::time_point last_frame_sent = Clock::now();
      bool reached = false;
      std::array<int, 3> closed_frames{};  // frames a searching joint's switch is closed, not referenced
      while (!reached) {
        const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
        if (elapsed > options.timeout_s) fail(kExitFault, "not done within " + fixed(options.timeout_s, 0) + " s");
        if (Clock::now() - last_frame_sent >= std::chrono::milliseconds(options.keep_alive_ms)) {
          checked([&] {
            session.send_identify_request();
            return 0;
          });
          last_frame_sent = Clock::now();
        }
        const link::TelemetryPayload f = checked([&] { return next(); });
        if (f.has(link::TelemetryFlag::kFault)) {
          // The moving joint furthest behind its reference before the fault is the one that stuck.
          int worst = 0;
          double worst_error = -1.0;
          for (int j = 0; j < 3; ++j) {
            if (delta[j] != 0 && lag[j] > worst_error) {
              worst = j;
              worst_error = lag[j];
            }
          }
          fail(kExitFault, joint_name(worst) + " " + (delta[worst] > 0 ? "moving up" : "moving down") +
                               ": fault: " + link::describe_fault(f) + " (" + fixed(worst_error, 2) +
                               " deg behind its reference: stuck, or blocked before its switch)");
        }
        for (int j = 0; j < 3; ++j) {
          const double step = static_cast<std::int16_t>(f.counts[j] - last[j]) * board::kEncoderCountDeg;
          report.travelled_deg[j] += std::abs(step);
          if (delta[j] != 0) one_way[j] += std::abs(step);
          if (clearing && delta[j] < 0) open_run[j] = f.home_switch(j) ? 0.0 : open_run[j] - step;
        }
        last = f.counts;
        if (f.has(link::TelemetryFlag::kDriveEnable)) {
          for (int j = 0; j < 3; ++j) lag[j] = std::abs(f.following_error_deg(j));
        }
        if (!f.has(link::TelemetryFlag::kDriveEnable)) {  // a switch referenced its joint (or a disable)
          const int now = (f.home >> 3) & 7;
          for (int j = 0; j < 3; ++j) {
            if (((now >> j) & 1) != 0 && ((referenced >> j) & 1) == 0) {
              if (clearing) {
                kicked |= 1 << j;
                continue;
              }
              say("homing: " + joint_name(j) + " referenced (" + fixed(one_way[j], 2) +
                  " deg up from below its switch)");
              one_way[j] = 0.0;
            }
          }
          break;
        }
        for (int j = 0; j < 3; ++j) {
          if (delta[j] != 0 && one_way[j] > options.max_travel_deg) {
            fail(kExitFault, joint_name(j) + ": no home switch within " + fixed(options.max_travel_deg, 0) + " deg " +
                                 (delta[j] > 0 ? "up" : "down") + " (switch missing or not wired?)");
          }
        }
        // A switch closed under a joint still searching with the drives on, frames after its edge:
        // the edge was missed (the board references within a few cycles); stop and clear it again.
        for (int j = 0; j < 3; ++j) {
          const bool missed = !clearing && delta[j] > 0 && f.has(link::TelemetryFlag::kDriveEnable) &&
                              f.home_switch(j) && !f.referenced(j);
          closed_frames[j] = missed ? closed_frames[j] + 1 : 0;
        }
        // Clearing: the drives stop as soon as one moving joint has cleared its switch by the margin,
        // so that joint is held (delta 0) from the next jog on while the others clear, never carried
        // down with them (into the end of its travel: from a start below its switch it would follow
        // the longest clear of the others).
        bool goal = false;
        for (int j = 0; j < 3; ++j) {
          if (closed_frames[j] >= 5) goal = true;
          if (clearing && delta[j] != 0 && open_run[j] >= options.clear_margin_deg) goal = true;
        }
        bool recentre = false;
        for (int j = 0; j < 3; ++j) {
          const double provisional = (f.counts[j] - board::kHomeCount) * board::kEncoderCountDeg;
          if (delta[j] != 0 && std::abs(provisional) > options.recentre_deg) recentre = true;
        }
        if (goal || recentre) {
          checked([&] { return disable(); });
          reached = true;
        }
      }
    }
    checked([&] { return disable(); });
  } catch (const StopRequested& stopped) {
    fail(stopped.code, stopped.why);
  }
  report.final = *session.last_telemetry();
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

}  // namespace delta::controller

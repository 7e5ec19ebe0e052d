// deltactl bench: the bench bring-up checks of a new robot or board (docs/bench.md), each with the
// drives off but for the board's own bounded jog: `switches` watches the home switches while the
// arms are moved by hand, `scale` measures the encoder's counts per degree between two fixture
// angles, `soak` runs the link both ways at full rate and reports every counter, `jog` turns one
// joint a little, open loop, and checks it moved the right way. The checks live in
// delta/controller/bench.hpp; this file is their command line.
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "command.hpp"
#include "delta/board_facts.hpp"
#include "delta/controller/bench.hpp"
#include "delta/controller/realtime.hpp"
#include "delta/controller/run_job.hpp"
#include "delta/table.hpp"
#include "delta/utf8_text.hpp"
#include "options.hpp"

namespace delta::controller {
namespace {

constexpr int kStreamingPriority = 80;  // SCHED_FIFO, as the host's streaming thread (the virtual board's: 70)

volatile std::sig_atomic_t bench_stop = 0;
void request_bench_stop(int signal_number) {
  if (bench_stop == 0) bench_stop = signal_number;
}

[[noreturn]] void fail(int code, const std::string& message) {
  std::cerr << "deltactl: error: " << escape_invalid_utf8(message) << '\n';
  throw CommandExit{code};
}

struct BenchCommon {
  std::string port;
  bool limits_confirmed = false;
  int link_timeout_ms = 1000;
};

// The common frame of every bench check: the limits confirmed (else exit 2, nothing opened), the
// port opened, the board identified and refused when faulted or driving (exit 3), the check, and
// the drives off on every way out (a signal stops the check and is its exit, 128 + N).
template <typename Check>
void run_bench(const std::string& name, const BenchCommon& common, Check&& check) {
  if (!common.limits_confirmed) {
    fail(kExitBadInput, "bench " + name +
                            ": set the drives' current limits low first (the MCBL's LPC and LCC, docs/bench.md), "
                            "then pass --limits-confirmed");
  }
  struct sigaction action {};
  action.sa_handler = request_bench_stop;
  sigemptyset(&action.sa_mask);
  for (int signal_number : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) ::sigaction(signal_number, &action, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  std::unique_ptr<io::SerialPort> port;
  try {
    port = open_board_port(common.port);
  } catch (const HostFailure& error) {
    fail(error.code(), error.what());
  }
  link::LinkSession session(*port, host_session_options(common.link_timeout_ms));
  bench::Outcome outcome;
  try {
    Connected c;
    try {
      c = connect_board(session);
    } catch (const HostFailure& error) {
      fail(error.code(), error.what());
    }
    bench::DrivesOff drives_off(session);  // from here on, every way out sends a disable
    if (const std::string why = bench::refusal(c.telemetry, port->name()); !why.empty()) fail(kExitFault, why);
    // Every telemetry frame is read as it comes (a stalled host shows as late frames in a soak, and
    // a jog's disable goes out at once): real time when permitted, as a run's streaming thread.
    const std::string realtime_note = make_thread_realtime(kStreamingPriority);
    if (!realtime_note.empty()) std::cerr << "bench " << name << ": normal scheduling (" << realtime_note << ")\n";
    const bench::Output output{port->name(), [](const std::string& line) { std::cout << line << std::endl; },
                               [](const std::string& line) { std::cerr << line << std::endl; }};
    outcome = check(session, output);
    const link::TelemetryPayload last = drives_off.finish();
    if (outcome.code == 0 && last.has(link::TelemetryFlag::kFault)) {
      outcome = {kExitFault, "the board latched a fault at the end: " + link::describe_state(last)};
    }
  } catch (const link::LinkError& error) {
    fail(error.kind() == link::LinkError::Kind::kLinkLost ? kExitLinkLost : kExitFault, error.what());
  }
  if (outcome.code != 0) fail(outcome.code, "bench " + name + ": " + outcome.error);
}

void common_options(CLI::App* sub, BenchCommon& common) {
  sub->add_option("--port", common.port, "serial port (see 'deltactl host --help')")->required();
  sub->add_flag("--limits-confirmed", common.limits_confirmed,
                "the drives' current limits are set low (the MCBL's LPC and LCC): required");
  sub->add_option("--link-timeout-ms", common.link_timeout_ms, "wall time without a frame: link lost")
      ->check(options::whole_number(10, 60000))
      ->capture_default_str();
}

const std::string kExitCodes =
    "Exit codes: 0 the check passed; 1 it failed (the reason printed); 2 bad input, or no\n"
    "--limits-confirmed (nothing opened); 3 the board has a fault latched, its drives are on, or it\n"
    "refused (the cause printed); 4 the link was lost or the port cannot be opened; 5 the board speaks\n"
    "another link protocol; 128+N stopped by signal N (SIGINT, SIGTERM, SIGHUP, SIGQUIT). On every way\n"
    "out the drives are off (a disable is sent).";

struct SwitchesCli {
  BenchCommon common;
  bench::SwitchesOptions options;
};
struct ScaleCli {
  BenchCommon common;
  bench::ScaleOptions options;
  int joint = 1;
};
struct SoakCli {
  BenchCommon common;
  bench::SoakOptions options;
  double minutes = 0.0, seconds = 0.0;
};
struct JogCli {
  BenchCommon common;
  bench::JogOptions options;
  int joint = 1;
  double max_move_deg = 5.0;
  std::string direction, expect_sign;
};

// deltactl bench switches.
void add_switches_command(CLI::App* bench) {
  auto switches = std::make_shared<SwitchesCli>();
  CLI::App* sw = bench->add_subcommand("switches", "Watch the home switches while the arms are moved by hand");
  sw->footer(
      "\nWhat it does: reads every telemetry frame (1 kHz) with the drives off and watches the three home\n"
      "switches.\n"
      "What you do: move each arm by hand up through its home switch (it closes at and above the home\n"
      "angle, 30.00 deg) and back down, a few times.\n"
      "What it prints: the switches' states at the start, then one line per change: the board time, the\n"
      "switch, closed or opened, its joint's encoder count there, and all three counts. At the end\n"
      "(--duration S of board time, or Ctrl-C): one line per switch: seen open and closed or\n"
      "not, the count at each closing and opening edge and the spread of the closing counts (the\n"
      "switch's repeatability). Exit 1 when a switch was not seen both open and closed (its wiring,\n"
      "or the arm was not moved through it); Ctrl-C ends the watch as the duration does.\n" +
      kExitCodes + "\nExample: deltactl bench switches --port icebreaker --limits-confirmed\n");
  common_options(sw, switches->common);
  sw->add_option("--duration", switches->options.duration_s, "seconds of board time (default: until Ctrl-C)")
      ->check(options::real_number(0, 1e6, true));
  sw->callback([switches] {
    run_bench("switches", switches->common, [&](link::LinkSession& session, const bench::Output& output) {
      return bench::watch_switches(session, switches->options, bench_stop, output);
    });
  });
}

// deltactl bench scale.
void add_scale_command(CLI::App* bench) {
  auto scale = std::make_shared<ScaleCli>();
  CLI::App* sc = bench->add_subcommand("scale", "Measure one joint's encoder counts per degree between two fixtures");
  sc->footer(
      "\nWhat it does: with the drives off, reads joint J's encoder count with the joint held at a first\n"
      "known angle (--from) and then at a second (--to), each the mean over 100 telemetry frames\n"
      "(0.1 s), and compares the counts per degree between them with the board's scale, 100 counts\n"
      "per degree (0.01 deg a count).\n"
      "What you do: put joint J on its first fixture (an angle gauge or a stop at --from degrees), hold\n"
      "it still there and press Enter; then the same at --to. --settle S reads S seconds of board time\n"
      "after each prompt instead of Enter; --first-at-start reads the first fixture at once.\n"
      "What it prints: each reading (count, degrees, its spread), then the counts per degree measured,\n"
      "the expected 100 and the error in %. Exit 1 when the error is outside --tolerance-percent, or a\n"
      "reading moved more than 5 counts (the joint was not held still). The angles are differences:\n"
      "where the encoders count from (homed or not) does not matter.\n" +
      kExitCodes + "\nExample: deltactl bench scale --port icebreaker --limits-confirmed --joint 1 --from 0 --to 60\n");
  common_options(sc, scale->common);
  sc->add_option("--joint", scale->joint, "the joint, 1-3")->required()->check(CLI::Range(1, 3));
  sc->add_option("--from", scale->options.from_deg, "the first fixture's angle [deg]")
      ->required()
      ->check(options::real_number(-360, 360));
  sc->add_option("--to", scale->options.to_deg, "the second fixture's angle [deg], at least 5 deg from --from")
      ->required()
      ->check(options::real_number(-360, 360));
  sc->add_option("--tolerance-percent", scale->options.tolerance_percent, "the largest error accepted [%]")
      ->check(options::real_number(0, 100, true))
      ->capture_default_str();
  sc->add_option("--settle", scale->options.settle_s, "read S seconds of board time after each prompt (no Enter)")
      ->check(options::real_number(0, 3600));
  sc->add_flag("--first-at-start", scale->options.first_at_start,
               "the joint is at the first fixture already: read it at once");
  sc->callback([scale] {
    if (std::abs(scale->options.to_deg - scale->options.from_deg) < 5.0) {
      fail(kExitBadInput, "bench scale: --from and --to must be at least 5 deg apart (a count is 0.01 deg)");
    }
    scale->options.joint = scale->joint - 1;
    run_bench("scale", scale->common, [&](link::LinkSession& session, const bench::Output& output) {
      return bench::check_scale(session, scale->options, bench_stop, output);
    });
  });
}

// deltactl bench soak.
void add_soak_command(CLI::App* bench) {
  auto soak = std::make_shared<SoakCli>();
  CLI::App* so = bench->add_subcommand("soak", "Run the link both ways at full rate, drives off; report every counter");
  so->footer(
      "\nWhat it does: for --minutes (or --seconds) of board time, with the drives off, reads every\n"
      "telemetry frame (1 kHz, 54 bytes), keeps an identify request on its way at all times (each\n"
      "answered by a 30-byte identify: the board's line about 85 % busy) and sends 8 disable commands\n"
      "a frame (the host's line as busy as a run's setpoints make it; the board refuses setpoints with\n"
      "the drives off, and a disable is always taken and keeps them off).\n"
      "What you do: nothing; leave the robot powered as for a run (the drives' enable wired).\n"
      "What it prints: a progress line every 10 s on stderr, then every counter: the board's (bad\n"
      "frames, underruns, saturations, slew limits, refused: their rise during the soak), the host's\n"
      "(CRC errors, bad lengths, unknown types, bytes outside frames, lost telemetry frames: sequence\n"
      "gaps, missed telemetry periods: tick gaps, late telemetry frames: more than --late-ms of wall\n"
      "time after the one before, unanswered identify requests) and the totals. Exit 0 only when none counted a\n"
      "fault, else 1 naming those that did.\n" +
      kExitCodes + "\nExample: deltactl bench soak --port icebreaker --limits-confirmed --minutes 30\n");
  common_options(so, soak->common);
  CLI::Option* minutes =
      so->add_option("--minutes", soak->minutes, "minutes of board time")->check(options::real_number(0, 10080, true));
  so->add_option("--seconds", soak->seconds, "seconds of board time (instead of --minutes)")
      ->check(options::real_number(0, 604800, true))
      ->excludes(minutes);
  so->add_option("--late-ms", soak->options.late_ms,
                 "a telemetry frame more than this much wall time after the one before counts as late")
      ->check(options::whole_number(2, 60000))
      ->capture_default_str();
  so->callback([soak] {
    if (soak->minutes <= 0 && soak->seconds <= 0) fail(kExitBadInput, "bench soak: needs --minutes M or --seconds S");
    soak->options.duration_s = soak->minutes > 0 ? soak->minutes * 60.0 : soak->seconds;
    run_bench("soak", soak->common, [&](link::LinkSession& session, const bench::Output& output) {
      return bench::soak(session, soak->options, bench_stop, output);
    });
  });
}

// deltactl bench jog.
void add_jog_command(CLI::App* bench) {
  auto jog = std::make_shared<JogCli>();
  CLI::App* jg = bench->add_subcommand("jog", "Turn one joint a little, open loop (the board's 0.5 s jog), check it");
  jg->footer(
      "\nWhat it does: sends the board's bench jog for joint J: the board turns the drives on, applies\n"
      "+0.05 A (--direction +) or -0.05 A (--direction -) to joint J open loop, the others at 0, for\n"
      "0.5 s of board time, then turns the drives off itself (an e-stop, a disable, an encoder skip or\n"
      "a safety input end it at once). Taken with the drives off, no fault latched and no homing under\n"
      "way, homed or not; the host reads every frame of it and sends a disable after it.\n"
      "The board bounds the jog's time and current, not its travel (a free arm can turn far in 0.5 s):\n"
      "the host ends it with a disable once the joint has moved --max-move-deg (default 5 deg).\n"
      "What you do: clear the arm's way, keep the e-stop at hand.\n"
      "What it prints: the counts the joint moved during the jog, the current applied, the direction\n"
      "seen (count rising or falling) and the counts in the 0.2 s after (the drives off). Exit 1 when\n"
      "the joint moved fewer than 5 counts (its motor, its drive or the arm stuck) or the other way\n"
      "than --expect-sign (default: the jog's own sign, a positive current raises the count: otherwise\n"
      "the motor or the encoder is reversed; 'any' checks only that it moved).\n" +
      kExitCodes + "\nExample: deltactl bench jog --port icebreaker --limits-confirmed --joint 2 --direction +\n");
  common_options(jg, jog->common);
  jg->add_option("--joint", jog->joint, "the joint, 1-3")->required()->check(CLI::Range(1, 3));
  jg->add_option("--direction", jog->direction, "+ (positive current) or -")
      ->required()
      ->check(CLI::IsMember({"+", "-"}));
  jg->add_option("--max-move-deg", jog->max_move_deg,
                 "the host ends the jog (a disable) once the joint has moved this far [deg]")
      ->check(options::real_number(0.1, 90))
      ->capture_default_str();
  jg->add_option("--expect-sign", jog->expect_sign,
                 "+, - or any: the count's expected direction (default: --direction)")
      ->check(CLI::IsMember({"+", "-", "any"}));
  jg->callback([jog] {
    jog->options.joint = jog->joint - 1;
    jog->options.negative = jog->direction == "-";
    jog->options.max_move_counts = static_cast<int>(std::lround(jog->max_move_deg / board::kEncoderCountDeg));
    const std::string sign = jog->expect_sign.empty() ? jog->direction : jog->expect_sign;
    jog->options.expect_sign = sign == "+" ? 1 : sign == "-" ? -1 : 0;
    run_bench("jog", jog->common, [&](link::LinkSession& session, const bench::Output& output) {
      return bench::jog(session, jog->options, bench_stop, output);
    });
  });
}

const RegisterCommand command("bench", 76, [](CLI::App& root) {
  CLI::App* bench = root.add_subcommand("bench", "Bench bring-up checks: home switches, encoder scale, link soak, jog");
  bench->require_subcommand(1);
  bench->footer(
      "\nThe checks of a first power-up (docs/bench.md), on the board's port, with the drives off: only\n"
      "'bench jog' turns them on, for the board's own 0.5 s open-loop jog at 0.05 A. Each needs\n"
      "--limits-confirmed: set the drives' current limits low first (the MCBL's LPC and LCC). Each\n"
      "refuses a board with a fault latched or its drives on (exit 3, naming why) and leaves the\n"
      "drives off however it ends (Ctrl-C included).\n" +
      kExitCodes);
  for (const auto add : {add_switches_command, add_scale_command, add_soak_command, add_jog_command}) add(bench);
});

}  // namespace
}  // namespace delta::controller

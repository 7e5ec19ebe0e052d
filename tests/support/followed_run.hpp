// A closed-loop run on the model board (kept to real time) with the measuring stage following the
// plate, for tests: the board started with the caller's arguments, homed, `host run` recorded to
// DIR/run.csv, the board stopped (DIR/truth.csv, DIR/stage.csv complete), and `merge` of the two
// logs into DIR/data.csv (report DIR/merge.json). Any step that fails is a fatal test failure:
// callers check ::testing::Test::HasFatalFailure().
#pragma once

#include <gtest/gtest.h>

#include <iostream>
#include <string>
#include <vector>

#include "run_command.hpp"
#include "virtual_board_process.hpp"

namespace delta::test {

// `stage_arguments`: the stage's clock, rate and seed (--stage-clock, --stage-rate, --stage-seed)
// and any other board argument (--effects); `run_arguments`: the trajectory and duration.
inline void followed_run_and_merge(const std::string& dir, const std::string& weights,
                                   const std::vector<std::string>& stage_arguments, const std::string& run_arguments) {
  const std::string link = dir + "tty";
  {
    std::vector<std::string> arguments = {"--fidelity", "model",  "--truth",     dir + "truth.csv",
                                          "--stage",    "follow", "--stage-log", dir + "stage.csv"};
    arguments.insert(arguments.end(), stage_arguments.begin(), stage_arguments.end());
    VirtualBoardProcess board(link, arguments);
    std::cout << board.ready_line(20000) << '\n';
    ASSERT_NE(board.ready_line(20000).find("ready"), std::string::npos);
    const CommandResult home = run_deltactl("host home --port " + link + " --weights " + weights);
    std::cout << home.out << home.err;
    ASSERT_EQ(home.exit_code, 0);
    const CommandResult run = run_deltactl("host run --port " + link + " --weights " + weights + " " + run_arguments +
                                           " --record " + dir + "run.csv");
    std::cout << run.err;
    ASSERT_EQ(run.exit_code, 0);
    EXPECT_EQ(board.terminate(), 0);
  }
  const CommandResult merge = run_deltactl("merge --run " + dir + "run.csv --stage " + dir + "stage.csv --out " + dir +
                                           "data.csv --report " + dir + "merge.json");
  std::cout << merge.out << merge.err;
  ASSERT_EQ(merge.exit_code, 0);
}

}  // namespace delta::test

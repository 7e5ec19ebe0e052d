// deltactl joint-loop: the acceptance tables, the plot, and a bad option.
#include <gtest/gtest.h>

#include <filesystem>

#include "../support/run_command.hpp"

namespace delta::test {
namespace {

TEST(JointLoopCommand, PrintsTheTablesWritesThePlotAndPasses) {
  const std::string plot = ::testing::TempDir() + "joint_loop_test.png";
  std::filesystem::remove(plot);
  const CommandResult result = run_deltactl("joint-loop --plot " + plot);
  EXPECT_EQ(result.exit_code, 0) << result.err;
  for (const char* text : {"| alpha_1 ", "| alpha_3 ", "span fixed [counts]", "| fixed      | off |",
                           "acceptance (1.1 % of p-p, fixed within 5 % of double, span <= 1 count, DOB step): pass"}) {
    EXPECT_NE(result.out.find(text), std::string::npos) << text << "\n" << result.out;
  }
  EXPECT_GT(std::filesystem::file_size(plot), 1000u);
}

TEST(JointLoopCommand, RejectsANegativeLoadStepWithExitCodeTwo) {
  const CommandResult result = run_deltactl("joint-loop --load-step -1");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("--load-step"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace delta::test

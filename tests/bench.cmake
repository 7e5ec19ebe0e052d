# The bench bring-up checks (`deltactl bench`, docs/bench.md): their counts, scales and jogs fed
# telemetry frames and against a scripted board (no board needed).
delta_add_gtest(bench_check_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench/test_bench_checks.cpp
  LIBRARIES delta::controller delta::host
  LABELS host bench)

# `deltactl bench` against the model-fidelity virtual board over its pty: the refusals (no
# --limits-confirmed, a fault latched), the switches toggled by the stage's drag, the scale between
# two held angles, the soak on a clean link and on one that drops bytes. Needs the virtual board.
if(DELTA_HOST_ONLY)
  return()
endif()
delta_add_gtest(bench_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench/test_bench.cpp
  LIBRARIES delta::host delta::sim nlohmann_json::nlohmann_json
  LABELS host bench virtual_board
  # The refusals before a port is opened and the help touch no board.
  SERIAL PARALLEL_TESTS BenchCli.EverySubcommandRefusesWithoutLimitsConfirmedBeforeOpeningThePort
    BenchCli.EverySubcommandsHelpSaysWhatItDoesWhatToDoWhatItPrintsAndItsExitCodes)

# The layout: hls/ and rtl/ hold no command-line, table or plot code; hls/ no float or double;
# CLI11 only in host/cli/; the host's wings depend only downwards.
add_test(NAME Layout.TheTreeKeepsItsLayersApart
  COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/check_layout.sh)
set_tests_properties(Layout.TheTreeKeepsItsLayersApart PROPERTIES LABELS host)
# Every tracked C++ file follows .clang-format.
add_test(NAME Format.EveryCppFileFollowsClangFormat COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/check_format.sh)
set_tests_properties(Format.EveryCppFileFollowsClangFormat PROPERTIES LABELS host)
# Every command block of the root README runs as written (the two commands excepted: CI runs them).
add_test(NAME Readme.EveryCommandRunsAsWritten
  COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/readme_commands.sh ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR})
set_tests_properties(Readme.EveryCommandRunsAsWritten PROPERTIES LABELS host TIMEOUT 900 RUN_SERIAL TRUE)
# Every script's --help prints its usage (its leading comment block), never a line of its code.
add_test(NAME Scripts.HelpPrintsTheUsageAndNoCode
  COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/script_help.sh ${PROJECT_SOURCE_DIR})
set_tests_properties(Scripts.HelpPrintsTheUsageAndNoCode PROPERTIES LABELS host)
# The FPGA tools' choice (YoWASP's yosys 0.55 / nextpnr 0.8 when installed, else Debian's) and the
# YoWASP runner's mounts, with a stand-in for the npm packages (no synthesis).
add_test(NAME Scripts.FpgaToolsChoiceAndYowaspMounts
  COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/fpga_tools.sh ${PROJECT_SOURCE_DIR})
set_tests_properties(Scripts.FpgaToolsChoiceAndYowaspMounts PROPERTIES LABELS host)
# The house's limits: no function over 120 lines in host/ and sim/, no RTL line over 100 columns,
# no test named by a number, every test area in tests/README.md (what the tree does not meet yet is
# in tests/layout/house_limits_known.txt, which may only shrink); and the check's power to fail.
add_test(NAME Layout.HouseLimits COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/house_limits.sh ${PROJECT_SOURCE_DIR})
set_tests_properties(Layout.HouseLimits PROPERTIES LABELS host)

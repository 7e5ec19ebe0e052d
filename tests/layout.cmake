# The layout: hls/ and rtl/ hold no command-line, table or plot code; hls/ no float or double.
add_test(NAME Layout.HlsAndRtlHoldNoCommandLineCodeAndHlsNoFloatingPoint
  COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/check_layout.sh)
set_tests_properties(Layout.HlsAndRtlHoldNoCommandLineCodeAndHlsNoFloatingPoint PROPERTIES LABELS host)
# Every tracked C++ file follows .clang-format.
add_test(NAME Format.EveryCppFileFollowsClangFormat COMMAND ${PROJECT_SOURCE_DIR}/tests/layout/check_format.sh)
set_tests_properties(Format.EveryCppFileFollowsClangFormat PROPERTIES LABELS host)

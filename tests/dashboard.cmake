# The operator's dashboard (`host serve --http`) and `deltactl plot` (docs/dashboard.md): Python
# scripts (standard library only) against the model virtual board, so not in the host-only build.
if(DELTA_HOST_ONLY)
  return()
endif()
find_program(DELTA_PYTHON3 python3 REQUIRED)
set(delta_dashboard_tests ${CMAKE_CURRENT_LIST_DIR}/dashboard)
set(delta_dashboard_artefacts ${PROJECT_BINARY_DIR}/test-artefacts/dashboard)
add_test(NAME Dashboard.PlotEveryRecording
  COMMAND ${DELTA_PYTHON3} ${delta_dashboard_tests}/plot_test.py $<TARGET_FILE:deltactl>
          ${PROJECT_SOURCE_DIR}/weights/paper_like.json ${delta_dashboard_artefacts}/plots)
add_test(NAME Dashboard.Api
  COMMAND ${DELTA_PYTHON3} ${delta_dashboard_tests}/dashboard_api_test.py $<TARGET_FILE:deltactl>
          ${PROJECT_SOURCE_DIR}/weights/paper_like.json)
add_test(NAME Dashboard.Guard
  COMMAND ${DELTA_PYTHON3} ${delta_dashboard_tests}/dashboard_guard_test.py $<TARGET_FILE:deltactl>
          ${PROJECT_SOURCE_DIR}/weights/paper_like.json)
# Headless chromium (Debian's, from scripts/setup.sh) on the page during a run; exit 77 without it.
# Its screenshots stay in test-artefacts/dashboard/.
add_test(NAME Dashboard.Browser
  COMMAND ${DELTA_PYTHON3} ${delta_dashboard_tests}/dashboard_browser_test.py $<TARGET_FILE:deltactl>
          ${PROJECT_SOURCE_DIR}/weights/paper_like.json ${delta_dashboard_artefacts})
# Real time: the model board and the host's 1 kHz streaming thread each need a core.
set_tests_properties(Dashboard.PlotEveryRecording Dashboard.Api Dashboard.Guard Dashboard.Browser PROPERTIES
  LABELS "dashboard;host;virtual_board" RUN_SERIAL TRUE TIMEOUT 300 SKIP_RETURN_CODE 77)
# Its waits follow the board's progress (a loaded machine slows the model board): more time in all.
set_tests_properties(Dashboard.Browser PROPERTIES TIMEOUT 600)
# 30 plots of 600-s recordings, one gnuplot at a time: 30 s on an idle machine, 150 s seen at load 10.
set_tests_properties(Dashboard.Guard PROPERTIES TIMEOUT 600)

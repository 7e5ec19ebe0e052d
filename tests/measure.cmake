# The lab's measurement path: `deltactl merge` (clocks aligned from the data), the virtual measuring
# stage and `deltactl host record` against the model board (SPEC.md, "The lab's measurements").
delta_add_gtest(measure_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/measure/merge_test.cpp
  LIBRARIES delta::diagnosis delta::sim delta::host
  LABELS measure diagnosis)
if(DELTA_HOST_ONLY)
  return()
endif()
# Not yet in the suite: the model board's drag through host record and merge (the merged plate is
# still 2-30 um from the truth, not 1 um) and the virtual part of docs/lab_loop.md, run as written.
# Both are kept here for the work that makes them pass:
# delta_add_gtest(measure_board_tests
#   SOURCES ${CMAKE_CURRENT_LIST_DIR}/measure/stage_board_test.cpp
#   LIBRARIES delta::host
#   LABELS measure virtual_board)
#
# # docs/lab_loop.md: its virtual part run as written (drag, record, merge, diagnose, train,
# # quantise, a closed-loop run with the stage following, merge, compare).
# add_test(NAME LabLoopDoc.VirtualPartRunsAsWritten
#          COMMAND bash ${CMAKE_CURRENT_LIST_DIR}/measure/lab_loop_doc.sh ${PROJECT_SOURCE_DIR} $<TARGET_FILE:deltactl>
#                  ${PROJECT_BINARY_DIR}/tests/lab_loop_doc)
# set_tests_properties(LabLoopDoc.VirtualPartRunsAsWritten PROPERTIES LABELS "measure;virtual_board" RUN_SERIAL TRUE
#                      PASS_REGULAR_EXPRESSION "PASS" FAIL_REGULAR_EXPRESSION "FAIL" TIMEOUT 900)

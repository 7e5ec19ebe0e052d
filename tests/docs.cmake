# The documentation checked against the tree (tests/docs/): the contracts page against the project's
# contract list, every link of every Markdown file, every deltactl command line against its --help,
# every curl command of the docs run as written, and docs/bench.md's wiring tables against the pcf.
find_program(DELTA_PYTHON3 python3 REQUIRED)
set(delta_docs_tests ${CMAKE_CURRENT_LIST_DIR}/docs)
# docs/contracts.md holds every contract of ../shared/SPEC.md (beside the clone in CI); skipped
# (exit 77) where that list is absent.
add_test(NAME Docs.ContractsHoldEveryContractOfTheList
  COMMAND ${DELTA_PYTHON3} ${delta_docs_tests}/check_contracts.py ${PROJECT_SOURCE_DIR}/docs/contracts.md
          ${PROJECT_SOURCE_DIR}/../shared/SPEC.md)
add_test(NAME Docs.EveryLinkResolves
  COMMAND ${DELTA_PYTHON3} ${delta_docs_tests}/check_doc_links.py ${PROJECT_SOURCE_DIR})
# Every `deltactl` command line of the docs names commands and options its --help lists, and every
# scripts/ command line a script of the tree and options it reads.
add_test(NAME Docs.EveryDeltactlCommandAndOptionExists
  COMMAND ${DELTA_PYTHON3} ${delta_docs_tests}/check_doc_commands.py $<TARGET_FILE:deltactl> ${PROJECT_SOURCE_DIR})
# docs/bench.md's wiring tables against rtl/board/icebreaker.pcf: every row's port on its FPGA pin
# with its pull-up, every port of the pcf in a row; and the check itself against the pcf the tables
# describe, changed one way at a time (a port moved, a pull-up flipped, a port missing or extra).
add_test(NAME Docs.BenchWiringMatchesTheIcebreakerPcf
  COMMAND ${DELTA_PYTHON3} ${delta_docs_tests}/check_bench_pins.py ${PROJECT_SOURCE_DIR}/docs/bench.md
          ${PROJECT_SOURCE_DIR}/rtl/board/icebreaker.pcf)
add_test(NAME Docs.BenchWiringCheckCatchesEveryChangedPin
  COMMAND ${DELTA_PYTHON3} ${delta_docs_tests}/check_bench_pins.py --mutations ${PROJECT_SOURCE_DIR}/docs/bench.md)
set_tests_properties(Docs.ContractsHoldEveryContractOfTheList Docs.EveryLinkResolves
                     Docs.EveryDeltactlCommandAndOptionExists Docs.BenchWiringMatchesTheIcebreakerPcf
                     Docs.BenchWiringCheckCatchesEveryChangedPin PROPERTIES
  LABELS "docs;host" TIMEOUT 60 SKIP_RETURN_CODE 77)
# Every curl command of the docs, as written, against `host serve --http` on the model virtual board
# (kept to real time: alone on the machine, as the dashboard's tests).
if(NOT DELTA_HOST_ONLY)
  add_test(NAME Docs.EveryCurlCommandRunsAsWritten
    COMMAND ${DELTA_PYTHON3} ${delta_docs_tests}/doc_curl_test.py $<TARGET_FILE:deltactl>
            ${PROJECT_SOURCE_DIR}/weights/paper_like_deployed.json ${PROJECT_SOURCE_DIR})
  set_tests_properties(Docs.EveryCurlCommandRunsAsWritten PROPERTIES
    LABELS "docs;dashboard;host;virtual_board" RUN_SERIAL TRUE TIMEOUT 300)
endif()

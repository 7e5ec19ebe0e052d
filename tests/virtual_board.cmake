# The virtual board (host/cosim: Verilated board core + robot world + UART line) behind
# `deltactl virtual-board`, and the host's link session over its pseudo-terminal. Needs Verilator.
if(DELTA_HOST_ONLY)
  return()
endif()
delta_add_gtest(virtual_board_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/virtual_board/test_virtual_board.cpp
          ${CMAKE_CURRENT_LIST_DIR}/virtual_board/test_measuring_stage.cpp
          ${CMAKE_CURRENT_LIST_DIR}/virtual_board/test_board_safety_inputs.cpp
  LIBRARIES delta::board_cosim delta::golden delta::nn delta::host delta::gateware
  LABELS virtual_board cosim)

# An independent client (python3 + pyserial, its own CRC-16, no project code) identifies the board
# through PATH. The Python with pyserial (Debian's python3-serial) may not be the first python3 on
# PATH (pyenv): take the first candidate that imports serial.
set(delta_pyserial_python "")
foreach(candidate /usr/bin/python3 python3)
  find_program(delta_python_candidate_path NAMES ${candidate} NO_CACHE)
  if(delta_python_candidate_path)
    execute_process(COMMAND ${delta_python_candidate_path} -c "import serial" RESULT_VARIABLE no_serial
                    OUTPUT_QUIET ERROR_QUIET)
    if(no_serial EQUAL 0)
      set(delta_pyserial_python ${delta_python_candidate_path})
      break()
    endif()
  endif()
endforeach()
if(delta_pyserial_python)
  add_test(NAME virtual_board_identify_python
           COMMAND ${delta_pyserial_python} ${CMAKE_CURRENT_LIST_DIR}/virtual_board/identify_client.py
                   $<TARGET_FILE:deltactl> ${PROJECT_SOURCE_DIR}/weights/paper_like.json
                   ${PROJECT_BINARY_DIR}/tests/virtual_board_identify_python)
  set_tests_properties(virtual_board_identify_python PROPERTIES LABELS "virtual_board;cosim"
                       PASS_REGULAR_EXPRESSION "PASS" FAIL_REGULAR_EXPRESSION "FAIL" TIMEOUT 120)
else()
  message(STATUS "virtual_board_identify_python: no python3 with pyserial (apt install python3-serial); test not added")
endif()

# The host controller (`deltactl host`) against the virtual board through a pty: issue 13's
# acceptance. Needs the virtual board (Verilator), so not in the host-only build.
if(DELTA_HOST_ONLY)
  return()
endif()
delta_add_gtest(host_controller_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/host_controller_test.cpp
  LIBRARIES delta::controller delta::golden delta::nn delta::host
  LABELS host host_controller virtual_board)

# The board link v2, host side (docs/board_link.md): payloads, CRC-32 and the weights CRC, the
# identify.mem that `deltactl quantise` writes, the gateware build id, and the golden model of the
# setpoint interpolation. Host-only: neither SystemC nor Verilator.
delta_add_gtest(link_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/link/test_payloads.cpp
    ${CMAKE_CURRENT_LIST_DIR}/link/test_crc32.cpp
    ${CMAKE_CURRENT_LIST_DIR}/link/test_identify.cpp
    ${CMAKE_CURRENT_LIST_DIR}/link/test_setpoint_interpolation.cpp
  LIBRARIES delta::host delta::golden delta::gateware
  LABELS link)
target_include_directories(link_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR})  # support/run_command.hpp

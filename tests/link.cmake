# The board link v2, host side (docs/board_link.md): payloads, CRC-32 and the weights CRC, the
# identify.mem that `deltactl quantise` writes, the gateware build id, and the golden model of the
# setpoint interpolation. Host-only: neither SystemC nor Verilator.
delta_add_gtest(link_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/link/payloads_test.cpp
  LIBRARIES delta::host
  LABELS link)

# Joint control: double and fixed-point controllers, closed loops on the plant, HLS and RTL bit-exactness.
delta_add_gtest(control_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_fixed.cpp
    ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_closed_loop.cpp
    ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_loop_command.cpp
  LIBRARIES delta::control
  LABELS control)
if(NOT DELTA_HOST_ONLY)
  delta_add_gtest(control_bit_exact_tests
    SOURCES
      ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_bit_exact.cpp
      ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_axes.cpp
    LIBRARIES delta::control delta::joint_hls delta::joint_rtl
    LABELS control rtl)
  delta_add_gtest(control_gate_level_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_gate_level.cpp
    LIBRARIES delta_joint_gate_model delta_joint_handshake
    LABELS control rtl gate_level)
endif()

# Joint control: double and fixed-point controllers, closed loops on the plant, HLS and RTL bit-exactness.
delta_add_gtest(control_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_fixed.cpp
    ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_closed_loop.cpp
    ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_loop_command.cpp
  LIBRARIES delta::control
  LABELS control)
if(NOT DELTA_HOST_ONLY)
  # The joint synthesis top (hls/joint/joint_top.cpp) with the coefficient header the golden model
  # writes, and its C-simulation testbench on 100,000 closed-loop periods of golden vectors
  # (seed 20261121; the vectors and the header come from one run of joint_golden_vectors).
  set(joint_export_dir ${CMAKE_CURRENT_BINARY_DIR}/joint_export)
  set(joint_vector_periods 100000)
  set(joint_vector_seed 20261121)
  add_executable(joint_golden_vectors ${CMAKE_CURRENT_LIST_DIR}/control/joint_golden_vectors.cpp)
  target_link_libraries(joint_golden_vectors PRIVATE delta::control)
  add_custom_command(
    OUTPUT ${joint_export_dir}/joint_coefficients.hpp ${joint_export_dir}/joint_golden_vectors.txt
    COMMAND ${CMAKE_COMMAND} -E make_directory ${joint_export_dir}
    COMMAND joint_golden_vectors ${joint_export_dir} ${joint_vector_periods} ${joint_vector_seed}
    DEPENDS joint_golden_vectors
    COMMENT "Joint golden vectors and coefficient header from the golden model")
  add_library(delta_joint_top STATIC ${PROJECT_SOURCE_DIR}/hls/joint/joint_top.cpp ${joint_export_dir}/joint_coefficients.hpp)
  add_library(delta::joint_top ALIAS delta_joint_top)
  target_include_directories(delta_joint_top PRIVATE ${joint_export_dir})
  target_link_libraries(delta_joint_top PUBLIC delta::hls_joint)
  add_executable(joint_top_tb ${PROJECT_SOURCE_DIR}/hls/joint/joint_top_tb.cpp ${joint_export_dir}/joint_golden_vectors.txt)
  target_link_libraries(joint_top_tb PRIVATE delta::joint_top)
  set_target_properties(joint_top_tb PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
  add_test(NAME JointHlsTop.MatchesGoldenVectors COMMAND joint_top_tb ${joint_export_dir}/joint_golden_vectors.txt)
  set_tests_properties(JointHlsTop.MatchesGoldenVectors PROPERTIES LABELS "control;hls")

  delta_add_gtest(control_bit_exact_tests
    SOURCES
      ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_bit_exact.cpp
      ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_axes.cpp
    LIBRARIES delta::control delta::joint_top delta::joint_rtl
    LABELS control rtl)
  delta_add_gtest(control_gate_level_tests
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/control/test_joint_gate_level.cpp
    LIBRARIES delta_joint_gate_model delta_joint_handshake
    LABELS control rtl gate_level)
endif()

# Fixed-point network: golden model, HLS C-simulation, export and accuracy command.
delta_add_gtest(fixed_point_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_golden.cpp
  LIBRARIES delta::golden
  LABELS fixed_point)

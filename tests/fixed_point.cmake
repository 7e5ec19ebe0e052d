# Fixed-point network: golden model, HLS C-simulation, export and accuracy command.
delta_add_gtest(fixed_point_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_golden.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_hls_csim.cpp
  LIBRARIES delta::golden delta::hls_network
  LABELS fixed_point)

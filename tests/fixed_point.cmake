# Fixed-point network: golden model, HLS C-simulation, export and the deltactl commands.
if(DELTA_HOST_ONLY)  # needs SystemC and Verilator
  return()
endif()
delta_add_gtest(fixed_point_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_golden.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_hls_csim.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_cli_fixed.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_backlash_compensation.cpp
    ${CMAKE_CURRENT_LIST_DIR}/fixed_point/test_deployed_model.cpp
  LIBRARIES delta::golden delta::hls_network
  LABELS fixed_point)
target_include_directories(fixed_point_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR})

# The synthesis top itself (hls/network/network_top.cpp), compiled with the weights header that
# `deltactl quantise` generates from the shipped weights, against that run's golden vectors.
set(fixed_point_export_dir ${CMAKE_CURRENT_BINARY_DIR}/fixed_point_export)
add_custom_command(
  OUTPUT ${fixed_point_export_dir}/fixed_network_weights.hpp ${fixed_point_export_dir}/golden_vectors.txt
  COMMAND ${CMAKE_COMMAND} -E make_directory ${fixed_point_export_dir}
  COMMAND $<TARGET_FILE:deltactl> quantise --weights ${PROJECT_SOURCE_DIR}/weights/paper_like.json
          --out-dir ${fixed_point_export_dir} --vectors 20000 > ${fixed_point_export_dir}/files.txt
  DEPENDS deltactl ${PROJECT_SOURCE_DIR}/weights/paper_like.json
  COMMENT "Quantising weights/paper_like.json for the HLS top")
add_executable(network_top_tb
  ${PROJECT_SOURCE_DIR}/hls/network/network_top.cpp
  ${PROJECT_SOURCE_DIR}/hls/network/network_top_tb.cpp
  ${fixed_point_export_dir}/fixed_network_weights.hpp)
target_include_directories(network_top_tb PRIVATE ${fixed_point_export_dir})
target_link_libraries(network_top_tb PRIVATE delta::hls_network)
set_target_properties(network_top_tb PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
add_test(NAME HlsTop.MatchesGoldenVectors COMMAND network_top_tb ${fixed_point_export_dir}/golden_vectors.txt)
set_tests_properties(HlsTop.MatchesGoldenVectors PROPERTIES LABELS fixed_point)

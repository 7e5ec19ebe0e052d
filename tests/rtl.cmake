# RTL tests: Verilated network against the golden model (C++ and SystemC testbenches), the
# gate-level netlist, lint (rtl/*/CMakeLists.txt) and the rtl back end of deltactl.
if(DELTA_HOST_ONLY)  # needs SystemC and Verilator
  return()
endif()
delta_add_gtest(rtl_network_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_network_rtl.cpp ${CMAKE_CURRENT_LIST_DIR}/rtl/test_backend_rtl.cpp
  LIBRARIES delta::rtl_network
  LABELS rtl)
target_include_directories(rtl_network_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)

# The deployed model's backlash compensation: RTL, and its gate-level netlist.
delta_add_gtest(rtl_compensation_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_backlash_compensation_rtl.cpp
  LIBRARIES delta::rtl_network
  LABELS rtl)
delta_add_gtest(rtl_compensation_gate_level_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_backlash_compensation_rtl.cpp
  LIBRARIES delta_rtl_compensation_gate_model delta::golden
  LABELS rtl)
target_include_directories(rtl_compensation_gate_level_tests PRIVATE ${PROJECT_SOURCE_DIR}/rtl/network/sim/include)
target_compile_definitions(rtl_compensation_gate_level_tests PRIVATE DELTA_COMPENSATION_GATE_LEVEL)

delta_add_gtest(rtl_gate_level_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_network_gate_level.cpp
  LIBRARIES delta_rtl_network_gate_model delta::golden
  LABELS rtl)
target_include_directories(rtl_gate_level_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl
                           ${PROJECT_SOURCE_DIR}/rtl/network/sim/include)

# SystemC testbench: its own sc_main (SystemC owns main), one CTest entry.
add_executable(rtl_network_systemc_test ${CMAKE_CURRENT_LIST_DIR}/rtl/test_network_systemc.cpp)
target_include_directories(rtl_network_systemc_test PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)
target_link_libraries(rtl_network_systemc_test PRIVATE delta_rtl_network_sc_model delta::golden PkgConfig::SystemC)
set_target_properties(rtl_network_systemc_test PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
add_test(NAME rtl_network_systemc COMMAND rtl_network_systemc_test)
set_tests_properties(rtl_network_systemc PROPERTIES LABELS rtl)

delta_add_gtest(rtl_board_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_network_crossing.cpp ${CMAKE_CURRENT_LIST_DIR}/rtl/test_board_facts.cpp
          ${CMAKE_CURRENT_LIST_DIR}/rtl/test_uart_line.cpp
  LIBRARIES delta::rtl_board delta::golden delta::control
  LABELS rtl)
target_include_directories(rtl_board_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)

# The link v2 through the board core's pins (docs/board_link.md).
delta_add_gtest(rtl_board_link_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_board_link.cpp ${CMAKE_CURRENT_LIST_DIR}/rtl/test_board_safety.cpp
  LIBRARIES delta::rtl_board delta::golden delta::host delta::gateware
  LABELS rtl link)
target_include_directories(rtl_board_link_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)

# The board core's gate-level netlist in lockstep with its RTL over the link.
delta_add_gtest(rtl_board_gate_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_board_gate_level.cpp
  LIBRARIES delta::rtl_board delta_board_gate_model delta::golden delta::host delta::gateware
  LABELS rtl gate link)
target_include_directories(rtl_board_gate_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)

delta_add_gtest(rtl_cosim_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_cosim.cpp
  LIBRARIES delta::board_cosim delta::golden delta::nn delta::host
  LABELS rtl cosim)
target_include_directories(rtl_cosim_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)
delta_add_gtest(rtl_link_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_link_crc16.cpp
  LIBRARIES delta_link_crc16_model delta::host
  LABELS rtl)
delta_add_gtest(rtl_model_board_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_model_board.cpp
  LIBRARIES delta::board_cosim delta::controller delta::golden delta::nn delta::host
  LABELS rtl cosim)
target_include_directories(rtl_model_board_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)

# The model board module by module: each module's registers against the same instance's inside
# the Verilated board core (Vboard_core_probe), clock by clock under random stimulus.
delta_add_gtest(rtl_model_board_module_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/rtl/test_model_board_modules.cpp
  LIBRARIES delta_rtl_board_probe_model delta::virtual_board delta::rtl_board delta::golden delta::nn delta::host
  LABELS rtl cosim)
target_include_directories(rtl_model_board_module_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/rtl)

# One gateware for every model: the bitstream's sources (rtl/board/CMakeLists.txt's board_sources)
# elaborated by yosys with the mem folder `deltactl quantise` writes for two W.json in turn: the
# tanh tables and identify.mem (the build id) byte-identical, the elaborated design byte-identical,
# and the same from those three files alone (a few seconds, no synthesis).
add_test(NAME Gateware.PlaceCellsPinsTheNamedCellsOrStopsWithTheLineAndLeavesTheNetlist
  COMMAND bash ${CMAKE_CURRENT_LIST_DIR}/rtl/place_cells_checks.sh ${PROJECT_SOURCE_DIR})
set_tests_properties(Gateware.PlaceCellsPinsTheNamedCellsOrStopsWithTheLineAndLeavesTheNetlist PROPERTIES
  LABELS rtl TIMEOUT 60)
get_directory_property(delta_bitstream_sources DIRECTORY ${PROJECT_SOURCE_DIR}/rtl/board DEFINITION board_sources)
add_test(NAME Gateware.TheBitstreamsInputsAreTheSameWhicheverWeightsTheBuildWasConfiguredWith
  COMMAND bash ${CMAKE_CURRENT_LIST_DIR}/rtl/bitstream_inputs_without_model.sh ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR}
          $<TARGET_FILE:deltactl> icebreaker_top ${PROJECT_SOURCE_DIR}/weights/paper_like_deployed.json
          ${PROJECT_SOURCE_DIR}/weights/paper_like_calibration_deployed.json ${delta_bitstream_sources})
set_tests_properties(Gateware.TheBitstreamsInputsAreTheSameWhicheverWeightsTheBuildWasConfiguredWith PROPERTIES
  LABELS rtl TIMEOUT 300)

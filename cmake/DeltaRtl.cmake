# Verilator and FPGA helpers for rtl/: lint tests, one shared Verilated library per RTL top,
# the gate-level (yosys netlist) model, and FPGA flow targets outside the default build.
#
# Every Verilator invocation gets the one waiver file rtl/lint_waivers.vlt, so lint, models and
# gate-level builds see the same rules; lint gets absolute source paths, models relative ones.

set(DELTA_RTL_WAIVERS ${PROJECT_SOURCE_DIR}/rtl/lint_waivers.vlt)
# `include search path (readmemh_load.svh).
set(DELTA_RTL_INCLUDE -I${PROJECT_SOURCE_DIR}/rtl/network)
# The FPGA tools the netlists are made with (scripts/ice40_synth.sh: yosys 0.55 from npm when
# scripts/setup.sh has installed it, else Debian's yosys 0.23) and their iCE40 cell models, which
# simulate those netlists.
get_property(delta_fpga_tools GLOBAL PROPERTY DELTA_FPGA_TOOLS_CHOSEN)
if(NOT delta_fpga_tools)
  execute_process(
    COMMAND bash -c "source '${PROJECT_SOURCE_DIR}/scripts/ice40_synth.sh' && echo \"$fpga_tools;$ice40_cells_sim\""
    OUTPUT_VARIABLE delta_fpga_tools OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE delta_fpga_tools_result)
  if(NOT delta_fpga_tools_result EQUAL 0)
    message(FATAL_ERROR "scripts/ice40_synth.sh: cannot choose the FPGA tools")
  endif()
  set_property(GLOBAL PROPERTY DELTA_FPGA_TOOLS_CHOSEN "${delta_fpga_tools}")
  if(delta_fpga_tools MATCHES "^yowasp;")
    message(STATUS "FPGA tools: yosys 0.55, nextpnr-ice40 0.8 (YoWASP, npm)")
  else()
    message(STATUS "FPGA tools: Debian's yosys 0.23, nextpnr-ice40 0.4 (scripts/setup.sh installs the newer ones from npm)")
  endif()
endif()
list(GET delta_fpga_tools 0 DELTA_FPGA_TOOLS)
list(GET delta_fpga_tools 1 DELTA_ICE40_CELLS_SIM)
find_package(ZLIB REQUIRED)  # Verilator's FST writer

function(_delta_absolute_paths out_var)
  set(paths)
  foreach(source IN LISTS ARGN)
    get_filename_component(source "${source}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    list(APPEND paths "${source}")
  endforeach()
  set(${out_var} ${paths} PARENT_SCOPE)
endfunction()

# Paths relative to the current source folder, where verilate() runs Verilator, through the tree's
# root (rtl/network: ../../rtl/network/x.sv, so the waivers' "*rtl/..." patterns match): the
# generated C++ names its sources as given, so a clone in another folder generates the same code
# and every model's translation units are compiler-cache hits.
function(_delta_relative_paths out_var)
  file(RELATIVE_PATH to_root "${CMAKE_CURRENT_SOURCE_DIR}" "${PROJECT_SOURCE_DIR}")
  _delta_absolute_paths(absolute ${ARGN})
  set(paths)
  foreach(source IN LISTS absolute)
    file(RELATIVE_PATH source "${PROJECT_SOURCE_DIR}" "${source}")
    if(to_root)
      set(source "${to_root}/${source}")
    endif()
    list(APPEND paths "${source}")
  endforeach()
  set(${out_var} ${paths} PARENT_SCOPE)
endfunction()

# delta_verilate(TARGET [TRACE_FST] [SYSTEMC] PREFIX Vname TOP_MODULE top SOURCES ... VERILATOR_ARGS ...):
# Verilator's verilate() with the sources and -I folders relative to the current source folder.
function(delta_verilate target)
  cmake_parse_arguments(ARG "TRACE_FST;SYSTEMC" "PREFIX;TOP_MODULE" "SOURCES;VERILATOR_ARGS" ${ARGN})
  _delta_relative_paths(sources ${ARG_SOURCES})
  set(arguments)
  foreach(argument IN LISTS ARG_VERILATOR_ARGS)
    if(argument MATCHES "^-I(/.*)$")
      _delta_relative_paths(include_dir ${CMAKE_MATCH_1})
      set(argument -I${include_dir})
    endif()
    list(APPEND arguments ${argument})
  endforeach()
  set(options)
  foreach(flag TRACE_FST SYSTEMC)
    if(ARG_${flag})
      list(APPEND options ${flag})
    endif()
  endforeach()
  verilate(${target} ${options} PREFIX ${ARG_PREFIX} TOP_MODULE ${ARG_TOP_MODULE}
    SOURCES ${sources} VERILATOR_ARGS ${arguments})
endfunction()

# delta_rtl_lint(NAME TOP top SOURCES a.sv ... [LIBRARIES lib.v ...] [ARGS ...])
# CTest entry rtl_lint_NAME: `verilator --lint-only -Wall` must print nothing and exit 0.
# LIBRARIES are read with -v (vendor cell models: linted only through the waiver file).
function(delta_rtl_lint name)
  cmake_parse_arguments(ARG "" "TOP" "SOURCES;LIBRARIES;ARGS" ${ARGN})
  _delta_absolute_paths(sources ${ARG_SOURCES})
  set(libraries)
  foreach(library IN LISTS ARG_LIBRARIES)
    list(APPEND libraries -v ${library})
  endforeach()
  add_test(NAME rtl_lint_${name}
    COMMAND ${VERILATOR_BIN} --lint-only -Wall ${DELTA_RTL_INCLUDE} --top-module ${ARG_TOP} ${ARG_ARGS}
            ${DELTA_RTL_WAIVERS} ${sources} ${libraries})
  set_tests_properties(rtl_lint_${name} PROPERTIES LABELS "rtl;lint" FAIL_REGULAR_EXPRESSION "%Warning|%Error")
endfunction()

# delta_verilated_library(TARGET PREFIX Vname TOP top SOURCES a.sv ... [SYSTEMC] [ARGS ...])
# A static library holding the Verilated model (FST tracing compiled in, used only on request).
# Verilated once; every test executable and deltactl link this one library.
function(delta_verilated_library target)
  cmake_parse_arguments(ARG "SYSTEMC" "PREFIX;TOP" "SOURCES;ARGS" ${ARGN})
  add_library(${target} STATIC)
  set(systemc_option)
  if(ARG_SYSTEMC)
    set(systemc_option SYSTEMC)
    target_link_libraries(${target} PUBLIC PkgConfig::SystemC)
  endif()
  delta_verilate(${target} ${systemc_option} TRACE_FST
    PREFIX ${ARG_PREFIX} TOP_MODULE ${ARG_TOP}
    SOURCES ${DELTA_RTL_WAIVERS} ${ARG_SOURCES}
    VERILATOR_ARGS -Wall ${DELTA_RTL_INCLUDE} -O3 --x-assign unique --x-initial unique ${ARG_ARGS})
  # Generated code and Verilator's headers are not ours to warn about.
  target_compile_options(${target} PRIVATE -w)
  target_include_directories(${target} SYSTEM PUBLIC ${VERILATOR_ROOT}/include ${VERILATOR_ROOT}/include/vltstd)
  target_link_libraries(${target} PUBLIC Threads::Threads)
endfunction()

# delta_gate_level_library(TARGET PREFIX Vname TOP top NETLIST file.v RUNTIME library)
# Verilates a yosys netlist (made at build time by a custom command that outputs NETLIST) with
# yosys's iCE40 cell models, builds the model archive with Verilator's own makefile and exposes
# it as the INTERFACE library TARGET, compiled through the compiler cache (cmake/Ccache.cmake).
# The Verilator runtime (verilated.cpp, FST writer) comes from RUNTIME, a delta_verilated_library
# target: one runtime for every model.
# NO_ICE40_DEFAULT_ASSIGNMENTS: cells_sim.v's input-port defaults are SystemVerilog that
# Verilator 5.006 does not parse; the netlist connects every port it uses. Lint warnings are
# off: the netlist is generated, not written.
function(delta_gate_level_library target)
  cmake_parse_arguments(ARG "" "PREFIX;TOP;NETLIST;RUNTIME" "" ${ARGN})
  set(model_dir ${CMAKE_CURRENT_BINARY_DIR}/${ARG_PREFIX}.dir)
  # Run in the netlist's folder and named by its file name: the generated code holds no path of the tree.
  get_filename_component(netlist_dir "${ARG_NETLIST}" DIRECTORY)
  get_filename_component(netlist_name "${ARG_NETLIST}" NAME)
  file(RELATIVE_PATH model_dir_relative "${netlist_dir}" "${model_dir}")
  set(archive ${model_dir}/${ARG_PREFIX}__ALL.a)
  # Verilator's makefile compiles through the compiler cache too (verilated.mk's OBJCACHE).
  list(JOIN DELTA_CCACHE_LAUNCHER " " delta_objcache)
  add_custom_command(OUTPUT ${archive}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${model_dir}
    COMMAND ${CMAKE_COMMAND} -E env "OBJCACHE=${delta_objcache}"
            ${VERILATOR_BIN} --cc --build -j 2 -O3 --prefix ${ARG_PREFIX} --Mdir ${model_dir_relative}
            --top-module ${ARG_TOP} -DNO_ICE40_DEFAULT_ASSIGNMENTS -Wno-fatal -Wno-lint -Wno-style
            -Wno-TIMESCALEMOD -Wno-UNOPTFLAT --trace-fst -CFLAGS "-O2 -w"
            ${netlist_name} ${DELTA_ICE40_CELLS_SIM}
    WORKING_DIRECTORY ${netlist_dir}
    DEPENDS ${ARG_NETLIST}
    COMMENT "Verilating the gate-level netlist ${ARG_NETLIST}"
    VERBATIM)
  add_custom_target(${target}_build DEPENDS ${archive})
  add_library(${target} INTERFACE)
  add_dependencies(${target} ${target}_build)
  target_include_directories(${target} SYSTEM INTERFACE ${model_dir} ${VERILATOR_ROOT}/include
                             ${VERILATOR_ROOT}/include/vltstd)
  target_compile_definitions(${target} INTERFACE VM_TRACE=1 VM_TRACE_FST=1)
  target_link_libraries(${target} INTERFACE ${archive} ${ARG_RUNTIME} Threads::Threads ZLIB::ZLIB)
endfunction()

# Board facts: the C++ header delta/board_facts.hpp generated from the one source,
# rtl/board/delta_board_pkg.sv (every `localparam int Name /*verilator public*/ = value;` line), at
# configure time, with a table of all of them (kBoardFacts) that the BoardFacts test compares with
# the Verilated package (public: Verilator lists it in the model's scope).
# Editing the package reconfigures (CMAKE_CONFIGURE_DEPENDS). Target: delta::board_facts.
set(DELTA_BOARD_PKG ${PROJECT_SOURCE_DIR}/rtl/board/delta_board_pkg.sv)
set(DELTA_BOARD_FACTS_DIR ${PROJECT_BINARY_DIR}/generated/include)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${DELTA_BOARD_PKG})

# SystemVerilog integer literal (123, 1_000, -1, 16'd3000, 24'h6DB6DB) -> decimal.
function(_delta_sv_integer literal out_var)
  string(REPLACE "_" "" literal "${literal}")
  string(STRIP "${literal}" literal)
  if(literal MATCHES "^(-?)[0-9]*'[sS]?([dDhH])([0-9a-fA-F]+)$")
    set(sign "${CMAKE_MATCH_1}")
    set(base "${CMAKE_MATCH_2}")
    set(digits "${CMAKE_MATCH_3}")  # saved: the next MATCHES resets CMAKE_MATCH_*
    if(base MATCHES "[hH]")
      math(EXPR value "${sign}0x${digits}")
    else()
      math(EXPR value "${sign}${digits}")
    endif()
  elseif(literal MATCHES "^-?[0-9]+$")
    set(value "${literal}")
  else()
    message(FATAL_ERROR "${DELTA_BOARD_PKG}: cannot read the integer '${literal}'")
  endif()
  set(${out_var} "${value}" PARENT_SCOPE)
endfunction()

file(STRINGS ${DELTA_BOARD_PKG} board_pkg_lines)
set(board_facts "")
set(board_fact_table "")
set(board_fact_count 0)
foreach(line IN LISTS board_pkg_lines)
  if(line MATCHES "^[ ]*localparam int ([A-Za-z0-9]+) /\\*verilator public\\*/ = ([^;]+);[ ]*(//[ ]*(.*))?$")
    set(name "${CMAKE_MATCH_1}")
    set(comment "${CMAKE_MATCH_4}")
    _delta_sv_integer("${CMAKE_MATCH_2}" value)
    set(DELTA_BOARD_${name} ${value})  # for CMake (e.g. the Verilated test build's -G values)
    if(comment)
      string(APPEND board_facts "constexpr long long k${name} = ${value};  // ${comment}\n")
    else()
      string(APPEND board_facts "constexpr long long k${name} = ${value};\n")
    endif()
    math(EXPR board_fact_count "${board_fact_count} + 1")
    string(APPEND board_fact_table "    {\"${name}\", k${name}},\n")
  elseif(line MATCHES "^[ ]*localparam")
    message(FATAL_ERROR "${DELTA_BOARD_PKG}: a localparam the generator cannot read: '${line}' "
                        "(write `localparam int Name /*verilator public*/ = value;` on one line)")
  endif()
endforeach()
if(board_fact_count EQUAL 0)
  message(FATAL_ERROR "${DELTA_BOARD_PKG}: no board facts found")
endif()
set(board_facts_header "// Generated from rtl/board/delta_board_pkg.sv by cmake/BoardFacts.cmake: do not edit.
// The board's facts for C++ (host, co-simulation, tests); the package says what each one means.
#pragma once

namespace delta::board {

${board_facts}
// Derived from the facts above (written here once, used wherever the value is needed).
// One encoder count [deg].
constexpr double kEncoderCountDeg = static_cast<double>(kEncoderCountMicrodeg) * 1e-6;
// How long the stage sync output holds each level: 2^StageSyncBit control periods [s].
constexpr double kStageSyncLevelSeconds =
    static_cast<double>(1LL << kStageSyncBit) / static_cast<double>(kControlRateHz);

struct BoardFact {
  const char* name;  // as in the package
  long long value;
};
// Every fact above, for checks against the RTL.
inline constexpr BoardFact kBoardFacts[] = {
${board_fact_table}};

}  // namespace delta::board
")
file(CONFIGURE OUTPUT ${DELTA_BOARD_FACTS_DIR}/delta/board_facts.hpp CONTENT "${board_facts_header}" @ONLY)

add_library(delta_board_facts INTERFACE)
add_library(delta::board_facts ALIAS delta_board_facts)
target_include_directories(delta_board_facts INTERFACE ${DELTA_BOARD_FACTS_DIR})

# Hardening: every bad input, option and output path handled per SPEC.
pkg_check_modules(hardening_matio REQUIRED IMPORTED_TARGET matio)  # writes a compressed .mat bomb
delta_add_gtest(hardening_tests
  SOURCES hardening/test_output_file.cpp hardening/test_bad_input.cpp
  LIBRARIES delta::host PkgConfig::hardening_matio)

# Fuzzing in CI: build the libFuzzer harnesses with clang (skipped, exit 77, without clang), then
# a few seconds of each on the kept corpus. The long run is scripts/fuzz.sh long (README).
add_test(NAME fuzz_build COMMAND bash ${PROJECT_SOURCE_DIR}/scripts/fuzz.sh build)
set_tests_properties(fuzz_build PROPERTIES FIXTURES_SETUP fuzz SKIP_RETURN_CODE 77 TIMEOUT 1200 LABELS fuzz
                     ENVIRONMENT DELTA_FUZZ_BUILD=${PROJECT_BINARY_DIR}/fuzz)
foreach(harness csv effects weights mat)
  add_test(NAME fuzz_short_${harness} COMMAND bash ${PROJECT_SOURCE_DIR}/scripts/fuzz.sh run ${harness} 5)
  set_tests_properties(fuzz_short_${harness} PROPERTIES FIXTURES_REQUIRED fuzz SKIP_RETURN_CODE 77 TIMEOUT 120
                       LABELS fuzz ENVIRONMENT DELTA_FUZZ_BUILD=${PROJECT_BINARY_DIR}/fuzz)
endforeach()

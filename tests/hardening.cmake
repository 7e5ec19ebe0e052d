# Hardening (issue 17): every bad input, option and output path handled per SPEC.
delta_add_gtest(hardening_tests
  SOURCES hardening/output_file_test.cpp hardening/bad_input_test.cpp
  LIBRARIES delta::host)


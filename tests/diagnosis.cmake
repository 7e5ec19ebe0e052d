# Sim-to-real diagnosis: model, fit, attribution, CLI contract, and a quick subset of the blind suite.
add_library(delta_blind_suite STATIC ${CMAKE_CURRENT_SOURCE_DIR}/diagnosis/blind_suite.cpp)
target_include_directories(delta_blind_suite PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/diagnosis)
target_link_libraries(delta_blind_suite PUBLIC delta::host delta::sim nlohmann_json::nlohmann_json)

# The whole blind suite (scripts/blind_suite.sh runs it; too long for CTest).
add_executable(diagnosis_blind_suite ${CMAKE_CURRENT_SOURCE_DIR}/diagnosis/blind_suite_main.cpp)
target_link_libraries(diagnosis_blind_suite PRIVATE delta_blind_suite)
set_target_properties(diagnosis_blind_suite PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
add_dependencies(diagnosis_blind_suite deltactl)

delta_add_gtest(diagnosis_tests
  SOURCES
    ${CMAKE_CURRENT_SOURCE_DIR}/diagnosis/test_effect_model.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/diagnosis/test_diagnose_cli.cpp
    ${CMAKE_CURRENT_SOURCE_DIR}/diagnosis/test_alternatives.cpp
  LIBRARIES delta::diagnosis delta_blind_suite
  LABELS diagnosis)
# test_alternatives.cpp tests a step of the pipeline through its internal header.
target_include_directories(diagnosis_tests PRIVATE ${PROJECT_SOURCE_DIR}/host/diagnosis/src)

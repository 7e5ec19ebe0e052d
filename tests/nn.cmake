# Neural-network inverse kinematics (float): training, weights files, MATLAB exchange, hybrid, CLI.
delta_add_gtest(nn_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/nn/test_training.cpp
    ${CMAKE_CURRENT_LIST_DIR}/nn/test_weights_file.cpp
    ${CMAKE_CURRENT_LIST_DIR}/nn/test_matlab.cpp
    ${CMAKE_CURRENT_LIST_DIR}/nn/test_hybrid.cpp
    ${CMAKE_CURRENT_LIST_DIR}/nn/test_deployed.cpp
    ${CMAKE_CURRENT_LIST_DIR}/nn/test_cli.cpp
  LIBRARIES delta::nn
  LABELS nn)

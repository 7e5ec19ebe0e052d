# Robot model: kinematics, effects, virtual robot.
delta_add_gtest(sim_tests
  SOURCES sim/kinematics_test.cpp sim/effects_test.cpp sim/robot_world_test.cpp
  LIBRARIES delta::sim)

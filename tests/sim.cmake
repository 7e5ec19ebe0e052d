# Robot model: kinematics, effects, virtual robot.
delta_add_gtest(sim_tests
  SOURCES sim/test_kinematics.cpp sim/test_effects.cpp sim/test_robot_world.cpp
  LIBRARIES delta::sim)

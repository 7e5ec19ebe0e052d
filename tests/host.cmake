# Host foundation: SPEC readers and the deltactl simulate / compare / ik commands.
delta_add_gtest(host_foundation_tests
  SOURCES host/cli_foundation_test.cpp host/serial_io_test.cpp host/frame_codec_test.cpp host/motion_profile_test.cpp host/trajectory_check_test.cpp
  LIBRARIES delta::host)

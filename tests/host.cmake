# Host foundation: SPEC readers and the deltactl simulate / compare / ik commands.
delta_add_gtest(host_foundation_tests
  SOURCES host/test_cli_foundation.cpp host/test_serial_io.cpp host/test_frame_codec.cpp host/test_motion_profile.cpp host/test_trajectory_check.cpp host/test_run_report.cpp
    host/test_recording_plot.cpp
  LIBRARIES delta::host)

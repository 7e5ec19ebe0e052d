# The host-only build (DELTA_HOST_ONLY, the lab PC's package) configures, builds and runs without
# SystemC or Verilator: built into build/host-only by scripts/host_only_build.sh.
if(NOT DELTA_HOST_ONLY)
  add_test(NAME HostOnlyBuild.DeltactlBuildsAndRunsWithoutSystemCOrVerilator
    COMMAND ${PROJECT_SOURCE_DIR}/scripts/host_only_build.sh ${PROJECT_BINARY_DIR}/host-only)
  set_tests_properties(HostOnlyBuild.DeltactlBuildsAndRunsWithoutSystemCOrVerilator PROPERTIES
    LABELS host TIMEOUT 1200 PROCESSORS 2 FIXTURES_SETUP host_only_tree)  # Deploy.Package packages the tree
endif()

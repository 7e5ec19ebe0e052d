# Deployment to the lab PC (host/deploy, docs/lab_setup.md): the configuration file, config check,
# flash --dry-run, doctor; the udev rules, the systemd unit, the Debian package (cpack, lintian,
# installed into a scratch root), and doctor against the virtual board (full build only).
delta_add_gtest(deploy_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/deploy/test_deploy.cpp
  LIBRARIES delta::deploy delta::controller delta::host
  LABELS deploy host)
# The stand-in bitstream (an empty design of the UP5K's layout) of the flash and package tests.
add_executable(deploy_blank_bitstream ${CMAKE_CURRENT_LIST_DIR}/deploy/blank_bitstream.cpp)
target_link_libraries(deploy_blank_bitstream PRIVATE delta::deploy)
set_target_properties(deploy_blank_bitstream PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)

add_test(NAME Deploy.UdevRules
  COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/check_udev_rules.sh ${PROJECT_SOURCE_DIR}/host/deploy/udev/70-delta-board.rules)
add_test(NAME Deploy.SystemdUnit
  COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/verify_unit.sh ${PROJECT_SOURCE_DIR}/host/deploy/systemd/deltactl.service
          $<TARGET_FILE:deltactl>)
# The maintainer scripts run against stand-ins of systemctl, adduser, ... (which calls, which files).
add_test(NAME Deploy.MaintainerScripts
  COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/maintainer_scripts_test.sh ${PROJECT_SOURCE_DIR}/host/deploy/debian)
set_tests_properties(Deploy.UdevRules Deploy.SystemdUnit Deploy.MaintainerScripts PROPERTIES LABELS "deploy;host"
                     SKIP_RETURN_CODE 77)

# The package is the host-only build's (the lab PC's): this build's in the host-only build; in the
# full build (CI) the tree HostOnlyBuild.* builds into build/host-only (fixture host_only_tree).
if(DELTA_HOST_ONLY)
  add_test(NAME Deploy.Package COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/package_test.sh ${PROJECT_BINARY_DIR}
                                       $<TARGET_FILE:deploy_blank_bitstream>)
  set_tests_properties(Deploy.Package PROPERTIES LABELS "deploy;host" SKIP_RETURN_CODE 77 TIMEOUT 600)
else()
  add_test(NAME Deploy.Package
    COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/package_test.sh ${PROJECT_BINARY_DIR}/host-only
            $<TARGET_FILE:deploy_blank_bitstream> $<TARGET_FILE:deltactl>)
  set_tests_properties(Deploy.Package PROPERTIES LABELS "deploy;host" SKIP_RETURN_CODE 77 TIMEOUT 600
                       FIXTURES_REQUIRED host_only_tree)
  add_test(NAME Deploy.WeightsPipeline
    COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/weights_pipeline_test.sh ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR})
  set_tests_properties(Deploy.WeightsPipeline PROPERTIES LABELS "deploy;host" TIMEOUT 300)
  add_test(NAME Deploy.DoctorVirtualBoard
    COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/doctor_virtual_board.sh $<TARGET_FILE:deltactl>
            ${PROJECT_SOURCE_DIR}/weights/paper_like.json)
  add_test(NAME Deploy.FlashVirtualBoard
    COMMAND ${PROJECT_SOURCE_DIR}/scripts/deploy/flash_virtual_board.sh $<TARGET_FILE:deltactl>
            ${PROJECT_SOURCE_DIR}/weights/paper_like.json $<TARGET_FILE:deploy_blank_bitstream>)
  set_tests_properties(Deploy.DoctorVirtualBoard Deploy.FlashVirtualBoard PROPERTIES
    LABELS "deploy;virtual_board;cosim" TIMEOUT 180)
endif()

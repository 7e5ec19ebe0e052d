# The host controller's plan under feed holds (no board needed).
delta_add_gtest(stream_plan_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_stream_plan.cpp
  LIBRARIES delta::controller
  LABELS host host_controller)

# A model load (host load, serve) against a scripted board: paced by the board's acceptance, the
# refusals named, the retry from frame 0 (no board needed).
delta_add_gtest(model_load_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_model_load.cpp
  LIBRARIES delta::controller delta::golden delta::host delta::gateware
  LABELS host host_controller)

# The host controller (`deltactl host`) against the virtual board through a pty: its
# acceptance. Needs the virtual board (Verilator), so not in the host-only build.
if(DELTA_HOST_ONLY)
  return()
endif()
delta_add_gtest(host_controller_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_host_controller.cpp
  LIBRARIES delta::controller delta::golden delta::nn delta::host nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  # Alone on the machine: the virtual board and the host's 1 kHz streaming thread each need a core,
  # and a host starved beyond its 200 ms lead lets the board's watchdog fault the run (as it would on the robot).
  # The refusals before any byte is sent need neither.
  SERIAL PARALLEL_TESTS HostRun.BadTrajectoriesAreRefusedBeforeAnyByteIsSent HostRun.CheckPrintsTheBoxAndEveryProblemWithoutAPort)

# `host load` onto virtual boards started with no model (both fidelities): status before and after,
# a load with the drives on refused, host run refusing no model or another model, then running.
delta_add_gtest(host_load_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_host_load.cpp
  LIBRARIES delta::golden delta::host nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  SERIAL)

# `host serve` and `host ctl` against the model-fidelity virtual board (kept to real time).
delta_add_gtest(host_serve_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_host_serve.cpp
  LIBRARIES delta::host nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  SERIAL)

# Every way out of a run (a foreign disable, signals, SIGKILL, ctl interrupted) and `host serve`
# under any bytes and 50,000 connections, recordings confined and never overwritten.
delta_add_gtest(host_safety_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_host_safety.cpp
  LIBRARIES delta::controller delta::host nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  # Serve without a board (its socket, its connections, its folder) and the refusals before a port
  # is opened run beside the others.
  SERIAL PARALLEL_TESTS HostSafety.TrajectoriesBeyondTheLongestRunOrNotRegularFilesAreRefused
    HostServeSafety.AnyBytesOnTheSocketAreAnsweredAndServeLives
    HostServeSafety.CtlRunWithANameThatIsNotUtf8IsRefusedNamingIt
    HostServeSafety.ThousandsOfConnectionsLeaveServeSmall
    HostServeSafety.SilentConnectionsDoNotDelayAnEstop
    HostServeSafety.RecordingsStayInTheirFolderAndAreNeverOverwritten
    HostServeSafety.SocketPathThatIsNotASocketIsRefusedAndKept)

# Homing against the references (docs/homing.md): random starts, a run stopped mid-path, a seized
# arm and a missing switch, a board homed by hand, every jog's setpoint within the homing bounds.
delta_add_gtest(homing_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_homing.cpp
  LIBRARIES delta::controller delta::host delta::golden nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  # The jogs' bounds are arithmetic on the shipped networks: no board.
  SERIAL PARALLEL_TESTS Homing.EveryJogMeetsTheHomingBoundsWithTheShippedNetworksIncludingTheCalibrationDrags)

# The board's own safety (its e-stop and drive-fault inputs, its e-stop command) through the host:
# the drives off and the cause latched, named, refused clears, then a run again.
delta_add_gtest(board_safety_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_board_safety.cpp
  LIBRARIES delta::host nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  SERIAL)

# A calibration tied to the robot's reference: host record refuses a board not homed at its
# references and its header says how the counts were referenced, the stage that drags after homing
# (the acceptance: a random power-up pose, home, drag, record), lost frames, park.
delta_add_gtest(referenced_calibration_tests
  SOURCES ${CMAKE_CURRENT_LIST_DIR}/host_controller/test_referenced_calibration.cpp
  LIBRARIES delta::host nlohmann_json::nlohmann_json
  LABELS host host_controller virtual_board
  SERIAL)

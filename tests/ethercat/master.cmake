# Tests of the EtherCAT master subset (protocol/ethercat/master.cmake) against emulated slaves
# on the simulated segment. Included from tests/CMakeLists.txt.
drivecheck_add_gtest(ethercat_master_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/master_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/master_interop_test.cpp
  LIBRARIES drivecheck::ethercat_master)

# The master on a real link: AF_PACKET on a veth pair in a namespace the test creates (needs
# root; skips with the reason otherwise), label `ethercat` like ethercat.veth-link.
drivecheck_add_gtest(ethercat_master_raw_link_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/master_raw_link_test.cpp
  LIBRARIES drivecheck::ethercat_master drivecheck::ethercat_raw)
add_test(NAME ethercat.veth-master COMMAND ethercat_master_raw_link_tests)
set_tests_properties(ethercat.veth-master PROPERTIES RUN_SERIAL TRUE LABELS ethercat TIMEOUT 120
  SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")

# `drivecheck run --bus ethercat:IF` against `drivecheck drive --bus ethercat:PEER` on a veth
# pair in a namespace the test creates, the verdicts compared with `run --bus ethercat:sim`
# (issue 20, "Tested for real in CI"). Label `ethercat` only: it runs two drivecheck processes
# in real time for about a minute.
add_executable(ethercat_run_veth_tests ${CMAKE_CURRENT_LIST_DIR}/run_veth_test.cpp)
target_link_libraries(ethercat_run_veth_tests PRIVATE drivecheck::reports drivecheck::ethercat GTest::gtest
  GTest::gtest_main drivecheck::warnings)
target_include_directories(ethercat_run_veth_tests PRIVATE ${PROJECT_SOURCE_DIR})
target_compile_definitions(ethercat_run_veth_tests PRIVATE
  DRIVECHECK_BINARY="$<TARGET_FILE:drivecheck>")
add_dependencies(ethercat_run_veth_tests drivecheck)
add_test(NAME ethercat.run-veth COMMAND ethercat_run_veth_tests)
set_tests_properties(ethercat.run-veth PROPERTIES RUN_SERIAL TRUE LABELS ethercat TIMEOUT 480
  SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")

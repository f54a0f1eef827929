# Tests of the EtherCAT master subset (protocol/ethercat/master.cmake) against emulated slaves
# on the simulated segment. Included from tests/CMakeLists.txt.
drivecheck_add_gtest(ethercat_master_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/master_test.cpp
  LIBRARIES drivecheck::ethercat_master)

# The master on a real link: AF_PACKET on a veth pair in a namespace the test creates (needs
# root; skips with the reason otherwise), label `ethercat` like ethercat.veth-link.
drivecheck_add_gtest(ethercat_master_raw_link_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/master_raw_link_test.cpp
  LIBRARIES drivecheck::ethercat_master drivecheck::ethercat_raw)
add_test(NAME ethercat.veth-master COMMAND ethercat_master_raw_link_tests)
set_tests_properties(ethercat.veth-master PROPERTIES LABELS ethercat TIMEOUT 120
  SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")

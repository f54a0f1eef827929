# Tests of the EtherCAT master subset (protocol/ethercat/master.cmake) against emulated slaves
# on the simulated segment. Included from tests/CMakeLists.txt.
drivecheck_add_gtest(ethercat_master_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/master_test.cpp
  LIBRARIES drivecheck::ethercat_master)

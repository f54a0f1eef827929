# Tests of the EtherCAT mailbox and CoE layer (protocol/ethercat/coe.cmake).
# Included from tests/CMakeLists.txt.
drivecheck_add_gtest(ethercat_coe_tests
  SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/coe_mailbox_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/coe_codec_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/coe_sdo_server_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/coe_sdo_client_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/coe_objects_test.cpp
    ${CMAKE_CURRENT_LIST_DIR}/coe_sdo_info_test.cpp
  LIBRARIES drivecheck::ethercat_coe)

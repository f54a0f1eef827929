# protocol/ethercat: the mailbox and CoE layer (ETG.1000.4/.6 mailbox, CoE with CiA 301 SDO
# semantics). Pure codecs and state machines fed mailbox bytes and time; the ESC front end and
# the master's link layer (the other protocol/ethercat files) move the bytes.
# Included from protocol/CMakeLists.txt (this file, not a CMakeLists.txt of the folder, so that
# it merges beside the lower layers' own target).
add_library(drivecheck_ethercat_coe
  ${CMAKE_CURRENT_LIST_DIR}/mailbox.cpp
  ${CMAKE_CURRENT_LIST_DIR}/coe.cpp
  ${CMAKE_CURRENT_LIST_DIR}/coe_sdo_server.cpp
  ${CMAKE_CURRENT_LIST_DIR}/coe_sdo_client.cpp
  ${CMAKE_CURRENT_LIST_DIR}/coe_objects.cpp
  ${CMAKE_CURRENT_LIST_DIR}/coe_sdo_info.cpp
)
add_library(drivecheck::ethercat_coe ALIAS drivecheck_ethercat_coe)
target_include_directories(drivecheck_ethercat_coe PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(drivecheck_ethercat_coe PUBLIC drivecheck::cia301 fmt::fmt
                                              PRIVATE drivecheck::warnings)

# protocol/ethercat: the EtherCAT dissector (dissector.hpp): datagrams, registers, mailboxes and
# CoE as one line each, for `drivecheck decode`, the evidence of a run and the fuzz target
# ethercat_pcap. Included from protocol/CMakeLists.txt, beside coe.cmake.
add_library(drivecheck_ethercat_dissector
  ${CMAKE_CURRENT_LIST_DIR}/dissector.cpp
)
add_library(drivecheck::ethercat_dissector ALIAS drivecheck_ethercat_dissector)
target_include_directories(drivecheck_ethercat_dissector PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(drivecheck_ethercat_dissector
  PUBLIC drivecheck::ethercat drivecheck::ethercat_coe fmt::fmt
  PRIVATE drivecheck::warnings)

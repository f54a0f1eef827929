# protocol/ethercat: the master subset (scan, SII read, SM/FMMU setup, AL transitions, mailbox
# polling with CoE SDO, cyclic LRW). Driven through a Link (SimSegment or RawLink) on its clock.
# Included from protocol/CMakeLists.txt, beside the lower layers' and the CoE layer's targets.
add_library(drivecheck_ethercat_master
  ${CMAKE_CURRENT_LIST_DIR}/master_link.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master_scan.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master_sii.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master_config.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master_al.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master_mailbox.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master_process_data.cpp
  ${CMAKE_CURRENT_LIST_DIR}/master.cpp
)
add_library(drivecheck::ethercat_master ALIAS drivecheck_ethercat_master)
target_include_directories(drivecheck_ethercat_master PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(drivecheck_ethercat_master
  PUBLIC drivecheck::ethercat drivecheck::ethercat_coe fmt::fmt
  PRIVATE drivecheck::warnings)

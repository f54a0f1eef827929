# Driver of one conformance CTest test (see DrivecheckConformance.cmake):
#   cmake -DDRIVECHECK=<program> -DBUS=<bus> -DEXPECT_EXIT=<code> -DOUTPUT_DIR=<dir>
#         -DRUN_ARGS=<arguments separated by |> [-DREQUIRE_FAILURE=ON]
#         -P DrivecheckConformanceRun.cmake
# BUS socketcan:@<resource> takes the interface CTest allocated to the test.
# REQUIRE_FAILURE: the run must report at least one failing vector (the deviation tests: a
# deviation that no vector catches fails its test) and the failures are listed.

include(${CMAKE_CURRENT_LIST_DIR}/DrivecheckFailedVectors.cmake)

foreach(var DRIVECHECK BUS EXPECT_EXIT OUTPUT_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "DrivecheckConformanceRun.cmake: ${var} is not set")
  endif()
endforeach()

set(bus ${BUS})
if(BUS MATCHES "^socketcan:@(.+)$")
  string(TOUPPER "${CMAKE_MATCH_1}" resource)
  set(allocation "$ENV{CTEST_RESOURCE_GROUP_0_${resource}}")
  if(NOT allocation MATCHES "id:([^,]+)")
    message(FATAL_ERROR
      "${BUS}: no interface allocated; run ctest with --resource-spec-file (a spec with a "
      "\"${CMAKE_MATCH_1}\" resource listing the CAN interfaces)")
  endif()
  set(bus socketcan:${CMAKE_MATCH_1})
endif()

string(REPLACE "|" ";" run_args "${RUN_ARGS}")
file(MAKE_DIRECTORY ${OUTPUT_DIR})
execute_process(
  COMMAND ${DRIVECHECK} run --bus ${bus} ${run_args}
  RESULT_VARIABLE status OUTPUT_VARIABLE console)
message("${console}")

if(REQUIRE_FAILURE AND status STREQUAL "3")
  # The DUT stopped answering (a fatal deviation): that is detected too.
  message(STATUS "the drive stopped answering: detected (exit 3)")
  return()
endif()
if(NOT status STREQUAL EXPECT_EXIT)
  message(FATAL_ERROR
    "drivecheck run exited with ${status}, expected ${EXPECT_EXIT}; reports in ${OUTPUT_DIR}")
endif()

if(REQUIRE_FAILURE)
  # The console lists each failing vector as "× <id> — ..." ("x <id> ..." without UTF-8).
  drivecheck_failed_vectors("${console}" failed)
  if(NOT failed)
    message(FATAL_ERROR "no vector failed: the deviation went undetected (${OUTPUT_DIR})")
  endif()
  list(LENGTH failed n)
  string(REPLACE ";" "\n  " listing "${failed}")
  message(STATUS "caught by ${n} vector(s):\n  ${listing}")
endif()

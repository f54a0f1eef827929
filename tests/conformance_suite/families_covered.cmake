# conformance.families-covered: every vector's family is one of FAMILIES, the families the
# per-family conformance tests run (tests/conformance_suite/CMakeLists.txt); a vector in any
# other family would run in no CTest test.
#   cmake -DDRIVECHECK=<program> -DFAMILIES=<list> -DVECTORS=<dir> -P families_covered.cmake
cmake_policy(SET CMP0057 NEW)
execute_process(COMMAND ${DRIVECHECK} vectors list ${VECTORS}
                RESULT_VARIABLE status OUTPUT_VARIABLE listing ERROR_VARIABLE errors)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "drivecheck vectors list failed (${status}):\n${errors}")
endif()
string(REPLACE "\n" ";" lines "${listing}")
set(uncovered "")
set(count 0)
foreach(line IN LISTS lines)
  # ID  LEVEL  FAMILY  TITLE  [SOURCE]; the header line starts with "ID".
  if(line MATCHES "^([a-z0-9][^ ]*) +(must|should|may) +([^ ]+)")
    math(EXPR count "${count} + 1")
    if(NOT CMAKE_MATCH_3 IN_LIST FAMILIES)
      list(APPEND uncovered "${CMAKE_MATCH_1} (family ${CMAKE_MATCH_3})")
    endif()
  endif()
endforeach()
if(count EQUAL 0)
  message(FATAL_ERROR "drivecheck vectors list printed no vector")
endif()
if(uncovered)
  list(JOIN uncovered "\n  " text)
  message(FATAL_ERROR "vectors in no conformance test's family:\n  ${text}\n"
                      "add the family to tests/conformance_suite/CMakeLists.txt")
endif()
message(STATUS "${count} vectors, all in the tested families")

# The vectors a `drivecheck run` console lists as failed ("× <id> — ..." or, without UTF-8,
# "x <id> ..."), for the CTest scripts that judge a run by which vectors failed.
#
#   include(DrivecheckFailedVectors)   (or include(<path>/DrivecheckFailedVectors.cmake) in -P)
#   drivecheck_failed_vectors(<console text> <out list variable>)
#   drivecheck_expect_failed_exactly(<console text> <id>...)   FATAL_ERROR unless exactly those
include_guard(GLOBAL)
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...) in the functions below, also under -P

function(drivecheck_failed_vectors console out)
  string(REPLACE "\n" ";" lines "${console}")
  set(failed "")
  foreach(line IN LISTS lines)
    if(line MATCHES "^(×|x) ([^ ]+)")
      list(APPEND failed ${CMAKE_MATCH_2})
    endif()
  endforeach()
  set(${out} "${failed}" PARENT_SCOPE)
endfunction()

function(drivecheck_expect_failed_exactly console)
  drivecheck_failed_vectors("${console}" failed)
  set(expected ${ARGN})
  foreach(id IN LISTS expected)
    if(NOT id IN_LIST failed)
      message(FATAL_ERROR "${id} did not fail (failed: ${failed})")
    endif()
  endforeach()
  list(LENGTH failed n)
  list(LENGTH expected m)
  if(NOT n EQUAL m)
    message(FATAL_ERROR "${n} vectors failed, expected exactly ${expected}: ${failed}")
  endif()
endfunction()

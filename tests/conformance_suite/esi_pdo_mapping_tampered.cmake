# The ESI's PdoMapping flags (conformance/esi_checks.hpp, esi/pdo/<idx>/mappable and
# esi/pdo/<idx>/entries-mappable) against a tampered copy of the reference drive's own ESI
# (reference_drive/ethercat/reference_drive.xml):
#   6041h PdoMapping T -> R   the statusword, which TxPDO 1A00h maps (live, and in the ESI's own
#                             TxPdo 1A00h), is no longer TxPDO-mappable per the ESI: with
#                             --strict (the checks are SHOULD) exactly esi/pdo/1a00/mappable and
#                             esi/pdo/1a00/entries-mappable fail, exit 1
#   every PdoMapping removed  the ESI says nothing about mappability: the entries-mappable
#                             results are not applicable, no mappable vector runs, exit 0
#   cmake -DDRIVECHECK=<program> -DESI=<reference_drive.xml> -DOUT=<dir> -P esi_pdo_mapping_tampered.cmake
include(${CMAKE_CURRENT_LIST_DIR}/../../cmake/DrivecheckFailedVectors.cmake)
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...)
foreach(var DRIVECHECK ESI OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "esi_pdo_mapping_tampered.cmake: ${var} is not set")
  endif()
endforeach()
file(READ ${ESI} text)
file(MAKE_DIRECTORY ${OUT})

# 1. 6041h T -> R: its object's first <PdoMapping> after <Index>#x6041</Index>.
string(FIND "${text}" "<Index>#x6041</Index>" at)
if(at LESS 0)
  message(FATAL_ERROR "${ESI}: no object 6041h")
endif()
string(SUBSTRING "${text}" 0 ${at} head)
string(SUBSTRING "${text}" ${at} -1 tail)
string(FIND "${tail}" "<PdoMapping>T</PdoMapping>" flag)
string(FIND "${tail}" "</Object>" object_end)
if(flag LESS 0 OR flag GREATER object_end)
  message(FATAL_ERROR "${ESI}: object 6041h has no <PdoMapping>T</PdoMapping>")
endif()
string(SUBSTRING "${tail}" 0 ${flag} before)
math(EXPR after "${flag} + 26")
string(SUBSTRING "${tail}" ${after} -1 rest)
file(WRITE ${OUT}/tampered.xml "${head}${before}<PdoMapping>R</PdoMapping>${rest}")

execute_process(
  COMMAND ${DRIVECHECK} run --bus ethercat:sim --esi ${OUT}/tampered.xml --filter esi/pdo/*
          --strict --json ${OUT}/report.json --junit ${OUT}/junit.xml --html ${OUT}/report.html
  RESULT_VARIABLE status OUTPUT_VARIABLE console ERROR_VARIABLE errors)
message("${console}${errors}")
if(NOT status STREQUAL "1")
  message(FATAL_ERROR "drivecheck run exited with ${status}, expected 1 (failures)")
endif()
drivecheck_expect_failed_exactly("${console}" esi/pdo/1a00/mappable esi/pdo/1a00/entries-mappable)

# 2. No PdoMapping at all: nothing to judge mappability by.
string(REGEX REPLACE "<PdoMapping>[A-Za-z]*</PdoMapping>" "" bare "${text}")
file(WRITE ${OUT}/no-pdo-mapping.xml "${bare}")
execute_process(
  COMMAND ${DRIVECHECK} run --bus ethercat:sim --esi ${OUT}/no-pdo-mapping.xml
          --filter esi/pdo/* --strict --json ${OUT}/bare.json --junit ${OUT}/bare.xml
          --html ${OUT}/bare.html
  RESULT_VARIABLE status OUTPUT_VARIABLE console ERROR_VARIABLE errors)
message("${console}${errors}")
if(NOT status STREQUAL "0")
  message(FATAL_ERROR "drivecheck run (no PdoMapping) exited with ${status}, expected 0")
endif()
if(console MATCHES "esi/pdo/[0-9a-f]+/mappable")
  message(FATAL_ERROR "a mappable vector ran though the ESI flags nothing")
endif()
foreach(id 1600 1601 1602 1603 1a00 1a01 1a02 1a03)
  string(FIND "${console}" "- esi/pdo/${id}/entries-mappable (n/a: the ESI's Dictionary gives no"
         na)
  if(na LESS 0)
    message(FATAL_ERROR "esi/pdo/${id}/entries-mappable is not `not applicable`")
  endif()
endforeach()

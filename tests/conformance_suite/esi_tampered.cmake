# The ESI cross-check against a tampered copy of the reference drive's own ESI
# (reference_drive/ethercat/reference_drive.xml): `drivecheck run --bus ethercat:sim --esi` must
# exit 1 and fail exactly where the copy lies about the drive:
#   Type@ProductCode + 1   esi/identity/product-code (1018h:02) and esi/identity/sii-product-code
#   6041h Access ro -> wo  esi/od/6041-00/read-wo (the statusword reads)
#   cmake -DDRIVECHECK=<program> -DESI=<reference_drive.xml> -DOUT=<dir> -P esi_tampered.cmake
include(${CMAKE_CURRENT_LIST_DIR}/../../cmake/DrivecheckFailedVectors.cmake)
cmake_policy(SET CMP0057 NEW)  # if(... IN_LIST ...)
foreach(var DRIVECHECK ESI OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "esi_tampered.cmake: ${var} is not set")
  endif()
endforeach()
file(READ ${ESI} text)
string(REGEX MATCH "ProductCode=\"#x([0-9A-F]+)\"" product "${text}")
if(NOT product)
  message(FATAL_ERROR "${ESI}: no ProductCode to tamper with")
endif()
math(EXPR other "0x${CMAKE_MATCH_1} + 1" OUTPUT_FORMAT HEXADECIMAL)
string(REGEX REPLACE "^0x" "" other "${other}")
string(TOUPPER "${other}" other)
string(REPLACE "${product}" "ProductCode=\"#x${other}\"" text "${text}")
# The statusword's object: the first <Flags> after <Index>#x6041</Index>.
string(FIND "${text}" "<Index>#x6041</Index>" at)
if(at LESS 0)
  message(FATAL_ERROR "${ESI}: no object 6041h")
endif()
string(SUBSTRING "${text}" 0 ${at} head)
string(SUBSTRING "${text}" ${at} -1 tail)
string(FIND "${tail}" "<Access>ro</Access>" access)
string(SUBSTRING "${tail}" 0 ${access} before)
math(EXPR after "${access} + 19")
string(SUBSTRING "${tail}" ${after} -1 rest)
set(text "${head}${before}<Access>wo</Access>${rest}")
file(MAKE_DIRECTORY ${OUT})
file(WRITE ${OUT}/tampered.xml "${text}")

execute_process(
  COMMAND ${DRIVECHECK} run --bus ethercat:sim --esi ${OUT}/tampered.xml --filter esi/*
          --json ${OUT}/report.json --junit ${OUT}/junit.xml --html ${OUT}/report.html
  RESULT_VARIABLE status OUTPUT_VARIABLE console ERROR_VARIABLE errors)
message("${console}${errors}")
if(NOT status STREQUAL "1")
  message(FATAL_ERROR "drivecheck run exited with ${status}, expected 1 (failures)")
endif()
drivecheck_expect_failed_exactly("${console}" esi/identity/product-code esi/identity/sii-product-code esi/od/6041-00/read-wo)

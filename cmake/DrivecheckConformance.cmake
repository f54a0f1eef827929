# Conformance runs as CTest tests.
#
#   drivecheck_add_conformance_test(<name>
#       [BUS sim|socketcan:<if>|socketcan:@<resource>|ethercat:sim]   default sim (the embedded drive)
#       [NODE <1..127>]                                   default 1
#       [PROFILE <file|name>]                             default drivecheck run's: cia402-reference on
#                                                         sim, chosen from 1000h on a real bus
#       [EDS <file>]
#       [FILTER <glob>]                                   e.g. "cia402/homing/*"
#       [DEVIATIONS <name>...]                            embedded drive only
#       [STRICT] [ALLOW_MOTION]
#       [REQUIRE_FAILURE]                                 at least one vector must fail
#       [EXPECT_EXIT <code>]                              default 0 (all required vectors pass)
#       [LABELS <label>...]                               default conformance
#       [ARGS <extra drivecheck run arguments>...])
#
# Adds the CTest test <name>: `drivecheck run` with those options, reports (report.html,
# junit.xml, report.json, trace.log) in <build dir>/conformance/<name>/. The test passes when
# drivecheck exits with EXPECT_EXIT.
#
# A lab with several CAN interfaces: give BUS socketcan:@<resource> (e.g. socketcan:@can) and
# describe the interfaces in a CTest resource spec file; each test then claims one interface
# and the tests run in parallel, one drive per interface:
#
#   resources.json: {"version": {"major": 1, "minor": 0},
#                    "local": [{"can": [{"id": "can0"}, {"id": "can1"}]}]}
#   ctest -L conformance --resource-spec-file resources.json -j 2
#
# CTest passes the claimed interface in CTEST_RESOURCE_GROUP_0_<RESOURCE> ("id:can1,slots:1");
# the test's driver (DrivecheckConformanceRun.cmake) turns it into --bus socketcan:can1.
#
# Outside this source tree: include() this file and set DRIVECHECK_EXECUTABLE to the
# drivecheck program (otherwise the `drivecheck` target or the one on PATH is used).

set(_drivecheck_conformance_dir ${CMAKE_CURRENT_LIST_DIR})

function(drivecheck_add_conformance_test name)
  cmake_parse_arguments(arg "STRICT;ALLOW_MOTION;REQUIRE_FAILURE"
                        "BUS;NODE;PROFILE;EDS;FILTER;EXPECT_EXIT"
                        "DEVIATIONS;LABELS;ARGS" ${ARGN})
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "drivecheck_add_conformance_test(${name}): unknown arguments "
                        "${arg_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT arg_BUS)
    set(arg_BUS sim)
  endif()
  if(NOT arg_NODE)
    set(arg_NODE 1)
  endif()
  if(NOT DEFINED arg_EXPECT_EXIT)
    set(arg_EXPECT_EXIT 0)
  endif()
  if(NOT arg_LABELS)
    set(arg_LABELS conformance)
  endif()

  if(DRIVECHECK_EXECUTABLE)
    set(program ${DRIVECHECK_EXECUTABLE})
  elseif(TARGET drivecheck)
    set(program $<TARGET_FILE:drivecheck>)
  else()
    find_program(DRIVECHECK_EXECUTABLE drivecheck REQUIRED)
    set(program ${DRIVECHECK_EXECUTABLE})
  endif()

  set(out ${CMAKE_CURRENT_BINARY_DIR}/conformance/${name})
  set(run_args --node ${arg_NODE} --junit ${out}/junit.xml --html ${out}/report.html
               --json ${out}/report.json)
  # The CAN trace; an EtherCAT run has none yet (drivecheck run refuses --trace there).
  if(NOT arg_BUS MATCHES "^ethercat:")
    list(APPEND run_args --trace ${out}/trace.log)
  endif()
  if(arg_PROFILE)
    list(APPEND run_args --profile ${arg_PROFILE})
  endif()
  if(arg_EDS)
    list(APPEND run_args --eds ${arg_EDS})
  endif()
  if(arg_FILTER)
    list(APPEND run_args --filter ${arg_FILTER})
  endif()
  foreach(deviation IN LISTS arg_DEVIATIONS)
    list(APPEND run_args --deviation ${deviation})
  endforeach()
  if(arg_STRICT)
    list(APPEND run_args --strict)
  endif()
  if(arg_ALLOW_MOTION)
    list(APPEND run_args --allow-motion)
  endif()
  list(APPEND run_args ${arg_ARGS})
  # The list goes to the driver as one argument, '|'-separated (a ';' list would not survive
  # the CTest command line); no argument may contain '|'.
  string(REPLACE ";" "|" run_args_joined "${run_args}")

  add_test(NAME ${name}
    COMMAND ${CMAKE_COMMAND}
      -DDRIVECHECK=${program}
      -DBUS=${arg_BUS}
      -DEXPECT_EXIT=${arg_EXPECT_EXIT}
      -DOUTPUT_DIR=${out}
      -DREQUIRE_FAILURE=${arg_REQUIRE_FAILURE}
      "-DRUN_ARGS=${run_args_joined}"
      -P ${_drivecheck_conformance_dir}/DrivecheckConformanceRun.cmake)
  set_tests_properties(${name} PROPERTIES LABELS "${arg_LABELS}")
  if(arg_BUS MATCHES "^socketcan:@(.+)$")
    set_tests_properties(${name} PROPERTIES RESOURCE_GROUPS "${CMAKE_MATCH_1}:1")
  endif()
endfunction()

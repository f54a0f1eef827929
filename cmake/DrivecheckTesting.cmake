# drivecheck_add_gtest(<name> SOURCES <files...> LIBRARIES <targets...> [LABELS <labels...>])
#
# One GoogleTest executable; each TEST becomes its own CTest test (discovered before the
# tests run, so a sanitizer build does not run them at build time), labelled `unit` unless
# LABELS says otherwise.
include(GoogleTest)

function(drivecheck_add_gtest name)
  cmake_parse_arguments(arg "" "" "SOURCES;LIBRARIES;LABELS" ${ARGN})
  if(NOT arg_LABELS)
    set(arg_LABELS unit)
  endif()
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LIBRARIES} GTest::gtest GTest::gmock GTest::gtest_main
                                        drivecheck::warnings)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  # The test bodies themselves unoptimised: what they exercise is the libraries, built -O2 in
  # RelWithDebInfo, and -O2 on the large gtest translation units more than doubled their
  # compile time (json_report_test.cpp: 24 s at -O2 -g, 10 s at -O0 -g), which is most of a
  # fresh build and so of CI. (A later -O on the command line wins.)
  target_compile_options(${name} PRIVATE $<$<CONFIG:RelWithDebInfo,Release>:-O0>)
  gtest_discover_tests(${name}
    DISCOVERY_MODE PRE_TEST
    TEST_PREFIX "${name}."
    PROPERTIES LABELS "${arg_LABELS}")
endfunction()

# drivecheck_add_benchmark(<name> SOURCES <files...> LIBRARIES <targets...> [ARGS <args...>]
#                          [CUSTOM_MAIN])
#
# One Google Benchmark program, registered as a CTest test of the same name labelled `bench`
# (the dev and asan test presets exclude that label; `ctest --preset bench` runs them).
# The program gets Google Benchmark's main() unless CUSTOM_MAIN is given; ARGS are passed
# to it when CTest runs it. Measure with an optimised build (dev preset: RelWithDebInfo).
find_package(benchmark REQUIRED)

function(drivecheck_add_benchmark name)
  cmake_parse_arguments(arg "CUSTOM_MAIN" "" "SOURCES;LIBRARIES;ARGS" ${ARGN})
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LIBRARIES} benchmark::benchmark drivecheck::warnings)
  if(NOT arg_CUSTOM_MAIN)
    target_link_libraries(${name} PRIVATE benchmark::benchmark_main)
  endif()
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  add_test(NAME ${name} COMMAND ${name} ${arg_ARGS})
  set_tests_properties(${name} PROPERTIES RUN_SERIAL TRUE LABELS bench)
endfunction()

# Warning flags for every drivecheck target. Sanitizer and optimisation flags do not belong
# here: the presets in CMakePresets.json own them.
add_library(drivecheck_warnings INTERFACE)
target_compile_options(drivecheck_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wnull-dereference
  -Wimplicit-fallthrough
  $<$<BOOL:${DRIVECHECK_WERROR}>:-Werror>)
add_library(drivecheck::warnings ALIAS drivecheck_warnings)

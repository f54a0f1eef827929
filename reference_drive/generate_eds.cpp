// reference_drive_eds: prints the reference drive's EDS (CiA 306, CRLF line ends), generated
// from the standard ServoDrive's object dictionary (servo_drive_eds.hpp: the CiA 301 part of
// reference_drive/dictionary.cpp and the CiA 402 objects of the application). The checked-in
// reference_drive/reference_drive.eds is this program's output:
//
//   build/dev/reference_drive/reference_drive_eds > reference_drive/reference_drive.eds
//
// With a file argument it writes there instead. Exit 0, or 1 with a message on stderr.
#include <fmt/format.h>

#include <cstdio>
#include <fstream>

#include "reference_drive/servo_drive_eds.hpp"

int main(int argc, char** argv) {
  const auto text = drivecheck::reference_drive::servo_drive_eds_text();
  if (!text) {
    fmt::print(stderr, "reference_drive_eds: {}\n", text.error());
    return 1;
  }
  if (argc > 1) {
    std::ofstream out(argv[1], std::ios::binary);
    out << *text;
    if (!out.flush()) {
      fmt::print(stderr, "reference_drive_eds: cannot write {}\n", argv[1]);
      return 1;
    }
    return 0;
  }
  std::fwrite(text->data(), 1, text->size(), stdout);
  return std::fflush(stdout) == 0 ? 0 : 1;
}

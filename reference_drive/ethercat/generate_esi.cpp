// reference_drive_esi: prints the reference drive's ESI (ETG.2000 EtherCAT Slave Information),
// generated from the standard EthercatDrive's object dictionary and SII (esi_image.hpp). The
// checked-in reference_drive/ethercat/reference_drive.xml is this program's output:
//
//   build/dev/reference_drive/ethercat/reference_drive_esi
//   reference_drive/ethercat/reference_drive.xml
//
// With a file argument it writes there instead of stdout. Exit 0, or 1 with a message on stderr.
#include <fmt/format.h>

#include <cstdio>
#include <fstream>

#include "reference_drive/ethercat/esi_image.hpp"

int main(int argc, char** argv) {
  const auto text = drivecheck::reference_drive::ethercat::standard_drive_esi_text();
  if (!text) {
    fmt::print(stderr, "reference_drive_esi: {}\n", text.error());
    return 1;
  }
  if (argc > 1) {
    std::ofstream out(argv[1], std::ios::binary);
    out << *text;
    if (!out.flush()) {
      fmt::print(stderr, "reference_drive_esi: cannot write {}\n", argv[1]);
      return 1;
    }
    return 0;
  }
  std::fwrite(text->data(), 1, text->size(), stdout);
  return std::fflush(stdout) == 0 ? 0 : 1;
}

// Where drivecheck finds what it ships: the vectors (with the drive profiles in drives/ and
// manuals.yaml) and the reference drive's EDS, under <folder of the drivecheck binary>/
// DRIVECHECK_DATA_RELATIVE, i.e. <prefix>/share/drivecheck beside <prefix>/bin. The build tree
// has the same layout (build/<preset>/share/drivecheck links to the source tree), so an
// installed, unpacked or moved drivecheck and the one in the build tree find their data alike,
// and no absolute path of the building machine is compiled in.
//
//   share/drivecheck/vectors/               the vector tree (drives/, manuals.yaml, *.yaml)
//   share/drivecheck/reference_drive.eds    the reference drive's EDS
//
// The manuals (for the sha256 check of citations) are not shipped: --manuals DIR, else
// $DRIVECHECK_MANUALS; without either, the check is skipped and commands say so.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace drivecheck::cli {

// <binary's folder>/../share/drivecheck (made absolute, not canonical).
std::filesystem::path data_dir();
// data_dir()/vectors (or $DRIVECHECK_VECTORS, where the data is not beside the binary: a
// binary copied alone, as into the SocketCAN test VM) and data_dir()/reference_drive.eds.
std::filesystem::path shipped_vectors_dir();
std::filesystem::path reference_drive_eds();

// --manuals DIR, else $DRIVECHECK_MANUALS, else none.
std::optional<std::filesystem::path> manuals_dir(const std::string& option);

// The one line commands print when the manuals are not available.
inline constexpr const char* kManualsSkipped =
    "manuals not available (give --manuals DIR or DRIVECHECK_MANUALS): sha256 of cited "
    "manuals not checked";

}  // namespace drivecheck::cli

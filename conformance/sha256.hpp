// SHA-256 (FIPS 180-4) of bytes and files: pins the manuals a vector cites (vectors/manuals.yaml)
// and identifies the EDS a run used (RunInfo::eds_sha256). Small and dependency-free.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>

#include "protocol/common/expected.hpp"

namespace drivecheck::conformance {

// Lower-case hex digest, 64 characters.
std::string sha256_hex(std::span<const std::uint8_t> bytes);
std::string sha256_hex(std::string_view text);
// The digest of a file's bytes; error: "path: cannot read".
Expected<std::string, std::string> sha256_file(const std::filesystem::path& path);

}  // namespace drivecheck::conformance

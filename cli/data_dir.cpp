#include "cli/data_dir.hpp"

#include <cstdlib>
#include <system_error>

#ifndef DRIVECHECK_DATA_RELATIVE
#error "DRIVECHECK_DATA_RELATIVE must be defined by the build (cli/CMakeLists.txt)"
#endif

namespace drivecheck::cli {

std::filesystem::path data_dir() {
  std::error_code ec;
  // Linux: the binary itself, whatever the working directory or the name it was called by.
  auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) self = std::filesystem::current_path(ec) / "drivecheck";
  return (self.parent_path() / DRIVECHECK_DATA_RELATIVE).lexically_normal();
}

std::filesystem::path shipped_vectors_dir() {
  if (const char* env = std::getenv("DRIVECHECK_VECTORS"); env != nullptr && *env != '\0')
    return std::filesystem::path(env);
  return data_dir() / "vectors";
}

std::filesystem::path reference_drive_eds() {
  return data_dir() / "reference_drive.eds";
}

std::optional<std::filesystem::path> manuals_dir(const std::string& option) {
  if (!option.empty()) return std::filesystem::path(option);
  if (const char* env = std::getenv("DRIVECHECK_MANUALS"); env != nullptr && *env != '\0')
    return std::filesystem::path(env);
  return std::nullopt;
}

}  // namespace drivecheck::cli

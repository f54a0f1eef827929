// Stored parameters in a file, for a drive that runs as a real process (`drivecheck drive
// --store FILE`): the ParameterStorage (protocol/cia301/store_restore.hpp) behind 1010h/1011h.
//
// The file is text, one entry per line, the value's bytes as they travel in an SDO (little
// endian), hex; '-' for no bytes:
//
//   # drivecheck stored parameters v1
//   1017:00 E803          1017h sub 0 = 03E8h (1000 ms)
//   1400:01 01020080      1400h sub 1 = 80000201h
//
// The first line is the format marker above; '#' starts a comment line; blank lines are
// ignored; anything else is an error "file:line: message". A missing file means nothing is
// stored. Writes are atomic: the new content goes to FILE.tmp, is flushed to the disk (fsync)
// and renamed over FILE, so a crash leaves the old file or the new one, never a mix.
#pragma once

#include <string>
#include <string_view>

#include "protocol/cia301/store_restore.hpp"

namespace drivecheck::reference_drive {

inline constexpr std::string_view kParameterFileMarker = "# drivecheck stored parameters v1";

// The text of stored parameters (first line the marker).
std::string format_parameter_file(const cia301::ObjectDictionary::StoredParameters& parameters);
// Parses that text; `file` only names it in errors.
Expected<cia301::ObjectDictionary::StoredParameters, TextError> parse_parameter_file(
    std::string_view text, const std::string& file = "");

class FileParameterStorage final : public cia301::ParameterStorage {
 public:
  explicit FileParameterStorage(std::string path) : path_(std::move(path)) {}

  // Missing file: nothing stored. Errors: "file:line: message", or the system's reason.
  Expected<cia301::ObjectDictionary::StoredParameters, std::string> read() override;
  Expected<void, std::string> write(
      const cia301::ObjectDictionary::StoredParameters& parameters) override;

  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace drivecheck::reference_drive

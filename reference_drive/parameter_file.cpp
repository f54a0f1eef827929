#include "reference_drive/parameter_file.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>

namespace drivecheck::reference_drive {
namespace {

constexpr std::size_t kMaxFileSize = std::size_t{1} << 20;

std::optional<unsigned> hex_digit(char c) {
  if (c >= '0' && c <= '9') return static_cast<unsigned>(c - '0');
  if (c >= 'a' && c <= 'f') return static_cast<unsigned>(c - 'a' + 10);
  if (c >= 'A' && c <= 'F') return static_cast<unsigned>(c - 'A' + 10);
  return std::nullopt;
}

std::optional<std::uint32_t> parse_hex(std::string_view text) {
  std::uint32_t value = 0;
  if (text.empty()) return std::nullopt;
  for (const char c : text) {
    const auto d = hex_digit(c);
    if (!d) return std::nullopt;
    value = value * 16 + *d;
  }
  return value;
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t'))
    text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) {
    text.remove_suffix(1);
  }
  return text;
}

std::string system_error(const std::string& what, const std::string& path) {
  return fmt::format("{}: {}: {}", path, what, std::strerror(errno));
}

bool write_all(int fd, std::string_view data) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

}  // namespace

std::string format_parameter_file(const cia301::ObjectDictionary::StoredParameters& parameters) {
  std::string text(kParameterFileMarker);
  text += '\n';
  for (const auto& p : parameters) {
    text += fmt::format("{:04X}:{:02X} ", p.index, p.sub_index);
    if (p.bytes.empty()) text += '-';
    for (const std::uint8_t b : p.bytes)
      text += fmt::format("{:02X}", b);
    text += '\n';
  }
  return text;
}

Expected<cia301::ObjectDictionary::StoredParameters, TextError> parse_parameter_file(
    std::string_view text, const std::string& file) {
  cia301::ObjectDictionary::StoredParameters out;
  int line_number = 0;
  bool marker_seen = false;
  while (!text.empty()) {
    const auto end = text.find('\n');
    std::string_view line = trim(text.substr(0, end));
    text = end == std::string_view::npos ? std::string_view{} : text.substr(end + 1);
    ++line_number;
    const auto fail = [&](std::string message) {
      return Unexpected(TextError{file, line_number, std::move(message)});
    };
    if (!marker_seen) {
      if (line != kParameterFileMarker) {
        return fail(fmt::format("not a drivecheck parameter file (the first line must be '{}')",
                                kParameterFileMarker));
      }
      marker_seen = true;
      continue;
    }
    if (line.empty() || line.front() == '#') continue;
    // "IIII:SS BYTES"
    const auto space = line.find_first_of(" \t");
    if (space == std::string_view::npos || line.size() < 7 || line[4] != ':' || space != 7) {
      return fail(fmt::format("'{}' is not 'IIII:SS BYTES' (index and sub-index in hex)", line));
    }
    const auto index = parse_hex(line.substr(0, 4));
    const auto sub_index = parse_hex(line.substr(5, 2));
    if (!index || !sub_index) {
      return fail(fmt::format("'{}': index and sub-index must be hex digits", line.substr(0, 7)));
    }
    const std::string_view hex = trim(line.substr(space));
    cia301::ObjectDictionary::StoredEntry entry;
    entry.index = static_cast<std::uint16_t>(*index);
    entry.sub_index = static_cast<std::uint8_t>(*sub_index);
    if (hex != "-") {
      if (hex.empty() || hex.size() % 2 != 0) {
        return fail(fmt::format("{:04X}:{:02X}: the value must be hex byte pairs or '-'",
                                entry.index, entry.sub_index));
      }
      for (std::size_t i = 0; i < hex.size(); i += 2) {
        const auto byte = parse_hex(hex.substr(i, 2));
        if (!byte) {
          return fail(fmt::format("{:04X}:{:02X}: '{}' is not a hex byte", entry.index,
                                  entry.sub_index, hex.substr(i, 2)));
        }
        entry.bytes.push_back(static_cast<std::uint8_t>(*byte));
      }
    }
    for (const auto& seen : out) {
      if (seen.index == entry.index && seen.sub_index == entry.sub_index) {
        return fail(fmt::format("{:04X}:{:02X} is stored twice", entry.index, entry.sub_index));
      }
    }
    out.push_back(std::move(entry));
  }
  if (!marker_seen) {
    return Unexpected(TextError{file, 0, "empty file: not a drivecheck parameter file"});
  }
  return out;
}

Expected<cia301::ObjectDictionary::StoredParameters, std::string> FileParameterStorage::read() {
  struct stat st {};
  if (::stat(path_.c_str(), &st) != 0) {
    if (errno == ENOENT) return cia301::ObjectDictionary::StoredParameters{};
    return Unexpected(system_error("cannot read", path_));
  }
  if (S_ISDIR(st.st_mode)) return Unexpected(fmt::format("{}: is a directory", path_));
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Unexpected(system_error("cannot read", path_));
  std::string text;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const std::string error = system_error("cannot read", path_);
      ::close(fd);
      return Unexpected(error);
    }
    if (n == 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
    if (text.size() > kMaxFileSize) {
      ::close(fd);
      return Unexpected(fmt::format("{}: larger than {} bytes", path_, kMaxFileSize));
    }
  }
  ::close(fd);
  auto parsed = parse_parameter_file(text, path_);
  if (!parsed) return Unexpected(parsed.error().to_string());
  return std::move(*parsed);
}

Expected<void, std::string> FileParameterStorage::write(
    const cia301::ObjectDictionary::StoredParameters& parameters) {
  const std::string text = format_parameter_file(parameters);
  const std::string temporary = path_ + ".tmp";
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Unexpected(system_error("cannot create", temporary));
  if (!write_all(fd, text) || ::fsync(fd) != 0) {
    const std::string error = system_error("cannot write", temporary);
    ::close(fd);
    ::unlink(temporary.c_str());
    return Unexpected(error);
  }
  if (::close(fd) != 0) {
    const std::string error = system_error("cannot write", temporary);
    ::unlink(temporary.c_str());
    return Unexpected(error);
  }
  if (::rename(temporary.c_str(), path_.c_str()) != 0) {
    const std::string error = system_error("cannot replace", path_);
    ::unlink(temporary.c_str());
    return Unexpected(error);
  }
  // The rename itself must reach the disk: fsync the directory.
  const auto slash = path_.rfind('/');
  const std::string directory = slash == std::string::npos ? "." : path_.substr(0, slash + 1);
  const int dir = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
  return {};
}

}  // namespace drivecheck::reference_drive

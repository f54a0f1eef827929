// write_file_atomically: temp file in the target's directory, write, fsync, rename, fsync of
// the directory (POSIX rename(2) replaces the target atomically within one file system).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

std::string errno_text(int error) {
  return std::generic_category().message(error);
}

// Closes a descriptor at scope end (if still open).
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }
  // close(2)'s result; the descriptor is gone either way.
  int close() {
    const int rc = ::close(fd_);
    fd_ = -1;
    return rc;
  }

 private:
  int fd_;
};

// The process umask without changing it (umask(2) can only read by writing, which would race
// with other threads creating files): Linux reports it in /proc/self/status ("Umask:\t0022").
mode_t current_umask() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("Umask:", 0) == 0)
      return static_cast<mode_t>(std::strtoul(line.c_str() + 6, nullptr, 8) & 0777);
  }
  return 022;
}

}  // namespace

Expected<void, std::string> write_file_atomically(const std::filesystem::path& path,
                                                  std::string_view contents) {
  if (path.empty() || !path.has_filename()) {
    return Unexpected(std::string("cannot write a report to '") + path.string() +
                      "': not a file name");
  }
  const std::filesystem::path directory =
      path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec) {
    return Unexpected("cannot create directory " + directory.string() + ": " + ec.message());
  }

  std::string temp = (directory / ("." + path.filename().string() + ".tmp-XXXXXX")).string();
  FileDescriptor fd(::mkstemp(temp.data()));
  if (fd.get() < 0) {
    return Unexpected("cannot create a temporary file in " + directory.string() + ": " +
                      errno_text(errno));
  }
  const auto fail = [&](std::string what, int error) -> Expected<void, std::string> {
    if (fd.get() >= 0) fd.close();
    ::unlink(temp.c_str());
    return Unexpected(what + ": " + errno_text(error));
  };

  std::size_t written = 0;
  while (written < contents.size()) {
    const ssize_t n = ::write(fd.get(), contents.data() + written, contents.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      return fail("cannot write " + temp, errno);
    }
    written += static_cast<std::size_t>(n);
  }
  // mkstemp creates 0600; a report is an ordinary file (0666 less the umask).
  if (::fchmod(fd.get(), 0666 & ~current_umask()) != 0) return fail("cannot chmod " + temp, errno);
  if (::fsync(fd.get()) != 0) return fail("cannot fsync " + temp, errno);
  if (fd.close() != 0) return fail("cannot close " + temp, errno);
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    return fail("cannot rename " + temp + " to " + path.string(), errno);
  }
  // Make the rename itself durable; a directory that cannot be opened or synced does not
  // make the (complete, renamed) file wrong, so this is best effort.
  FileDescriptor dir(::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (dir.get() >= 0) ::fsync(dir.get());
  return {};
}

}  // namespace drivecheck::reports

// `drivecheck drive` as a child process, for the programs that test it inside the VM (the
// drivecheck binary comes into the VM's /bin through run-in-vm --extra). The test opens its own
// SocketCanBus first, starts the drive, and waits for the boot-up message itself.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

namespace drivecheck::vm {

class DriveProcess {
 public:
  // Runs `binary args...` (execvp: a bare name is looked up in PATH). nullptr and `error` when
  // the process cannot be started.
  static std::unique_ptr<DriveProcess> start(const std::string& binary,
                                             const std::vector<std::string>& args,
                                             std::string& error);
  ~DriveProcess();  // SIGKILL if still running
  DriveProcess(const DriveProcess&) = delete;
  DriveProcess& operator=(const DriveProcess&) = delete;

  // Sends `signal_number` (SIGTERM, SIGINT) and waits for the exit: the exit status, 128 +
  // signal when killed by one, -1 when it had to be killed after `timeout`.
  int stop(int signal_number, std::chrono::milliseconds timeout);
  pid_t pid() const { return pid_; }

 private:
  explicit DriveProcess(pid_t pid) : pid_(pid) {}
  pid_t pid_;
  bool reaped_ = false;
};

// "--drivecheck=PATH" among the arguments (removed), else "drivecheck" (found in PATH).
std::string take_drivecheck_path(int& argc, char** argv);

}  // namespace drivecheck::vm

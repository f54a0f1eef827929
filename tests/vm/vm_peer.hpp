// Peer processes for the programs that run inside the test VM: a test (or benchmark) starts
// its own executable again as `PROGRAM --peer ROLE READY_FD ARGS...`, so that two processes
// with two sockets talk over vcan, as a master and a drive would.
//
// Roles (run_peer):
//   echo IF [ID]        SocketCanBus on IF (only standard id ID if given): answers every
//                       frame with the same frame, id + 1; quits on kQuitFrame
//   raw-echo IF ID      the same with a plain blocking raw socket (benchmark baseline)
//   stamped-echo IF ID  the same with a StampedRawSocket (benchmark: cost of the kernel work)
//   send IF FRAME...    sends the candump-text frames with SocketCanBus, then exits
//   raw-send IF FRAME...  sends them with a plain raw socket (can inject error frames)
//   count IF N MS       receives with SocketCanBus until N frames or MS ms of silence; exits 0
//                       when exactly N frames came with 32-bit big-endian sequence numbers
//                       0..N-1 in data[0..3], in order
// Every role prints its problems to stderr and exits non-zero on failure.
#pragma once

#include <linux/can.h>
#include <sys/types.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "protocol/can/frame.hpp"

namespace drivecheck::vm {

// Extended id 1FFFFFFF, no data: tells echo peers to exit.
can::Frame quit_frame();

class PeerProcess {
 public:
  // Starts the peer and waits (at most 5 s) until it reports that its socket is open.
  // On failure returns nullptr and sets `error`.
  static std::unique_ptr<PeerProcess> start(const std::string& role,
                                            const std::vector<std::string>& args,
                                            std::string& error);
  ~PeerProcess();  // kills a peer that is still running
  PeerProcess(const PeerProcess&) = delete;
  PeerProcess& operator=(const PeerProcess&) = delete;

  // Exit status of the peer, or -1 when it had to be killed after `timeout`.
  int wait(std::chrono::milliseconds timeout);

 private:
  explicit PeerProcess(pid_t pid) : pid_(pid) {}
  pid_t pid_;
  bool reaped_ = false;
};

// If argv is `PROGRAM --peer ROLE READY_FD ...`, runs that role and returns its exit status;
// otherwise returns -1 (the caller runs its tests).
int run_peer_if_asked(int argc, char** argv);

// A plain blocking raw CAN socket bound to `interface`, with one standard-id filter when
// `filter_id` >= 0; -1 on error (errno set).
int open_raw_socket(const std::string& interface, int filter_id = -1);

// A raw socket doing the kernel work SocketCanBus does per frame, without its code: kernel
// receive timestamps (SO_TIMESTAMPING), the drop counter (SO_RXQ_OVFL), and a blocking
// recvmsg() with a receive timeout. The benchmark's line c.
class StampedRawSocket {
 public:
  // nullptr on error (errno set).
  static std::unique_ptr<StampedRawSocket> open(const std::string& interface, int filter_id);
  ~StampedRawSocket();
  StampedRawSocket(const StampedRawSocket&) = delete;
  StampedRawSocket& operator=(const StampedRawSocket&) = delete;
  bool send(const can_frame& frame);
  // Waits for a frame; with `limited`, fails (ETIMEDOUT) after 1 s without one.
  bool receive(can_frame& frame, bool limited = true);

 private:
  explicit StampedRawSocket(int socket_fd) : socket_fd_(socket_fd) {}
  int socket_fd_;
};

// Round trips measured in one run of a benchmark: rate and latency percentiles.
struct RoundTrips {
  double per_second = 0;
  double p50_us = 0;
  double p99_us = 0;
};
// Summarises round-trip latencies (sorted in place) measured over `elapsed`.
RoundTrips summarize(std::vector<double>& latencies_us,
                     std::chrono::steady_clock::duration elapsed);

}  // namespace drivecheck::vm

// Expedited SDO round trips over vcan0 against `drivecheck drive` (its own process), inside the
// test VM, next to the raw-socket baseline:
//   a. plain blocking raw socket client -> drivecheck drive: upload 1000h (605h -> 585h)
//   b. drivecheck's SdoClient on a SocketCanBus -> drivecheck drive: the same upload
//   c. baseline: plain raw socket client -> raw-socket echo peer (vm_peer raw-echo): the
//      fastest round trip two processes make over vcan0 on this machine
// Rounds rotate which mode goes first; the median round of each is reported. Exits 1 when a
// round trip fails or the drive does not start; there is no pass mark on the figures.
//
//   reference_drive_vm_bench [--drivecheck=PATH] [ROUNDS [SECONDS_PER_ROUND]]   (5 x 1 s)
#include <fmt/format.h>
#include <linux/can.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <optional>
#include <vector>

#include "protocol/can/socketcan_bus.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "tests/vm/drive_process.hpp"
#include "tests/vm/vm_peer.hpp"

namespace {

using namespace std::chrono_literals;
using drivecheck::can::SocketCanBus;
using Clock = std::chrono::steady_clock;

constexpr const char* kInterface = "vcan0";
constexpr std::uint8_t kNode = 5;
constexpr std::uint32_t kEchoRequest = 0x611;  // answered with 612h by the raw-echo peer

using Round = drivecheck::vm::RoundTrips;
using drivecheck::vm::summarize;

// Round trips of `one` (false: failed) for `length`.
std::optional<Round> timed_round(Clock::duration length, const std::function<bool()>& one) {
  std::vector<double> latencies;
  const auto start = Clock::now();
  auto now = start;
  while (now - start < length) {
    if (!one()) return std::nullopt;
    const auto done = Clock::now();
    latencies.push_back(std::chrono::duration<double, std::micro>(done - now).count());
    now = done;
  }
  return summarize(latencies, now - start);
}

bool raw_exchange(int fd, const can_frame& out, canid_t answer_id, can_frame& in) {
  if (::write(fd, &out, sizeof out) != static_cast<ssize_t>(sizeof out)) return false;
  for (;;) {
    if (::read(fd, &in, sizeof in) != static_cast<ssize_t>(sizeof in)) return false;
    if (in.can_id == answer_id) return true;
  }
}

// Drops frames waiting on a raw socket (answers to another mode's requests).
void drain(int fd) {
  can_frame stale{};
  while (::recv(fd, &stale, sizeof stale, MSG_DONTWAIT) > 0) {
  }
}

double median_of(std::vector<Round> rounds, double Round::*field) {
  std::sort(rounds.begin(), rounds.end(),
            [field](const Round& a, const Round& b) { return a.*field < b.*field; });
  return rounds[rounds.size() / 2].*field;
}

struct Mode {
  const char* name;
  std::function<std::optional<Round>(Clock::duration)> round;
  std::vector<Round> rounds;
};

int run(const std::string& drivecheck, int rounds, Clock::duration length) {
  std::string error;
  auto echo = drivecheck::vm::PeerProcess::start("raw-echo",
                                                 {kInterface, std::to_string(kEchoRequest)}, error);
  if (!echo) {
    fmt::print(stderr, "bench: {}\n", error);
    return 1;
  }
  drivecheck::can::SocketCanOptions options;
  options.filters = {drivecheck::can::Filter::standard(0x580 + kNode),
                     drivecheck::can::Filter::standard(0x700 + kNode)};
  auto opened = SocketCanBus::open(kInterface, options);
  if (!opened) {
    fmt::print(stderr, "bench: {}\n",
               drivecheck::can::describe_open_error(kInterface, opened.error()));
    return 1;
  }
  SocketCanBus& bus = **opened;
  auto drive = drivecheck::vm::DriveProcess::start(
      drivecheck, {"drive", "--bus", fmt::format("socketcan:{}", kInterface), "--node", "5"},
      error);
  if (!drive) {
    fmt::print(stderr, "bench: {}\n", error);
    return 1;
  }
  const auto boot = bus.receive(bus.now() + 5s);
  if (!boot || drivecheck::can::to_candump(boot->frame) != "705#00") {
    fmt::print(stderr, "bench: no boot-up message from drivecheck drive\n");
    return 1;
  }

  const int sdo_raw = drivecheck::vm::open_raw_socket(kInterface, 0x580 + kNode);
  const int echo_raw =
      drivecheck::vm::open_raw_socket(kInterface, static_cast<int>(kEchoRequest + 1));
  if (sdo_raw < 0 || echo_raw < 0) {
    fmt::print(stderr, "bench: raw socket: {}\n", std::strerror(errno));
    return 1;
  }
  timeval read_timeout{1, 0};
  for (const int fd : {sdo_raw, echo_raw}) {
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &read_timeout, sizeof read_timeout);
  }

  // ccs=2: upload 1000h:00; the answer is 43 00 10 00 92 01 02 00 (00020192h).
  can_frame upload{};
  upload.can_id = 0x600 + kNode;
  upload.len = 8;
  const std::uint8_t request[8] = {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0};
  std::memcpy(upload.data, request, 8);
  drivecheck::cia301::SdoClient client(bus, kNode);

  std::vector<Mode> modes = {
      {"a. raw socket -> drivecheck drive",
       [&](Clock::duration l) {
         drain(sdo_raw);
         return timed_round(l, [&] {
           can_frame in{};
           return raw_exchange(sdo_raw, upload, 0x580 + kNode, in) && in.data[0] == 0x43 &&
                  in.data[4] == 0x92 && in.data[5] == 0x01 && in.data[6] == 0x02;
         });
       },
       {}},
      {"b. SdoClient -> drivecheck drive",
       [&](Clock::duration l) {
         return timed_round(l, [&] {
           const auto value = client.upload_value<std::uint32_t>({0x1000, 0});
           return value && *value == 0x00020192u;
         });
       },
       {}},
      {"c. raw socket -> raw echo (baseline)",
       [&](Clock::duration l) {
         can_frame out = upload;
         out.can_id = kEchoRequest;
         drain(echo_raw);
         return timed_round(l, [&] {
           can_frame in{};
           return raw_exchange(echo_raw, out, kEchoRequest + 1, in) &&
                  std::memcmp(in.data, out.data, 8) == 0;
         });
       },
       {}},
  };
  for (auto& mode : modes) {  // warm-up
    if (!mode.round(200ms)) {
      fmt::print(stderr, "bench: {}: a round trip failed\n", mode.name);
      return 1;
    }
  }
  for (int i = 0; i < rounds; ++i) {
    for (std::size_t k = 0; k < modes.size(); ++k) {
      Mode& mode = modes[(k + static_cast<std::size_t>(i)) % modes.size()];
      const auto round = mode.round(length);
      if (!round) {
        fmt::print(stderr, "bench: {}: a round trip failed\n", mode.name);
        return 1;
      }
      mode.rounds.push_back(*round);
    }
  }
  fmt::print("\nexpedited SDO round trips over vcan0, median of {} rounds of {} ms:\n", rounds,
             std::chrono::duration_cast<std::chrono::milliseconds>(length).count());
  for (const auto& mode : modes) {
    fmt::print("  {:38} {:6.0f}/s   p50 {:6.1f} us   p99 {:7.1f} us\n", mode.name,
               median_of(mode.rounds, &Round::per_second), median_of(mode.rounds, &Round::p50_us),
               median_of(mode.rounds, &Round::p99_us));
  }
  fmt::print("  a/c: {:.1f}% of the baseline's round trips per second\n",
             100 * median_of(modes[0].rounds, &Round::per_second) /
                 median_of(modes[2].rounds, &Round::per_second));

  can_frame quit{};
  quit.can_id = drivecheck::vm::quit_frame().id | CAN_EFF_FLAG;
  [[maybe_unused]] const auto n = ::write(echo_raw, &quit, sizeof quit);
  const int drive_status = drive->stop(SIGTERM, 3000ms);
  const int echo_status = echo->wait(3s);
  ::close(sdo_raw);
  ::close(echo_raw);
  if (drive_status != 0 || echo_status != 0) {
    fmt::print(stderr, "bench: drivecheck drive exit {}, echo peer exit {}\n", drive_status,
               echo_status);
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (const int status = drivecheck::vm::run_peer_if_asked(argc, argv); status >= 0) return status;
  const std::string drivecheck = drivecheck::vm::take_drivecheck_path(argc, argv);
  const int rounds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  const double seconds = argc > 2 ? std::atof(argv[2]) : 1.0;
  return run(drivecheck, rounds,
             std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds)));
}

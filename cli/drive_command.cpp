// drivecheck drive: the reference drive serving a real CAN interface, as a stand-in device
// for testing masters and PLCs.
//
//   drivecheck drive --bus socketcan:IF --node N [--store FILE] [--profile NAME|FILE]
//                    [--deviation NAME...]
//   drivecheck drive --bus ethercat:IF --node N ...   (the same drive as an EtherCAT slave)
//
// With ethercat:IF the drive sits behind an emulated EtherCAT slave controller
// (reference_drive/ethercat/ethercat_drive.hpp) on a raw Ethernet interface (AF_PACKET: a NIC
// or a veth end; needs root or CAP_NET_RAW): every EtherCAT frame arriving there is processed
// and sent back, as the last slave of a line does. --node has no meaning there (the master
// gives station addresses); `ethercat:sim` is refused (a simulated segment has no outside).
//
// The drive (reference_drive/servo_drive.hpp: the CiA 301 device with the CiA 402 application)
// powers on (boot-up message), then serves SDO, NMT, heartbeat/guarding, EMCY, SYNC, PDOs and
// the power drive system until SIGINT or SIGTERM, which stop the bus loop (Bus::stop(),
// async-signal-safe) and end the program with exit 0. --profile takes a drive profile
// (vectors/drives/NAME.yaml, or a file) and makes the drive behave as that manual documents;
// what the reference drive cannot show of it is listed on stderr. --deviation injects named
// deviations (reference_drive/deviations.inc; repeatable, or comma-separated). With --store,
// 1010h saves parameters to FILE (atomically) and they are applied at power on and after
// resets; without it they live in memory until the program ends. Exit 2: bad options, an
// unknown personality or deviation, an interface that cannot be opened, an unreadable FILE
// ("file:line: message"). Exit 3: the interface failed while serving.
#include <fmt/format.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "cli/options.hpp"
#include "cli/signal_scope.hpp"
#include "cli/vector_dirs.hpp"
#include "protocol/can/candump_log.hpp"
#include "protocol/can/socketcan_bus.hpp"
#include "protocol/ethercat/raw_link.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"
#include "reference_drive/parameter_file.hpp"
#include "reference_drive/servo_drive.hpp"

namespace drivecheck::cli {
namespace {

struct DriveOptions {
  std::string bus;
  int node = 0;
  std::string store;
  std::string personality;
  std::vector<std::string> vectors;  // --vectors DIR: where else --profile NAME is looked up
  std::string old_personality;       // --personality, the deprecated name of --profile
  std::vector<std::string> deviations;
};

// The bus the signal handlers stop; set only while the loop runs.
std::atomic<can::Bus*> g_running_bus{nullptr};
std::atomic<ethercat::Link*> g_running_link{nullptr};
volatile sig_atomic_t g_signal = 0;

extern "C" void stop_on_signal(int signal_number) {
  g_signal = signal_number;
  if (can::Bus* bus = g_running_bus.load()) bus->stop();
  if (ethercat::Link* link = g_running_link.load()) link->stop();
}

constexpr std::string_view kEthercatPrefix = "ethercat:";

// The interface of `ethercat:IF`, or nullopt for any other bus.
std::optional<std::string_view> ethercat_interface(std::string_view bus) {
  if (bus.substr(0, kEthercatPrefix.size()) != kEthercatPrefix) return std::nullopt;
  return bus.substr(kEthercatPrefix.size());
}

// The reference drive as an EtherCAT slave on a raw interface, until a signal stops it.
void serve_ethercat(const DriveOptions& options, std::string_view interface,
                    const profile::DriveProfile* personality,
                    const reference_drive::DeviationSet& deviations,
                    cia301::ParameterStorage* storage) {
  if (interface == "sim") {
    usage_error("drive",
                "--bus ethercat:sim has no meaning for drive (the simulated segment has "
                "no outside): serve an interface with ethercat:IF");
  }
  auto link = ethercat::RawLink::open(interface);
  if (!link) usage_error("drive", ethercat::describe_open_error(interface, link.error()));
  reference_drive::ethercat::EthercatDriveOptions config;
  config.profile = personality;
  config.deviations = deviations;
  config.storage = storage;
  auto drive = reference_drive::ethercat::EthercatDrive::create(**link, std::move(config));
  if (!drive) {
    fmt::print(stderr, "drivecheck drive: {}\n", drive.error());
    exit_with(kExitUsage);
    return;
  }
  for (const std::string& line : (*drive)->servo().not_applied()) {
    fmt::print(stderr, "drivecheck drive: personality {}: not shown: {}\n", personality->name,
               line);
  }
  fmt::print(stderr, "drivecheck drive: EtherCAT slave on {}{}{}{}; Ctrl-C stops\n", options.bus,
             personality ? ", personality " + personality->name : std::string(),
             deviations.empty() ? std::string() : ", deviations " + deviations.names(),
             options.store.empty() ? "" : ", parameters in " + options.store);
  {
    SignalScope signals(stop_on_signal);
    g_signal = 0;
    g_running_link.store(link->get());
    (*drive)->serve(**link);
    (*drive)->power_on();
    (*link)->run_until(ethercat::kForever);
    g_running_link.store(nullptr);
  }
  const auto& stats = (*link)->stats();
  if (g_signal != 0) {
    fmt::print(stderr, "drivecheck drive: stopped by signal {} ({} frames received, {} sent)\n",
               static_cast<int>(g_signal), stats.frames_received, stats.frames_sent);
    return;
  }
  const std::error_code error = (*link)->last_error();
  fmt::print(stderr, "drivecheck drive: the link loop ended: {}\n",
             error ? error.message() : std::string("no reason given"));
  exit_with(kExitDutLost);
}

void run_drive(const DriveOptions& options) {
  const auto ethercat = ethercat_interface(options.bus);
  const auto spec = parse_bus_spec(options.bus);
  if (!ethercat && (!spec || spec->kind != BusSpec::Kind::socketcan)) {
    usage_error("drive",
                "--bus must be socketcan:IF or ethercat:IF: the reference drive serves a real bus");
  }

  // Bad names are bad input: report them before touching the bus.
  // A user's --vectors directories are linted as run lints them; --profile NAME is looked up
  // there too.
  const VectorDirs dirs = vector_dirs(options.vectors);
  lint_user_dirs_or_exit(dirs, "drive");
  std::optional<profile::DriveProfile> personality;
  if (!options.personality.empty()) {
    auto loaded = find_profile(options.personality, dirs);
    if (!loaded) usage_error("drive", "--profile: " + loaded.error().to_string());
    personality = std::move(*loaded);
  }
  auto deviations = reference_drive::DeviationSet::parse(options.deviations);
  if (!deviations) usage_error("drive", "--deviation: " + deviations.error());

  std::unique_ptr<reference_drive::FileParameterStorage> storage;
  if (!options.store.empty()) {
    storage = std::make_unique<reference_drive::FileParameterStorage>(options.store);
    // A bad file is bad input: report it before touching the bus.
    if (auto stored = storage->read(); !stored) {
      fmt::print(stderr, "{}\n", stored.error());
      exit_with(kExitUsage);
      return;
    }
  }

  if (ethercat) {
    serve_ethercat(options, *ethercat, personality ? &*personality : nullptr, *deviations,
                   storage.get());
    return;
  }

  auto bus = can::SocketCanBus::open(spec->interface);
  if (!bus) usage_error("drive", can::describe_open_error(spec->interface, bus.error()));

  reference_drive::ServoDriveOptions config;
  config.node = static_cast<std::uint8_t>(options.node);
  config.profile = personality ? &*personality : nullptr;
  config.deviations = *deviations;
  config.storage = storage.get();
  auto drive = reference_drive::ServoDrive::create(**bus, std::move(config));
  if (!drive) {
    fmt::print(stderr, "drivecheck drive: {}\n", drive.error());
    exit_with(kExitUsage);
    return;
  }
  for (const std::string& line : (*drive)->not_applied()) {
    fmt::print(stderr, "drivecheck drive: personality {}: not shown: {}\n", personality->name,
               line);
  }

  fmt::print(stderr, "drivecheck drive: node {} on {}{}{}{}; Ctrl-C stops\n", options.node,
             options.bus, personality ? ", personality " + personality->name : std::string(),
             deviations->empty() ? std::string() : ", deviations " + deviations->names(),
             options.store.empty() ? "" : ", parameters in " + options.store);
  {
    SignalScope signals(stop_on_signal);
    g_signal = 0;
    g_running_bus.store(bus->get());
    (*drive)->power_on();
    (*bus)->run_until(can::kForever);
    g_running_bus.store(nullptr);
  }
  const auto& stats = (*bus)->stats();
  if (g_signal != 0) {
    fmt::print(stderr, "drivecheck drive: stopped by signal {} ({} frames sent, {} received)\n",
               static_cast<int>(g_signal), stats.frames_sent, stats.frames_received);
    return;
  }
  const std::error_code error = (*bus)->last_error();
  fmt::print(stderr, "drivecheck drive: the bus loop ended: {}\n",
             error ? error.message() : std::string("no reason given"));
  exit_with(kExitDutLost);
}

}  // namespace

void add_drive_command(CLI::App& app) {
  auto options = std::make_shared<DriveOptions>();
  CLI::App* cmd = app.add_subcommand(
      "drive", "Run the reference drive (CiA 301 + CiA 402 device) on a real CAN interface");
  cmd->add_option("--bus", options->bus,
                  "The CAN interface to serve, or the Ethernet interface for the drive as an "
                  "EtherCAT slave")
      ->required()
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            const auto ethercat = ethercat_interface(value);
            if (!ethercat) return bus_validator()(value);
            if (ethercat->empty() || ethercat->size() > can::kMaxInterfaceNameLength) {
              return fmt::format("interface name '{}' must have 1..{} characters", *ethercat,
                                 can::kMaxInterfaceNameLength);
            }
            return std::string();
          },
          "socketcan:IF|ethercat:IF"))
      ->type_name("socketcan:IF|ethercat:IF");
  cmd->add_option("--node", options->node, "Node id of the drive")
      ->required()
      ->check(CLI::Range(kMinNodeId, kMaxNodeId));
  cmd->add_option("--store", options->store,
                  "Keep stored parameters (1010h/1011h) in this file (default: in memory)")
      ->type_name("FILE");
  cmd->add_option("--profile", options->personality,
                  "Behave as the drive of this profile (drivecheck profiles: cia402-reference, "
                  "festo-cmmp, kollmorgen-s300-s700, irtsa-drive-fb, esr-triodrive; or a file)")
      ->type_name("NAME|FILE");
  // The old name of --profile (run and fuzz call it --profile): still taken, with a warning.
  cmd->add_option("--personality", options->old_personality, "Deprecated: use --profile")
      ->type_name("NAME|FILE")
      ->group("");
  cmd->add_option("--deviation", options->deviations,
                  "Inject a named deviation (repeatable or comma-separated; see "
                  "reference_drive/deviations.inc)")
      ->type_name("NAME");
  add_vectors_option(*cmd, options->vectors);
  cmd->callback([options, cmd] {
    if (!options->old_personality.empty()) {
      warn_deprecated_option("drive", "--personality", "--profile");
      if (cmd->count("--profile") == 0) options->personality = options->old_personality;
    }
    run_drive(*options);
  });
}

}  // namespace drivecheck::cli

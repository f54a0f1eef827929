// drivecheck run: the conformance suite against a drive. With no options, the embedded
// default: the reference drive on the simulated bus (1 Mbit/s), every shipped vector
// (cli/data_dir.hpp), reports under reports/out/ (report.html, junit.xml, report.json).
//
// Reports: when none of --junit/--html/--json is given, all three go to reports/out/ relative
// to the current directory; otherwise exactly the ones given are written.
// Exit codes: conformance::exit_code() (0 pass, 1 fail, 3 DUT lost, 130 interrupted), 2 for bad
// input (vector or profile errors with file:line, an unreadable EDS, a bus that cannot open).
#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "cli/embedded_drive.hpp"
#include "cli/options.hpp"
#include "cli/signal_scope.hpp"
#include "cli/vector_dirs.hpp"
#include "conformance/capabilities.hpp"
#include "conformance/engine.hpp"
#include "conformance/esi_checks.hpp"
#include "conformance/ethercat_port.hpp"
#include "conformance/od_checks.hpp"
#include "conformance/provenance.hpp"
#include "conformance/sha256.hpp"
#include "conformance/stall_log.hpp"
#include "conformance/vector_file.hpp"
#include "conformance/vector_lint.hpp"
#include "conformance/vector_order.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/can/socketcan_bus.hpp"
#include "protocol/can/trace_recorder.hpp"
#include "protocol/cia301/nmt_master.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_lint.hpp"
#include "protocol/ethercat/esi.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/pcap.hpp"
#include "protocol/ethercat/raw_link.hpp"
#include "protocol/ethercat/recording_link.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reports/report_writers.hpp"

#ifndef DRIVECHECK_VERSION
#error "DRIVECHECK_VERSION must be defined by the build (cli/CMakeLists.txt)"
#endif

namespace drivecheck::cli {
namespace {

constexpr std::string_view kEthercatSim = "ethercat:sim";
constexpr std::string_view kEthercatPrefix = "ethercat:";

// The interface of `ethercat:IF` (not `ethercat:sim`), or nullopt for any other bus.
std::optional<std::string> ethercat_interface(std::string_view bus) {
  if (bus.substr(0, kEthercatPrefix.size()) != kEthercatPrefix || bus == kEthercatSim)
    return std::nullopt;
  return std::string(bus.substr(kEthercatPrefix.size()));
}

// `--bus ethercat:IF`: the DUT is slave 0 (position 0) of the segment behind an AF_PACKET link
// on IF (a NIC wired to the slaves, or a veth end with `drivecheck drive --bus ethercat:PEER` on
// the other side), brought up to PREOP by the master; the engine talks CoE through the
// EtherCAT port and takes its time from the link's clock (the process data cycle runs in it).
// Every wait is bounded by the master's timeouts: a silent link ends the bring-up with an
// error, or the run's SDOs with "no answer" (and the run with DUT lost), never in a hang.
struct EthercatTarget {
  std::unique_ptr<ethercat::RawLink> raw;
  // With --pcap: the raw link behind a recorder (every frame sent and received), else null.
  std::unique_ptr<ethercat::RecordingLink> recording;
  ethercat::Link* link = nullptr;  // what the master and the clock use: recording or raw
  std::unique_ptr<ethercat::Master> master;
  std::unique_ptr<conformance::EthercatPort> port;
  std::unique_ptr<conformance::EthercatClock> clock;
};

// `pcap` (with --pcap) is created here, on the link's clock (CLOCK_MONOTONIC + its Unix
// offset), and records from the first frame of the bring-up; the caller keeps it alive longer
// than the target.
std::unique_ptr<EthercatTarget> open_ethercat(const std::string& interface,
                                              const std::string& pcap_path,
                                              std::unique_ptr<ethercat::PcapWriter>& pcap) {
  auto target = std::make_unique<EthercatTarget>();
  auto link = ethercat::RawLink::open(interface);
  if (!link) usage_error("run", ethercat::describe_open_error(interface, link.error()));
  target->raw = std::move(*link);
  target->link = target->raw.get();
  if (!pcap_path.empty()) {
    pcap = std::make_unique<ethercat::PcapWriter>(pcap_path, target->raw->unix_offset());
    if (!pcap->ok()) usage_error("run", pcap->error());
    target->recording = std::make_unique<ethercat::RecordingLink>(
        *target->raw, [writer = pcap.get()](const ethercat::TimedFrame& frame,
                                            ethercat::FrameDirection) { writer->write(frame); });
    target->link = target->recording.get();
  }
  ethercat::MasterConfig config;
  // A real link: the answer comes from another process or machine, which a loaded host may
  // not schedule within the simulated segment's 2 ms.
  config.port.response_timeout = std::chrono::milliseconds(20);
  config.sii.timeout = std::chrono::milliseconds(500);
  target->master = std::make_unique<ethercat::Master>(*target->link, config);
  if (auto up = target->master->bring_up(ethercat::AlState::preop); !up) {
    fmt::print(stderr, "drivecheck run: EtherCAT bring-up to PREOP on {} failed: {}\n", interface,
               up.error().message());
    exit_with(kExitDutLost);
  }
  if (target->master->slaves().size() > 1) {
    fmt::print(stderr,
               "drivecheck run: {} EtherCAT slaves on {}: the one at position 0 (station "
               "{:04X}h) is tested\n",
               target->master->slaves().size(), interface,
               target->master->slaves()[0].info.station);
  }
  target->port = std::make_unique<conformance::EthercatPort>(*target->master);
  target->clock = std::make_unique<conformance::EthercatClock>(*target->link, *target->port);
  return target;
}

struct RunOptions {
  std::string bus = "sim";
  int node = 1;
  std::string profile;  // empty: chosen (cia402-reference on sim, from 1000h on a real bus)
  std::string eds;
  std::string esi;
  std::vector<std::string> filters;
  std::vector<std::string> levels;
  std::string rerun;
  bool strict = false;
  bool allow_motion = false;
  bool allow_factory_restore = false;
  std::uint64_t seed = 1;
  std::string order = "file";
  std::string junit;
  std::string html;
  std::string json;
  std::string trace;
  std::string pcap;
  std::vector<std::string> vectors;  // --vectors DIR: a user's own, beside the shipped ones
  std::vector<std::string> deviations;
  std::string color = "auto";
};

// SIGINT/SIGTERM from the start of the run: before the engine exists (while the vectors load)
// the handler only notes it; the run then stops before touching the bus, writing nothing.
std::atomic<bool> g_interrupted{false};
std::atomic<conformance::Engine*> g_engine{nullptr};

extern "C" void interrupt_run(int) {
  g_interrupted.store(true);
  if (auto* engine = g_engine.load()) engine->interrupt();
}

// The engine the signal handlers interrupt, set while the run goes on. A signal that came
// before it was set interrupts it at once.
class InterruptScope {
 public:
  explicit InterruptScope(conformance::Engine& engine) {
    g_engine.store(&engine);
    if (g_interrupted.load()) engine.interrupt();
  }
  ~InterruptScope() { g_engine.store(nullptr); }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;
};

// Interrupted before the run began: exit 130, no report (nothing was run).
void exit_if_interrupted(std::string_view while_doing) {
  if (!g_interrupted.load()) return;
  fmt::print(stderr, "drivecheck run: interrupted while {}; nothing was run, no report written\n",
             while_doing);
  exit_with(kExitInterrupted);
}

// Whether `vector` is selected by one of the --filter values (none: all): a glob over the id
// ("cia402/fsa/*"), or a family as the reports' matrix names it ("cia301/sdo"), or a glob over
// the family ("cia301/*").
bool selected_by_filters(const std::vector<std::string>& filters,
                         const conformance::Vector& vector) {
  if (filters.empty()) return true;
  const std::string family = vector.family();
  return std::any_of(filters.begin(), filters.end(), [&](const std::string& filter) {
    return profile::glob_match(filter, vector.id) || profile::glob_match(filter, family);
  });
}
bool selected_by_filters(const std::vector<std::string>& filters, std::string_view id) {
  conformance::Vector probe;
  probe.id = std::string(id);
  return selected_by_filters(filters, probe);
}

// The ids a report lists as fail or error (--rerun).
std::set<std::string> failed_ids(const std::string& report_file) {
  auto report = reports::read_json_report(report_file);
  if (!report) {
    fmt::print(stderr, "{}\n", report.error().to_string());
    exit_with(kExitUsage);
    return {};
  }
  std::set<std::string> ids;
  for (const auto& vector : report->vectors) {
    if (vector.verdict == conformance::Verdict::fail ||
        vector.verdict == conformance::Verdict::error)
      ids.insert(vector.id);
  }
  return ids;
}

[[noreturn]] void bad_input(const std::string& message) {
  fmt::print(stderr, "{}\n", message);
  exit_with(kExitUsage);
  std::abort();  // exit_with(non-zero) throws
}

void run(const RunOptions& options) {
  g_interrupted.store(false);
  const SignalScope signals(interrupt_run);
  // `ethercat:sim`: the reference drive as an EtherCAT slave on a simulated segment, the vectors
  // through CoE (conformance/ethercat_port.hpp); otherwise simulated like `sim`.
  const bool ethercat_sim = options.bus == kEthercatSim;
  // `ethercat:IF`: a real EtherCAT link (open_ethercat).
  const auto ethercat_if = ethercat_interface(options.bus);
  const auto spec = ethercat_sim || ethercat_if ? Expected<BusSpec, std::string>(BusSpec{})
                                                : parse_bus_spec(options.bus);
  if (!spec) usage_error("run", spec.error());
  const bool sim = spec->kind == BusSpec::Kind::sim && !ethercat_if;
  // EtherCAT has no CAN frames for a candump log: its trace is the pcap (and `drivecheck
  // decode` of it the text form).
  if ((ethercat_sim || ethercat_if) && !options.trace.empty())
    usage_error("run",
                "--trace writes a candump log of CAN frames; on --bus ethercat use --pcap "
                "FILE.pcap (`drivecheck decode FILE.pcap` prints it as text)");
  // An EDS (CiA 306) describes a device's CANopen interface: over EtherCAT the same drive has
  // the CoE objects (1C00h-1C33h) and the PDO defaults of its ESI (ETG.2000), so the live
  // checks against the EDS would judge the wrong description. drivecheck reads no ESI yet.
  if ((ethercat_sim || ethercat_if) && !options.eds.empty())
    usage_error("run",
                "--eds checks a device against its EDS, which describes the CANopen interface; "
                "over EtherCAT the description is the device's ESI: give it with --esi FILE "
                "(lint the EDS on its own: drivecheck eds lint FILE)");
  // An ESI (ETG.2000) describes an EtherCAT slave: on CAN the description is the EDS.
  if (!ethercat_sim && !ethercat_if && !options.esi.empty())
    usage_error("run",
                "--esi checks an EtherCAT slave against its ESI (ETG.2000); it needs --bus "
                "ethercat:sim or ethercat:IF (on CAN give the device's EDS with --eds FILE)");
  auto order = conformance::parse_vector_order(options.order);
  if (!order) usage_error("run", order.error());
  // `shuffle` alone: a seed drawn here, recorded in the reports so that the run can be repeated.
  if (order->kind == conformance::VectorOrder::Kind::shuffle && !order->seed) {
    std::random_device entropy;
    order->seed = (std::uint64_t{entropy()} << 32) | entropy();
  }
  if (!sim && !options.deviations.empty())
    usage_error("run", "--deviation injects faults into the embedded drive: only with --bus sim");
  std::optional<std::set<std::string>> rerun_ids;
  if (!options.rerun.empty()) rerun_ids = failed_ids(options.rerun);
  // A result judged from a file (the EDS lint, the ESI's SII checks) that --filter, --level or
  // --rerun leaves out.
  const auto result_deselected = [&](const conformance::VectorResult& result) {
    if (!selected_by_filters(options.filters, result.id)) return true;
    if (!options.levels.empty() &&
        std::find(options.levels.begin(), options.levels.end(),
                  conformance::to_string(result.level)) == options.levels.end())
      return true;
    return rerun_ids && !rerun_ids->contains(result.id);
  };

  // Vectors, profile, EDS: all bad input is reported before the bus is touched.
  // The shipped tree and the user's --vectors directories (cli/vector_dirs.hpp).
  const VectorDirs dirs = vector_dirs(options.vectors);
  const std::filesystem::path& vectors_dir = dirs.tree;
  // Every vector and profile loaded is linted as `drivecheck vectors lint` does (schema, ids,
  // sources, profiles, collisions with the user's directories, the user's manuals); the
  // shipped manuals' sha256 is lint's business, not the run's.
  auto vectors = lint(dirs, std::nullopt);
  const std::string lint_command =
      fmt::format("drivecheck vectors lint {}{}", vectors_dir.string(), dirs.user_arguments());
  // Warnings do not stop a run; they are counted here and listed by `drivecheck vectors lint`
  // (every run would otherwise repeat the same list before its verdicts).
  if (!vectors.warnings.empty()) {
    fmt::print(stderr, "drivecheck run: {} lint warning(s) in the vectors ({})\n",
               vectors.warnings.size(), lint_command);
  }
  if (!vectors.ok()) {
    for (const auto& error : vectors.errors)
      fmt::print(stderr, "{}\n", error.to_string());
    fmt::print(stderr, "drivecheck run: {} error(s) in the vectors ({})\n", vectors.errors.size(),
               lint_command);
    exit_with(kExitUsage);
    return;
  }
  exit_if_interrupted("loading the vectors");
  // The profile: as given; else the embedded default on the simulated bus; else chosen from the
  // DUT's 1000h once the bus is open (choose_generic_profile, below).
  const std::string first_profile = !options.profile.empty() ? options.profile
                                    : sim                    ? "cia402-reference"
                                                             : "cia301-device";
  auto profile = find_profile(first_profile, dirs);
  if (!profile) bad_input(profile.error().to_string());
  std::string profile_choice =
      !options.profile.empty() ? fmt::format("--profile {}", options.profile)
      : sim                    ? std::string(
                                     "the embedded default (--bus sim without --profile): the reference "
                                                        "drive's own profile")
            : std::string();

  std::optional<cia301::ObjectDictionary> eds_od;
  std::string eds_sha256;
  std::vector<std::string> eds_findings;
  std::vector<cia306::Diagnostic> eds_diagnostics;  // for the eds/lint results
  std::optional<conformance::EdsIdentity> eds_identity;
  bool eds_declares_dummy_u8 = false;  // [DummyUsage] Dummy0005=1: pdo.dummy-mapping
  if (!options.eds.empty()) {
    auto eds = cia306::read_eds_file(options.eds);
    if (!eds) bad_input(eds.error().to_string());
    // The EDS is linted first and every finding shown (as drivecheck eds lint prints them).
    // A file the reader cannot make sense of is refused; lint findings about what the EDS
    // describes (e.g. no error control) are shown and the run goes on: the drive is judged
    // on the bus, not by its EDS.
    auto findings = eds->diagnostics;
    for (auto& finding : cia306::lint_eds(eds->eds, options.eds))
      findings.push_back(std::move(finding));
    for (const auto& finding : findings) {
      fmt::print(stderr, "{}\n", finding.to_string());
      eds_findings.push_back(finding.to_string());
    }
    if (eds->has_errors()) {
      bad_input(fmt::format("drivecheck run: {} has errors (drivecheck eds lint {})", options.eds,
                            options.eds));
    }
    if (!findings.empty())
      fmt::print(stderr, "drivecheck run: {}: {} finding(s) above; the EDS is used\n", options.eds,
                 findings.size());
    auto od = cia306::to_object_dictionary(eds->eds, static_cast<std::uint8_t>(options.node),
                                           options.eds);
    if (!od) {
      for (const auto& d : od.error())
        fmt::print(stderr, "{}\n", d.to_string());
      bad_input(fmt::format("drivecheck run: {} does not give an object dictionary", options.eds));
    }
    eds_od.emplace(std::move(*od));
    eds_diagnostics = std::move(findings);
    eds_declares_dummy_u8 = eds->eds.dummy_usage[0x0005].value_or(false);
    const auto& device_info = eds->eds.device_info;
    eds_identity = conformance::EdsIdentity{device_info.vendor_number, device_info.product_number,
                                            device_info.revision_number};
    eds_sha256 = conformance::sha256_file(options.eds).value_or("");
  }

  // The ESI (--esi, EtherCAT only): read before the bus is touched; its device is chosen once
  // the master has read the slave's SII (below).
  std::optional<ethercat::EsiFile> esi;
  std::string esi_sha256;
  std::optional<conformance::EsiDeviceIdentity> esi_identity;
  if (!options.esi.empty()) {
    auto read = ethercat::read_esi_file(options.esi);
    if (!read) bad_input(fmt::format("drivecheck run: {}", read.error().to_string()));
    esi.emplace(std::move(*read));
    esi_sha256 = conformance::sha256_file(options.esi).value_or("");
  }

  // The bus: the embedded drive on a simulated bus, or a real interface.
  std::unique_ptr<ethercat::PcapWriter> ethercat_pcap;  // outlives the segment that feeds it
  std::unique_ptr<can::SimBus> sim_bus;
  std::unique_ptr<can::SimPort> sim_port;
  std::unique_ptr<EmbeddedDrive> drive;
  std::unique_ptr<can::SocketCanBus> socket_bus;
  std::unique_ptr<EmbeddedEthercat> ethercat_drive;
  std::unique_ptr<EthercatTarget> ethercat_target;
  can::Bus* port = nullptr;
  if (ethercat_if) {
    // --pcap on a real link: what the harness sends and receives on it (frames of others on
    // the wire are not seen: the socket takes EtherType 88A4h addressed to it).
    ethercat_target = open_ethercat(*ethercat_if, options.pcap, ethercat_pcap);
    port = ethercat_target->clock.get();
  } else if (ethercat_sim) {
    // --pcap on EtherCAT: every frame of the segment (sent and returned) from the first frame of
    // the bring-up, at the segment's time + its Unix offset (0 on the simulated segment, as on
    // --bus sim: simulated time 0 is 1970-01-01); flushed after every vector.
    EmbeddedEthercat::Monitor monitor;
    if (!options.pcap.empty()) {
      ethercat_pcap = std::make_unique<ethercat::PcapWriter>(
          options.pcap, ethercat::SimSegmentConfig{}.unix_offset);
      if (!ethercat_pcap->ok()) usage_error("run", ethercat_pcap->error());
      monitor = [writer = ethercat_pcap.get()](const ethercat::TimedFrame& frame,
                                               ethercat::FrameDirection) { writer->write(frame); };
    }
    auto created = EmbeddedEthercat::create(*profile, options.deviations, std::move(monitor));
    if (!created) usage_error("run", created.error());
    ethercat_drive = std::move(*created);
    port = &ethercat_drive->clock();
  } else if (sim) {
    sim_bus = std::make_unique<can::SimBus>(
        can::SimBusConfig{.bitrate = 1'000'000, .seed = options.seed});
    sim_port = sim_bus->attach("harness");
    auto created = EmbeddedDrive::create(*sim_bus, static_cast<std::uint8_t>(options.node),
                                         *profile, options.deviations);
    if (!created) usage_error("run", created.error());
    drive = std::move(*created);
    port = sim_port.get();
  } else {
    auto opened = can::SocketCanBus::open(spec->interface);
    if (!opened) usage_error("run", can::describe_open_error(spec->interface, opened.error()));
    socket_bus = std::move(*opened);
    port = socket_bus.get();
  }

  // Traces: the whole simulated wire, or what the harness port sees on a real bus.
  std::unique_ptr<can::TraceRecorder> recorder;
  std::unique_ptr<can::RecordingBus> recording;
  if (!ethercat_sim && !ethercat_if && (!options.trace.empty() || !options.pcap.empty())) {
    auto opened = can::TraceRecorder::open(
        {options.trace, options.pcap},
        {.interface = sim ? "sim" : spec->interface, .unix_offset = port->unix_offset()});
    if (!opened) usage_error("run", opened.error());
    recorder = std::move(*opened);
    if (sim) {
      sim_bus->add_monitor(recorder->monitor());
    } else {
      recording = std::make_unique<can::RecordingBus>(*port, *recorder);
      port = recording.get();
    }
  }

  // A real bus without --profile: 1000h says what the DUT is (CiA 301 §7.5.2.1: bits 0..15 the
  // device profile number).
  if (options.profile.empty() && !sim) {
    // EtherCAT: the master brought the slave to PREOP already.
    if (!ethercat_target)
      (void)port->send(cia301::NmtMaster().command(cia301::NmtCommand::enter_pre_operational,
                                                   static_cast<std::uint8_t>(options.node)));
    conformance::EngineOptions probe_options;
    probe_options.node = static_cast<std::uint8_t>(options.node);
    probe_options.real_bus = true;
    std::optional<std::uint32_t> device_type;
    {
      std::optional<conformance::Engine> probe;
      if (ethercat_target)
        probe.emplace(*port, *ethercat_target->port, *profile, probe_options);
      else
        probe.emplace(*port, *profile, probe_options);
      device_type = probe->read_device_type();
    }
    const auto choice = conformance::choose_generic_profile(device_type);
    if (choice.name != profile->name) {
      profile = find_profile(choice.name, dirs);
      if (!profile) bad_input(profile.error().to_string());
    }
    profile_choice = choice.why;
  }
  fmt::print("drivecheck run: profile {} ({})\n", profile->name, profile_choice);
  // The device declares dummy mapping in its EDS (CiA 306 [DummyUsage] Dummy0005=1, the
  // UNSIGNED8 dummy the vectors map): judged as a claim of pdo.dummy-mapping (FORMAT.md).
  if (eds_declares_dummy_u8 && !profile->supports("pdo.dummy-mapping")) {
    profile->features.insert("pdo.dummy-mapping");
    fmt::print(
        "drivecheck run: {} declares dummy mapping ([DummyUsage] Dummy0005=1): "
        "pdo.dummy-mapping is taken as claimed\n",
        options.eds);
  }

  // EDS-driven object dictionary checks (family eds/od) from the EDS and the profile's objects.
  auto od_vectors =
      conformance::generate_od_vectors(eds_od ? &*eds_od : nullptr, options.eds, *profile,
                                       eds_identity, static_cast<std::uint8_t>(options.node));
  for (auto& vector : od_vectors)
    vectors.vectors.push_back(std::move(vector));
  // The ESI cross-check (conformance/esi_checks.hpp): the ESI's device of the slave's SII
  // identity, its vectors, and the SII against it.
  std::vector<conformance::VectorResult> esi_results;
  if (esi) {
    ethercat::Master& master = ethercat_drive ? ethercat_drive->master() : *ethercat_target->master;
    const ethercat::SiiHeader& sii = master.slaves().at(0).sii.image.header;
    const ethercat::EsiDevice* device =
        ethercat::find_esi_device(*esi, sii.product_code, sii.revision);
    if (device == nullptr && esi->devices.size() == 1) device = &esi->devices.front();
    if (device == nullptr) {
      std::vector<std::string> described;
      for (const auto& d : esi->devices)
        described.push_back(fmt::format("{:08X}h (line {})", d.product_code, d.line));
      bad_input(fmt::format(
          "drivecheck run: {} describes no device with the slave's product code {:08X}h (SII "
          "words 0Ah-0Bh); it describes {}",
          options.esi, sii.product_code, fmt::join(described, ", ")));
    }
    esi_identity = conformance::EsiDeviceIdentity{
        esi->vendor_id, device->product_code, device->revision_number, device->name, device->line};
    fmt::print(
        "drivecheck run: ESI {} (sha256 {}): device '{}' ({}:{}): vendor ID {:08X}h, product "
        "code {:08X}h, revision {:08X}h; {} object(s), {} RxPDO(s), {} TxPDO(s)\n",
        options.esi, esi_sha256, device->name, options.esi, device->line, esi->vendor_id,
        device->product_code, device->revision_number, device->objects.size(),
        device->rx_pdos.size(), device->tx_pdos.size());
    for (auto& vector : conformance::generate_esi_vectors(*esi, *device))
      vectors.vectors.push_back(std::move(vector));
    esi_results = conformance::esi_sii_results(*esi, *device, sii, *profile, options.strict);
    for (auto& result :
         conformance::esi_pdo_mapping_results(*esi, *device, *profile, options.strict))
      esi_results.push_back(std::move(result));
    std::erase_if(esi_results, result_deselected);
  }
  // The selection first, then its order: a shuffle depends on the seed and the selection only.
  std::erase_if(vectors.vectors, [&](const conformance::Vector& vector) {
    if (!selected_by_filters(options.filters, vector)) return true;
    if (!options.levels.empty() &&
        std::find(options.levels.begin(), options.levels.end(),
                  conformance::to_string(vector.level)) == options.levels.end())
      return true;
    return rerun_ids && !rerun_ids->contains(vector.id);
  });
  const std::string probe_id = "eds/od/undocumented-objects";
  const bool run_probe =
      eds_od && selected_by_filters(options.filters, probe_id) &&
      (options.levels.empty() ||
       std::find(options.levels.begin(), options.levels.end(), "must") != options.levels.end()) &&
      (!rerun_ids || rerun_ids->contains(probe_id));
  // The EDS itself (CTT 1.0): one result per lint rule, judged from the file (no bus).
  std::vector<conformance::VectorResult> lint_results;
  if (eds_od) {
    lint_results =
        conformance::eds_lint_results(eds_diagnostics, options.eds, *profile, options.strict);
    std::erase_if(lint_results, result_deselected);
  }
  for (auto& result : esi_results)
    lint_results.push_back(std::move(result));
  if (vectors.vectors.empty() && !run_probe && lint_results.empty()) {
    // An empty selection is no pass: say which part of the selection left nothing.
    std::vector<std::string> parts;
    for (const auto& filter : options.filters)
      parts.push_back("--filter " + filter);
    for (const auto& level : options.levels)
      parts.push_back("--level " + level);
    if (rerun_ids)
      parts.push_back(fmt::format("--rerun {} ({} failed)", options.rerun, rerun_ids->size()));
    fmt::print(stderr,
               "drivecheck run: no vector matches {} (drivecheck vectors list shows them)\n",
               parts.empty() ? std::string("(the vector set is empty)")
                             : fmt::format("{}", fmt::join(parts, " ")));
    exit_with(kExitUsage);
    return;
  }
  conformance::apply_order(vectors.vectors, *order);
  if (order->kind != conformance::VectorOrder::Kind::file)
    fmt::print("drivecheck run: vectors in {} order (repeat with --order {})\n",
               conformance::to_string(*order), conformance::to_string(*order));
  const std::size_t total = vectors.vectors.size() + lint_results.size();
  const auto color_mode = options.color == "always"  ? reports::ColorMode::always
                          : options.color == "never" ? reports::ColorMode::never
                                                     : reports::ColorMode::automatic;
  reports::ConsoleReporter console(stdout,
                                   reports::ConsoleOptions::detect(stdout, total, color_mode));

  conformance::EngineOptions engine_options;
  engine_options.node = static_cast<std::uint8_t>(options.node);
  engine_options.strict = options.strict;
  engine_options.allow_motion = options.allow_motion;
  engine_options.allow_factory_restore = options.allow_factory_restore;
  engine_options.real_bus = !sim;
  // The selection is made above (filters, levels, --rerun); the engine runs what it is given.
  engine_options.simulation = drive            ? drive->simulation()
                              : ethercat_drive ? ethercat_drive->simulation()
                                               : nullptr;
  engine_options.eds = eds_od ? &*eds_od : nullptr;
  // A real bus: a watcher thread notes the harness's own stalls (conformance/stall_log.hpp),
  // so that a busy host is never charged to the device: a check that fails in a vector during
  // which the harness stalled is `error: harness late`, and the vector runs again.
  std::optional<conformance::StallLog> stalls;
  std::optional<conformance::StallWatcher> stall_watcher;
  if (!sim) {
    stalls.emplace(std::chrono::milliseconds(1),
                   profile->timing_value("harness_slack").value_or(std::chrono::milliseconds(2)));
    engine_options.stalls = &*stalls;
    stall_watcher.emplace(
        *stalls, [port] { return port->now(); }, std::chrono::milliseconds(1));
  }
  engine_options.on_vector_started = [&](const conformance::Vector& v) {
    console.vector_started(v.id);
  };
  engine_options.on_vector_finished = [&](const conformance::VectorResult& r) {
    console.vector_finished(r);
    // An interrupted or killed run keeps every vector it finished in the pcap.
    if (ethercat_pcap) ethercat_pcap->flush();
  };

  conformance::RunInfo info;
  info.tool_version = DRIVECHECK_VERSION;
  // Provenance for the reports: the revision, the vector set's digest, the cited documents.
  info.revision = std::string(reports::build_revision());
  if (auto digest = conformance::vector_set_digest(dirs.all())) {
    info.vector_digest = digest->sha256;
    info.vector_files = digest->files;
  } else {
    bad_input("drivecheck run: " + digest.error());
  }
  info.documents = conformance::cited_documents(dirs.manual_lists());
  info.started_utc = utc_now();
  info.bus = options.bus;
  info.profile_file = profile->path.string();
  info.profile_choice = profile_choice;
  info.eds_file = options.eds;
  info.eds_sha256 = eds_sha256;
  info.eds_findings = std::move(eds_findings);
  info.esi_file = options.esi;
  info.esi_sha256 = esi_sha256;
  info.esi_device = esi_identity;
  info.seed = options.seed;
  info.order = conformance::to_string(*order);
  std::string selection_text = fmt::format("{}", fmt::join(options.filters, " "));
  for (const auto& level : options.levels)
    selection_text += (selection_text.empty() ? "level " : " level ") + level;
  if (rerun_ids) selection_text += (selection_text.empty() ? "" : " ") + ("rerun " + options.rerun);
  if (drive) {
    info.personality = drive->personality();
    info.deviations = drive->deviations();
  }
  if (ethercat_drive) {
    info.personality = ethercat_drive->personality();
    info.deviations = ethercat_drive->deviations();
  }

  conformance::RunResult result;
  {
    exit_if_interrupted("preparing the run");
    std::optional<conformance::Engine> engine_storage;
    if (ethercat_drive)
      engine_storage.emplace(*port, ethercat_drive->port(), *profile, std::move(engine_options));
    else if (ethercat_target)
      engine_storage.emplace(*port, *ethercat_target->port, *profile, std::move(engine_options));
    else
      engine_storage.emplace(*port, *profile, std::move(engine_options));
    conformance::Engine& engine = *engine_storage;
    InterruptScope interrupts(engine);
    // The simulated bus runs in this thread; if a simulated node livelocks (events at one
    // instant forever) nothing returns. A watchdog thread stops such a run (exit 3).
    std::jthread watchdog;
    if (sim) {
      watchdog = std::jthread([&engine](const std::stop_token& stop) {
        constexpr auto kTick = std::chrono::milliseconds(100);
        constexpr auto kStallLimit = std::chrono::seconds(10);
        auto last = engine.progress();
        auto still = std::chrono::milliseconds(0);
        while (!stop.stop_requested()) {
          std::this_thread::sleep_for(kTick);
          const auto progress = engine.progress();
          still = progress == last ? still + kTick : std::chrono::milliseconds(0);
          last = progress;
          if (still >= kStallLimit) {
            engine.declare_stalled();
            still = std::chrono::milliseconds(0);
          }
        }
      });
    }
    result = engine.run(vectors.vectors, std::move(info));
    result.info.filter = selection_text;
    if (!result.interrupted) {
      for (auto& lint_result : lint_results) {
        console.vector_started(lint_result.id);
        console.vector_finished(lint_result);
        result.vectors.push_back(std::move(lint_result));
      }
    }
    if (run_probe && !result.interrupted && !result.dut_lost) {
      console.vector_started(probe_id);
      result.vectors.push_back(engine.probe_undocumented_objects(
          [&eds_od](std::uint16_t index) { return eds_od->find(index) != nullptr; },
          fmt::format("EDS {}", options.eds)));
      console.vector_finished(result.vectors.back());
    }
  }
  console.finish(result);
  if (result.dut_lost)
    fmt::print(stderr, "drivecheck run: the drive stopped answering (node {} on {})\n",
               options.node, options.bus);

  // Reports.
  const bool defaults = options.junit.empty() && options.html.empty() && options.json.empty();
  const std::filesystem::path out = "reports/out";
  const auto junit = defaults ? out / "junit.xml" : std::filesystem::path(options.junit);
  const auto html = defaults ? out / "report.html" : std::filesystem::path(options.html);
  const auto json = defaults ? out / "report.json" : std::filesystem::path(options.json);
  bool written = true;
  const auto report = [&](const Expected<void, std::string>& done) {
    if (!done) {
      fmt::print(stderr, "drivecheck run: {}\n", done.error());
      written = false;
    }
  };
  if (!junit.empty()) report(reports::write_junit_report(junit, result));
  if (!html.empty()) report(reports::write_html_report(html, result));
  if (!json.empty()) report(reports::write_json_report(json, result));
  if (ethercat_pcap) {
    ethercat_pcap->flush();
    if (!ethercat_pcap->ok()) {
      fmt::print(stderr, "drivecheck run: the pcap is incomplete: {}\n", ethercat_pcap->error());
      written = false;
    }
  }
  if (recorder) {
    (void)recorder->flush();
    if (recorder->error()) {
      fmt::print(stderr, "drivecheck run: the trace is incomplete: {}\n", *recorder->error());
      written = false;
    }
  }
  const int code = conformance::exit_code(result);
  exit_with(code == kExitPass && !written ? kExitUsage : code);
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto options = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand(
      "run",
      "Run the conformance vectors against a drive (default: the reference drive on the "
      "simulated bus)");
  cmd->add_option("--bus", options->bus,
                  "The bus: sim, socketcan:IF for a real drive, ethercat:sim (the reference "
                  "drive as an EtherCAT slave on a simulated segment, vectors over CoE), or "
                  "ethercat:IF (the EtherCAT slave at position 0 behind the Ethernet interface "
                  "IF; needs root or CAP_NET_RAW)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            if (value == kEthercatSim) return {};
            if (const auto interface = ethercat_interface(value)) {
              if (interface->empty() || interface->size() > can::kMaxInterfaceNameLength) {
                return fmt::format("interface name '{}' must have 1..{} characters", *interface,
                                   can::kMaxInterfaceNameLength);
              }
              return {};
            }
            return bus_validator()(value);
          },
          "sim|socketcan:IF|ethercat:sim|ethercat:IF"))
      ->capture_default_str();
  cmd->add_option("--node", options->node, "Node id of the drive under test")
      ->check(CLI::Range(kMinNodeId, kMaxNodeId))
      ->capture_default_str();
  cmd->add_option("--profile", options->profile,
                  "Drive profile: a vectors/drives/*.yaml file or its name (e.g. festo-cmmp); "
                  "on the simulated bus also the reference drive's personality. Default: "
                  "cia402-reference on --bus sim; on a real bus chosen from the drive's 1000h "
                  "(device profile 402: cia402-device, else cia301-device)")
      ->type_name("FILE|NAME");
  cmd->add_option("--eds", options->eds, "The drive's EDS/DCF file")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  cmd->add_option("--esi", options->esi,
                  "The EtherCAT slave's ESI (ETG.2000 XML): its identity, dictionary and PDO "
                  "defaults checked as vectors (esi/*; --bus ethercat:* only)")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  cmd->add_option("--filter", options->filters,
                  "Only vectors whose id or family matches, e.g. cia402/fsa/* or cia301/sdo "
                  "(repeatable: any of them)")
      ->type_name("GLOB");
  cmd->add_option("--level", options->levels,
                  "Only vectors of this requirement level (repeatable: any of them)")
      ->check(CLI::IsMember({"must", "should", "may"}))
      ->type_name("must|should|may");
  cmd->add_option("--rerun", options->rerun,
                  "Run again only the vectors a JSON report lists as fail or error")
      ->check(CLI::ExistingFile)
      ->type_name("REPORT.json");
  cmd->add_flag("--strict", options->strict,
                "SHOULD and MAY failures are failures (default: warnings)");
  cmd->add_flag("--allow-motion", options->allow_motion,
                "Allow vectors that move the motor (needed on a real bus)");
  cmd->add_flag("--allow-factory-restore", options->allow_factory_restore,
                "Allow vectors that restore the factory defaults (1011h), which wipes the "
                "drive's stored parameters, its commissioning (needed on a real bus)");
  cmd->add_option("--seed", options->seed, "Seed of the simulated bus and faults")
      ->check(seed_validator())
      ->capture_default_str();
  cmd->add_option("--order", options->order,
                  "Run order of the selected vectors: file, reverse, shuffle:SEED (shuffle alone "
                  "draws a seed; the reports record it)")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            const auto parsed = conformance::parse_vector_order(value);
            return parsed ? std::string() : parsed.error();
          },
          "file|reverse|shuffle[:SEED]"))
      ->capture_default_str();
  cmd->add_option("--junit", options->junit, "Write a JUnit XML report")->type_name("FILE");
  cmd->add_option("--html", options->html, "Write an HTML report")->type_name("FILE");
  cmd->add_option("--json", options->json, "Write a JSON report")->type_name("FILE");
  cmd->add_option("--trace", options->trace,
                  "Record every frame to a candump -L log (CAN only; on EtherCAT use --pcap)")
      ->type_name("FILE.log");
  cmd->add_option("--pcap", options->pcap,
                  "Record every frame to a pcap file for Wireshark (CAN: LINKTYPE_CAN_SOCKETCAN; "
                  "EtherCAT: Ethernet frames, both ways; `drivecheck decode FILE` reads both)")
      ->type_name("FILE");
  add_vectors_option(*cmd, options->vectors);
  cmd->add_option("--deviation", options->deviations,
                  "Inject a named deviation into the embedded drive (repeatable; --bus sim only)")
      ->type_name("NAME");
  cmd->add_option("--color", options->color,
                  "Colour the verdict marks: auto (on a terminal, unless NO_COLOR is set), "
                  "always, never")
      ->check(CLI::IsMember({"auto", "always", "never"}))
      ->type_name("auto|always|never")
      ->capture_default_str();
  cmd->callback([options] { run(*options); });
}

}  // namespace drivecheck::cli

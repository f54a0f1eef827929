// drivecheck fuzz: the live-bus fuzzer (fuzz/live/live_fuzzer.hpp) against a drive on a bus.
//
//   drivecheck fuzz --bus socketcan:can0 --node 5 --duration 1h [--eds FILE] [--allow-motion]
//   drivecheck fuzz --bus sim --duration 60s [--profile NAME] [--deviation NAME...] (node 1)
//   drivecheck fuzz --replay anomaly-1-sdo-no-answer.min.log --bus ... --node N
//   drivecheck fuzz --bus ethercat:sim --duration 60s [--profile NAME] [--deviation NAME...]
//   drivecheck fuzz --bus ethercat:IF --duration 1h [--eds FILE]   (the slave at position 0)
//
// --bus ethercat:...: the mailbox and CoE fuzzer (fuzz/live/ethercat_fuzzer.hpp) through an
// EtherCAT master (protocol/ethercat/master.hpp) on a simulated segment with the reference drive
// as an emulated slave (ethercat:sim, simulated time), or on an AF_PACKET link (ethercat:IF);
// reproducers are pcaps (anomaly-<n>-<kind>.pcap, Wireshark decodes them) and a text listing of
// the steps, which --replay FILE.txt sends again (exit 1 if its anomaly reproduces). --node,
// --babble-limit and --sdo-timeout are for CAN.
//
// --bus sim: the embedded reference drive (cli/embedded_drive.hpp) on the simulated bus in
// this process, in simulated time (a 60 s run takes about a second); --profile gives it that
// profile's personality, --deviation injects faults; a fresh drive for every minimisation try.
// The objects the generator addresses: the EDS (--eds), else the profile's object list.
//
// Output: one line per anomaly and a summary on stdout, the reproducers (candump -L logs) and
// summary.json in --out DIR (default reports/fuzz/). Exit codes: 0 nothing found, 1 anomalies
// found (replay: the anomaly reproduced), 2 bad usage or input, 3 the device does not answer at
// the start, 130 interrupted (the drive is put in a safe state first).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "cli/embedded_drive.hpp"
#include "cli/options.hpp"
#include "cli/signal_scope.hpp"
#include "cli/vector_dirs.hpp"
#include "fuzz/live/ethercat_fuzzer.hpp"
#include "fuzz/live/live_fuzzer.hpp"
#include "protocol/can/candump_log.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/can/socketcan_bus.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/raw_link.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"
#include "reports/report_writers.hpp"

#ifndef DRIVECHECK_VERSION
#error "DRIVECHECK_VERSION must be defined by the build (cli/CMakeLists.txt)"
#endif

namespace drivecheck::cli {
namespace {

struct FuzzOptions {
  std::string bus;
  int node = 0;
  std::string duration = "60s";
  bool allow_motion = false;
  std::uint64_t seed = 1;
  std::string profile = "cia402-reference";
  std::string old_personality;       // --personality, the deprecated name of --profile
  std::vector<std::string> vectors;  // --vectors DIR: where else --profile NAME is looked up
  std::vector<std::string> deviations;
  std::string eds;
  std::string out = "reports/fuzz";
  std::string replay;
  std::uint64_t max_cases = 0;
  double babble_limit = 2000.0;
  std::string sdo_timeout = "100ms";
  bool no_minimise = false;
};

std::atomic<bool> g_interrupted{false};
std::atomic<can::Bus*> g_stoppable{nullptr};
std::atomic<ethercat::Link*> g_stoppable_link{nullptr};

extern "C" void interrupt_fuzz(int) {
  g_interrupted.store(true);
  if (auto* bus = g_stoppable.load()) bus->stop();
  if (auto* link = g_stoppable_link.load()) link->stop();
}

// The signal handlers stop the bus in g_stoppable while this lives; cleared at its end.
class InterruptScope {
 public:
  InterruptScope() : signals_(interrupt_fuzz) {}
  ~InterruptScope() {
    g_stoppable.store(nullptr);
    g_stoppable_link.store(nullptr);
  }
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  SignalScope signals_;
};

// The embedded reference drive on a simulated bus; power_cycle() builds a new bus and drive
// with the same seed, so every try starts from the same state.
class SimTarget final : public fuzz_live::Target {
 public:
  SimTarget(std::uint8_t node, std::uint64_t seed, const profile::DriveProfile& profile,
            std::vector<std::string> deviations)
      : node_(node), seed_(seed), profile_(profile), deviations_(std::move(deviations)) {}

  Expected<void, std::string> start() {
    drive_.reset();
    port_.reset();
    bus_ = std::make_unique<can::SimBus>(can::SimBusConfig{.bitrate = 1'000'000, .seed = seed_});
    port_ = bus_->attach("harness");
    auto created = EmbeddedDrive::create(*bus_, node_, profile_, deviations_);
    if (!created) return Unexpected(std::move(created).error());
    drive_ = std::move(*created);
    return {};
  }
  can::Bus& port() override { return *port_; }
  bool power_cycle() override { return start().has_value(); }
  std::string interface_name() const override { return "sim"; }

 private:
  std::uint8_t node_;
  std::uint64_t seed_;
  const profile::DriveProfile& profile_;
  std::vector<std::string> deviations_;
  std::unique_ptr<can::SimBus> bus_;
  std::unique_ptr<can::SimPort> port_;
  std::unique_ptr<EmbeddedDrive> drive_;
};

class SocketCanTarget final : public fuzz_live::Target {
 public:
  SocketCanTarget(std::unique_ptr<can::SocketCanBus> bus, std::string interface)
      : bus_(std::move(bus)), interface_(std::move(interface)) {}
  can::Bus& port() override { return *bus_; }
  bool power_cycle() override { return false; }
  std::string interface_name() const override { return interface_; }

 private:
  std::unique_ptr<can::SocketCanBus> bus_;
  std::string interface_;
};

bool writable(cia301::AccessType access) {
  return access == cia301::AccessType::rw || access == cia301::AccessType::wo ||
         access == cia301::AccessType::rwr || access == cia301::AccessType::rww;
}

std::vector<fuzz_live::FuzzObject> objects_of(const profile::DriveProfile& profile) {
  std::vector<fuzz_live::FuzzObject> objects;
  for (const auto& spec : profile.objects) {
    objects.push_back({spec.index, spec.sub, cia301::info(spec.type).size, writable(spec.access),
                       spec.min, spec.max});
  }
  return objects;
}

std::vector<fuzz_live::FuzzObject> objects_of(const cia301::ObjectDictionary& od) {
  std::vector<fuzz_live::FuzzObject> objects;
  for (const auto& object : od.objects()) {
    for (const auto& entry : object.entries()) {
      objects.push_back({object.index(), entry.sub_index(), cia301::info(entry.type()).size,
                         writable(entry.access()), std::nullopt, std::nullopt});
    }
  }
  return objects;
}

// The objects to fuzz: the EDS given, else the profile's list; the standard profile has none,
// and on the simulated bus (CAN or EtherCAT) the reference drive's own EDS describes exactly that
// drive. nullopt: the EDS could not be read (its errors are printed).
std::optional<std::vector<fuzz_live::FuzzObject>> fuzz_objects(const FuzzOptions& options,
                                                               const profile::DriveProfile& profile,
                                                               bool sim, std::uint8_t node) {
  std::string eds_file = options.eds;
  if (eds_file.empty() && sim && profile.objects.empty() && profile.name == "cia402-reference")
    eds_file = reference_drive_eds().string();
  if (eds_file.empty()) return objects_of(profile);
  auto eds = cia306::read_eds_file(eds_file);
  if (!eds) {
    fmt::print(stderr, "{}\n", eds.error().to_string());
    return std::nullopt;
  }
  auto od = cia306::to_object_dictionary(eds->eds, node, eds_file);
  if (!od) {
    for (const auto& d : od.error())
      fmt::print(stderr, "{}\n", d.to_string());
    usage_error("fuzz", fmt::format("{} does not give an object dictionary", eds_file));
  }
  return objects_of(*od);
}

void print_progress(std::string_view line) {
  fmt::print("{}\n", line);
  std::fflush(stdout);
}

// The end of a replay (CAN or EtherCAT): whether the reproducer's own anomaly came back, and
// the exit code (1 when it reproduces).
template <typename AnomalyKind>
void finish_replay(const std::optional<AnomalyKind>& expected, bool reproduced) {
  if (expected) {
    fmt::print("the reproducer's anomaly ({}) {}\n", fuzz_live::to_string(*expected),
               reproduced ? "reproduces" : "does not reproduce");
  }
  exit_with(g_interrupted.load() ? kExitInterrupted : reproduced ? kExitFail : kExitPass);
}

// OUT/summary.json, written atomically; false (and why, on stderr) when it could not be.
bool write_summary(const std::string& folder, const std::string& json) {
  const auto path = std::filesystem::path(folder) / "summary.json";
  if (auto done = reports::write_file_atomically(path, json); !done) {
    fmt::print(stderr, "drivecheck fuzz: {}\n", done.error());
    return false;
  }
  fmt::print("summary: {}\n", path.string());
  return true;
}

void create_output_folder(const std::string& folder) {
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  if (error) usage_error("fuzz", fmt::format("cannot create {}: {}", folder, error.message()));
}

double seconds(can::Duration duration) {
  return std::chrono::duration<double>(duration).count();
}

// reports/fuzz/summary.json (schema "drivecheck-fuzz" 1).
std::string summary_json(const FuzzOptions& options, const fuzz_live::FuzzSummary& summary,
                         const std::string& started, const std::string& personality) {
  nlohmann::ordered_json json;
  json["schema"] = "drivecheck-fuzz";
  json["schema_version"] = 1;
  json["generator"] = fmt::format("drivecheck {}", DRIVECHECK_VERSION);
  json["started_utc"] = started;
  json["bus"] = options.bus;
  json["node"] = options.node;
  json["seed"] = options.seed;
  json["personality"] = personality;
  json["deviations"] = options.deviations;
  json["allow_motion"] = options.allow_motion;
  json["outcome"] = std::string(fuzz_live::to_string(summary.outcome));
  json["duration_s"] = seconds(parse_duration(options.duration).value_or(can::Duration{0}));
  json["elapsed_s"] = seconds(summary.elapsed);
  json["cases_run"] = summary.cases_run;
  json["cases_by_kind"] = summary.cases_by_kind;
  json["anomalies_by_kind"] = summary.anomalies_by_kind;
  json["emcy_frames"] = summary.emcy_frames;
  json["device"] = {
      {"device_type", fmt::format("{:08X}", summary.device_type)},
      {"cia402", summary.cia402},
      {"heartbeat_ms",
       std::chrono::duration_cast<std::chrono::milliseconds>(summary.heartbeat_period).count()},
      {"guarding", summary.guarding},
      {"objects", summary.objects},
      {"lost_during_run", summary.device_lost}};
  auto anomalies = nlohmann::ordered_json::array();
  for (const auto& a : summary.anomalies) {
    nlohmann::ordered_json item;
    item["case"] = a.case_number;
    item["case_kind"] = a.case_kind;
    item["kind"] = std::string(fuzz_live::to_string(a.anomaly.kind));
    item["detail"] = a.anomaly.detail;
    item["case_frames"] = a.case_frames;
    item["log"] = a.log.string();
    item["minimised"] = a.minimised;
    item["minimised_frames"] = a.minimised_frames;
    item["minimisation_tries"] = a.minimisation_tries;
    item["reproducer"] = a.minimised_log.string();
    auto frames = nlohmann::ordered_json::array();
    for (const auto& frame : a.reproducer)
      frames.push_back(can::to_candump(frame));
    item["reproducer_frames"] = frames;
    item["note"] = a.minimisation_note;
    anomalies.push_back(item);
  }
  json["anomalies"] = anomalies;
  json["notes"] = summary.notes;
  return json.dump(2) + "\n";
}

constexpr std::string_view kEthercatSim = "ethercat:sim";
constexpr std::string_view kEthercatPrefix = "ethercat:";

bool is_ethercat(std::string_view bus) {
  return bus.substr(0, kEthercatPrefix.size()) == kEthercatPrefix;
}

// `--bus ethercat:sim`: the reference drive as an emulated EtherCAT slave on a simulated segment
// and a master brought up to PREOP over a TapLink; power_cycle() builds all of it again, so
// every minimisation try starts from the same state.
class SimEthercatTarget final : public fuzz_live::EthercatTarget {
 public:
  SimEthercatTarget(const profile::DriveProfile& profile, std::vector<std::string> deviations)
      : profile_(profile), deviations_(std::move(deviations)) {}

  Expected<void, std::string> start() {
    master_.reset();
    tap_.reset();
    drive_.reset();
    segment_ = std::make_unique<ethercat::SimSegment>();
    auto parsed = reference_drive::DeviationSet::parse(deviations_);
    if (!parsed) return Unexpected(std::move(parsed).error());
    reference_drive::ethercat::EthercatDriveOptions options;
    options.profile = profile_.name == "cia402-reference" ? nullptr : &profile_;
    options.deviations = std::move(*parsed);
    auto drive = reference_drive::ethercat::EthercatDrive::create(*segment_, std::move(options));
    if (!drive) return Unexpected(std::move(drive).error());
    drive_ = std::move(*drive);
    segment_->attach(*drive_);
    drive_->power_on();
    tap_ = std::make_unique<fuzz_live::TapLink>(*segment_);
    ethercat::MasterConfig config;
    config.scan.expected_slaves = 1;
    master_ = std::make_unique<ethercat::Master>(*tap_, config);
    if (auto up = master_->bring_up(ethercat::AlState::preop); !up)
      return Unexpected(fmt::format("EtherCAT bring-up to PREOP: {}", up.error().message()));
    return {};
  }
  ethercat::Master& master() override { return *master_; }
  fuzz_live::TapLink& link() override { return *tap_; }
  bool power_cycle() override { return start().has_value(); }
  std::string interface_name() const override { return std::string(kEthercatSim); }

 private:
  const profile::DriveProfile& profile_;
  std::vector<std::string> deviations_;
  std::unique_ptr<ethercat::SimSegment> segment_;
  std::unique_ptr<reference_drive::ethercat::EthercatDrive> drive_;
  std::unique_ptr<fuzz_live::TapLink> tap_;
  std::unique_ptr<ethercat::Master> master_;
};

// `--bus ethercat:IF`: the slave at position 0 behind an AF_PACKET link, with the master's
// timeouts of `drivecheck run --bus ethercat:IF` (a real link answers from another process).
class RawEthercatTarget final : public fuzz_live::EthercatTarget {
 public:
  RawEthercatTarget(std::unique_ptr<ethercat::RawLink> link, std::string interface)
      : link_(std::move(link)), tap_(*link_), interface_(std::move(interface)) {
    ethercat::MasterConfig config;
    config.port.response_timeout = std::chrono::milliseconds(20);
    config.sii.timeout = std::chrono::milliseconds(500);
    master_ = std::make_unique<ethercat::Master>(tap_, config);
  }
  Expected<void, ethercat::MasterError> start() {
    return master_->bring_up(ethercat::AlState::preop);
  }
  ethercat::Master& master() override { return *master_; }
  fuzz_live::TapLink& link() override { return tap_; }
  bool power_cycle() override { return false; }
  std::string interface_name() const override { return interface_; }
  ethercat::Link& raw() { return *link_; }

 private:
  std::unique_ptr<ethercat::RawLink> link_;
  fuzz_live::TapLink tap_;
  std::string interface_;
  std::unique_ptr<ethercat::Master> master_;
};

// reports/fuzz/summary.json of an EtherCAT run (schema "drivecheck-fuzz" 1, "transport":
// "ethercat"; the anomalies carry pcap and text reproducers instead of candump logs).
std::string ethercat_summary_json(const FuzzOptions& options,
                                  const fuzz_live::EthercatFuzzSummary& summary,
                                  const std::string& started, const std::string& personality) {
  nlohmann::ordered_json json;
  json["schema"] = "drivecheck-fuzz";
  json["schema_version"] = 1;
  json["generator"] = fmt::format("drivecheck {}", DRIVECHECK_VERSION);
  json["started_utc"] = started;
  json["transport"] = "ethercat";
  json["bus"] = options.bus;
  json["slave"] = 0;
  json["seed"] = options.seed;
  json["personality"] = personality;
  json["deviations"] = options.deviations;
  json["allow_motion"] = options.allow_motion;
  json["outcome"] = std::string(fuzz_live::to_string(summary.outcome));
  json["duration_s"] = seconds(parse_duration(options.duration).value_or(can::Duration{0}));
  json["elapsed_s"] = seconds(summary.elapsed);
  json["cases_run"] = summary.cases_run;
  json["cases_by_kind"] = summary.cases_by_kind;
  json["cases_by_state"] = summary.cases_by_state;
  json["anomalies_by_kind"] = summary.anomalies_by_kind;
  json["coe_emergencies"] = summary.emergencies;
  json["mailbox_error_replies"] = summary.mailbox_errors;
  json["device"] = {{"device_type", fmt::format("{:08X}", summary.device_type)},
                    {"al_states", summary.states},
                    {"lost_during_run", summary.device_lost}};
  auto anomalies = nlohmann::ordered_json::array();
  for (const auto& a : summary.anomalies) {
    nlohmann::ordered_json item;
    item["case"] = a.case_number;
    item["case_kind"] = a.case_kind;
    item["al_state"] = a.state;
    item["kind"] = std::string(fuzz_live::to_string(a.anomaly.kind));
    item["detail"] = a.anomaly.detail;
    item["steps"] = a.steps;
    item["pcap"] = a.pcap.string();
    item["text"] = a.text.string();
    item["minimised"] = a.minimised;
    item["minimised_steps"] = a.minimised_steps;
    item["minimisation_tries"] = a.minimisation_tries;
    item["reproducer"] = a.minimised_pcap.string();
    item["reproducer_text"] = a.minimised_text.string();
    item["note"] = a.minimisation_note;
    anomalies.push_back(item);
  }
  json["anomalies"] = anomalies;
  json["notes"] = summary.notes;
  return json.dump(2) + "\n";
}

void fuzz_ethercat(const FuzzOptions& options) {
  const bool sim = options.bus == kEthercatSim;
  const std::string interface = options.bus.substr(kEthercatPrefix.size());
  if (!sim && !options.deviations.empty())
    usage_error("fuzz",
                "--deviation injects faults into the embedded drive: only with --bus ethercat:sim");
  // Replay: the steps of a text reproducer (anomaly-<n>-<kind>[.min].txt; the pcap beside it is
  // for reading), checked against the safety rules like generated steps.
  std::optional<fuzz_live::EthercatReproducer> reproducer;
  if (!options.replay.empty()) {
    std::ifstream in(options.replay, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    if (!in) usage_error("fuzz", fmt::format("cannot read {}", options.replay));
    auto parsed = fuzz_live::parse_ethercat_reproducer(text.str(), options.replay);
    if (!parsed) {
      fmt::print(stderr, "{}\n", parsed.error());
      exit_with(kExitUsage);
      return;
    }
    for (std::size_t i = 0; i < parsed->c.steps.size(); ++i) {
      if (!fuzz_live::is_allowed_mailbox(parsed->c.steps[i], options.allow_motion)) {
        usage_error("fuzz", fmt::format("{}: step {} is not sent: a guarded write (1010h/1011h, "
                                        "1F50h+, PDO/SM configuration, 6040h without "
                                        "--allow-motion) or a mailbox type other than CoE",
                                        options.replay, i + 1));
      }
    }
    reproducer = std::move(*parsed);
  }
  const auto duration = parse_duration(options.duration);
  if (!duration) usage_error("fuzz", duration.error());
  const VectorDirs dirs = vector_dirs(options.vectors);
  lint_user_dirs_or_exit(dirs, "fuzz");
  auto profile = find_profile(options.profile, dirs);
  if (!profile) {
    fmt::print(stderr, "{}\n", profile.error().to_string());
    exit_with(kExitUsage);
    return;
  }
  fuzz_live::EthercatFuzzerOptions fuzz_options;
  fuzz_options.seed = options.seed;
  fuzz_options.duration = *duration;
  fuzz_options.max_cases = options.max_cases;
  fuzz_options.allow_motion = options.allow_motion;
  fuzz_options.minimise = !options.no_minimise;
  fuzz_options.out_dir = options.out;
  fuzz_options.interrupted = &g_interrupted;
  fuzz_options.progress = print_progress;
  auto objects = fuzz_objects(options, *profile, sim, 1);
  if (!objects) {
    exit_with(kExitUsage);
    return;
  }
  fuzz_options.objects = std::move(*objects);

  std::unique_ptr<fuzz_live::EthercatTarget> target;
  std::string personality;
  g_interrupted.store(false);
  InterruptScope interrupts;
  if (sim) {
    auto sim_target = std::make_unique<SimEthercatTarget>(*profile, options.deviations);
    if (auto started = sim_target->start(); !started) usage_error("fuzz", started.error());
    target = std::move(sim_target);
    personality = profile->name == "cia402-reference" ? std::string() : profile->name;
  } else {
    auto link = ethercat::RawLink::open(interface);
    if (!link) usage_error("fuzz", ethercat::describe_open_error(interface, link.error()));
    auto raw_target = std::make_unique<RawEthercatTarget>(std::move(*link), interface);
    g_stoppable_link.store(&raw_target->raw());
    if (auto up = raw_target->start(); !up) {
      fmt::print(stderr, "drivecheck fuzz: EtherCAT bring-up to PREOP on {} failed: {}\n",
                 interface, up.error().message());
      exit_with(kExitDutLost);
      return;
    }
    target = std::move(raw_target);
  }

  if (reproducer) {
    const auto result = fuzz_live::replay_ethercat_case(*target, reproducer->c, fuzz_options);
    for (const auto& note : result.notes)
      fmt::print("note: {}\n", note);
    if (!result.device_answered) {
      fmt::print(stderr, "drivecheck fuzz: the EtherCAT slave does not answer on {}\n",
                 options.bus);
      exit_with(kExitDutLost);
      return;
    }
    const bool reproduced =
        result.anomaly && (!reproducer->anomaly || result.anomaly->kind == *reproducer->anomaly);
    fmt::print("replayed {} step(s) of {} in {}: {}\n", reproducer->c.steps.size(), options.replay,
               ethercat::al_state_name(reproducer->c.state),
               result.anomaly ? fmt::format("{}: {}", fuzz_live::to_string(result.anomaly->kind),
                                            result.anomaly->detail)
                              : std::string("no anomaly"));
    finish_replay(reproducer->anomaly, reproduced);
    return;
  }

  create_output_folder(options.out);
  const std::string started = utc_now();
  fmt::print("drivecheck fuzz: EtherCAT slave 0 on {}, seed {}, {}{}\n", options.bus, options.seed,
             options.duration,
             options.deviations.empty()
                 ? std::string()
                 : fmt::format(", deviations {}", fmt::join(options.deviations, " ")));
  const auto summary = fuzz_live::run_ethercat_fuzzer(*target, fuzz_options);

  fmt::print(
      "{} case(s) in {:.1f} s of link time ({}), {} anomal{}, {} CoE emergenc{}, {} "
      "mailbox error repl{}\n",
      summary.cases_run, seconds(summary.elapsed), fmt::join(summary.states, "/"),
      summary.anomalies.size(), summary.anomalies.size() == 1 ? "y" : "ies", summary.emergencies,
      summary.emergencies == 1 ? "y" : "ies", summary.mailbox_errors,
      summary.mailbox_errors == 1 ? "y" : "ies");
  for (const auto& [kind, count] : summary.anomalies_by_kind)
    fmt::print("  {}: {}\n", kind, count);
  for (const auto& a : summary.anomalies) {
    if (!a.minimised) continue;
    fmt::print("  reproducer for {} ({} step(s)): {}\n", fuzz_live::to_string(a.anomaly.kind),
               a.minimised_steps.size(), a.minimised_pcap.string());
  }
  for (const auto& note : summary.notes)
    fmt::print("note: {}\n", note);
  const bool written =
      write_summary(options.out, ethercat_summary_json(options, summary, started, personality));
  switch (summary.outcome) {
    case fuzz_live::EthercatFuzzOutcome::device_lost_at_start:
      fmt::print(stderr, "drivecheck fuzz: the EtherCAT slave does not answer on {}\n",
                 options.bus);
      exit_with(kExitDutLost);
      return;
    case fuzz_live::EthercatFuzzOutcome::interrupted:
      exit_with(kExitInterrupted);
      return;
    case fuzz_live::EthercatFuzzOutcome::anomalies:
      exit_with(kExitFail);
      return;
    case fuzz_live::EthercatFuzzOutcome::clean:
      exit_with(written ? kExitPass : kExitUsage);
      return;
  }
}

void fuzz(const FuzzOptions& options) {
  if (is_ethercat(options.bus)) {
    fuzz_ethercat(options);
    return;
  }
  const auto spec = parse_bus_spec(options.bus);
  if (!spec) usage_error("fuzz", spec.error());
  const bool sim = spec->kind == BusSpec::Kind::sim;
  if (!sim && !options.deviations.empty())
    usage_error("fuzz", "--deviation injects faults into the embedded drive: only with --bus sim");
  const auto duration = parse_duration(options.duration);
  if (!duration) usage_error("fuzz", duration.error());
  const auto sdo_timeout = parse_duration(options.sdo_timeout);
  if (!sdo_timeout || sdo_timeout->count() <= 0)
    usage_error("fuzz", "--sdo-timeout: " + options.sdo_timeout);
  if (!(options.babble_limit > 0)) usage_error("fuzz", "--babble-limit must be above 0");
  const auto node = static_cast<std::uint8_t>(options.node);

  // A user's --vectors directories are linted as run lints them.
  const VectorDirs dirs = vector_dirs(options.vectors);
  lint_user_dirs_or_exit(dirs, "fuzz");
  auto profile = find_profile(options.profile, dirs);
  if (!profile) {
    fmt::print(stderr, "{}\n", profile.error().to_string());
    exit_with(kExitUsage);
    return;
  }

  fuzz_live::LiveFuzzerOptions fuzz_options;
  fuzz_options.node = node;
  fuzz_options.seed = options.seed;
  fuzz_options.duration = *duration;
  fuzz_options.max_cases = options.max_cases;
  fuzz_options.allow_motion = options.allow_motion;
  if (profile->supports("cia402")) fuzz_options.cia402 = true;
  fuzz_options.babble_limit = options.babble_limit;
  fuzz_options.sdo_timeout = *sdo_timeout;
  fuzz_options.minimise = !options.no_minimise;
  fuzz_options.out_dir = options.out;
  fuzz_options.interrupted = &g_interrupted;
  fuzz_options.progress = print_progress;
  auto objects = fuzz_objects(options, *profile, sim, node);
  if (!objects) {
    exit_with(kExitUsage);
    return;
  }
  fuzz_options.objects = std::move(*objects);

  // Replay: the reproducer's harness frames against a fresh device.
  std::vector<can::LogRecord> records;
  std::optional<fuzz_live::AnomalyKind> expected;
  if (!options.replay.empty()) {
    std::ifstream in(options.replay, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    if (!in) usage_error("fuzz", fmt::format("cannot read {}", options.replay));
    auto parsed = can::read_candump_log(text.str(), options.replay);
    if (!parsed) {
      fmt::print(stderr, "{}\n", parsed.error().to_string());
      exit_with(kExitUsage);
      return;
    }
    records = std::move(*parsed);
    expected = fuzz_live::reproducer_anomaly(text.str());
  }

  std::unique_ptr<fuzz_live::Target> target;
  std::string personality;
  if (sim) {
    auto sim_target = std::make_unique<SimTarget>(node, options.seed, *profile, options.deviations);
    if (auto started = sim_target->start(); !started) usage_error("fuzz", started.error());
    target = std::move(sim_target);
    personality = profile->name == "cia402-reference" ? std::string() : profile->name;
  } else {
    auto opened = can::SocketCanBus::open(spec->interface);
    if (!opened) usage_error("fuzz", can::describe_open_error(spec->interface, opened.error()));
    target = std::make_unique<SocketCanTarget>(std::move(*opened), spec->interface);
    g_stoppable.store(&target->port());
  }
  g_interrupted.store(false);
  InterruptScope interrupts;
  if (!sim) g_stoppable.store(&target->port());

  if (!options.replay.empty()) {
    const auto result = fuzz_live::replay_reproducer(*target, records, fuzz_options);
    for (const auto& note : result.notes)
      fmt::print("note: {}\n", note);
    if (!result.device_answered) {
      fmt::print(stderr, "drivecheck fuzz: node {} does not answer on {}\n", options.node,
                 options.bus);
      exit_with(kExitDutLost);
      return;
    }
    const bool reproduced = result.anomaly && (!expected || result.anomaly->kind == *expected);
    fmt::print("replayed {} harness frame(s) of {}: {}\n", result.frames_sent, options.replay,
               result.anomaly ? fmt::format("{}: {}", fuzz_live::to_string(result.anomaly->kind),
                                            result.anomaly->detail)
                              : std::string("no anomaly"));
    finish_replay(expected, reproduced);
    return;
  }

  create_output_folder(options.out);
  const std::string started = utc_now();
  fmt::print("drivecheck fuzz: node {} on {}, seed {}, {}{}\n", options.node, options.bus,
             options.seed, options.duration,
             options.deviations.empty()
                 ? std::string()
                 : fmt::format(", deviations {}", fmt::join(options.deviations, " ")));
  const auto summary = fuzz_live::run_live_fuzzer(*target, fuzz_options);

  fmt::print("{} case(s) in {:.1f} s of bus time, {} anomal{}, {} EMCY frame(s)\n",
             summary.cases_run, seconds(summary.elapsed), summary.anomalies.size(),
             summary.anomalies.size() == 1 ? "y" : "ies", summary.emcy_frames);
  for (const auto& [kind, count] : summary.anomalies_by_kind)
    fmt::print("  {}: {}\n", kind, count);
  for (const auto& a : summary.anomalies) {
    if (!a.minimised) continue;
    fmt::print("  reproducer for {} ({} frame(s)): {}\n", fuzz_live::to_string(a.anomaly.kind),
               a.minimised_frames, a.minimised_log.string());
  }
  for (const auto& note : summary.notes)
    fmt::print("note: {}\n", note);
  const bool written =
      write_summary(options.out, summary_json(options, summary, started, personality));

  switch (summary.outcome) {
    case fuzz_live::FuzzOutcome::device_lost_at_start:
      fmt::print(stderr, "drivecheck fuzz: node {} does not answer on {}\n", options.node,
                 options.bus);
      exit_with(kExitDutLost);
      return;
    case fuzz_live::FuzzOutcome::interrupted:
      exit_with(kExitInterrupted);
      return;
    case fuzz_live::FuzzOutcome::anomalies:
      exit_with(kExitFail);
      return;
    case fuzz_live::FuzzOutcome::clean:
      exit_with(written ? kExitPass : kExitUsage);
      return;
  }
}

}  // namespace

void add_fuzz_command(CLI::App& app) {
  auto options = std::make_shared<FuzzOptions>();
  CLI::App* cmd = app.add_subcommand(
      "fuzz", "Fuzz a live drive's CANopen services (or the reference drive with --bus sim)");
  cmd->add_option("--bus", options->bus,
                  "The bus: sim, socketcan:IF, ethercat:sim (the reference drive as an "
                  "EtherCAT slave on a simulated segment: mailbox and CoE cases) or ethercat:IF "
                  "(the EtherCAT slave at position 0 behind interface IF; root or CAP_NET_RAW)")
      ->required()
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            if (!is_ethercat(value)) return bus_validator()(value);
            const auto interface = value.substr(kEthercatPrefix.size());
            if (interface.empty() || interface.size() > can::kMaxInterfaceNameLength) {
              return fmt::format("interface name '{}' must have 1..{} characters", interface,
                                 can::kMaxInterfaceNameLength);
            }
            return {};
          },
          "sim|socketcan:IF|ethercat:sim|ethercat:IF"));
  cmd->add_option("--node", options->node,
                  "Node id of the drive (required with socketcan; the embedded drive: 1)")
      ->check(CLI::Range(kMinNodeId, kMaxNodeId));
  cmd->add_option("--duration", options->duration,
                  "How long to fuzz (bus time: simulated on --bus sim; a hard bound, every wait "
                  "ends with it), e.g. 90s, 10min, 2h")
      ->check(duration_validator())
      ->capture_default_str();
  cmd->add_flag("--allow-motion", options->allow_motion,
                "Also fuzz in Operation Enabled (the motor may move)");
  cmd->add_option("--seed", options->seed, "Seed of the case generator (and the simulated bus)")
      ->check(seed_validator())
      ->capture_default_str();
  cmd->add_option("--profile", options->profile,
                  "Drive profile (vectors/drives): the objects to fuzz; on --bus sim also the "
                  "reference drive's personality")
      ->type_name("NAME|FILE")
      ->capture_default_str();
  cmd->add_option("--deviation", options->deviations,
                  "Inject a named deviation into the embedded drive (repeatable; --bus sim only)")
      ->type_name("NAME");
  add_vectors_option(*cmd, options->vectors);
  cmd->add_option("--eds", options->eds, "The drive's EDS/DCF: the objects to fuzz")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  cmd->add_option("--out", options->out, "Directory of the reproducers and summary.json")
      ->type_name("DIR")
      ->capture_default_str();
  cmd->add_option("--replay", options->replay,
                  "Send a reproducer's harness frames again and re-run the oracle (exit 1 if "
                  "its anomaly reproduces)")
      ->check(CLI::ExistingFile)
      ->type_name("FILE");
  cmd->add_option("--max-cases", options->max_cases, "Stop after this many cases (0: no limit)")
      ->capture_default_str();
  cmd->add_option("--babble-limit", options->babble_limit,
                  "Frames per second from the node above which it babbles")
      ->capture_default_str();
  cmd->add_option("--sdo-timeout", options->sdo_timeout, "How long the SDO ping waits")
      ->check(duration_validator())
      ->capture_default_str();
  cmd->add_flag("--no-minimise", options->no_minimise, "Do not minimise anomalies");
  // The old name of --profile: still taken, with a warning.
  cmd->add_option("--personality", options->old_personality, "Deprecated: use --profile")
      ->type_name("NAME|FILE")
      ->group("");
  cmd->callback([options, cmd] {
    if (!options->old_personality.empty()) {
      warn_deprecated_option("fuzz", "--personality", "--profile");
      if (cmd->count("--profile") == 0) options->profile = options->old_personality;
    }
    if (options->node == 0) {
      // The embedded drive is node 1, as in drivecheck run; a real bus needs to be told.
      if (options->bus != "sim" && !is_ethercat(options->bus))
        usage_error("fuzz", "--node is required with --bus socketcan:IF");
      options->node = 1;
    }
    fuzz(*options);
  });
}

}  // namespace drivecheck::cli

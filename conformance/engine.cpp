// The run: filter, applicability, one VectorRun per vector, dut-lost accounting, identity,
// and on a real bus the safety measures (harness heartbeat, 1016h, motion envelope).
#include "conformance/engine.hpp"

#include <fmt/format.h>

#include <chrono>
#include <set>

#include "conformance/can_port.hpp"
#include "conformance/capabilities.hpp"
#include "conformance/pdo_tracker.hpp"
#include "conformance/repeats.hpp"
#include "conformance/samples.hpp"
#include "conformance/vector_run.hpp"
#include "conformance/verdict.hpp"
#include "protocol/cia301/dissector.hpp"
#include "protocol/cia301/nmt_master.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {

namespace {

// A report stays readable (and a run of hundreds of long vectors stays in megabytes, not
// gigabytes): a vector keeps its first kHeadFrames and last kTailFrames frames. The first show
// the setup and the stimulus, the last what led to the verdict; the trace log has the rest.
constexpr std::size_t kHeadFrames = 150;
constexpr std::size_t kTailFrames = 450;

constexpr std::size_t kMaxSamples = 1500;

void keep_head_and_tail(VectorResult& result) {
  // Samples feed the timing diagram: a long vector's are thinned by time, every bit edge kept
  // (samples.hpp).
  result.samples_elided += thin_samples(result.samples, kMaxSamples);
  auto& frames = result.frames;
  // Repeated patterns first (repeats.hpp): frames alike in identifier, data and sender.
  std::vector<std::string> keys;
  keys.reserve(frames.size());
  for (const auto& f : frames)
    keys.push_back(fmt::format("{} {}", f.from_harness ? 'h' : 'd', f.frame));
  (void)fold_repeats(frames, keys, 0, [](const EvidenceFrame& f) { return f.at; });
  if (frames.size() <= kHeadFrames + kTailFrames) return;
  const auto [from, to] = safe_cut(frames, kHeadFrames, frames.size() - kTailFrames);
  if (from == to) return;
  frames.erase(frames.begin() + static_cast<std::ptrdiff_t>(from),
               frames.begin() + static_cast<std::ptrdiff_t>(to));
  result.frames_elided = to - from;
  result.frames_elided_at = from;
}

// The capability probes (capabilities.hpp) through one harness VectorRun: SDO transfers and, on
// CAN, a node guarding request (a remote frame on 700h+N).
class RunProbe final : public DeviceProbe {
 public:
  explicit RunProbe(VectorRun& run) : run_(run) {}
  Answer upload(std::uint16_t index, std::uint8_t sub) override {
    return answer(run_.sdo_upload({index, sub}));
  }
  Answer block_upload(std::uint16_t index, std::uint8_t sub) override {
    return answer(run_.sdo_upload({index, sub}, Transfer::block));
  }
  Answer download(std::uint16_t index, std::uint8_t sub,
                  std::span<const std::uint8_t> data) override {
    return answer(run_.sdo_download({index, sub}, data));
  }
  std::optional<bool> guarding_answered() override {
    const std::uint32_t cob = 0x700U + run_.node();
    if (run_.send(can::Frame::remote(cob, 1))) return false;
    const auto deadline = run_.now() + run_.resolve({{}, "response"});
    while (auto frame = run_.pump(deadline)) {
      if (frame->frame.id == cob && !frame->frame.is_remote()) return true;
    }
    return false;
  }

 private:
  static Answer answer(const SdoOutcome& outcome) {
    return {outcome.ok, outcome.data, outcome.abort};
  }
  VectorRun& run_;
};

}  // namespace

class Engine::Impl {
 public:
  Impl(can::Bus& bus, DutPort* port, const profile::DriveProfile& profile, EngineOptions options,
       const std::atomic<bool>& interrupted, const std::atomic<bool>& stalled,
       std::atomic<std::uint64_t>& progress)
      : bus_(bus),
        own_port_(port == nullptr ? std::make_unique<CanPort>() : nullptr),
        port_(port != nullptr ? *port : *own_port_),
        profile_(profile),
        options_(std::move(options)),
        dissector_(dissector_options(options_)),
        pdo_(profile_, options_.node),
        capabilities_(options_.eds),
        context_{bus_,        port_,   profile_, options_, dissector_,
                 interrupted, stalled, progress, pdo_,     std::nullopt,
                 false,       {},      {},       {},       std::nullopt} {
    bus_.set_frame_handler({});
    bus_.set_loopback(true);
    if (options_.harness_node == options_.node)
      options_.harness_node = options_.node == 127 ? 126 : 127;
  }
  ~Impl() {
    if (heartbeat_timer_ != can::kNoTimer) bus_.cancel_timer(heartbeat_timer_);
  }

  static cia301::DissectorOptions dissector_options(const EngineOptions& options) {
    cia301::DissectorOptions dissector;
    if (options.eds != nullptr) {
      const auto* od = options.eds;
      dissector.object_name = [od](std::uint16_t index,
                                   std::uint8_t sub) -> std::optional<std::string> {
        if (const auto* entry = od->find(index, sub)) return entry->name();
        return std::nullopt;
      };
    }
    return dissector;
  }

  VectorResult run_vector(const Vector& vector, bool* dut_spoke) {
    VectorResult result = result_for(vector);
    result.started = bus_.now();
    const auto wall_start = std::chrono::steady_clock::now();

    const ApplicabilityContext applicability{
        options_.simulation != nullptr,
        !options_.real_bus || options_.allow_motion,
        !options_.real_bus && options_.simulation != nullptr && options_.simulation->can_bus_off(),
        &capabilities_,
        !options_.real_bus || options_.allow_factory_restore,
        options_.node,
        port_.link()};
    if (auto reason = not_applicable_reason(vector, profile_, applicability); !reason.empty()) {
      result.verdict = Verdict::not_applicable;
      result.message = std::move(reason);
      result.finished = result.started;
      if (dut_spoke != nullptr) *dut_spoke = true;  // not a silence
      return result;
    }
    if (options_.real_bus && vector.motion) prepare_motion(result);
    VectorRun run(context_, vector, result);
    const auto status = run.run_steps();
    // Ctrl-C while the steps ran: whatever the steps made of the stopped bus is no verdict on
    // the DUT. Sampled before the teardown, so that a vector decided before it stays decided.
    const bool interrupted = status != StepStatus::ok && context_.interrupted.load();
    // Cleanup (FORMAT.md "Isolation"), whatever the outcome: the drive safe first after
    // motion, the vector's `finally:` steps, the teardown, then the engine's restore.
    if (run.steps_started()) {
      if (!vector.finally_steps.empty()) run.teardown();
      run.run_finally();
    }
    run.teardown();
    run.restore();
    run.drain();
    if (interrupted) {
      const std::size_t step = run.current_step();
      result.verdict = Verdict::interrupted;
      result.warning = false;
      result.message = fmt::format(
          "interrupted by the user {}: no verdict (the checks and frames so far are kept)",
          step < vector.steps.size() ? fmt::format("in {}", step_place(vector.steps, step))
                                     : std::string("in the setup"));
      keep_head_and_tail(result);
      result.finished = bus_.now();
      result.wall_seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
      if (dut_spoke != nullptr) *dut_spoke = true;  // not a silence of the DUT
      return result;
    }
    if (context_.stalled.load()) {
      decide_verdict(result, vector, profile_, Outcome::harness_error,
                     "the simulation stopped advancing (a livelock in a simulated node): "
                     "the run was stopped by the watchdog",
                     options_.strict);
      result.finished = bus_.now();
      if (dut_spoke != nullptr) *dut_spoke = false;
      return result;
    }
    if (status == StepStatus::not_applicable) {
      // A value the vector takes from the device does not exist on it (device_values.hpp).
      result.verdict = Verdict::not_applicable;
      result.message = run.message();
      result.finished = bus_.now();
      if (dut_spoke != nullptr) *dut_spoke = run.dut_spoke();
      return result;
    }
    const Outcome outcome = status == StepStatus::ok       ? Outcome::pass
                            : status == StepStatus::failed ? Outcome::fail
                                                           : Outcome::harness_error;
    decide_verdict(result, vector, profile_, outcome, run.message(), options_.strict);
    if (result.verdict == Verdict::fail && !run.standing_leaks().empty()) {
      // The failure may be an earlier vector's change that could not be undone.
      result.verdict = Verdict::error;
      result.warning = false;
      result.message = fmt::format(
          "not judged: a change of an earlier vector could not be undone ({}); the failure may "
          "be its doing:\n{}",
          run.standing_leaks(), result.message);
    }
    keep_head_and_tail(result);
    result.finished = bus_.now();
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (dut_spoke != nullptr) *dut_spoke = run.dut_spoke();
    return result;
  }

  // Real bus, before the first motion vector: the envelope, the harness heartbeat, 1016h.
  void prepare_motion(VectorResult& result) {
    if (motion_prepared_) return;
    motion_prepared_ = true;
    Vector probe;
    probe.id = "harness/motion-envelope";
    probe.setup = Setup::none;
    probe.nmt.reset();
    VectorResult scratch;
    VectorRun run(context_, probe, scratch);
    struct EnvelopeObject {
      std::uint16_t index;
      std::uint8_t sub;
      const char* name;
    };
    constexpr std::array<EnvelopeObject, 10> kEnvelope{{
        {0x607D, 1, "software position limit min"},
        {0x607D, 2, "software position limit max"},
        {0x607F, 0, "max profile velocity"},
        {0x6080, 0, "max motor speed"},
        {0x6072, 0, "max torque"},
        {0x6065, 0, "following error window"},
        {0x6066, 0, "following error time out"},
        {0x6085, 0, "quick stop deceleration"},
        {0x605A, 0, "quick stop option code"},
        {0x6007, 0, "abort connection option code"},
    }};
    for (const auto& object : kEnvelope) {
      const auto outcome = run.sdo_upload({object.index, object.sub});
      result.checks.push_back(
          Check{0,
                "envelope",
                fmt::format("{:04X}h sub {} ({}) recorded", object.index, object.sub, object.name),
                outcome.describe(),
                true,
                {},
                {}});
    }
    // On EtherCAT the master's process data cycle is the harness's heartbeat: a slave in
    // SAFEOP/OP whose SM watchdog expires leaves OP and runs its 6007h reaction (ETG.1000.6,
    // ESC datasheet Section I, the process data watchdog). A CAN heartbeat does not exist
    // there, and making the drive consume one would fault it.
    if (port_.link() == LinkKind::ethercat) {
      result.checks.push_back(Check{0,
                                    "envelope",
                                    "dead-harness stop: the slave's SM watchdog (EtherCAT: no "
                                    "heartbeat consumer is set up)",
                                    "the master cycles the process data",
                                    true,
                                    {},
                                    {}});
      for (auto& frame : scratch.frames)
        result.frames.push_back(std::move(frame));
      return;
    }
    // The harness becomes a heartbeat producer; the DUT consumes it (1016h sub 1:
    // node-ID in bits 16..23, time in ms in bits 0..15, 3x our period). What 1016h sub 1 held
    // before is put back at the end of the run (restore_heartbeat_consumer).
    const auto before = run.sdo_upload({0x1016, 1});
    if (before.ok && before.data.size() == 4) original_consumer_ = before.data;
    result.checks.push_back(Check{0,
                                  "envelope",
                                  "1016h sub 1 recorded (restored after the run)",
                                  before.describe(),
                                  true,
                                  {},
                                  {}});
    start_heartbeat();
    const auto period_ms = static_cast<std::uint32_t>(
        std::chrono::duration_cast<std::chrono::milliseconds>(options_.harness_heartbeat).count());
    const std::uint32_t consumer =
        static_cast<std::uint32_t>(options_.harness_node) << 16 | (period_ms * 3 & 0xFFFF);
    const std::array<std::uint8_t, 4> bytes{
        static_cast<std::uint8_t>(consumer), static_cast<std::uint8_t>(consumer >> 8),
        static_cast<std::uint8_t>(consumer >> 16), static_cast<std::uint8_t>(consumer >> 24)};
    const auto outcome = run.sdo_download({0x1016, 1}, bytes);
    if (outcome.ok)
      context_.harness_consumer = std::vector<std::uint8_t>(bytes.begin(), bytes.end());
    result.checks.push_back(
        Check{0,
              "envelope",
              fmt::format("1016h sub 1 := {:08X}h (consume the harness heartbeat)", consumer),
              outcome.describe(),
              true,
              {},
              {}});
    for (auto& frame : scratch.frames)
      result.frames.push_back(std::move(frame));
  }

  // End of a real-bus run whose motion preparation took over 1016h sub 1: the DUT's own value
  // goes back, then the harness heartbeat stops (in this order, so the DUT never sees its
  // consumer time out). Nothing to do, or nothing possible (DUT lost), is said in a note.
  void restore_heartbeat_consumer(RunResult& result) {
    if (!motion_prepared_ || port_.link() == LinkKind::ethercat) return;
    if (!original_consumer_) {
      result.harness_notes.push_back(
          "1016h sub 1 could not be read before the run, so it was not restored: the DUT may "
          "still consume the harness heartbeat (node " +
          std::to_string(options_.harness_node) + ")");
    } else if (result.dut_lost) {
      result.harness_notes.push_back(
          "the DUT stopped answering: 1016h sub 1 was not restored, it may still consume the "
          "harness heartbeat");
    } else {
      Vector probe;
      probe.id = "harness/restore-1016h";
      probe.setup = Setup::none;
      probe.nmt.reset();
      VectorResult scratch;
      VectorRun run(context_, probe, scratch);
      const auto outcome = run.sdo_download({0x1016, 1}, *original_consumer_);
      const auto value = static_cast<std::uint32_t>(cia301::load_unsigned(*original_consumer_));
      result.harness_notes.push_back(
          outcome.ok ? fmt::format("1016h sub 1 restored to {:08X}h after the run", value)
                     : fmt::format("1016h sub 1 could not be restored to {:08X}h: {}", value,
                                   outcome.describe()));
    }
    if (heartbeat_timer_ != can::kNoTimer) bus_.cancel_timer(heartbeat_timer_);
    heartbeat_timer_ = can::kNoTimer;
  }

  void start_heartbeat() {
    if (heartbeat_timer_ != can::kNoTimer) return;
    const auto tick = [this](auto&& self) -> void {
      (void)bus_.send(can::Frame::standard(0x700U + options_.harness_node, {0x05}));
      heartbeat_timer_ =
          bus_.start_timer_after(options_.harness_heartbeat, [this, self] { self(self); });
    };
    tick(tick);
  }

  DutIdentity read_identity() {
    DutIdentity identity;
    Vector probe;
    probe.id = "harness/identity";
    VectorResult scratch;
    VectorRun run(context_, probe, scratch);
    const auto u32 = [&](std::uint16_t index, std::uint8_t sub) -> std::optional<std::uint32_t> {
      const auto outcome = run.sdo_upload({index, sub});
      if (!outcome.ok || outcome.data.size() != 4) return std::nullopt;
      return static_cast<std::uint32_t>(cia301::load_unsigned(outcome.data));
    };
    const auto text = [&](std::uint16_t index) -> std::optional<std::string> {
      const auto outcome = run.sdo_upload({index, 0});
      if (!outcome.ok) return std::nullopt;
      std::string value(outcome.data.begin(), outcome.data.end());
      while (!value.empty() && value.back() == '\0')
        value.pop_back();
      return value;
    };
    identity.device_type = u32(0x1000, 0);
    identity.device_name = text(0x1008);
    identity.hardware_version = text(0x1009);
    identity.software_version = text(0x100A);
    identity.vendor_id = u32(0x1018, 1);
    identity.product_code = u32(0x1018, 2);
    identity.revision = u32(0x1018, 3);
    identity.serial = u32(0x1018, 4);
    identity_answered_ = run.dut_spoke();
    return identity;
  }

  // Once per run, before the first vector: the object needs of the selected vectors and the
  // profile's `detect:` features (capabilities.hpp), with the DUT in pre-operational.
  void probe_capabilities(const std::vector<const Vector*>& selected,
                          std::optional<std::uint32_t> device_type) {
    std::set<profile::ObjectNeed> needs;
    for (const auto* vector : selected)
      for (const auto& need : object_needs(*vector))
        needs.insert(need);
    if (needs.empty() && profile_.detect.empty()) return;
    Vector probe;
    probe.id = "harness/capabilities";
    probe.setup = Setup::none;
    probe.nmt.reset();
    probe.timeout = DurationSpec{std::chrono::minutes(10), {}};
    VectorResult scratch;
    VectorRun run(context_, probe, scratch);
    RunProbe device(run);
    capabilities_.probe(device, needs, profile_.detect, device_type);
  }

  can::Bus& bus_;
  std::unique_ptr<DutPort> own_port_;  // CAN: the engine's own CanPort
  DutPort& port_;
  const profile::DriveProfile& profile_;
  EngineOptions options_;
  cia301::Dissector dissector_;
  PdoTracker pdo_;  // the DUT's PDO configuration over the whole run (it outlives vectors)
  Capabilities capabilities_;  // what the DUT has, probed once per run
  EngineContext context_;
  bool motion_prepared_ = false;
  std::optional<std::vector<std::uint8_t>> original_consumer_;  // 1016h sub 1 before the run
  bool identity_answered_ = false;
  can::TimerId heartbeat_timer_ = can::kNoTimer;
};

Engine::Engine(can::Bus& port, const profile::DriveProfile& profile, EngineOptions options)
    : impl_(std::make_unique<Impl>(port, nullptr, profile, std::move(options), interrupted_,
                                   stalled_, progress_)) {}

Engine::Engine(can::Bus& clock, DutPort& dut, const profile::DriveProfile& profile,
               EngineOptions options)
    : impl_(std::make_unique<Impl>(clock, &dut, profile, std::move(options), interrupted_, stalled_,
                                   progress_)) {}

void Engine::declare_stalled() {
  stalled_.store(true);
  impl_->bus_.stop();
}

Engine::~Engine() = default;

void Engine::interrupt() {
  interrupted_.store(true);
  impl_->bus_.stop();
}

DutIdentity Engine::read_identity() {
  return impl_->read_identity();
}

std::optional<std::uint32_t> Engine::read_device_type() {
  Vector probe;
  probe.id = "harness/device-type";
  probe.setup = Setup::none;
  probe.nmt.reset();
  VectorResult scratch;
  VectorRun run(impl_->context_, probe, scratch);
  const auto outcome = run.sdo_upload({0x1000, 0});
  if (!outcome.ok || outcome.data.size() != 4) return std::nullopt;
  return static_cast<std::uint32_t>(cia301::load_unsigned(outcome.data));
}

// `error: harness late` (VectorRun::fail_timed): the harness, not the DUT, was late.
static bool harness_was_late(const VectorResult& result) {
  return result.verdict == Verdict::error && result.message.rfind("error: harness late", 0) == 0;
}

VectorResult Engine::run_vector(const Vector& vector) {
  return impl_->run_vector(vector, nullptr);
}

VectorResult Engine::probe_undocumented_objects(
    const std::function<bool(std::uint16_t)>& documented, const std::string& source) {
  Vector probe;
  probe.id = "eds/od/undocumented-objects";
  probe.title =
      "Every object the device answers in 1000h-1FFFh and 6000h-67FFh MUST be in its description";
  probe.sources.push_back(Source{source, "", "", 0, 0, 0});
  probe.setup = Setup::none;
  probe.nmt.reset();
  probe.timeout = DurationSpec{std::chrono::minutes(30), {}};
  probe.file = "(generated)";
  VectorResult result;
  result.id = probe.id;
  result.family = probe.family();
  result.title = probe.title;
  result.sources = {source};
  result.file = probe.file;
  result.started = impl_->bus_.now();
  const auto wall_start = std::chrono::steady_clock::now();
  VectorRun run(impl_->context_, probe, result);
  std::vector<std::string> found;
  std::vector<EvidenceFrame> kept;
  for (const auto& [first, last] : {std::pair{0x1000, 0x1FFF}, std::pair{0x6000, 0x67FF}}) {
    for (int index = first; index <= last && !interrupted_.load() && !stalled_.load(); ++index) {
      const auto idx = static_cast<std::uint16_t>(index);
      if (documented(idx)) continue;
      const auto frames_before = result.frames.size();
      const auto outcome = run.sdo_upload({idx, 0});
      const bool absent = outcome.abort && *outcome.abort == 0x06020000;
      const bool silent = !outcome.ok && !outcome.abort;
      if (!absent && !silent) {
        found.push_back(fmt::format("{:04X}h ({})", idx, outcome.describe()));
        kept.insert(kept.end(), result.frames.begin() + static_cast<std::ptrdiff_t>(frames_before),
                    result.frames.end());
      }
      result.frames.resize(frames_before);
    }
  }
  result.frames = std::move(kept);
  const std::string expected = "every object answered is described (others abort 06020000h)";
  const auto actual = found.empty()
                          ? std::string("none undescribed")
                          : fmt::format("{} undescribed: {}", found.size(), fmt::join(found, ", "));
  result.checks.push_back(Check{0, "probe", expected, actual, found.empty(), {}, {}});
  decide_verdict(result, probe, impl_->profile_, found.empty() ? Outcome::pass : Outcome::fail,
                 fmt::format("{}: probe: Expected {}; Actual {}\n  Expected: {}\n  Actual:   {}",
                             probe.file, expected, actual, expected, actual),
                 impl_->options_.strict);
  if (interrupted_.load()) {
    // Ctrl-C during the scan: a partial scan proves nothing either way.
    result.verdict = Verdict::interrupted;
    result.warning = false;
    result.message = "interrupted by the user during the scan: no verdict (" + actual + " so far)";
  }
  result.finished = impl_->bus_.now();
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

std::vector<std::string> describe_commissioning(const profile::Commissioning& c) {
  std::vector<std::string> lines;
  if (c.writes.empty()) return lines;
  lines.push_back(fmt::format(
      "applies to {}{}", fmt::join(c.vectors, ", "),
      c.except.empty() ? std::string() : fmt::format(" except {}", fmt::join(c.except, ", "))));
  for (const auto& w : c.writes) {
    lines.push_back(fmt::format("{:04X}h sub {} := {} ({} bytes): {} [{}]", w.index, w.sub, w.value,
                                w.size, w.why, fmt::join(w.sources, "; ")));
  }
  return lines;
}

RunResult Engine::run(const std::vector<Vector>& vectors, RunInfo info) {
  RunResult result;
  const auto& options = impl_->options_;
  info.node = options.node;
  info.strict = options.strict;
  info.allow_motion = options.allow_motion;
  info.allow_factory_restore = options.allow_factory_restore;
  info.filter = options.filter;
  info.profile_name = impl_->profile_.name;
  info.profile_title = impl_->profile_.title;
  if (info.profile_file.empty()) info.profile_file = impl_->profile_.path.string();
  info.commissioning = describe_commissioning(impl_->profile_.commissioning);
  result.info = std::move(info);
  const auto sim_start = impl_->bus_.now();
  const auto wall_start = std::chrono::steady_clock::now();
  const auto finish = [&] {
    result.simulated = impl_->bus_.now() - sim_start;
    result.wall_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    return result;
  };

  // Wake the DUT to a state where SDO works (pre-operational) and read who it is.
  cia301::NmtMaster master;
  (void)impl_->bus_.send(master.command(cia301::NmtCommand::enter_pre_operational, options.node));
  result.info.dut = impl_->read_identity();
  if (!impl_->identity_answered_) {
    result.dut_lost = true;
    return finish();
  }
  {
    std::vector<const Vector*> selected;
    for (const auto& vector : vectors)
      if (options.filter.empty() || profile::glob_match(options.filter, vector.id))
        selected.push_back(&vector);
    impl_->probe_capabilities(selected, result.info.dut.device_type);
    result.info.capabilities = impl_->capabilities_.describe();
  }
  std::size_t silent = 0;
  for (const auto& vector : vectors) {
    if (!options.filter.empty() && !profile::glob_match(options.filter, vector.id)) continue;
    if (interrupted_.load()) {
      result.interrupted = true;
      break;
    }
    if (options.on_vector_started) options.on_vector_started(vector);
    bool dut_spoke = true;
    auto vector_result = impl_->run_vector(vector, &dut_spoke);
    // The harness was late itself (a busy host): no verdict on the DUT, so the vector runs
    // again; the report keeps what each earlier attempt saw.
    std::vector<std::string> late_attempts;
    while (harness_was_late(vector_result) &&
           static_cast<int>(late_attempts.size()) + 1 < options.harness_late_attempts &&
           !interrupted_.load() && !stalled_.load()) {
      late_attempts.push_back(vector_result.message);
      vector_result = impl_->run_vector(vector, &dut_spoke);
    }
    if (!late_attempts.empty()) {
      std::vector<Check> earlier;
      for (std::size_t i = 0; i < late_attempts.size(); ++i) {
        earlier.push_back(Check{0,
                                "harness",
                                fmt::format("attempt {} of {} judged: the harness was late, no "
                                            "verdict; run again",
                                            i + 1, late_attempts.size() + 1),
                                late_attempts[i],
                                true,
                                {},
                                {}});
      }
      vector_result.checks.insert(vector_result.checks.begin(), earlier.begin(), earlier.end());
      result.harness_notes.push_back(fmt::format(
          "{}: run {} times, the harness was late in the first {} (a busy host); the verdict is "
          "the last attempt's",
          vector.id, late_attempts.size() + 1, late_attempts.size()));
    }
    if (options.on_vector_finished) options.on_vector_finished(vector_result);
    result.vectors.push_back(std::move(vector_result));
    if (stalled_.load()) {
      result.dut_lost = true;
      break;
    }
    if (interrupted_.load()) {
      result.interrupted = true;
      break;
    }
    silent = dut_spoke ? 0 : silent + 1;
    if (options.max_silent_vectors > 0 && silent >= options.max_silent_vectors) {
      result.dut_lost = true;
      break;
    }
  }
  // Isolation: what the engine put back or could not (each with its vector id).
  auto& context = impl_->context_;
  for (auto& text : context.notes)
    result.harness_notes.push_back(std::move(text));
  context.notes.clear();
  for (const auto& [ref, leak] : context.leaks)
    result.harness_notes.push_back("at the end of the run: " + leak.describe());
  impl_->restore_heartbeat_consumer(result);
  for (auto& note : impl_->capabilities_.notes())
    result.harness_notes.push_back(std::move(note));
  return finish();
}

}  // namespace drivecheck::conformance

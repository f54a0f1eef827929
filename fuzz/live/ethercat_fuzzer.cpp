#include "fuzz/live/ethercat_fuzzer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>

#include "fuzz/live/minimiser.hpp"
#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/pcap.hpp"

namespace drivecheck::fuzz_live {
namespace {

using ethercat::AlState;
using ethercat::Duration;
using ethercat::MasterErrc;
using ethercat::MasterError;
using ethercat::TimePoint;

constexpr std::uint8_t kCoeType = static_cast<std::uint8_t>(ethercat::MailboxType::coe);
// The master's mailbox timeout (MailboxPollOptions::timeout, 1 s by default): how long a step
// that a repeat follows waits for its reply.
constexpr Duration kReplyTimeout = std::chrono::seconds(1);

bool cycling_state(AlState state) {
  return state == AlState::safeop || state == AlState::op;
}

EthercatAnomaly classify(const MasterError& error, std::string_view during) {
  EthercatAnomaly a;
  a.detail = fmt::format("{}: {}", during, error.message());
  if (error.code == MasterErrc::no_response || error.code == MasterErrc::link_error) {
    a.kind = EthercatAnomalyKind::device_silent;
  } else if (error.code == MasterErrc::process_data_wkc) {
    a.kind = EthercatAnomalyKind::working_counter;
  } else if (error.code == MasterErrc::al_state_lost || error.code == MasterErrc::al_timeout) {
    a.kind = EthercatAnomalyKind::al_state_lost;
  } else if (error.code == MasterErrc::al_refused) {
    a.kind = error.al_status_code == 0 ? EthercatAnomalyKind::al_error_without_code
                                       : EthercatAnomalyKind::al_error;
  } else if (error.code == MasterErrc::mailbox_timeout) {
    a.kind = EthercatAnomalyKind::coe_no_answer;
  } else if (error.code == MasterErrc::mailbox_error || error.code == MasterErrc::sdo_abort) {
    a.kind = EthercatAnomalyKind::coe_ping_refused;
  } else {
    a.kind = EthercatAnomalyKind::device_silent;  // working_counter of a register access, ...
  }
  return a;
}

struct Collected {
  std::size_t sdo_replies = 0;  // new (not duplicate) CoE SDO responses
  std::size_t errors = 0;       // ERR replies
  std::size_t others = 0;
};

struct CaseResult {
  std::optional<EthercatAnomaly> anomaly;
  bool cut_short = false;
};

class Fuzzer {
 public:
  Fuzzer(EthercatTarget& target, const EthercatFuzzerOptions& options)
      : target_(target), options_(options) {}

  EthercatFuzzSummary run();
  EthercatReplayResult replay(const EthercatCase& c);

 private:
  ethercat::Master& master() { return target_.master(); }
  ethercat::MasterMailbox& mailbox() { return *target_.master().mailbox(0); }
  TimePoint now() { return target_.link().now(); }
  bool interrupted() const { return options_.interrupted && options_.interrupted->load(); }
  // Link time used since the run started, across power cycles (a new simulated segment starts
  // its clock again at 0): minimisation tries count against --duration too.
  Duration elapsed() { return used_ + (now() - start_); }
  bool out_of_time() { return elapsed() >= options_.duration; }
  TimePoint end() { return now() + (options_.duration - elapsed()); }
  void restart_clock() {
    used_ = Duration{0};
    start_ = now();
  }
  void progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }
  void install_tap() {
    target_.link().set_tap([this](const ethercat::TimedFrame& frame, bool) {
      if (recording_) frames_.push_back(frame);
    });
  }

  std::optional<EthercatAnomaly> pass_time(Duration duration);
  Expected<Collected, EthercatAnomaly> collect(Duration quiet, std::optional<TimePoint> need_by);
  std::vector<std::uint8_t> build(const MailboxStep& step,
                                  const std::vector<std::uint8_t>* previous);
  CaseResult run_case(const EthercatCase& c, std::span<const std::size_t> keep);
  std::optional<EthercatAnomaly> oracle();
  bool recover();
  bool power_cycle() {
    used_ += now() - start_;
    const bool cycled = target_.power_cycle();
    start_ = now();
    if (cycled) install_tap();
    return cycled;
  }
  std::filesystem::path write_pcap(const std::string& stem);
  std::filesystem::path write_text(const std::string& stem, const EthercatCase& c,
                                   std::span<const std::size_t> keep, const EthercatAnomaly& a);
  void minimise_into(EthercatAnomalyRecord& record, const EthercatCase& c, const std::string& stem);

  EthercatTarget& target_;
  const EthercatFuzzerOptions& options_;
  EthercatFuzzSummary summary_;
  TimePoint start_{};  // on the current link
  Duration used_{0};   // on the links before it
  bool recording_ = false;
  std::vector<ethercat::TimedFrame> frames_;
};

std::optional<EthercatAnomaly> Fuzzer::pass_time(Duration duration) {
  const TimePoint deadline = std::min(now() + duration, end());
  while (now() < deadline) {
    if (cycling_state(master().held_state())) {
      if (auto cycle = master().cycle(); !cycle) return classify(cycle.error(), "process data");
    }
    master().port().wait(std::min<Duration>(options_.cycle_period, deadline - now()));
  }
  return std::nullopt;
}

Expected<Collected, EthercatAnomaly> Fuzzer::collect(Duration quiet,
                                                     std::optional<TimePoint> need_by) {
  Collected got;
  TimePoint last = now();
  for (;;) {
    auto message = mailbox().poll();
    if (!message) {
      // Garbage in SM1 (no valid mailbox) is the slave's: the reply it stands for is lost.
      if (message.error().code == MasterErrc::mailbox_error) {
        ++got.others;
        last = now();
        continue;
      }
      return Unexpected(classify(message.error(), "reading the read mailbox"));
    }
    if (*message) {
      const ethercat::MailboxIn& in = **message;
      if (in.error) {
        ++got.errors;
        ++summary_.mailbox_errors;
      } else if (in.header.type == kCoeType &&
                 ethercat::peek_coe_service(in.data) ==
                     static_cast<std::uint8_t>(ethercat::CoeService::emergency)) {
        ++summary_.emergencies;
      } else if (in.header.type == kCoeType &&
                 ethercat::peek_coe_service(in.data) ==
                     static_cast<std::uint8_t>(ethercat::CoeService::sdo_response)) {
        ++got.sdo_replies;
      } else {
        ++got.others;
      }
      mailbox().protocol().reply_matched();
      last = now();
      continue;
    }
    const bool waiting_for_reply =
        need_by && got.sdo_replies + got.errors + got.others == 0 && now() < *need_by;
    if ((!waiting_for_reply && now() - last >= quiet) || now() >= end()) return got;
    if (auto a = pass_time(options_.cycle_period)) return Unexpected(std::move(*a));
  }
}

std::vector<std::uint8_t> Fuzzer::build(const MailboxStep& step,
                                        const std::vector<std::uint8_t>* previous) {
  auto& protocol = mailbox().protocol();
  const auto t = std::chrono::duration_cast<std::chrono::nanoseconds>(now().time_since_epoch());
  const auto type = static_cast<ethercat::MailboxType>(kCoeType);
  std::span<const std::uint8_t> data = step.data;
  if (!protocol.fits(data.size())) data = data.first(0);
  if (step.counter == CounterMode::repeat && previous) return *previous;
  if (step.counter == CounterMode::skip) (void)protocol.request(type, {}, t);
  std::vector<std::uint8_t> buffer = protocol.request(type, data, t);
  protocol.reply_matched();
  if (step.counter == CounterMode::zero) buffer[5] &= 0x8F;
  const std::uint16_t length = step.length.value_or(static_cast<std::uint16_t>(data.size()));
  buffer[0] = static_cast<std::uint8_t>(length);
  buffer[1] = static_cast<std::uint8_t>(length >> 8);
  buffer[4] = static_cast<std::uint8_t>((step.channel & 0x3F) | ((step.priority & 0x03) << 6));
  buffer[5] = static_cast<std::uint8_t>((buffer[5] & 0xF0) | (step.type & 0x0F));
  return buffer;
}

CaseResult Fuzzer::run_case(const EthercatCase& c, std::span<const std::size_t> keep) {
  CaseResult result;
  if (master().held_state() != c.state) {
    if (auto reached = master().request_state(c.state); !reached) {
      result.anomaly = classify(
          reached.error(), fmt::format("taking the slave to {}", ethercat::al_state_name(c.state)));
      return result;
    }
  }
  std::vector<std::uint8_t> previous;
  bool previous_answered = false;
  for (std::size_t k = 0; k < keep.size(); ++k) {
    if (interrupted() || out_of_time()) {
      result.cut_short = true;
      return result;
    }
    const MailboxStep& step = c.steps[keep[k]];
    std::vector<std::uint8_t> buffer = build(step, previous.empty() ? nullptr : &previous);
    if (auto sent = mailbox().send_raw(buffer); !sent) {
      result.anomaly = classify(sent.error(), fmt::format("writing step {} into SM0", k + 1));
      return result;
    }
    // The request a repeat follows must be answered first, or the repeat cannot be judged
    // (its reply would be still queued); every wait ends with the run.
    const bool repeat_follows = step.counter != CounterMode::repeat && k + 1 < keep.size() &&
                                c.steps[keep[k + 1]].counter == CounterMode::repeat;
    auto got =
        collect(options_.reply_wait,
                repeat_follows ? std::optional<TimePoint>(std::min(now() + kReplyTimeout, end()))
                               : std::nullopt);
    if (!got) {
      result.anomaly = std::move(got.error());
      return result;
    }
    if (step.counter == CounterMode::repeat && !previous.empty()) {
      if (previous_answered && got->sdo_replies > 0) {
        result.anomaly = EthercatAnomaly{
            EthercatAnomalyKind::mailbox_repeat_executed,
            fmt::format("step {}: the request sent again with the same counter ({}) was "
                        "executed again: {} new SDO repl{} (ETG.1000.4: a repeated request is "
                        "not executed twice)",
                        k + 1, (buffer[5] >> 4) & 0x07, got->sdo_replies,
                        got->sdo_replies == 1 ? "y" : "ies")};
        return result;
      }
    } else {
      previous_answered = got->sdo_replies > 0;
    }
    previous = std::move(buffer);
  }
  if (interrupted() || out_of_time()) {
    result.cut_short = true;
    return result;
  }
  result.anomaly = oracle();
  // The oracle's waits end with the run: a case it could not watch to the end is not judged.
  if (out_of_time()) {
    result.anomaly.reset();
    result.cut_short = true;
  }
  return result;
}

std::optional<EthercatAnomaly> Fuzzer::oracle() {
  const AlState held = master().held_state();
  if (auto drained = collect(options_.reply_wait, std::nullopt); !drained)
    return std::move(drained.error());
  if (auto a = pass_time(options_.observation)) return a;
  auto states = master().read_states();
  if (!states) return classify(states.error(), "reading the AL status");
  if (states->empty()) return EthercatAnomaly{EthercatAnomalyKind::device_silent, "no slave"};
  const ethercat::AlReading& al = (*states)[0];
  if (!al.in(held)) {
    return EthercatAnomaly{EthercatAnomalyKind::al_state_lost,
                           fmt::format("AL status {} ({:04X}h), expected {}", al.describe(),
                                       al.status, ethercat::al_state_name(held))};
  }
  if (al.error()) {
    if (al.code == 0) {
      return EthercatAnomaly{
          EthercatAnomalyKind::al_error_without_code,
          fmt::format("AL status {:04X}h: error indication set but AL status code 0000h "
                      "(ETG.1000.6: the slave writes the reason into 0134h)",
                      al.status)};
    }
    return EthercatAnomaly{EthercatAnomalyKind::al_error,
                           fmt::format("AL status {}", al.describe())};
  }
  // Close any transfer the case left open (the server answers a client's abort with nothing).
  const auto abort =
      ethercat::encode(ethercat::CoeSdoRequest{ethercat::CoeAbort{{0x1000, 0}, 0x08000000}});
  if (auto sent = mailbox().send(ethercat::MailboxType::coe, abort); !sent)
    return classify(sent.error(), "sending an SDO abort");
  std::optional<EthercatAnomaly> failure;
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (auto drained = collect(options_.reply_wait, std::nullopt); !drained)
      return std::move(drained.error());
    auto value = master().sdo_upload(0, {0x1000, 0});
    if (value && value->size() == 4) return std::nullopt;
    if (value) {
      failure = EthercatAnomaly{
          EthercatAnomalyKind::coe_ping_refused,
          fmt::format("SDO upload 1000h:00 returned {} octets, not 4", value->size())};
    } else {
      failure = classify(value.error(), "SDO upload 1000h:00");
      if (failure->kind == EthercatAnomalyKind::device_silent) return failure;
    }
  }
  return failure;
}

bool Fuzzer::recover() {
  if (auto down = master().request_state(AlState::preop); down) {
    if (auto states = master().read_states(); states && !states->empty()) {
      const auto& al = (*states)[0];
      if (al.in(AlState::preop) && !al.error()) return true;
    }
  }
  summary_.notes.push_back("the slave did not come back to PREOP after an anomaly: reset");
  return power_cycle();
}

std::filesystem::path Fuzzer::write_pcap(const std::string& stem) {
  if (options_.out_dir.empty()) return {};
  const auto path = options_.out_dir / (stem + ".pcap");
  ethercat::PcapWriter pcap(path, target_.link().unix_offset());
  for (const auto& frame : frames_)
    pcap.write(frame);
  pcap.flush();
  if (!pcap.ok()) {
    summary_.notes.push_back(fmt::format("cannot write {}: {}", path.string(), pcap.error()));
    return {};
  }
  return path;
}

std::filesystem::path Fuzzer::write_text(const std::string& stem, const EthercatCase& c,
                                         std::span<const std::size_t> keep,
                                         const EthercatAnomaly& a) {
  if (options_.out_dir.empty()) return {};
  const auto path = options_.out_dir / (stem + ".txt");
  std::ofstream out(path, std::ios::binary);
  out << fmt::format("# anomaly: {}: {}\n# case {} ({}) in {}, seed {}, on {}\n", to_string(a.kind),
                     a.detail, c.number, c.kind, ethercat::al_state_name(c.state), options_.seed,
                     target_.interface_name());
  for (const std::size_t i : keep)
    out << describe_step(c.steps[i]) << "\n";
  if (!out) {
    summary_.notes.push_back(fmt::format("cannot write {}", path.string()));
    return {};
  }
  return path;
}

void Fuzzer::minimise_into(EthercatAnomalyRecord& record, const EthercatCase& c,
                           const std::string& stem) {
  const EthercatAnomalyKind kind = record.anomaly.kind;
  bool lost = false;
  const auto fails = [&](std::span<const std::size_t> keep) {
    if (lost || interrupted()) return false;
    if (!power_cycle()) {
      lost = true;
      return false;
    }
    const CaseResult r = run_case(c, keep);
    return r.anomaly && r.anomaly->kind == kind;
  };
  const MinimiseResult m = minimise(c.steps.size(), fails, options_.max_minimise_tries);
  record.minimisation_tries = m.tries;
  if (lost) {
    record.minimisation_note = "the device could not be reset for a try: not minimised";
    return;
  }
  // The minimised case once more, recorded.
  if (!power_cycle()) return;
  frames_.clear();
  recording_ = true;
  const CaseResult r = run_case(c, m.kept);
  recording_ = false;
  if (!r.anomaly || r.anomaly->kind != kind) {
    record.minimisation_note = r.cut_short ? "the end of --duration came during minimisation"
                                           : "the minimised case did not show the anomaly again";
    return;
  }
  record.minimised = true;
  for (const std::size_t i : m.kept)
    record.minimised_steps.push_back(describe_step(c.steps[i]));
  record.minimised_pcap = write_pcap(stem + ".min");
  record.minimised_text = write_text(stem + ".min", c, m.kept, *r.anomaly);
  if (m.budget_exhausted)
    record.minimisation_note =
        fmt::format("try budget ({}) exhausted: may not be minimal", options_.max_minimise_tries);
}

EthercatFuzzSummary Fuzzer::run() {
  install_tap();
  restart_clock();
  if (master().slaves().empty() || master().mailbox(0) == nullptr) {
    summary_.outcome = EthercatFuzzOutcome::device_lost_at_start;
    summary_.notes.push_back("slave 0 has no mailbox (SII mailbox size 0): nothing to fuzz");
    return summary_;
  }
  auto first = master().sdo_upload(0, {0x1000, 0});
  if (!first || first->size() != 4) {
    summary_.outcome = EthercatFuzzOutcome::device_lost_at_start;
    summary_.notes.push_back(first ? "1000h:00 is not 4 octets"
                                   : "SDO upload 1000h:00: " + first.error().message());
    return summary_;
  }
  summary_.device_type = ethercat::get_le32(*first);

  // The states the slave reaches with this master (a slave without process data stays in PREOP).
  EthercatGeneratorOptions generator_options;
  generator_options.seed = options_.seed;
  generator_options.allow_motion = options_.allow_motion;
  if (const auto& out = master().slaves()[0].layout.mailbox_out)
    generator_options.write_size = out->length;
  generator_options.states = {AlState::preop};
  for (const AlState s : {AlState::safeop, AlState::op}) {
    if (auto up = master().request_state(s); up) {
      generator_options.states.push_back(s);
    } else {
      summary_.notes.push_back(fmt::format("the slave does not reach {}: cases run below it ({})",
                                           ethercat::al_state_name(s), up.error().message()));
      break;
    }
  }
  if (!recover()) {
    summary_.outcome = EthercatFuzzOutcome::device_lost_at_start;
    summary_.notes.push_back("the slave does not go back to PREOP");
    return summary_;
  }
  for (const AlState s : generator_options.states)
    summary_.states.push_back(ethercat::al_state_name(s));
  const EthercatCaseGenerator generator(generator_options, options_.objects);
  restart_clock();

  std::set<EthercatAnomalyKind> minimised_kinds;
  for (std::uint64_t number = 1;; ++number) {
    if (interrupted()) {
      summary_.outcome = EthercatFuzzOutcome::interrupted;
      break;
    }
    if (out_of_time()) break;
    if (options_.max_cases != 0 && summary_.cases_run >= options_.max_cases) break;
    const EthercatCase c = generator.generate(number);
    if (c.steps.empty()) continue;
    std::vector<std::size_t> all(c.steps.size());
    std::iota(all.begin(), all.end(), std::size_t{0});
    frames_.clear();
    recording_ = true;
    const CaseResult result = run_case(c, all);
    recording_ = false;
    if (result.cut_short) {
      if (interrupted()) continue;
      summary_.notes.push_back(fmt::format(
          "case {} ({}) was cut short by the end of --duration: not judged", number, c.kind));
      break;
    }
    ++summary_.cases_run;
    ++summary_.cases_by_kind[c.kind];
    ++summary_.cases_by_state[ethercat::al_state_name(c.state)];
    if (!result.anomaly) continue;

    EthercatAnomalyRecord record;
    record.case_number = number;
    record.case_kind = c.kind;
    record.state = ethercat::al_state_name(c.state);
    record.anomaly = *result.anomaly;
    for (const auto& step : c.steps)
      record.steps.push_back(describe_step(step));
    const std::string stem =
        fmt::format("anomaly-{}-{}", summary_.anomalies.size() + 1, to_string(record.anomaly.kind));
    ++summary_.anomalies_by_kind[std::string(to_string(record.anomaly.kind))];
    progress(fmt::format("case {} ({} in {}): {}: {}", number, c.kind, record.state,
                         to_string(record.anomaly.kind), record.anomaly.detail));
    if (summary_.anomalies.size() < options_.max_logs) {
      record.pcap = write_pcap(stem);
      record.text = write_text(stem, c, all, record.anomaly);
    }
    const bool first_of_kind = minimised_kinds.insert(record.anomaly.kind).second;
    if (options_.minimise && first_of_kind) {
      minimise_into(record, c, stem);
      if (!record.minimised && record.minimisation_note.empty())
        record.minimisation_note = "the device cannot be reset for minimisation";
      // Go on from a fresh device (or the one there is).
      (void)power_cycle();
    }
    summary_.anomalies.push_back(std::move(record));
    if (!recover()) {
      summary_.device_lost = true;
      summary_.notes.push_back("the device was lost: the run ends");
      break;
    }
  }
  summary_.elapsed = elapsed();
  if (summary_.outcome != EthercatFuzzOutcome::interrupted)
    summary_.outcome =
        summary_.anomalies.empty() ? EthercatFuzzOutcome::clean : EthercatFuzzOutcome::anomalies;
  // Leave the slave in PREOP: outputs are no longer taken, the drive's 6007h reaction runs.
  (void)master().request_state(AlState::preop);
  return summary_;
}

EthercatReplayResult Fuzzer::replay(const EthercatCase& c) {
  EthercatReplayResult result;
  install_tap();
  restart_clock();
  if (master().slaves().empty() || master().mailbox(0) == nullptr) return result;
  auto first = master().sdo_upload(0, {0x1000, 0});
  if (!first || first->size() != 4) return result;
  result.device_answered = true;
  std::vector<std::size_t> all(c.steps.size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  const CaseResult r = run_case(c, all);
  if (r.cut_short) result.notes.push_back("the replay was cut short: not judged");
  result.anomaly = r.anomaly;
  (void)master().request_state(AlState::preop);
  return result;
}

std::optional<std::uint8_t> hex_octet(std::string_view text) {
  if (text.size() != 2) return std::nullopt;
  unsigned value = 0;
  for (const char ch : text) {
    value <<= 4;
    if (ch >= '0' && ch <= '9') {
      value |= static_cast<unsigned>(ch - '0');
    } else if (ch >= 'A' && ch <= 'F') {
      value |= static_cast<unsigned>(ch - 'A' + 10);
    } else if (ch >= 'a' && ch <= 'f') {
      value |= static_cast<unsigned>(ch - 'a' + 10);
    } else {
      return std::nullopt;
    }
  }
  return static_cast<std::uint8_t>(value);
}

// "Cnt next Type 3 Length 10 Channel 0 Priority 0: ... | 00 20 40 ..."
std::optional<MailboxStep> parse_step(std::string_view line) {
  const auto bar = line.rfind(" |");
  const auto colon = line.find(':');
  if (bar == std::string_view::npos || colon == std::string_view::npos || colon > bar)
    return std::nullopt;
  std::istringstream fields{std::string(line.substr(0, colon))};
  std::string cnt, mode, type_word, length_word, channel_word, priority_word;
  unsigned type = 0, length = 0, channel = 0, priority = 0;
  if (!(fields >> cnt >> mode >> type_word >> type >> length_word >> length >> channel_word >>
        channel >> priority_word >> priority) ||
      cnt != "Cnt" || type_word != "Type" || length_word != "Length" || channel_word != "Channel" ||
      priority_word != "Priority" || type > 15 || length > 0xFFFF || channel > 63 || priority > 3)
    return std::nullopt;
  MailboxStep step;
  if (mode == "next") {
    step.counter = CounterMode::next;
  } else if (mode == "repeat") {
    step.counter = CounterMode::repeat;
  } else if (mode == "zero") {
    step.counter = CounterMode::zero;
  } else if (mode == "skip") {
    step.counter = CounterMode::skip;
  } else {
    return std::nullopt;
  }
  step.type = static_cast<std::uint8_t>(type);
  step.channel = static_cast<std::uint8_t>(channel);
  step.priority = static_cast<std::uint8_t>(priority);
  std::istringstream octets{std::string(line.substr(bar + 2))};
  std::string octet;
  while (octets >> octet) {
    const auto value = hex_octet(octet);
    if (!value) return std::nullopt;
    step.data.push_back(*value);
  }
  if (length != step.data.size()) step.length = static_cast<std::uint16_t>(length);
  return step;
}

}  // namespace

std::optional<EthercatAnomalyKind> ethercat_anomaly_kind_from_string(std::string_view text) {
  for (const auto kind :
       {EthercatAnomalyKind::device_silent, EthercatAnomalyKind::working_counter,
        EthercatAnomalyKind::al_state_lost, EthercatAnomalyKind::al_error_without_code,
        EthercatAnomalyKind::al_error, EthercatAnomalyKind::mailbox_repeat_executed,
        EthercatAnomalyKind::coe_no_answer, EthercatAnomalyKind::coe_ping_refused}) {
    if (to_string(kind) == text) return kind;
  }
  return std::nullopt;
}

Expected<EthercatReproducer, std::string> parse_ethercat_reproducer(std::string_view text,
                                                                    const std::string& name) {
  EthercatReproducer out;
  bool have_case = false;
  std::size_t number = 0;
  std::size_t start = 0;
  while (start < text.size()) {
    const auto end = text.find('\n', start);
    std::string_view line = text.substr(start, end == std::string_view::npos ? end : end - start);
    start = end == std::string_view::npos ? text.size() : end + 1;
    ++number;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (line.rfind("# anomaly: ", 0) == 0) {
      const auto rest = line.substr(11);
      out.anomaly = ethercat_anomaly_kind_from_string(rest.substr(0, rest.find(':')));
      continue;
    }
    if (line.rfind("# case ", 0) == 0) {
      const auto in = line.find(") in ");
      if (in == std::string_view::npos)
        return Unexpected(fmt::format("{}:{}: a '# case' line without its AL state", name, number));
      auto state = line.substr(in + 5);
      state = state.substr(0, state.find(','));
      std::optional<AlState> parsed;
      for (const AlState s : {AlState::init, AlState::preop, AlState::safeop, AlState::op})
        if (ethercat::al_state_name(s) == state) parsed = s;
      if (!parsed || *parsed == AlState::init)
        return Unexpected(
            fmt::format("{}:{}: AL state '{}' is not PREOP, SAFEOP or OP", name, number, state));
      out.c.state = *parsed;
      have_case = true;
      continue;
    }
    if (line.front() == '#') continue;
    auto step = parse_step(line);
    if (!step)
      return Unexpected(fmt::format(
          "{}:{}: not a step ('Cnt MODE Type T Length L Channel C Priority P: ... | octets')", name,
          number));
    out.c.steps.push_back(std::move(*step));
  }
  if (!have_case)
    return Unexpected(
        fmt::format("{}: no '# case N (kind) in STATE' line: not an EtherCAT "
                    "reproducer",
                    name));
  return out;
}

EthercatReplayResult replay_ethercat_case(EthercatTarget& target, const EthercatCase& c,
                                          const EthercatFuzzerOptions& options) {
  Fuzzer fuzzer(target, options);
  return fuzzer.replay(c);
}

std::string_view to_string(EthercatAnomalyKind kind) {
  switch (kind) {
    case EthercatAnomalyKind::device_silent:
      return "device-silent";
    case EthercatAnomalyKind::working_counter:
      return "working-counter";
    case EthercatAnomalyKind::al_state_lost:
      return "al-state-lost";
    case EthercatAnomalyKind::al_error_without_code:
      return "al-error-without-code";
    case EthercatAnomalyKind::al_error:
      return "al-error";
    case EthercatAnomalyKind::mailbox_repeat_executed:
      return "mailbox-repeat-executed";
    case EthercatAnomalyKind::coe_no_answer:
      return "coe-no-answer";
    case EthercatAnomalyKind::coe_ping_refused:
      return "coe-ping-refused";
  }
  return "device-silent";
}

std::string_view to_string(EthercatFuzzOutcome outcome) {
  switch (outcome) {
    case EthercatFuzzOutcome::clean:
      return "clean";
    case EthercatFuzzOutcome::anomalies:
      return "anomalies";
    case EthercatFuzzOutcome::device_lost_at_start:
      return "device-lost-at-start";
    case EthercatFuzzOutcome::interrupted:
      return "interrupted";
  }
  return "clean";
}

EthercatFuzzSummary run_ethercat_fuzzer(EthercatTarget& target,
                                        const EthercatFuzzerOptions& options) {
  Fuzzer fuzzer(target, options);
  return fuzzer.run();
}

}  // namespace drivecheck::fuzz_live

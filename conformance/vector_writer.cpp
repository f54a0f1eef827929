// Vector model → vector file text (vector_file.hpp: to_yaml, same_content). The inverse of the
// loader in vector_file.cpp: every key written here is one the loader reads (FORMAT.md
// "Steps (the closed vocabulary)"), and what the loader accepted comes back equal.
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "conformance/vector_file.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {

std::string to_text(const ValueSpec& value) {
  if (value.saved.empty()) return fmt::format("{}", value.literal);
  std::string text = "$" + value.saved;
  if (value.multiplier != 1) text += fmt::format("*{}", value.multiplier);
  if (value.divisor != 1) text += fmt::format("/{}", value.divisor);
  if (value.offset != 0) text += fmt::format("{:+}", value.offset);
  return text;
}

namespace {

// The keywords of the model's enums, as FORMAT.md spells them (the loader's inverse).
std::string level_keyword(Level level) {
  switch (level) {
    case Level::must:
      return "must";
    case Level::should:
      return "should";
    case Level::may:
      return "may";
  }
  return fmt::format("{}", static_cast<int>(level));  // not a keyword: fails to load, loudly
}

std::string setup_keyword(Setup setup) {
  switch (setup) {
    case Setup::reset_node:
      return "reset-node";
    case Setup::reset_communication:
      return "reset-communication";
    case Setup::restore_defaults:
      return "restore-defaults";
    case Setup::none:
      return "none";
  }
  return fmt::format("{}", static_cast<int>(setup));
}

std::string nmt_state_keyword(cia301::NmtState state) {
  switch (state) {
    case cia301::NmtState::boot_up:
      return "bootup";
    case cia301::NmtState::stopped:
      return "stopped";
    case cia301::NmtState::operational:
      return "operational";
    case cia301::NmtState::pre_operational:
      return "pre-operational";
  }
  return fmt::format("{}", static_cast<int>(state));
}

std::string nmt_command_keyword(cia301::NmtCommand command) {
  switch (command) {
    case cia301::NmtCommand::start:
      return "start";
    case cia301::NmtCommand::stop:
      return "stop";
    case cia301::NmtCommand::enter_pre_operational:
      return "pre-operational";
    case cia301::NmtCommand::reset_node:
      return "reset-node";
    case cia301::NmtCommand::reset_communication:
      return "reset-communication";
  }
  return fmt::format("{}", static_cast<int>(command));
}

std::string state_402_keyword(cia402::State state) {
  switch (state) {
    case cia402::State::not_ready_to_switch_on:
      return "not-ready-to-switch-on";
    case cia402::State::switch_on_disabled:
      return "switch-on-disabled";
    case cia402::State::ready_to_switch_on:
      return "ready-to-switch-on";
    case cia402::State::switched_on:
      return "switched-on";
    case cia402::State::operation_enabled:
      return "operation-enabled";
    case cia402::State::quick_stop_active:
      return "quick-stop-active";
    case cia402::State::fault_reaction_active:
      return "fault-reaction-active";
    case cia402::State::fault:
      return "fault";
  }
  return fmt::format("{}", static_cast<int>(state));
}

// nullopt: Transfer::automatic, which has no keyword (the key is left out).
std::optional<std::string> transfer_keyword(Transfer transfer) {
  switch (transfer) {
    case Transfer::automatic:
      return std::nullopt;
    case Transfer::expedited:
      return "expedited";
    case Transfer::segmented:
      return "segmented";
    case Transfer::block:
      return "block";
    case Transfer::complete_access:
      return "complete-access";
  }
  return fmt::format("{}", static_cast<int>(transfer));
}

std::string duration_text(const DurationSpec& duration) {
  if (duration.is_timing()) return "$timing." + duration.timing;
  return profile::format_duration(duration.value);
}

// FORMAT.md "COB-ID": 3 hex digits (11 bits) or 8 (29 bits), then `+N`.
std::string cob_id_text(const CobIdSpec& cob) {
  return fmt::format("{:0{}X}{}", cob.base, cob.extended ? 8 : 3, cob.plus_node ? "+N" : "");
}

std::string hex_bytes(const std::vector<std::uint8_t>& bytes) {
  return fmt::format("{:02X}", fmt::join(bytes, ""));
}

std::string pattern_bytes(const std::vector<std::optional<std::uint8_t>>& bytes) {
  std::string text;
  for (const auto& byte : bytes)
    text += byte ? fmt::format("{:02X}", *byte) : std::string("..");
  return text;
}

std::string value_text(const ValueSpec& value) {
  return to_text(value);
}

class Writer {
 public:
  void vectors(const std::vector<Vector>& list) {
    out_ << YAML::BeginSeq;
    for (const Vector& vector : list)
      one(vector);
    out_ << YAML::EndSeq;
  }

  std::string text() const { return std::string(out_.c_str()) + "\n"; }

 private:
  void key(std::string_view name) { out_ << YAML::Key << std::string(name) << YAML::Value; }
  void quoted(const std::string& text) { out_ << YAML::DoubleQuoted << text; }
  void plain(const std::string& text) { out_ << text; }

  void one(const Vector& v) {
    out_ << YAML::BeginMap;
    key("id");
    quoted(v.id);
    key("title");
    quoted(v.title);
    key("source");
    out_ << YAML::BeginSeq;
    for (const Source& source : v.sources)
      quoted(source.text);
    out_ << YAML::EndSeq;
    key("level");
    plain(level_keyword(v.level));
    key("requires");
    out_ << YAML::Flow << YAML::BeginSeq;
    for (const std::string& feature : v.requires_features)
      quoted(feature);
    out_ << YAML::EndSeq;
    if (!v.unless_features.empty()) {
      key("unless");
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const std::string& feature : v.unless_features)
        quoted(feature);
      out_ << YAML::EndSeq;
    }
    key("profiles");
    out_ << YAML::Flow << YAML::BeginSeq;
    for (const std::string& profile : v.profiles)
      quoted(profile);
    out_ << YAML::EndSeq;
    if (!v.transports.empty()) {
      key("transports");
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const std::string& link : v.transports)
        quoted(link);
      out_ << YAML::EndSeq;
    }
    key("motion");
    plain(v.motion ? "true" : "false");
    key("setup");
    plain(setup_keyword(v.setup));
    key("nmt");
    plain(v.nmt ? nmt_state_keyword(*v.nmt) : "none");
    if (v.drive_state) {
      key("drive_state");
      plain(state_402_keyword(*v.drive_state));
    }
    key("timeout");
    quoted(duration_text(v.timeout));
    key("steps");
    step_list(v.steps, 0, v.steps.size(), 0);
    if (!v.finally_steps.empty()) {
      key("finally");
      step_list(v.finally_steps, 0, v.finally_steps.size(), 0);
    }
    if (!v.note.empty()) {
      key("note");
      quoted(v.note);
    }
    out_ << YAML::EndMap;
  }

  // steps[begin, end) at `depth` repeats: the loader's unrolled repeats written back as
  // `repeat: {times, steps}` with the steps of their first iteration.
  void step_list(const std::vector<Step>& steps, std::size_t begin, std::size_t end,
                 std::size_t depth) {
    out_ << YAML::BeginSeq;
    std::size_t i = begin;
    while (i < end) {
      if (steps[i].repeats.size() <= depth) {
        step(steps[i]);
        ++i;
        continue;
      }
      const StepRepeat& repeat = steps[i].repeats[depth];
      const auto in_repeat = [&](std::size_t k) {
        return steps[k].repeats.size() > depth && steps[k].repeats[depth].number == repeat.number;
      };
      std::size_t first_end = i;
      while (first_end < end && in_repeat(first_end) &&
             steps[first_end].repeats[depth].iteration == steps[i].repeats[depth].iteration)
        ++first_end;
      std::size_t last = first_end;
      while (last < end && in_repeat(last))
        ++last;
      out_ << YAML::BeginMap;
      key("repeat");
      out_ << YAML::BeginMap;
      key("times");
      plain(fmt::format("{}", repeat.times));
      key("steps");
      step_list(steps, i, first_end, depth + 1);
      out_ << YAML::EndMap;
      if (!repeat.note.empty()) {
        key("note");
        quoted(repeat.note);
      }
      out_ << YAML::EndMap;
      i = last;
    }
    out_ << YAML::EndSeq;
  }

  void step(const Step& step) {
    out_ << YAML::BeginMap;
    std::visit([this](const auto& action) { this->action(action); }, step.action);
    // expect_frame and expect_sdo_response write their clause: with the action.
    if (!step.clause.empty() && frame_expected(step) == nullptr) {
      key("clause");
      quoted(step.clause);
    }
    if (!step.note.empty()) {
      key("note");
      quoted(step.note);
    }
    out_ << YAML::EndMap;
  }

  void duration_key(std::string_view name, const DurationSpec& duration) {
    key(name);
    quoted(duration_text(duration));
  }
  void name_key(std::string_view name, const std::string& value) {
    if (value.empty()) return;
    key(name);
    quoted(value);
  }
  void index_sub(std::uint16_t index, std::uint8_t sub) {
    key("index");
    plain(fmt::format("0x{:04X}", index));
    key("sub");
    plain(fmt::format("{}", sub));
  }
  void transfer(Transfer transfer) {
    if (const auto keyword = transfer_keyword(transfer)) {
      key("transfer");
      plain(*keyword);
    }
  }
  // `abort:` as written: the set's name, or the literal list.
  void abort(const AbortExpect& abort) {
    key("abort");
    if (!abort.set.empty()) {
      plain(abort.set);
      return;
    }
    out_ << YAML::Flow << YAML::BeginSeq;
    for (const std::uint32_t code : abort.codes)
      plain(fmt::format("0x{:08X}", code));
    out_ << YAML::EndSeq;
  }
  void expect(const SdoExpect& expect) {
    key("expect");
    if (expect.kind == SdoExpect::Kind::ok) {
      plain("ok");
      return;
    }
    if (expect.kind == SdoExpect::Kind::ok_or_abort) {
      plain("ok-or-abort");
      return;
    }
    out_ << YAML::Flow << YAML::BeginMap;
    switch (expect.kind) {
      case SdoExpect::Kind::ok:
      case SdoExpect::Kind::ok_or_abort:
        break;
      case SdoExpect::Kind::value:
        key("value");
        quoted(value_text(expect.value));
        if (expect.mask) {
          key("mask");
          plain(fmt::format("0x{:X}", *expect.mask));
        }
        break;
      case SdoExpect::Kind::range:
        key("range");
        out_ << YAML::Flow << YAML::BeginSeq << value_text(expect.low) << value_text(expect.high)
             << YAML::EndSeq;
        break;
      case SdoExpect::Kind::size:
        key("size");
        plain(fmt::format("{}", expect.size));
        break;
      case SdoExpect::Kind::data:
        key("data");
        quoted(hex_bytes(expect.data));
        break;
      case SdoExpect::Kind::abort:
        abort(expect.abort);
        if (!expect.abort.clause.empty()) {
          key("clause");
          quoted(expect.abort.clause);
        }
        break;
    }
    out_ << YAML::EndMap;
  }

  void action(const SendStep& s) {
    key("send");
    quoted(s.frame.text);
  }
  void action(const NmtStep& s) {
    key("nmt");
    plain(nmt_command_keyword(s.command));
    key("node");
    switch (s.node.kind) {
      case NodeKind::dut:
        plain("N");
        break;
      case NodeKind::broadcast:
        plain("all");
        break;
      case NodeKind::other:
        plain("other");
        break;
      case NodeKind::value:
        plain(fmt::format("{}", s.node.value));
        break;
    }
  }
  void action(const SdoWriteStep& s) {
    key("sdo_write");
    out_ << YAML::Flow << YAML::BeginMap;
    index_sub(s.index, s.sub);
    if (s.value) {
      key("value");
      quoted(value_text(*s.value));
      if (s.size) {
        key("size");
        plain(fmt::format("{}", *s.size));
      }
    } else {
      key("data");
      quoted(hex_bytes(s.data));
    }
    out_ << YAML::EndMap;
    transfer(s.transfer);
    expect(s.expect);
    if (const auto& refusal = s.refused_means_not_applicable) {
      key("refused_means_not_applicable");
      if (!refusal->set.empty()) {
        plain(refusal->set);
      } else {
        out_ << YAML::Flow << YAML::BeginSeq;
        for (const std::uint32_t code : refusal->codes)
          plain(fmt::format("0x{:08X}", code));
        out_ << YAML::EndSeq;
      }
    }
  }
  void action(const SdoReadStep& s) {
    key("sdo_read");
    out_ << YAML::Flow << YAML::BeginMap;
    index_sub(s.index, s.sub);
    out_ << YAML::EndMap;
    transfer(s.transfer);
    if (s.block_size != 0) {
      key("block_size");
      plain(fmt::format("{}", s.block_size));
    }
    expect(s.expect);
    key("signed");
    plain(s.is_signed ? "true" : "false");
    name_key("save", s.save);
    name_key("relative_to", s.relative_to);
  }
  void action(const WaitStep& s) { duration_key("wait", s.duration); }
  void action(const BusOffStep& s) { duration_key("bus_off", s.duration); }
  void action(const PowerCycleStep&) {
    key("power_cycle");
    out_ << YAML::Flow << YAML::BeginMap << YAML::EndMap;
  }
  static std::string al_state_keyword(std::uint8_t state) {
    switch (state) {
      case 1:
        return "init";
      case 2:
        return "preop";
      case 3:
        return "boot";
      case 4:
        return "safeop";
      default:
        return "op";
    }
  }
  void al_expect(const AlExpect& e) {
    out_ << YAML::Flow << YAML::BeginMap;
    if (e.state != 0) {
      key("state");
      plain(al_state_keyword(e.state));
    }
    key("error");
    plain(e.error ? "true" : "false");
    if (!e.names.empty()) {
      key("code");
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const auto& name : e.names)
        plain(name);
      out_ << YAML::EndSeq;
    }
    out_ << YAML::EndMap;
  }
  void action(const AlRequestStep& s) {
    key("al_request");
    plain(al_state_keyword(s.state));
    if (s.expect != AlExpect{}) {
      key("expect");
      al_expect(s.expect);
    }
    duration_key("within", s.within);
  }
  void action(const ExpectAlStep& s) {
    key("expect_al");
    al_expect(s.expect);
    duration_key("within", s.within);
  }
  void action(const ProcessDataStep& s) {
    key("process_data");
    out_ << YAML::Flow << YAML::BeginMap;
    key("cycles");
    plain(fmt::format("{}", s.cycles));
    out_ << YAML::EndMap;
  }
  void action(const CyclicStep& s) {
    key("cyclic");
    out_ << YAML::Flow << YAML::BeginMap;
    key("cycles");
    plain(fmt::format("{}", s.cycles));
    duration_key("period", s.period);
    out_ << YAML::EndMap;
    if (s.set.empty()) return;
    key("set");
    out_ << YAML::BeginSeq;
    for (const CyclicSetPoint& point : s.set) {
      out_ << YAML::Flow << YAML::BeginMap;
      index_sub(point.index, point.sub);
      key("value");
      quoted(value_text(point.value));
      key("size");
      plain(fmt::format("{}", point.size));
      out_ << YAML::EndMap;
    }
    out_ << YAML::EndSeq;
  }
  void action(const PauseProcessDataStep& s) {
    if (s.duration) {
      duration_key("pause_process_data", *s.duration);
    } else {
      key("pause_process_data");
      plain("watchdog");
    }
  }
  void action(const MailboxRepeatStep& s) {
    key("mailbox_repeat");
    out_ << YAML::Flow << YAML::BeginMap;
    index_sub(s.index, s.sub);
    key("size");
    plain(fmt::format("{}", s.size));
    key("value");
    plain(fmt::format("{}", s.value));
    key("repeat");
    plain(fmt::format("{}", s.repeat));
    out_ << YAML::EndMap;
  }
  void action(const ControlwordStep& s) {
    key("controlword");
    plain(fmt::format("0x{:04X}", s.value));
  }
  void action(const SimulateStep& s) {
    key("simulate");
    out_ << YAML::Flow << YAML::BeginMap;
    key("input");
    quoted(s.input);
    key("value");
    plain(fmt::format("{}", s.value));
    out_ << YAML::EndMap;
  }
  void action(const MarkStep& s) {
    key("mark");
    quoted(s.name);
  }
  void action(const ExpectFrameStep& s) { expect_frame("expect_frame", s, pattern_text); }
  void action(const SdoRequestStep& s) {
    key("sdo_request");
    quoted(sdo_octets_text(s.send.frame));
  }
  void action(const ExpectSdoResponseStep& s) {
    expect_frame("expect_sdo_response", s.expect, sdo_octets_text);
  }
  static std::string pattern_text(const FrameSpec& frame) { return frame.text; }
  // The octets of sdo_request / expect_sdo_response as written: the CAN frame's text after '#'.
  static std::string sdo_octets_text(const FrameSpec& frame) {
    const auto hash = frame.text.find('#');
    return hash == std::string::npos ? frame.text : frame.text.substr(hash + 1);
  }
  template <typename Text>
  void expect_frame(std::string_view action_key, const ExpectFrameStep& s, Text&& text) {
    key(action_key);
    quoted(text(s.pattern));
    if (s.abort) abort(*s.abort);
    if (!s.alternatives.empty()) {
      key("or");
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const FrameSpec& alternative : s.alternatives)
        quoted(text(alternative));
      out_ << YAML::EndSeq;
    }
    if (!s.clause.empty()) {
      key("clause");
      quoted(s.clause);
    }
    duration_key("within", s.within);
    name_key("mark", s.mark);
    name_key("since", s.since);
  }
  void action(const ExpectSilenceStep& s) {
    key("expect_silence");
    if (s.any) {
      plain("any");
    } else {
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const CobIdSpec& cob : s.cob_ids)
        quoted(cob_id_text(cob));
      for (const FrameSpec& pattern : s.patterns)
        quoted(pattern.text);
      out_ << YAML::EndSeq;
    }
    duration_key("for", s.duration);
    name_key("since", s.since);
  }
  void action(const ExpectBootupStep& s) {
    key("expect_bootup");
    out_ << YAML::Flow << YAML::BeginMap << YAML::EndMap;
    duration_key("within", s.within);
    name_key("mark", s.mark);
    name_key("since", s.since);
  }
  void action(const ExpectHeartbeatStep& s) {
    key("expect_heartbeat");
    plain(nmt_state_keyword(s.state));
    if (s.within) duration_key("within", *s.within);
    name_key("mark", s.mark);
    name_key("since", s.since);
  }
  void action(const ExpectEmcyStep& s) {
    key("expect_emcy");
    out_ << YAML::Flow << YAML::BeginMap;
    key("code");
    if (s.any_error) {
      plain("error");
    } else {
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const std::uint16_t code : s.codes)
        plain(fmt::format("0x{:04X}", code));
      out_ << YAML::EndSeq;
    }
    if (s.register_mask) {
      key("register");
      out_ << YAML::Flow << YAML::BeginMap;
      key("mask");
      plain(fmt::format("0x{:02X}", *s.register_mask));
      key("value");
      plain(fmt::format("0x{:02X}", s.register_value));
      out_ << YAML::EndMap;
    }
    if (!s.manufacturer.empty()) {
      key("manufacturer");
      quoted(pattern_bytes(s.manufacturer));
    }
    out_ << YAML::EndMap;
    duration_key("within", s.within);
    name_key("mark", s.mark);
    name_key("since", s.since);
  }
  void action(const ExpectStateStep& s) {
    key("expect_state");
    plain(state_402_keyword(s.state));
    duration_key("within", s.within);
  }
  void action(const ExpectStatuswordStep& s) {
    key("expect_statusword");
    out_ << YAML::Flow << YAML::BeginMap;
    key("mask");
    plain(fmt::format("0x{:04X}", s.mask));
    key("value");
    plain(fmt::format("0x{:04X}", s.value));
    out_ << YAML::EndMap;
    duration_key("within", s.within);
  }
  void action(const PollStep& s) {
    key("poll");
    out_ << YAML::Flow << YAML::BeginMap;
    index_sub(s.index, s.sub);
    if (s.range) {
      key("range");
      out_ << YAML::Flow << YAML::BeginSeq << value_text(s.range->first)
           << value_text(s.range->second) << YAML::EndSeq;
    } else {
      key("value");
      plain(fmt::format("0x{:X}", s.value));
      key("mask");
      plain(fmt::format("0x{:X}", s.mask));
    }
    out_ << YAML::EndMap;
    if (s.is_signed) {
      key("signed");
      plain("true");
    }
    duration_key("within", s.within);
    duration_key("every", s.every);
  }
  void action(const MeasureStep& s) {
    key("measure");
    out_ << YAML::Flow << YAML::BeginMap;
    key("from");
    quoted(s.from);
    key("to");
    quoted(s.to);
    if (s.frames.size() == 1) {
      key("frames");
      quoted(s.frames.front().text);
    } else if (!s.frames.empty()) {
      key("frames");
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const FrameSpec& pattern : s.frames)
        quoted(pattern.text);
      out_ << YAML::EndSeq;
    }
    if (!s.frames.empty()) {
      if (s.min_count) {
        key("min");
        plain(fmt::format("{}", *s.min_count));
      }
      if (s.max_count) {
        key("max");
        plain(fmt::format("{}", *s.max_count));
      }
    }
    if (s.min) duration_key("min", *s.min);
    if (s.max) duration_key("max", *s.max);
    out_ << YAML::EndMap;
  }
  void action(const ExpectPeriodicStep& s) {
    key("expect_periodic");
    quoted(cob_id_text(s.cob));
    duration_key("period", s.period);
    duration_key("tolerance", s.tolerance);
    key("count");
    plain(fmt::format("{}", s.count));
    name_key("mark", s.mark);
    name_key("last", s.last);
  }

  YAML::Emitter out_;
};

bool same_source(const Source& a, const Source& b) {
  return a.text == b.text && a.manual == b.manual && a.section == b.section && a.first == b.first &&
         a.last == b.last;
}

}  // namespace

std::string to_yaml(const std::vector<Vector>& vectors) {
  Writer writer;
  writer.vectors(vectors);
  return writer.text();
}

bool same_content(const Vector& a, const Vector& b) {
  const auto same_step = [](const Step& x, const Step& y) {
    return x.action == y.action && x.note == y.note && x.clause == y.clause &&
           x.repeats == y.repeats;
  };
  return a.id == b.id && a.title == b.title &&
         std::equal(a.sources.begin(), a.sources.end(), b.sources.begin(), b.sources.end(),
                    same_source) &&
         a.level == b.level && a.requires_features == b.requires_features &&
         a.unless_features == b.unless_features && a.profiles == b.profiles &&
         a.transports == b.transports && a.motion == b.motion && a.setup == b.setup &&
         a.nmt == b.nmt && a.drive_state == b.drive_state && a.timeout == b.timeout &&
         std::equal(a.steps.begin(), a.steps.end(), b.steps.begin(), b.steps.end(), same_step) &&
         std::equal(a.finally_steps.begin(), a.finally_steps.end(), b.finally_steps.begin(),
                    b.finally_steps.end(), same_step) &&
         a.note == b.note;
}

}  // namespace drivecheck::conformance

#include "conformance/vector_file.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include "conformance/device_values.hpp"
#include "protocol/cia301/sdo_abort_sets.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/ethercat/al_state_machine.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {

// ---- the model's small functions ----

std::string_view action_name(const Action& action) {
  constexpr std::array<std::string_view, std::variant_size_v<Action>> kNames{"send",
                                                                             "nmt",
                                                                             "sdo_write",
                                                                             "sdo_read",
                                                                             "wait",
                                                                             "controlword",
                                                                             "simulate",
                                                                             "mark",
                                                                             "expect_frame",
                                                                             "expect_silence",
                                                                             "expect_bootup",
                                                                             "expect_heartbeat",
                                                                             "expect_emcy",
                                                                             "expect_state",
                                                                             "expect_statusword",
                                                                             "poll",
                                                                             "measure",
                                                                             "expect_periodic",
                                                                             "bus_off",
                                                                             "al_request",
                                                                             "expect_al",
                                                                             "process_data",
                                                                             "pause_process_data",
                                                                             "mailbox_repeat",
                                                                             "sdo_request",
                                                                             "expect_sdo_response",
                                                                             "cyclic",
                                                                             "power_cycle"};
  return kNames[action.index()];
}

const SendStep* frame_sent(const Step& step) {
  if (const auto* send = std::get_if<SendStep>(&step.action)) return send;
  if (const auto* request = std::get_if<SdoRequestStep>(&step.action)) return &request->send;
  return nullptr;
}

const ExpectFrameStep* frame_expected(const Step& step) {
  if (const auto* frame = std::get_if<ExpectFrameStep>(&step.action)) return frame;
  if (const auto* response = std::get_if<ExpectSdoResponseStep>(&step.action))
    return &response->expect;
  return nullptr;
}

std::size_t step_number(const std::vector<Step>& steps, std::size_t index) {
  if (index < steps.size() && steps[index].number != 0) return steps[index].number;
  return index + 1;
}

std::vector<Iteration> iterations_of(const Step& step) {
  std::vector<Iteration> iterations;
  iterations.reserve(step.repeats.size());
  for (const StepRepeat& repeat : step.repeats)
    iterations.push_back(Iteration{repeat.iteration, repeat.times});
  return iterations;
}

std::string step_place(const std::vector<Step>& steps, std::size_t index) {
  return step_label(step_number(steps, index),
                    index < steps.size() ? iterations_of(steps[index]) : std::vector<Iteration>{});
}

std::string Vector::ethercat_only_step() const {
  const auto check = [](const std::vector<Step>& list, const char* where) -> std::string {
    for (std::size_t i = 0; i < list.size(); ++i) {
      const auto& action = list[i].action;
      if (std::holds_alternative<AlRequestStep>(action) ||
          std::holds_alternative<ExpectAlStep>(action) ||
          std::holds_alternative<ProcessDataStep>(action) ||
          std::holds_alternative<PauseProcessDataStep>(action) ||
          std::holds_alternative<MailboxRepeatStep>(action) ||
          std::holds_alternative<PowerCycleStep>(action))
        return fmt::format("{} {} ({})", where, step_place(list, i), action_name(action));
      const auto* write = std::get_if<SdoWriteStep>(&action);
      const auto* read = std::get_if<SdoReadStep>(&action);
      if ((write != nullptr && write->transfer == Transfer::complete_access) ||
          (read != nullptr && read->transfer == Transfer::complete_access))
        return fmt::format("{} {} ({} with complete access)", where, step_place(list, i),
                           action_name(action));
    }
    return {};
  };
  if (auto step = check(steps, "steps:"); !step.empty()) return step;
  return check(finally_steps, "finally:");
}

std::vector<CyclicSetPoint> Vector::cyclic_set_points() const {
  std::vector<CyclicSetPoint> out;
  for (const auto* list : {&steps, &finally_steps}) {
    for (const Step& step : *list) {
      const auto* cyclic = std::get_if<CyclicStep>(&step.action);
      if (cyclic == nullptr) continue;
      for (const CyclicSetPoint& point : cyclic->set) {
        const bool known = std::any_of(out.begin(), out.end(), [&](const CyclicSetPoint& p) {
          return p.index == point.index && p.sub == point.sub;
        });
        if (!known) out.push_back(point);
      }
    }
  }
  return out;
}

bool Vector::has_cyclic_step() const {
  for (const auto* list : {&steps, &finally_steps})
    for (const Step& step : *list)
      if (std::holds_alternative<CyclicStep>(step.action)) return true;
  return false;
}

bool Vector::has_bus_off_step() const {
  return std::any_of(steps.begin(), steps.end(), [](const Step& step) {
    return std::holds_alternative<BusOffStep>(step.action);
  });
}

std::string Vector::family() const {
  const auto first = id.find('/');
  if (first == std::string::npos) return id;
  const auto second = id.find('/', first + 1);
  return second == std::string::npos ? id : id.substr(0, second);
}

can::Frame FrameSpec::to_frame(std::uint8_t node) const {
  const std::uint32_t id = cob.resolve(node);
  const auto format = cob.extended ? can::IdFormat::extended : can::IdFormat::standard;
  if (remote) return can::Frame::remote(id, dlc, format);
  std::array<std::uint8_t, 8> data{};
  std::size_t n = 0;
  for (const auto& byte : bytes)
    data[n++] = byte.value_or(0);
  const std::span<const std::uint8_t> payload(data.data(), n);
  return cob.extended ? can::Frame::extended(id, payload) : can::Frame::standard(id, payload);
}

bool FrameSpec::matches(const can::Frame& frame, std::uint8_t node) const {
  if (frame.is_error()) return false;
  if (frame.id != cob.resolve(node) || frame.is_extended() != cob.extended) return false;
  if (remote) return frame.is_remote() && (any_tail || frame.dlc == dlc);
  if (frame.is_remote()) return false;
  const auto payload = frame.payload();
  if (any_tail ? payload.size() < bytes.size() : payload.size() != bytes.size()) return false;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (bytes[i] && *bytes[i] != payload[i]) return false;
  }
  return true;
}

bool AbortExpect::accepts(std::uint32_t code) const {
  return any() || std::find(codes.begin(), codes.end(), code) != codes.end();
}

std::string AbortExpect::describe() const {
  const std::string why = !citation.empty() && !clause.empty()
                              ? fmt::format("{}; {}", citation, clause)
                              : (citation.empty() ? clause : citation);
  const std::string codes_text =
      any() ? std::string("{any abort code}") : fmt::format("{{{:08X}h}}", fmt::join(codes, "h, "));
  const std::string name = set.empty() ? codes_text : fmt::format("{} {}", set, codes_text);
  return why.empty() ? fmt::format("abort in {}", name)
                     : fmt::format("abort in {} ({})", name, why);
}

std::optional<AbortExpect> AbortExpect::named(std::string_view set_name) {
  const auto set = cia301::find_sdo_abort_set(set_name);
  if (!set) return std::nullopt;
  AbortExpect expect;
  expect.codes.assign(set->codes().begin(), set->codes().end());
  expect.set = std::string(set->name);
  expect.citation = std::string(set->citation);
  return expect;
}

// ---- value syntax ----

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::optional<std::uint64_t> parse_hex(std::string_view text) {
  if (text.empty() || text.size() > 16) return std::nullopt;
  std::uint64_t value = 0;
  for (const char c : text) {
    const int digit = hex_digit(c);
    if (digit < 0) return std::nullopt;
    value = (value << 4) | static_cast<std::uint64_t>(digit);
  }
  return value;
}

// YAML integer: decimal or 0x hex, may be negative. Range: int64 for negatives, uint64 else
// (returned as the two's-complement int64 bit pattern together with `negative`).
struct Integer {
  std::int64_t value = 0;
  std::uint64_t bits = 0;
  bool negative = false;
};

Expected<Integer, std::string> parse_integer(std::string_view text) {
  const std::string shown(text);
  Integer result;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    result.negative = text.front() == '-';
    text.remove_prefix(1);
  }
  std::uint64_t magnitude = 0;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    const auto hex = parse_hex(text.substr(2));
    if (!hex) return Unexpected(fmt::format("'{}' is not an integer (decimal or 0x hex)", shown));
    magnitude = *hex;
  } else {
    const auto* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, magnitude);
    if (text.empty() || ec != std::errc{} || ptr != end)
      return Unexpected(fmt::format("'{}' is not an integer (decimal or 0x hex)", shown));
  }
  if (result.negative) {
    if (magnitude > std::uint64_t{1} << 63)
      return Unexpected(fmt::format("'{}' is out of range", shown));
    result.bits = ~magnitude + 1;
    result.value = static_cast<std::int64_t>(result.bits);
  } else {
    result.bits = magnitude;
    result.value = static_cast<std::int64_t>(magnitude);
  }
  return result;
}

Expected<std::vector<std::optional<std::uint8_t>>, std::string> parse_byte_pattern(
    std::string_view text, bool allow_wildcards) {
  std::vector<std::optional<std::uint8_t>> bytes;
  std::size_t i = 0;
  while (i < text.size()) {
    if (text[i] == ' ') {
      ++i;
      continue;
    }
    if (i + 1 >= text.size())
      return Unexpected(fmt::format("odd number of hex digits in '{}'", text));
    if (text[i] == '.' && text[i + 1] == '.') {
      if (!allow_wildcards)
        return Unexpected(
            fmt::format("'..' (don't care) is allowed only in expectations: '{}'", text));
      bytes.emplace_back(std::nullopt);
    } else {
      const int high = hex_digit(text[i]);
      const int low = hex_digit(text[i + 1]);
      if (high < 0 || low < 0)
        return Unexpected(fmt::format("byte {}: '{}' is not two hex digits{}", bytes.size(),
                                      text.substr(i, 2), allow_wildcards ? " or '..'" : ""));
      bytes.emplace_back(static_cast<std::uint8_t>(high * 16 + low));
    }
    i += 2;
  }
  return bytes;
}

}  // namespace

Expected<DurationSpec, std::string> parse_duration_spec(std::string_view text) {
  constexpr std::string_view kTiming = "$timing.";
  if (text.starts_with(kTiming)) {
    const auto key = text.substr(kTiming.size());
    if (profile::find_timing(key) == nullptr) {
      std::string known;
      for (const auto& timing : profile::timing_table())
        known += fmt::format(" {}", timing.name);
      return Unexpected(fmt::format("unknown timing name '{}' (known:{})", key, known));
    }
    return DurationSpec{{}, std::string(key)};
  }
  auto value = profile::parse_duration(text);
  if (!value) return Unexpected(value.error() + " or $timing.<key>");
  return DurationSpec{*value, {}};
}

Expected<CobIdSpec, std::string> parse_cob_id(std::string_view text) {
  CobIdSpec cob;
  auto hex = text;
  if (text.ends_with("+N")) {
    cob.plus_node = true;
    hex.remove_suffix(2);
  }
  const auto value = parse_hex(hex);
  if (!value || hex.size() > 8 || (hex.size() > 3 && hex.size() != 8))
    return Unexpected(fmt::format(
        "'{}' is not a COB-ID (1..3 hex digits, or 8 for 29 bits, optionally followed by +N)",
        text));
  cob.extended = hex.size() == 8;
  const std::uint64_t limit = cob.extended ? can::kMaxExtendedId : can::kMaxStandardId;
  if (*value + (cob.plus_node ? 127U : 0U) > limit)
    return Unexpected(fmt::format("COB-ID '{}' is out of range (max {:X}h{})", text, limit,
                                  cob.plus_node ? " including the node-ID" : ""));
  cob.base = static_cast<std::uint32_t>(*value);
  return cob;
}

Expected<FrameSpec, std::string> parse_frame_spec(std::string_view text, bool pattern) {
  FrameSpec spec;
  spec.text = std::string(text);
  const auto hash = text.find('#');
  if (hash == std::string_view::npos)
    return Unexpected(fmt::format("'{}' is not a frame (COBID#DATA in candump syntax)", text));
  if (text.substr(hash + 1).starts_with("#"))
    return Unexpected(fmt::format("'{}': CAN FD (##) is not classic CAN", text));
  auto cob = parse_cob_id(text.substr(0, hash));
  if (!cob) return Unexpected(cob.error());
  spec.cob = *cob;
  auto data = text.substr(hash + 1);
  if (data.ends_with("*")) {
    if (!pattern)
      return Unexpected(fmt::format("'{}': a trailing '*' is allowed only in expectations", text));
    spec.any_tail = true;
    data.remove_suffix(1);
  }
  if (data.starts_with("R") || data.starts_with("r")) {
    spec.remote = true;
    const auto dlc = data.substr(1);
    if (!dlc.empty()) {
      if (dlc.size() != 1 || dlc[0] < '0' || dlc[0] > '8')
        return Unexpected(fmt::format("'{}': remote frame DLC must be 0..8", text));
      spec.dlc = static_cast<std::uint8_t>(dlc[0] - '0');
    }
    return spec;
  }
  auto bytes = parse_byte_pattern(data, pattern);
  if (!bytes) return Unexpected(fmt::format("'{}': {}", text, bytes.error()));
  if (bytes->size() > 8)
    return Unexpected(
        fmt::format("'{}': {} data bytes (classic CAN carries at most 8)", text, bytes->size()));
  spec.bytes = std::move(*bytes);
  spec.dlc = static_cast<std::uint8_t>(spec.bytes.size());
  return spec;
}

// The 8 octets of an SDO message (sdo_request, expect_sdo_response: FORMAT.md "Raw SDO
// steps") as the CAN frame that carries them: `cob`#octets (600+N or 580+N), `text` that frame
// as written.
Expected<FrameSpec, std::string> parse_sdo_octets(std::string_view text, bool pattern,
                                                  std::uint32_t cob) {
  if (text.find('#') != std::string_view::npos || text.find('*') != std::string_view::npos)
    return Unexpected(fmt::format(
        "'{}': the 8 octets of an SDO message, without COB-ID or '*' (the link decides: "
        "{:X}h+N on CAN, a CoE SDO mailbox on EtherCAT)",
        text, cob));
  auto bytes = parse_byte_pattern(text, pattern);
  if (!bytes) return Unexpected(fmt::format("'{}': {}", text, bytes.error()));
  if (bytes->size() != 8)
    return Unexpected(
        fmt::format("'{}': {} octets; an SDO message has exactly 8 (CiA 301 "
                    "§7.2.4.3: command, index, sub-index, 4 data octets)",
                    text, bytes->size()));
  FrameSpec spec;
  spec.text = fmt::format("{:X}+N#{}", cob, text);
  spec.cob = CobIdSpec{cob, true, false};
  spec.bytes = std::move(*bytes);
  spec.dlc = 8;
  return spec;
}

Expected<Source, std::string> parse_source(std::string_view text) {
  Source source;
  source.text = std::string(text);
  const auto para = text.find("§");
  if (para == std::string_view::npos)
    return Unexpected(
        fmt::format("source '{}' has no '§': write '<manual file> §<section> L<first>-<last>' or "
                    "'CiA 301 §<clause>' / 'CiA 402-2 §<clause>'",
                    text));
  auto head = text.substr(0, para);
  while (head.ends_with(" "))
    head.remove_suffix(1);
  auto rest = text.substr(para + std::string_view("§").size());
  if (head.starts_with("CiA ")) {
    if (rest.empty() || rest.front() == ' ')
      return Unexpected(fmt::format("source '{}': the clause after '§' is missing", text));
    const auto end = rest.find(' ');
    source.section = std::string(rest.substr(0, end));
    return source;
  }
  if (head.empty() || head.find(' ') != std::string_view::npos || !head.ends_with(".txt"))
    return Unexpected(fmt::format(
        "source '{}': '{}' is neither a manual file (*.txt) nor 'CiA <document>'", text, head));
  source.manual = std::string(head);
  const auto lines = rest.rfind(" L");
  if (lines == std::string_view::npos)
    return Unexpected(
        fmt::format("source '{}': the line range ' L<first>-<last>' is missing", text));
  source.section = std::string(rest.substr(0, lines));
  if (source.section.empty())
    return Unexpected(fmt::format("source '{}': the section after '§' is missing", text));
  const auto range = rest.substr(lines + 2);
  const auto dash = range.find('-');
  const auto first_text = range.substr(0, dash);
  const auto last_text = dash == std::string_view::npos ? first_text : range.substr(dash + 1);
  const auto parse_line = [](std::string_view digits, std::size_t& out) {
    const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), out);
    return !digits.empty() && ec == std::errc{} && ptr == digits.data() + digits.size() && out > 0;
  };
  if (!parse_line(first_text, source.first) || !parse_line(last_text, source.last))
    return Unexpected(fmt::format(
        "source '{}': 'L{}' is not a line range L<first>-<last> (1-based)", text, range));
  if (source.first > source.last)
    return Unexpected(fmt::format("source '{}': line range L{}-{} runs backwards", text,
                                  source.first, source.last));
  return source;
}

// ---- YAML → model ----

namespace {

struct StepSyntax {
  std::string_view action;
  std::vector<std::string_view> modifiers;
};

const std::vector<StepSyntax>& step_syntax() {
  static const std::vector<StepSyntax> kSyntax{
      {"send", {}},
      {"nmt", {"node"}},
      {"sdo_write", {"transfer", "expect", "refused_means_not_applicable", "clause"}},
      {"sdo_read", {"transfer", "block_size", "expect", "signed", "save", "relative_to"}},
      {"wait", {}},
      {"controlword", {}},
      {"simulate", {}},
      {"mark", {}},
      {"expect_frame", {"within", "mark", "since", "abort", "clause", "or"}},
      {"expect_silence", {"for", "since", "clause"}},
      {"expect_bootup", {"within", "mark", "since", "clause"}},
      {"expect_heartbeat", {"within", "mark", "since", "clause"}},
      {"expect_emcy", {"within", "mark", "since", "clause"}},
      {"expect_state", {"within", "clause"}},
      {"expect_statusword", {"within", "clause"}},
      {"poll", {"within", "every", "clause", "signed"}},
      {"measure", {"clause"}},
      {"expect_periodic", {"period", "tolerance", "count", "mark", "last", "clause"}},
      {"bus_off", {}},
      {"al_request", {"expect", "within", "clause"}},
      {"expect_al", {"within", "clause"}},
      {"process_data", {}},
      {"pause_process_data", {}},
      {"mailbox_repeat", {}},
      {"sdo_request", {}},
      {"expect_sdo_response", {"within", "mark", "abort", "clause", "or"}},
      {"cyclic", {"set"}},
      {"power_cycle", {}},
  };
  return kSyntax;
}

constexpr std::array<std::string_view, 16> kVectorKeys{
    "id",     "title", "source", "level",       "requires", "unless", "profiles", "transports",
    "motion", "setup", "nmt",    "drive_state", "timeout",  "steps",  "finally",  "note"};

std::optional<cia402::State> parse_402_state(std::string_view text) {
  constexpr std::array<std::pair<std::string_view, cia402::State>, 8> kNames{{
      {"not-ready-to-switch-on", cia402::State::not_ready_to_switch_on},
      {"switch-on-disabled", cia402::State::switch_on_disabled},
      {"ready-to-switch-on", cia402::State::ready_to_switch_on},
      {"switched-on", cia402::State::switched_on},
      {"operation-enabled", cia402::State::operation_enabled},
      {"quick-stop-active", cia402::State::quick_stop_active},
      {"fault-reaction-active", cia402::State::fault_reaction_active},
      {"fault", cia402::State::fault},
  }};
  for (const auto& [name, state] : kNames) {
    if (name == text) return state;
  }
  return std::nullopt;
}

std::optional<cia301::NmtState> parse_nmt_state(std::string_view text) {
  if (text == "bootup" || text == "initialising") return cia301::NmtState::boot_up;
  if (text == "pre-operational") return cia301::NmtState::pre_operational;
  if (text == "operational") return cia301::NmtState::operational;
  if (text == "stopped") return cia301::NmtState::stopped;
  return std::nullopt;
}

class Parser {
 public:
  Parser(std::string file, VectorSet& out) : file_(std::move(file)), out_(out) {}

  void parse_document(const YAML::Node& root) {
    if (root.IsNull()) return;  // an empty file holds no vectors
    if (!root.IsSequence()) {
      error(root, "a vector file is a YAML sequence of vectors ('- id: ...')");
      return;
    }
    for (const auto& node : root) {
      const auto errors_before = out_.errors.size();
      Vector vector = parse_vector(node);
      if (out_.errors.size() == errors_before) out_.vectors.push_back(std::move(vector));
    }
  }

 private:
  static std::size_t line_of(const YAML::Node& node) {
    const auto mark = node.Mark();
    return mark.line < 0 ? 0 : static_cast<std::size_t>(mark.line) + 1;
  }

  void error(const YAML::Node& node, std::string message) {
    out_.errors.push_back(TextError{file_, static_cast<int>(line_of(node)), std::move(message)});
  }

  std::optional<std::string> scalar(const YAML::Node& node, std::string_view what) {
    if (!node.IsScalar()) {
      error(node, fmt::format("{}: expected a single value", what));
      return std::nullopt;
    }
    return node.Scalar();
  }

  template <class T>
  std::optional<T> integer(const YAML::Node& node, std::string_view what, std::int64_t min,
                           std::int64_t max) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    auto value = parse_integer(*text);
    if (!value) {
      error(node, fmt::format("{}: {}", what, value.error()));
      return std::nullopt;
    }
    const bool too_big = !value->negative && value->bits > static_cast<std::uint64_t>(max);
    if (too_big || value->value < min) {
      error(node, fmt::format("{}: {} is out of range {}..{}", what, *text, min, max));
      return std::nullopt;
    }
    return static_cast<T>(value->value);
  }

  std::optional<bool> boolean(const YAML::Node& node, std::string_view what) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    if (*text == "true") return true;
    if (*text == "false") return false;
    error(node, fmt::format("{}: '{}' is not true or false", what, *text));
    return std::nullopt;
  }

  std::optional<DurationSpec> duration(const YAML::Node& node, std::string_view what) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    auto spec = parse_duration_spec(*text);
    if (!spec) {
      error(node, fmt::format("{}: {}", what, spec.error()));
      return std::nullopt;
    }
    return *spec;
  }

  std::optional<std::string> name(const YAML::Node& node, std::string_view what) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    const bool ok = !text->empty() && std::all_of(text->begin(), text->end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '-' || c == '.';
    });
    if (!ok) {
      error(node, fmt::format("{}: '{}' is not a name ([A-Za-z0-9_.-])", what, *text));
      return std::nullopt;
    }
    return text;
  }

  // The keys of a map, each checked against `allowed`; false (with errors) when not a map.
  bool check_map(const YAML::Node& node, std::string_view what,
                 const std::vector<std::string_view>& allowed) {
    if (!node.IsMap()) {
      error(node, fmt::format("{}: expected a map {{{}}}", what, fmt::join(allowed, ", ")));
      return false;
    }
    bool ok = true;
    for (const auto& entry : node) {
      const auto key = entry.first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        error(entry.first, fmt::format("{}: unknown key '{}' (allowed: {})", what, key,
                                       fmt::join(allowed, ", ")));
        ok = false;
      }
    }
    return ok;
  }

  std::vector<std::string> string_list(const YAML::Node& node, std::string_view what) {
    std::vector<std::string> items;
    if (node.IsScalar()) {
      items.push_back(node.Scalar());
    } else if (node.IsSequence()) {
      for (const auto& item : node) {
        if (auto text = scalar(item, what)) items.push_back(*text);
      }
    } else {
      error(node, fmt::format("{}: expected a value or a list", what));
    }
    return items;
  }

  std::optional<std::vector<std::uint8_t>> hex_data(const YAML::Node& node, std::string_view what) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    auto bytes = parse_byte_pattern(*text, false);
    if (!bytes) {
      error(node, fmt::format("{}: {}", what, bytes.error()));
      return std::nullopt;
    }
    std::vector<std::uint8_t> data;
    for (const auto& byte : *bytes)
      data.push_back(*byte);
    return data;
  }

  std::optional<ValueSpec> value_spec(const YAML::Node& node, std::string_view what) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    if (text->starts_with("$")) {
      auto saved = text->substr(1);
      // `$name+k` / `$name-k`: the saved value plus a literal. A name saved whole (names may
      // hold '-') wins over the split.
      std::int64_t offset = 0;
      const auto sign = saved.find_last_of("+-");
      if (sign != std::string::npos && sign > 0 && saves_.count(saved) == 0 &&
          !is_device_value(saved)) {
        const auto digits = saved.substr(sign + 1);
        const auto amount = parse_integer(digits);
        if (!amount || digits.starts_with('+') || digits.starts_with('-') ||
            amount->bits > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
          if (saved[sign] == '+' || saves_.count(saved.substr(0, sign)) != 0) {
            error(node, fmt::format("{}: '{}': expected $name+k or $name-k with an integer k "
                                    "(at most 2^63-1)",
                                    what, *text));
            return std::nullopt;
          }
        } else {
          offset = amount->value;
          if (saved[sign] == '-') offset = -offset;
          saved = saved.substr(0, sign);
        }
      }
      // `$name*m`, `$name/d`, `$name*m/d` (before the offset): a scaled saved value, m and d
      // positive integers. A name saved whole wins here too.
      std::int64_t multiplier = 1;
      std::int64_t divisor = 1;
      for (const char op : {'/', '*'}) {
        const auto at = saved.find_last_of(op);
        if (at == std::string::npos || saves_.count(saved) != 0 || is_device_value(saved)) continue;
        const auto digits = saved.substr(at + 1);
        const auto amount = parse_integer(digits);
        if (at == 0 || !amount || digits.starts_with('+') || digits.starts_with('-') ||
            amount->value < 1 ||
            amount->bits > static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max())) {
          error(node, fmt::format("{}: '{}': expected $name*m/d+k with integers m, d from 1 to "
                                  "2^31-1 (the product first, then the division toward zero)",
                                  what, *text));
          return std::nullopt;
        }
        (op == '*' ? multiplier : divisor) = amount->value;
        saved = saved.substr(0, at);
      }
      if (is_device_value(saved)) return ValueSpec{0, saved, offset, multiplier, divisor};
      if (saves_.count(saved) == 0) {
        error(node, fmt::format("{}: '{}' names no value saved earlier in this vector (save: {})",
                                what, *text, saved));
        return std::nullopt;
      }
      return ValueSpec{0, saved, offset, multiplier, divisor};
    }
    auto value = integer<std::int64_t>(node, what, std::numeric_limits<std::int64_t>::min(),
                                       std::numeric_limits<std::int64_t>::max());
    if (!value) {
      // parse_integer accepts up to 2^64-1 for bit patterns: retry as unsigned
      return std::nullopt;
    }
    return ValueSpec{*value, {}};
  }

  // `abort: <set-name>` (a row of sdo_abort_sets.inc) or `abort: [0x06090030, ...]` (a literal
  // list, which `clause:` must justify: the lint checks that).
  AbortExpect abort_expect(const YAML::Node& node, const YAML::Node* clause,
                           std::string_view what) {
    AbortExpect expect;
    if (node.IsScalar()) {
      const auto& text = node.Scalar();
      if (!text.empty() && std::isdigit(static_cast<unsigned char>(text.front()))) {
        error(node, fmt::format("{}: '{}': a literal code is written as a list ([{}]) with "
                                "clause:, or name a set ({})",
                                what, text, text, cia301::sdo_abort_set_names()));
      } else if (auto named = AbortExpect::named(text)) {
        expect = std::move(*named);
      } else {
        error(node, fmt::format("{}: unknown abort set '{}' (sets: {})", what, text,
                                cia301::sdo_abort_set_names()));
      }
    } else if (node.IsSequence()) {
      for (const auto& item : node) {
        if (auto code = integer<std::uint32_t>(item, what, 1, 0xFFFFFFFF))
          expect.codes.push_back(*code);
      }
      if (node.size() == 0) error(node, fmt::format("{}: the list of abort codes is empty", what));
    } else {
      error(node, fmt::format("{}: expected a set name or a list of codes", what));
    }
    expect.line = line_of(node);
    if (clause != nullptr && *clause) {
      if (auto text = scalar(*clause, "clause")) {
        if (text->empty()) error(*clause, "clause: empty");
        expect.clause = *text;
      }
    }
    return expect;
  }

  Transfer transfer(const YAML::Node& node) {
    auto text = scalar(node, "transfer");
    if (!text) return Transfer::automatic;
    if (*text == "expedited") return Transfer::expedited;
    if (*text == "segmented") return Transfer::segmented;
    if (*text == "block") return Transfer::block;
    if (*text == "complete-access") return Transfer::complete_access;
    error(node, fmt::format("transfer: '{}' is not expedited, segmented, block or complete-access",
                            *text));
    return Transfer::automatic;
  }

  std::optional<std::uint16_t> index(const YAML::Node& map, std::string_view what) {
    if (!map["index"]) {
      error(map, fmt::format("{}: 'index' is missing", what));
      return std::nullopt;
    }
    return integer<std::uint16_t>(map["index"], "index", 0, 0xFFFF);
  }
  std::optional<std::uint8_t> sub(const YAML::Node& map, std::string_view what) {
    if (!map["sub"]) {
      error(map, fmt::format("{}: 'sub' is missing", what));
      return std::nullopt;
    }
    return integer<std::uint8_t>(map["sub"], "sub", 0, 0xFF);
  }

  std::string mark_definition(const YAML::Node& node) {
    auto text = name(node, "mark");
    if (!text) return {};
    marks_.insert(*text);
    return *text;
  }
  std::string mark_reference(const YAML::Node& node, std::string_view what) {
    auto text = name(node, what);
    if (!text) return {};
    if (marks_.count(*text) == 0) {
      error(node, fmt::format("{}: unknown mark '{}' (marks must be set by an earlier step)", what,
                              *text));
    }
    return *text;
  }

  SdoExpect sdo_expect(const YAML::Node& node, bool read) {
    SdoExpect expect;
    if (node.IsScalar()) {
      if (node.Scalar() == "ok-or-abort") {
        expect.kind = SdoExpect::Kind::ok_or_abort;
      } else if (node.Scalar() != "ok") {
        error(node, fmt::format("expect: '{}' is not 'ok', 'ok-or-abort' or a map", node.Scalar()));
      }
      return expect;
    }
    const std::vector<std::string_view> keys =
        read ? std::vector<std::string_view>{"value", "mask",  "range", "size",
                                             "data",  "abort", "clause"}
             : std::vector<std::string_view>{"abort", "clause"};
    if (!check_map(node, "expect", keys)) return expect;
    std::size_t kinds = 0;
    if (node["abort"]) {
      ++kinds;
      expect.kind = SdoExpect::Kind::abort;
      const YAML::Node clause = node["clause"];
      expect.abort = abort_expect(node["abort"], &clause, "abort");
    } else if (node["clause"]) {
      error(node["clause"], "expect: 'clause' goes with 'abort'");
    }
    if (node["value"]) {
      ++kinds;
      expect.kind = SdoExpect::Kind::value;
      if (auto value = value_spec(node["value"], "value")) expect.value = *value;
      if (node["mask"]) {
        const auto mask = scalar(node["mask"], "mask");
        if (mask) {
          auto parsed = parse_integer(*mask);
          if (!parsed || parsed->negative)
            error(node["mask"], fmt::format("mask: '{}' is not an unsigned integer", *mask));
          else
            expect.mask = parsed->bits;
        }
      }
    } else if (node["mask"]) {
      error(node["mask"], "expect: 'mask' needs 'value'");
    }
    if (node["range"]) {
      ++kinds;
      expect.kind = SdoExpect::Kind::range;
      const auto& range = node["range"];
      if (!range.IsSequence() || range.size() != 2) {
        error(range, "range: expected [low, high]");
      } else {
        // Each bound a literal or `$name±k` (a saved value plus a literal).
        const auto low = value_spec(range[0], "range low");
        const auto high = value_spec(range[1], "range high");
        if (low && high) {
          expect.low = *low;
          expect.high = *high;
          const bool comparable =  // both literal, or one name with one scale
              low->saved == high->saved && low->multiplier == high->multiplier &&
              low->divisor == high->divisor;
          const auto lo = low->saved.empty() ? low->literal : low->offset;
          const auto hi = high->saved.empty() ? high->literal : high->offset;
          if (comparable && lo > hi) error(range, "range: low is above high");
        }
      }
    }
    if (node["size"]) {
      ++kinds;
      expect.kind = SdoExpect::Kind::size;
      expect.size = integer<std::size_t>(node["size"], "size", 0, 1 << 24).value_or(0);
    }
    if (node["data"]) {
      ++kinds;
      expect.kind = SdoExpect::Kind::data;
      expect.data = hex_data(node["data"], "data").value_or(std::vector<std::uint8_t>{});
    }
    if (kinds != 1)
      error(node, "expect: give exactly one of value, range, size, data, abort (or 'ok')");
    return expect;
  }

  // An AL state name (init preop safeop op boot) as its 0130h value.
  std::optional<std::uint8_t> al_state(const YAML::Node& node, std::string_view what) {
    auto text = scalar(node, what);
    if (!text) return std::nullopt;
    constexpr std::array<std::pair<std::string_view, std::uint8_t>, 5> kStates{
        {{"init", 1}, {"preop", 2}, {"boot", 3}, {"safeop", 4}, {"op", 8}}};
    for (const auto& [name, value] : kStates)
      if (*text == name) return value;
    error(node,
          fmt::format("{}: '{}' is not an AL state (init, preop, safeop, op, boot)", what, *text));
    return std::nullopt;
  }

  // `{state, error, code}` (al_request's expect:, expect_al's value). `code:` a name of
  // protocol/ethercat/al_status_codes.inc (`-` for `_`) or a list of them: the accepted set.
  std::optional<AlExpect> al_expect(const YAML::Node& node, std::string_view what,
                                    bool state_required) {
    if (!check_map(node, what, {"state", "error", "code"})) return std::nullopt;
    AlExpect expect;
    if (node["state"]) {
      auto state = al_state(node["state"], "state");
      if (!state) return std::nullopt;
      expect.state = *state;
    } else if (state_required) {
      error(node, fmt::format("{}: 'state' is required", what));
      return std::nullopt;
    }
    if (node["error"]) {
      auto error_bit = boolean(node["error"], "error");
      if (!error_bit) return std::nullopt;
      expect.error = *error_bit;
    }
    if (node["code"]) {
      if (!expect.error) {
        error(node["code"], fmt::format("{}: 'code' goes with 'error: true'", what));
        return std::nullopt;
      }
      for (const auto& text : string_list(node["code"], "code")) {
        std::string name = text;
        std::replace(name.begin(), name.end(), '-', '_');
        const auto table = ethercat::al_status_code_table();
        const auto it = std::find_if(table.begin(), table.end(),
                                     [&name](const auto& row) { return row.name == name; });
        if (it == table.end() || it->code == ethercat::AlStatusCode::no_error) {
          error(node["code"], fmt::format("{}: '{}' is no AL status code of "
                                          "protocol/ethercat/al_status_codes.inc",
                                          what, text));
          return std::nullopt;
        }
        expect.codes.push_back(static_cast<std::uint16_t>(it->code));
        expect.names.push_back(text);
      }
    }
    if (expect.error && expect.codes.empty()) {
      error(node,
            fmt::format("{}: 'error: true' needs 'code:' (the accepted AL status codes)", what));
      return std::nullopt;
    }
    return expect;
  }

  // expect_frame and expect_sdo_response: a pattern (`parse` reads it and the `or:` ones) with
  // abort:, or:, clause:, within:, since:, mark:.
  template <typename Parse>
  std::optional<ExpectFrameStep> parse_expect_frame(std::string_view action,
                                                    const YAML::Node& value,
                                                    const YAML::Node& step_map, Parse&& parse) {
    const auto modifier = [&step_map](std::string_view key) { return step_map[std::string(key)]; };
    ExpectFrameStep step;
    const std::string what(action);
    auto text = scalar(value, what);
    if (!text) return std::nullopt;
    auto pattern = parse(*text);
    if (!pattern) {
      error(value, fmt::format("{}: {}", what, pattern.error()));
      return std::nullopt;
    }
    step.pattern = std::move(*pattern);
    if (const auto node = modifier("abort")) {
      step.abort = abort_expect(node, nullptr, what + " abort");
      const auto& bytes = step.pattern.bytes;
      const bool abort_pattern =
          !step.pattern.remote && bytes.size() == 8 && bytes[0] && *bytes[0] == 0x80 &&
          std::all_of(bytes.begin() + 4, bytes.end(), [](const auto& b) { return !b.has_value(); });
      if (!abort_pattern)
        error(value, fmt::format("{}: with abort: the pattern must be an SDO abort "
                                 "with its code as don't-care (80......{}), not '{}'",
                                 what, "........", step.pattern.text));
    }
    if (const auto node = modifier("or")) {
      if (!node.IsSequence() || node.size() == 0) {
        error(node, fmt::format("{} or: expected a list of patterns", what));
      } else {
        for (const auto& item : node) {
          auto alt_text = scalar(item, what + " or");
          if (!alt_text) continue;
          auto alt = parse(*alt_text);
          if (!alt) {
            error(item, fmt::format("{} or: {}", what, alt.error()));
            continue;
          }
          step.alternatives.push_back(std::move(*alt));
        }
      }
    }
    if (const auto node = modifier("clause")) {
      if (auto clause_text = scalar(node, "clause")) {
        if (clause_text->empty()) error(node, "clause: empty");
        step.clause = *clause_text;
        if (step.abort) step.abort->clause = *clause_text;
      }
    }
    if (const auto node = modifier("within"))
      step.within = duration(node, "within").value_or(step.within);
    if (const auto node = modifier("since")) step.since = mark_reference(node, "since");
    if (const auto node = modifier("mark")) step.mark = mark_definition(node);
    return step;
  }

  std::optional<Action> parse_action(std::string_view action, const YAML::Node& value,
                                     const YAML::Node& step_map) {
    const auto modifier = [&step_map](std::string_view key) { return step_map[std::string(key)]; };
    if (action == "send") {
      auto text = scalar(value, "send");
      if (!text) return std::nullopt;
      auto frame = parse_frame_spec(*text, false);
      if (!frame) {
        error(value, fmt::format("send: {}", frame.error()));
        return std::nullopt;
      }
      return SendStep{std::move(*frame)};
    }
    if (action == "nmt") {
      NmtStep nmt;
      auto text = scalar(value, "nmt");
      if (!text) return std::nullopt;
      if (*text == "start") {
        nmt.command = cia301::NmtCommand::start;
      } else if (*text == "stop") {
        nmt.command = cia301::NmtCommand::stop;
      } else if (*text == "pre-operational") {
        nmt.command = cia301::NmtCommand::enter_pre_operational;
      } else if (*text == "reset-node") {
        nmt.command = cia301::NmtCommand::reset_node;
      } else if (*text == "reset-communication") {
        nmt.command = cia301::NmtCommand::reset_communication;
      } else {
        error(value, fmt::format("nmt: '{}' is not start, stop, pre-operational, reset-node or "
                                 "reset-communication",
                                 *text));
        return std::nullopt;
      }
      if (const auto node = modifier("node")) {
        auto spec = scalar(node, "node");
        if (!spec) return std::nullopt;
        if (*spec == "N") {
          nmt.node.kind = NodeKind::dut;
        } else if (*spec == "all" || *spec == "0") {
          nmt.node.kind = NodeKind::broadcast;
        } else if (*spec == "other") {
          nmt.node.kind = NodeKind::other;
        } else {
          auto id = integer<std::uint8_t>(node, "node", 1, 127);
          if (!id) return std::nullopt;
          nmt.node = {NodeKind::value, *id};
        }
      }
      return nmt;
    }
    if (action == "sdo_write") {
      SdoWriteStep write;
      if (!check_map(value, "sdo_write", {"index", "sub", "value", "size", "data"}))
        return std::nullopt;
      auto idx = index(value, "sdo_write");
      auto sb = sub(value, "sdo_write");
      if (!idx || !sb) return std::nullopt;
      write.index = *idx;
      write.sub = *sb;
      if (value["value"] && value["data"]) {
        error(value, "sdo_write: give 'value' (with 'size') or 'data', not both");
        return std::nullopt;
      }
      if (value["value"]) {
        write.value = value_spec(value["value"], "value");
        if (!write.value) return std::nullopt;
        if (value["size"]) {
          write.size = integer<std::size_t>(value["size"], "size", 1, 8);
          if (!write.size) return std::nullopt;
          if (write.value->saved.empty() && *write.size < 8) {
            const auto bits = 8 * *write.size;
            const std::int64_t low = -(std::int64_t{1} << (bits - 1));
            const std::int64_t high = (std::int64_t{1} << bits) - 1;
            if (write.value->literal < low || write.value->literal > high) {
              error(value["value"], fmt::format("value {} does not fit in {} byte(s)",
                                                write.value->literal, *write.size));
              return std::nullopt;
            }
          }
        }
      } else if (value["data"]) {
        if (value["size"]) {
          error(value["size"], "sdo_write: 'size' goes with 'value'; 'data' carries its length");
          return std::nullopt;
        }
        auto data = hex_data(value["data"], "data");
        if (!data) return std::nullopt;
        write.data = std::move(*data);
      } else {
        error(value, "sdo_write: 'value' or 'data' is missing");
        return std::nullopt;
      }
      if (const auto node = modifier("transfer")) write.transfer = transfer(node);
      if (const auto node = modifier("expect")) write.expect = sdo_expect(node, false);
      if (const auto node = modifier("refused_means_not_applicable")) {
        // A value CiA lets the device refuse: a refusal in the set means not applicable.
        const YAML::Node clause = modifier("clause");
        write.refused_means_not_applicable =
            abort_expect(node, &clause, "refused_means_not_applicable");
        if (write.expect.kind != SdoExpect::Kind::ok)
          error(node,
                "refused_means_not_applicable: goes with expect: ok (the write the vector "
                "needs); an expected refusal is expect: {abort: <set>}");
        if (write.refused_means_not_applicable->set == "any")
          error(node,
                "refused_means_not_applicable: 'any' would make every refusal not applicable: "
                "name the set of codes that mean 'value not supported' (value-range)");
      } else if (const auto clause = modifier("clause")) {
        error(clause, "sdo_write: 'clause' goes with 'refused_means_not_applicable'");
      }
      return write;
    }
    if (action == "sdo_read") {
      SdoReadStep read;
      if (!check_map(value, "sdo_read", {"index", "sub"})) return std::nullopt;
      auto idx = index(value, "sdo_read");
      auto sb = sub(value, "sdo_read");
      if (!idx || !sb) return std::nullopt;
      read.index = *idx;
      read.sub = *sb;
      if (const auto node = modifier("transfer")) read.transfer = transfer(node);
      if (const auto node = modifier("block_size")) {
        // The blksize the client offers in the block upload initiate (CiA 301 §7.2.4.3.13).
        auto size = integer<std::uint8_t>(node, "block_size", 1, 127);
        if (!size) return std::nullopt;
        if (read.transfer != Transfer::block) {
          error(node, "block_size: only with transfer: block");
          return std::nullopt;
        }
        read.block_size = *size;
      }
      if (const auto node = modifier("expect")) read.expect = sdo_expect(node, true);
      if (const auto node = modifier("signed"))
        read.is_signed = boolean(node, "signed").value_or(false);
      if (const auto node = modifier("save")) {
        auto saved = name(node, "save");
        if (!saved) return std::nullopt;
        read.save = *saved;
      }
      if (const auto node = modifier("relative_to")) {
        // The read minus a value saved before: a distance or a change, judged (and saved) as
        // such. Signed, so that a move the wrong way is a negative number; with a value or a
        // range only (a mask, a size or data are about the bytes read, not a difference).
        auto base = name(node, "relative_to");
        if (!base) return std::nullopt;
        if (saves_.count(*base) == 0) {
          error(node, fmt::format("relative_to: '{}' names no value saved earlier in this vector "
                                  "(save: {})",
                                  *base, *base));
          return std::nullopt;
        }
        if (!read.is_signed) {
          error(node, "relative_to: needs signed: true (a difference has a sign)");
          return std::nullopt;
        }
        const auto kind = read.expect.kind;
        if (!(kind == SdoExpect::Kind::ok || kind == SdoExpect::Kind::range ||
              (kind == SdoExpect::Kind::value && !read.expect.mask))) {
          error(node, "relative_to: goes with expect: {value: X} or {range: [lo, hi]} (or none)");
          return std::nullopt;
        }
        read.relative_to = *base;
      }
      return read;
    }
    if (action == "al_request") {
      AlRequestStep step;
      auto state = al_state(value, "al_request");
      if (!state) return std::nullopt;
      step.state = *state;
      if (const auto node = modifier("expect")) {
        auto expect = al_expect(node, "al_request expect", false);
        if (!expect) return std::nullopt;
        step.expect = std::move(*expect);
      }
      if (step.expect.state == 0 && step.expect.error) {
        error(value, "al_request: a refusal needs the AL state it leaves the slave in (state:)");
        return std::nullopt;
      }
      if (const auto node = modifier("within"))
        step.within = duration(node, "within").value_or(step.within);
      return step;
    }
    if (action == "expect_al") {
      ExpectAlStep step;
      auto expect = al_expect(value, "expect_al", true);
      if (!expect) return std::nullopt;
      step.expect = std::move(*expect);
      if (const auto node = modifier("within"))
        step.within = duration(node, "within").value_or(step.within);
      return step;
    }
    if (action == "cyclic") {
      CyclicStep step;
      if (!check_map(value, "cyclic", {"cycles", "period"})) return std::nullopt;
      if (!value["cycles"] || !value["period"]) {
        error(value, "cyclic: 'cycles' and 'period' are required");
        return std::nullopt;
      }
      auto cycles = integer<std::size_t>(value["cycles"], "cycles", 1, 10000);
      auto period = duration(value["period"], "period");
      if (!cycles || !period) return std::nullopt;
      if (!period->is_timing() && (period->value <= can::Duration::zero() ||
                                   period->value > std::chrono::milliseconds(50))) {
        // On EtherCAT the period is the process data cycle: within the SM watchdog (100 ms
        // by default, ESC 0420h) with room to spare.
        error(value["period"], "cyclic: 'period' above 0 and at most 50ms");
        return std::nullopt;
      }
      step.cycles = *cycles;
      step.period = *period;
      if (const auto set = modifier("set")) {
        const auto one = [&](const YAML::Node& item) -> bool {
          if (!check_map(item, "cyclic set", {"index", "sub", "value", "size"})) return false;
          if (!item["value"] || !item["size"]) {
            error(item, "cyclic set: 'value' and 'size' are required");
            return false;
          }
          auto idx = index(item, "cyclic set");
          auto sb = sub(item, "cyclic set");
          auto v = value_spec(item["value"], "value");
          auto size = integer<std::size_t>(item["size"], "size", 1, 8);
          if (!idx || !sb || !v || !size) return false;
          for (const auto& other : step.set) {
            if (other.index == *idx && other.sub == *sb) {
              error(item, fmt::format("cyclic set: {:04X}h sub {} twice", *idx, *sb));
              return false;
            }
          }
          step.set.push_back(CyclicSetPoint{*idx, *sb, *v, *size});
          return true;
        };
        if (set.IsSequence()) {
          for (const auto& item : set)
            if (!one(item)) return std::nullopt;
        } else if (!one(set)) {
          return std::nullopt;
        }
      }
      return step;
    }
    if (action == "process_data") {
      if (!check_map(value, "process_data", {"cycles"})) return std::nullopt;
      if (!value["cycles"]) {
        error(value, "process_data: 'cycles' is required");
        return std::nullopt;
      }
      auto cycles = integer<std::size_t>(value["cycles"], "cycles", 1, 100000);
      if (!cycles) return std::nullopt;
      return ProcessDataStep{*cycles};
    }
    if (action == "pause_process_data") {
      auto text = scalar(value, "pause_process_data");
      if (!text) return std::nullopt;
      if (*text == "watchdog") return PauseProcessDataStep{};
      auto d = duration(value, "pause_process_data");
      if (!d) return std::nullopt;
      if (!d->is_timing() &&
          (d->value <= can::Duration::zero() || d->value > std::chrono::seconds(10))) {
        error(value, "pause_process_data: 'watchdog', or a duration above 0 and at most 10s");
        return std::nullopt;
      }
      return PauseProcessDataStep{*d};
    }
    if (action == "mailbox_repeat") {
      MailboxRepeatStep step;
      if (!check_map(value, "mailbox_repeat", {"index", "sub", "size", "value", "repeat"}))
        return std::nullopt;
      auto idx = index(value, "mailbox_repeat");
      auto sb = sub(value, "mailbox_repeat");
      if (!idx || !sb) return std::nullopt;
      step.index = *idx;
      step.sub = *sb;
      if (!value["size"] || !value["value"] || !value["repeat"]) {
        error(value, "mailbox_repeat: 'size', 'value' and 'repeat' are required");
        return std::nullopt;
      }
      auto size = integer<std::size_t>(value["size"], "size", 1, 4);
      if (!size) return std::nullopt;
      step.size = *size;
      const auto bits = 8 * step.size;
      const std::int64_t low = -(std::int64_t{1} << (bits - 1));
      const std::int64_t high = (std::int64_t{1} << bits) - 1;
      auto first = integer<std::int64_t>(value["value"], "value", low, high);
      auto second = integer<std::int64_t>(value["repeat"], "repeat", low, high);
      if (!first || !second) return std::nullopt;
      if (*first == *second) {
        error(value["repeat"],
              "mailbox_repeat: 'repeat' must differ from 'value' (else a "
              "second execution could not be seen)");
        return std::nullopt;
      }
      step.value = *first;
      step.repeat = *second;
      return step;
    }
    if (action == "wait") {
      auto d = duration(value, "wait");
      if (!d) return std::nullopt;
      return WaitStep{*d};
    }
    if (action == "power_cycle") {
      if (!value.IsMap() || value.size() != 0) {
        error(value, "power_cycle: the value is {} (nothing to give)");
        return std::nullopt;
      }
      return PowerCycleStep{};
    }
    if (action == "bus_off") {
      auto d = duration(value, "bus_off");
      if (!d) return std::nullopt;
      if (!d->is_timing() &&
          (d->value <= can::Duration::zero() || d->value > std::chrono::seconds(10))) {
        error(value, "bus_off: the duration must be above 0 and at most 10s");
        return std::nullopt;
      }
      return BusOffStep{*d};
    }
    if (action == "controlword") {
      auto cw = integer<std::uint16_t>(value, "controlword", 0, 0xFFFF);
      if (!cw) return std::nullopt;
      return ControlwordStep{*cw};
    }
    if (action == "simulate") {
      if (!check_map(value, "simulate", {"input", "value"})) return std::nullopt;
      if (!value["input"] || !value["value"]) {
        error(value, "simulate: 'input' and 'value' are required");
        return std::nullopt;
      }
      auto input = scalar(value["input"], "input");
      auto v =
          integer<std::int64_t>(value["value"], "value", std::numeric_limits<std::int64_t>::min(),
                                std::numeric_limits<std::int64_t>::max());
      if (!input || !v) return std::nullopt;
      if (input->empty()) {
        error(value["input"], "simulate: input name is empty");
        return std::nullopt;
      }
      return SimulateStep{*input, *v};
    }
    if (action == "mark") {
      auto mark = mark_definition(value);
      if (mark.empty()) return std::nullopt;
      return MarkStep{mark};
    }
    if (action == "expect_frame") {
      auto step = parse_expect_frame(action, value, step_map, [](std::string_view text) {
        return parse_frame_spec(text, true);
      });
      if (!step) return std::nullopt;
      return *step;
    }
    if (action == "sdo_request") {
      auto text = scalar(value, "sdo_request");
      if (!text) return std::nullopt;
      auto frame = parse_sdo_octets(*text, false, cia301::kSdoRequestBase);
      if (!frame) {
        error(value, fmt::format("sdo_request: {}", frame.error()));
        return std::nullopt;
      }
      return SdoRequestStep{SendStep{std::move(*frame)}};
    }
    if (action == "expect_sdo_response") {
      auto step = parse_expect_frame(action, value, step_map, [](std::string_view text) {
        return parse_sdo_octets(text, true, cia301::kSdoResponseBase);
      });
      if (!step) return std::nullopt;
      return ExpectSdoResponseStep{std::move(*step)};
    }
    if (action == "expect_silence") {
      ExpectSilenceStep step;
      if (value.IsScalar() && value.Scalar() == "any") {
        step.any = true;
      } else if (value.IsSequence() && value.size() > 0) {
        for (const auto& item : value) {
          auto text = scalar(item, "expect_silence");
          if (!text) continue;
          if (text->find('#') != std::string::npos) {
            auto pattern = parse_frame_spec(*text, true);
            if (!pattern) {
              error(item, fmt::format("expect_silence: {}", pattern.error()));
              continue;
            }
            step.patterns.push_back(*pattern);
            continue;
          }
          auto cob = parse_cob_id(*text);
          if (!cob) {
            error(item, fmt::format("expect_silence: {}", cob.error()));
            continue;
          }
          step.cob_ids.push_back(*cob);
        }
      } else {
        error(value,
              "expect_silence: expected 'any' or a list of COB-IDs or frame patterns ([180+N, "
              "080, \"1A0#..*\"])");
        return std::nullopt;
      }
      const auto node = modifier("for");
      if (!node) {
        error(step_node_, "expect_silence: 'for:' (a duration) is required");
        return std::nullopt;
      }
      auto d = duration(node, "for");
      if (!d) return std::nullopt;
      step.duration = *d;
      if (const auto since = modifier("since")) step.since = mark_reference(since, "since");
      return step;
    }
    if (action == "expect_bootup") {
      ExpectBootupStep step;
      if (!(value.IsMap() && value.size() == 0) && !value.IsNull()) {
        error(value, "expect_bootup: the value is {}");
        return std::nullopt;
      }
      if (const auto node = modifier("within"))
        step.within = duration(node, "within").value_or(step.within);
      if (const auto node = modifier("since")) step.since = mark_reference(node, "since");
      if (const auto node = modifier("mark")) step.mark = mark_definition(node);
      return step;
    }
    if (action == "expect_heartbeat") {
      ExpectHeartbeatStep step;
      auto text = scalar(value, "expect_heartbeat");
      if (!text) return std::nullopt;
      auto state = parse_nmt_state(*text);
      if (!state) {
        error(value, fmt::format("expect_heartbeat: '{}' is not an NMT state (bootup "
                                 "initialising pre-operational operational stopped)",
                                 *text));
        return std::nullopt;
      }
      step.state = *state;
      if (const auto node = modifier("within")) step.within = duration(node, "within");
      if (const auto node = modifier("since")) step.since = mark_reference(node, "since");
      if (const auto node = modifier("mark")) step.mark = mark_definition(node);
      return step;
    }
    if (action == "expect_emcy") {
      ExpectEmcyStep step;
      if (!check_map(value, "expect_emcy", {"code", "register", "manufacturer"}))
        return std::nullopt;
      if (!value["code"]) {
        error(value, "expect_emcy: 'code' is missing");
        return std::nullopt;
      }
      const auto one = [&](const YAML::Node& item) {
        if (auto code = integer<std::uint16_t>(item, "code", 0, 0xFFFF))
          step.codes.push_back(*code);
      };
      if (value["code"].IsSequence()) {
        for (const auto& item : value["code"])
          one(item);
        if (value["code"].size() == 0) {
          error(value["code"], "expect_emcy: the list of codes is empty");
          return std::nullopt;
        }
      } else if (value["code"].IsScalar() && value["code"].Scalar() == "error") {
        step.any_error = true;
      } else {
        one(value["code"]);
      }
      if (step.codes.empty() && !step.any_error) return std::nullopt;
      if (const auto reg = value["register"]) {
        if (!check_map(reg, "register", {"mask", "value"}) || !reg["mask"] || !reg["value"]) {
          if (reg.IsMap()) error(reg, "register: 'mask' and 'value' are required");
          return std::nullopt;
        }
        step.register_mask = integer<std::uint8_t>(reg["mask"], "mask", 0, 0xFF);
        step.register_value = integer<std::uint8_t>(reg["value"], "value", 0, 0xFF).value_or(0);
      }
      if (const auto man = value["manufacturer"]) {
        auto text = scalar(man, "manufacturer");
        if (!text) return std::nullopt;
        auto bytes = parse_byte_pattern(*text, true);
        if (!bytes || bytes->size() > 5) {
          error(man, fmt::format("manufacturer: '{}' is not a pattern of at most 5 bytes", *text));
          return std::nullopt;
        }
        step.manufacturer = std::move(*bytes);
      }
      if (const auto node = modifier("within"))
        step.within = duration(node, "within").value_or(step.within);
      if (const auto node = modifier("since")) step.since = mark_reference(node, "since");
      if (const auto node = modifier("mark")) step.mark = mark_definition(node);
      return step;
    }
    if (action == "expect_state") {
      ExpectStateStep step;
      auto text = scalar(value, "expect_state");
      if (!text) return std::nullopt;
      auto state = parse_402_state(*text);
      if (!state) {
        error(value, fmt::format("expect_state: '{}' is not a CiA 402 state", *text));
        return std::nullopt;
      }
      step.state = *state;
      if (const auto node = modifier("within"))
        step.within = duration(node, "within").value_or(step.within);
      return step;
    }
    if (action == "expect_statusword") {
      ExpectStatuswordStep step;
      if (!check_map(value, "expect_statusword", {"mask", "value"})) return std::nullopt;
      if (!value["mask"] || !value["value"]) {
        error(value, "expect_statusword: 'mask' and 'value' are required");
        return std::nullopt;
      }
      auto mask = integer<std::uint16_t>(value["mask"], "mask", 0, 0xFFFF);
      auto v = integer<std::uint16_t>(value["value"], "value", 0, 0xFFFF);
      if (!mask || !v) return std::nullopt;
      step.mask = *mask;
      step.value = *v;
      if ((step.value & ~step.mask) != 0)
        error(value, fmt::format("expect_statusword: value {:04X}h has bits outside mask {:04X}h",
                                 step.value, step.mask));
      if (const auto node = modifier("within"))
        step.within = duration(node, "within").value_or(step.within);
      return step;
    }
    if (action == "poll") {
      PollStep step;
      if (!check_map(value, "poll", {"index", "sub", "value", "mask", "range"}))
        return std::nullopt;
      auto idx = index(value, "poll");
      auto sb = sub(value, "poll");
      if (!idx || !sb) return std::nullopt;
      step.index = *idx;
      step.sub = *sb;
      if (const auto node = modifier("signed"))
        step.is_signed = boolean(node, "signed").value_or(false);
      if (value["range"]) {
        // `range: [lo, hi]`: the value read until it is within (each bound a literal or
        // `$name±k`), instead of value/mask.
        if (value["value"] || value["mask"]) {
          error(value, "poll: give either 'range' or 'value' (with 'mask'), not both");
          return std::nullopt;
        }
        const auto& range = value["range"];
        if (!range.IsSequence() || range.size() != 2) {
          error(range, "poll: range: expected [low, high]");
          return std::nullopt;
        }
        const auto low = value_spec(range[0], "range low");
        const auto high = value_spec(range[1], "range high");
        if (!low || !high) return std::nullopt;
        if (low->saved == high->saved && low->multiplier == high->multiplier &&
            low->divisor == high->divisor &&
            (low->saved.empty() ? low->literal > high->literal : low->offset > high->offset)) {
          error(range, "poll: range: low is above high");
          return std::nullopt;
        }
        step.range.emplace(*low, *high);
      } else if (!value["value"]) {
        error(value, "poll: 'value' (or 'range') is missing");
        return std::nullopt;
      } else if (step.is_signed) {
        error(modifier("signed"), "poll: 'signed' goes with 'range'");
        return std::nullopt;
      }
      if (!step.range) {
        auto v = parse_integer(value["value"].Scalar());
        if (!value["value"].IsScalar() || !v) {
          error(value["value"], "poll: value is not an integer");
          return std::nullopt;
        }
        step.value = v->bits;
        if (value["mask"]) {
          auto m = parse_integer(value["mask"].IsScalar() ? value["mask"].Scalar() : "");
          if (!m || m->negative) {
            error(value["mask"], "poll: mask is not an unsigned integer");
            return std::nullopt;
          }
          step.mask = m->bits;
        }
      }
      const auto within = modifier("within");
      if (!within) {
        error(step_node_, "poll: 'within:' is required");
        return std::nullopt;
      }
      auto d = duration(within, "within");
      if (!d) return std::nullopt;
      step.within = *d;
      if (const auto node = modifier("every"))
        step.every = duration(node, "every").value_or(step.every);
      return step;
    }
    if (action == "measure") {
      MeasureStep step;
      if (!check_map(value, "measure", {"from", "to", "min", "max", "frames"})) return std::nullopt;
      if (!value["from"] || !value["to"]) {
        error(value, "measure: 'from' and 'to' are required");
        return std::nullopt;
      }
      step.from = mark_reference(value["from"], "from");
      step.to = mark_reference(value["to"], "to");
      if (value["frames"]) {
        // A count of frames: min and max are numbers of frames, not durations. One pattern, or
        // a list of them (a frame matching any counts once).
        const YAML::Node frames = value["frames"];
        std::vector<YAML::Node> items;
        if (frames.IsSequence()) {
          for (const YAML::Node& item : frames)
            items.push_back(item);
          if (items.empty()) {
            error(frames, "measure frames: an empty list (give one pattern or more)");
            return std::nullopt;
          }
        } else {
          items.push_back(frames);
        }
        for (const YAML::Node& item : items) {
          auto text = scalar(item, "measure frames");
          if (!text) return std::nullopt;
          auto pattern = parse_frame_spec(*text, true);
          if (!pattern) {
            error(item, fmt::format("measure frames: {}", pattern.error()));
            return std::nullopt;
          }
          step.frames.push_back(std::move(*pattern));
        }
        if (value["min"]) step.min_count = integer<std::size_t>(value["min"], "min", 0, 10000);
        if (value["max"]) step.max_count = integer<std::size_t>(value["max"], "max", 0, 10000);
        if (step.min_count && step.max_count && *step.min_count > *step.max_count)
          error(value, "measure: 'min' is above 'max'");
      } else {
        if (value["min"]) step.min = duration(value["min"], "min");
        if (value["max"]) step.max = duration(value["max"], "max");
      }
      if (!value["min"] && !value["max"]) error(value, "measure: give 'min', 'max' or both");
      return step;
    }
    if (action == "expect_periodic") {
      ExpectPeriodicStep step;
      auto text = scalar(value, "expect_periodic");
      if (!text) return std::nullopt;
      auto cob = parse_cob_id(*text);
      if (!cob) {
        error(value, fmt::format("expect_periodic: {}", cob.error()));
        return std::nullopt;
      }
      step.cob = *cob;
      const auto period = modifier("period");
      if (!period) {
        error(step_node_, "expect_periodic: 'period:' is required");
        return std::nullopt;
      }
      auto d = duration(period, "period");
      if (!d) return std::nullopt;
      step.period = *d;
      if (const auto node = modifier("tolerance"))
        step.tolerance = duration(node, "tolerance").value_or(step.tolerance);
      if (const auto node = modifier("count"))
        step.count = integer<std::size_t>(node, "count", 2, 10000).value_or(2);
      if (const auto node = modifier("mark")) step.mark = mark_definition(node);
      if (const auto node = modifier("last")) step.last = mark_definition(node);
      return step;
    }
    error(value, fmt::format("internal: action '{}' has no parser", action));
    return std::nullopt;
  }

  // A list of steps (`steps:`, `finally:`, a repeat's `steps:`) with its repeats unrolled
  // (FORMAT.md "Repeated steps"). `number`: the last step number given, in document order (a
  // repeat and each step in it counted once); `depth`: the repeats around the list.
  void parse_step_list(const YAML::Node& list, std::vector<Step>& out, std::size_t depth,
                       std::size_t& number) {
    for (const auto& item : list) {
      if (item.IsMap() && item["repeat"]) {
        parse_repeat(item, out, depth, number);
        continue;
      }
      ++number;
      if (auto step = parse_step(item)) {
        step->number = number;
        out.push_back(std::move(*step));
      }
    }
  }

  // `- repeat: {times: N, steps: [...]}` (with an optional `note:`): its steps N times over.
  void parse_repeat(const YAML::Node& node, std::vector<Step>& out, std::size_t depth,
                    std::size_t& number) {
    const std::size_t own = ++number;
    bool ok = true;
    for (const auto& entry : node) {
      const auto key = entry.first.Scalar();
      if (key != "repeat" && key != "note") {
        error(entry.first, fmt::format("repeat: unknown key '{}' (allowed: repeat, note)", key));
        ok = false;
      }
    }
    std::string note;
    if (const auto node_note = node["note"]) note = scalar(node_note, "note").value_or("");
    const YAML::Node value = node["repeat"];
    if (!value.IsMap()) {
      error(value, "repeat: expected a map {times: N, steps: [...]}");
      return;
    }
    for (const auto& entry : value) {
      const auto key = entry.first.Scalar();
      if (key != "times" && key != "steps") {
        error(entry.first, fmt::format("repeat: unknown key '{}' (allowed: times, steps)", key));
        ok = false;
      }
    }
    if (depth >= kMaxRepeatDepth) {
      error(node, fmt::format("repeat: nested too deep (at most {} repeats inside each other)",
                              kMaxRepeatDepth));
      return;
    }
    std::optional<std::size_t> times;
    if (const auto times_node = value["times"]) {
      times = integer<std::size_t>(times_node, "repeat: times", 1,
                                   static_cast<std::int64_t>(kMaxRepeatTimes));
    } else {
      error(value, "repeat: 'times:' is required (1..1000)");
    }
    const YAML::Node steps = value["steps"];
    if (!steps) {
      error(value, "repeat: 'steps:' is required (a non-empty list of steps)");
      return;
    }
    if (!steps.IsSequence() || steps.size() == 0) {
      error(steps, "repeat: steps: expected a non-empty list of steps");
      return;
    }
    std::vector<Step> body;
    const std::size_t errors_before = out_.errors.size();
    parse_step_list(steps, body, depth + 1, number);
    if (!ok || !times || out_.errors.size() != errors_before || body.empty()) return;
    if (out.size() + *times * body.size() > kMaxUnrolledSteps) {
      error(node, fmt::format("repeat: {} x {} steps make more than {} steps in this list", *times,
                              body.size(), kMaxUnrolledSteps));
      return;
    }
    const std::size_t line = line_of(node);
    out.reserve(out.size() + *times * body.size());
    for (std::size_t iteration = 1; iteration <= *times; ++iteration) {
      for (const Step& step : body) {
        Step copy = step;
        copy.repeats.insert(copy.repeats.begin(), StepRepeat{own, *times, iteration, note, line});
        out.push_back(std::move(copy));
      }
    }
  }

  std::optional<Step> parse_step(const YAML::Node& node) {
    if (!node.IsMap()) {
      error(node, "a step is a map with one action key, e.g. '- send: \"600+N#...\"'");
      return std::nullopt;
    }
    step_node_ = node;
    const StepSyntax* syntax = nullptr;
    YAML::Node action_value;
    // `mark` is an action on its own (`- mark: t0`) and a modifier of expectations.
    const bool mark_is_modifier = node.size() > 1 && node["mark"];
    for (const auto& entry : node) {
      const auto key = entry.first.Scalar();
      if (key == "mark" && mark_is_modifier) continue;
      for (const auto& candidate : step_syntax()) {
        if (candidate.action == key) {
          if (syntax != nullptr) {
            error(entry.first,
                  fmt::format("step has two actions: '{}' and '{}'", syntax->action, key));
            return std::nullopt;
          }
          syntax = &candidate;
          action_value = entry.second;
        }
      }
    }
    if (syntax == nullptr) {
      std::vector<std::string_view> actions;
      for (const auto& candidate : step_syntax())
        actions.push_back(candidate.action);
      actions.push_back("repeat");
      error(node, fmt::format("step has no action (one of: {})", fmt::join(actions, ", ")));
      return std::nullopt;
    }
    bool ok = true;
    for (const auto& entry : node) {
      const auto key = entry.first.Scalar();
      if (key == syntax->action || key == "note") continue;
      if (std::find(syntax->modifiers.begin(), syntax->modifiers.end(), key) ==
          syntax->modifiers.end()) {
        error(entry.first, fmt::format("{}: unknown key '{}' (allowed: {}{}note)", syntax->action,
                                       key, fmt::join(syntax->modifiers, ", "),
                                       syntax->modifiers.empty() ? "" : ", "));
        ok = false;
      }
    }
    if (!ok) return std::nullopt;
    Step step;
    step.line = line_of(node);
    if (const auto note = node["note"]) step.note = scalar(note, "note").value_or("");
    if (const auto clause = node["clause"]) {
      step.clause = scalar(clause, "clause").value_or("");
      if (step.clause.empty() && syntax->action != "expect_frame" &&
          syntax->action != "expect_sdo_response")
        error(clause, "clause: empty");
    }
    auto action = parse_action(syntax->action, action_value, node);
    if (!action) return std::nullopt;
    step.action = std::move(*action);
    if (const auto* read = std::get_if<SdoReadStep>(&step.action); read && !read->save.empty())
      saves_.insert(read->save);
    return step;
  }

  Vector parse_vector(const YAML::Node& node) {
    Vector vector;
    vector.file = file_;
    vector.line = line_of(node);
    marks_.clear();
    saves_.clear();
    if (!node.IsMap()) {
      error(node, "a vector is a map (id, title, source, level, steps, ...)");
      return vector;
    }
    for (const auto& entry : node) {
      const auto key = entry.first.Scalar();
      if (std::find(kVectorKeys.begin(), kVectorKeys.end(), key) == kVectorKeys.end())
        error(entry.first, fmt::format("unknown vector key '{}' (allowed: {})", key,
                                       fmt::join(kVectorKeys, ", ")));
    }
    for (const std::string_view required : {"id", "title", "source", "steps"}) {
      if (!node[std::string(required)])
        error(node,
              fmt::format("vector{}: '{}' is missing",
                          node["id"] && node["id"].IsScalar() ? " " + node["id"].Scalar() : "",
                          required));
    }
    if (const auto id = node["id"]) {
      if (auto text = scalar(id, "id")) {
        const bool charset = std::all_of(text->begin(), text->end(), [](char c) {
          return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '/' || c == '.' ||
                 c == '_' || c == '-';
        });
        if (!charset || text->find('/') == std::string::npos || text->front() == '/' ||
            text->back() == '/' || text->find("//") != std::string::npos) {
          error(id, fmt::format("id '{}': use [a-z0-9/._-] with at least two '/'-separated "
                                "components (family/name)",
                                *text));
        }
        vector.id = *text;
      }
    }
    if (const auto title = node["title"]) vector.title = scalar(title, "title").value_or("");
    if (const auto note = node["note"]) vector.note = scalar(note, "note").value_or("");
    if (const auto source = node["source"]) {
      const auto add = [&](const YAML::Node& item) {
        auto text = scalar(item, "source");
        if (!text) return;
        auto parsed = parse_source(*text);
        if (!parsed) {
          error(item, parsed.error());
          return;
        }
        parsed->line = line_of(item);
        vector.sources.push_back(std::move(*parsed));
      };
      if (source.IsSequence()) {
        for (const auto& item : source)
          add(item);
        if (source.size() == 0) error(source, "source: the list is empty");
      } else {
        add(source);
      }
    }
    if (const auto level = node["level"]) {
      auto text = scalar(level, "level");
      if (text == "must") {
        vector.level = Level::must;
      } else if (text == "should") {
        vector.level = Level::should;
      } else if (text == "may") {
        vector.level = Level::may;
      } else if (text) {
        error(level, fmt::format("level: '{}' is not must, should or may", *text));
      }
    }
    if (const auto req = node["requires"]) {
      for (auto& feature : string_list(req, "requires")) {
        if (!profile::is_known_feature(feature)) {
          error(req, fmt::format("requires: unknown feature '{}' (see vectors/FORMAT.md "
                                 "\"Features\")",
                                 feature));
        } else {
          vector.requires_features.push_back(std::move(feature));
        }
      }
    }
    if (const auto unless = node["unless"]) {
      for (auto& feature : string_list(unless, "unless")) {
        if (!profile::is_known_feature(feature) || profile::parse_object_need(feature) ||
            feature == "simulation" || feature == "motion") {
          error(unless, fmt::format("unless: '{}' is not a profile feature (see vectors/FORMAT.md "
                                    "\"Features\"; object needs, simulation and motion are not "
                                    "taken)",
                                    feature));
        } else if (std::find(vector.requires_features.begin(), vector.requires_features.end(),
                             feature) != vector.requires_features.end()) {
          error(unless, fmt::format("unless: '{}' is also in requires: (the vector would never "
                                    "apply)",
                                    feature));
        } else {
          vector.unless_features.push_back(std::move(feature));
        }
      }
    }
    if (const auto profiles = node["profiles"]) vector.profiles = string_list(profiles, "profiles");
    if (const auto transports = node["transports"]) {
      for (auto& link : string_list(transports, "transports")) {
        if (link != "can" && link != "ethercat") {
          error(transports, fmt::format("transports: unknown link '{}' (can or ethercat)", link));
        } else {
          vector.transports.push_back(std::move(link));
        }
      }
    }
    if (const auto motion = node["motion"])
      vector.motion = boolean(motion, "motion").value_or(false);
    if (vector.motion && std::find(vector.requires_features.begin(), vector.requires_features.end(),
                                   "motion") == vector.requires_features.end())
      vector.requires_features.emplace_back("motion");
    if (const auto setup = node["setup"]) {
      auto text = scalar(setup, "setup");
      if (text == "reset-node") {
        vector.setup = Setup::reset_node;
      } else if (text == "reset-communication") {
        vector.setup = Setup::reset_communication;
      } else if (text == "restore-defaults") {
        vector.setup = Setup::restore_defaults;
      } else if (text == "none") {
        vector.setup = Setup::none;
      } else if (text) {
        error(setup, fmt::format("setup: '{}' is not reset-node, reset-communication, "
                                 "restore-defaults or none",
                                 *text));
      }
    }
    if (const auto nmt = node["nmt"]) {
      auto text = scalar(nmt, "nmt");
      if (text == "none") {
        vector.nmt.reset();
      } else if (text) {
        auto state = parse_nmt_state(*text);
        if (!state || *state == cia301::NmtState::boot_up)
          error(nmt, fmt::format("nmt: '{}' is not pre-operational, operational, stopped or none",
                                 *text));
        else
          vector.nmt = *state;
      }
    }
    if (const auto drive_state = node["drive_state"]) {
      auto text = scalar(drive_state, "drive_state");
      if (text) {
        vector.drive_state = parse_402_state(*text);
        if (!vector.drive_state)
          error(drive_state, fmt::format("drive_state: '{}' is not a CiA 402 state", *text));
      }
    }
    if (const auto timeout = node["timeout"])
      vector.timeout = duration(timeout, "timeout").value_or(vector.timeout);
    if (const auto steps = node["steps"]) {
      if (!steps.IsSequence() || steps.size() == 0) {
        error(steps, "steps: expected a non-empty list of steps");
      } else {
        std::size_t number = 0;
        parse_step_list(steps, vector.steps, 0, number);
      }
    }
    // `finally:` after `steps:` (its steps may use the marks and saved values of the steps).
    if (const auto finally = node["finally"]) {
      if (!finally.IsSequence() || finally.size() == 0) {
        error(finally, "finally: expected a non-empty list of steps");
      } else {
        std::size_t number = 0;
        parse_step_list(finally, vector.finally_steps, 0, number);
      }
    }
    return vector;
  }

  std::string file_;
  VectorSet& out_;
  std::set<std::string> marks_;
  std::set<std::string> saves_;
  YAML::Node step_node_;
};

}  // namespace

std::vector<std::string_view> vector_file_keys() {
  std::vector<std::string_view> keys(kVectorKeys.begin(), kVectorKeys.end());
  for (const StepSyntax& step : step_syntax()) {
    keys.push_back(step.action);
    keys.insert(keys.end(), step.modifiers.begin(), step.modifiers.end());
  }
  keys.insert(keys.end(), {"repeat", "times"});  // FORMAT.md "Repeated steps"
  return keys;
}

VectorSet parse_vectors(std::string_view text, const std::string& file) {
  VectorSet set;
  set.files.push_back(file);
  if (const int bad = profile::first_invalid_utf8_line(text); bad != 0) {
    // yaml-cpp would read the bytes as they are and the writer could not give them back.
    set.errors.push_back(TextError{file, bad, "the text is not valid UTF-8"});
    return set;
  }
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    set.errors.push_back(TextError{file, e.mark.line < 0 ? 0 : e.mark.line + 1, e.msg});
    return set;
  }
  try {
    Parser(file, set).parse_document(root);
  } catch (const YAML::Exception& e) {  // e.g. a duplicate or non-scalar key
    set.errors.push_back(TextError{file, e.mark.line < 0 ? 0 : e.mark.line + 1, e.msg});
  }
  return set;
}

VectorSet load_vector_file(const std::filesystem::path& path, const std::string& display) {
  const std::string name = display.empty() ? path.string() : display;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    VectorSet set;
    set.errors.push_back(TextError{name, 0, "cannot read the file"});
    return set;
  }
  std::ostringstream text;
  text << in.rdbuf();
  return parse_vectors(text.str(), name);
}

VectorSet load_vector_tree(const std::filesystem::path& dir, bool as_given) {
  VectorSet set;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    set.errors.push_back(TextError{dir.string(), 0, "not a directory"});
    return set;
  }
  std::vector<std::filesystem::path> files;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec)) {
    const auto relative = it->path().lexically_relative(dir);
    if (it->is_directory() && relative == "drives") {
      it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file() || it->path().extension() != ".yaml") continue;
    // manuals.yaml: the citable manuals; coverage.yaml: scripts/generate-coverage's input.
    if (relative == "manuals.yaml" || relative == "coverage.yaml") continue;
    files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  const auto base = dir.lexically_normal().has_filename()
                        ? dir.lexically_normal().parent_path()
                        : dir.lexically_normal().parent_path().parent_path();
  std::map<std::string, std::pair<std::string, std::size_t>> seen;
  for (const auto& path : files) {
    auto display = as_given ? (dir / path.lexically_relative(dir)).lexically_normal().string()
                            : path.lexically_normal().lexically_relative(base).string();
    if (display.empty()) display = path.string();
    auto one = load_vector_file(path, display);
    set.files.push_back(display);
    for (auto& error : one.errors)
      set.errors.push_back(std::move(error));
    for (auto& vector : one.vectors) {
      const auto [it, inserted] = seen.emplace(vector.id, std::pair{vector.file, vector.line});
      if (!inserted) {
        set.errors.push_back(TextError{vector.file, static_cast<int>(vector.line),
                                       fmt::format("duplicate id '{}' (first at {}:{})", vector.id,
                                                   it->second.first, it->second.second)});
        continue;
      }
      set.vectors.push_back(std::move(vector));
    }
  }
  return set;
}

VectorSet load_vector_trees(const std::vector<std::filesystem::path>& dirs) {
  VectorSet set;
  std::map<std::string, std::pair<std::string, std::size_t>> seen;
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    auto one = load_vector_tree(dirs[i], i > 0);
    for (auto& file : one.files)
      set.files.push_back(std::move(file));
    for (auto& error : one.errors)
      set.errors.push_back(std::move(error));
    for (auto& vector : one.vectors) {
      const auto [it, inserted] = seen.emplace(vector.id, std::pair{vector.file, vector.line});
      if (!inserted) {
        set.errors.push_back(TextError{
            vector.file, static_cast<int>(vector.line),
            fmt::format("vector id '{}' is already defined at {}:{} (ids are unique across the "
                        "shipped vectors and every --vectors DIR)",
                        vector.id, it->second.first, it->second.second)});
        continue;
      }
      set.vectors.push_back(std::move(vector));
    }
  }
  return set;
}

}  // namespace drivecheck::conformance

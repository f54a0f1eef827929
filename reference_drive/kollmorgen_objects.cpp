#include "reference_drive/kollmorgen_objects.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <limits>
#include <span>
#include <utility>
#include <vector>

namespace drivecheck::reference_drive {
namespace {

// Where a channel parameter's value comes from.
enum class Origin : std::uint8_t { maxcmd, stored, power_stage, node_id, serial_number };

// Sub 6 check data (002 §6.1.1 L5195-5199).
constexpr std::uint32_t kCheckEeprom = 0x00020000;
constexpr std::uint32_t kCheckReadOnly = 0x00200000;
// Sub 5 formats (L5164-5178).
constexpr std::uint32_t kFormatFunction = 0;
constexpr std::uint32_t kFormatUnsigned8 = 4;
constexpr std::uint32_t kFormatInteger32 = 7;
constexpr std::uint32_t kFormatUnsigned32 = 8;

constexpr std::uint8_t kSerialSub = 4;
constexpr std::uint8_t kValueSub = 1;
constexpr std::uint8_t kStdInSub = 1;
constexpr std::uint8_t kStdOutSub = 2;

constexpr std::int64_t kInt32Max = std::numeric_limits<std::int32_t>::max();

// One ASCII parameter of the object channel (the header lists them with their sources).
struct Parameter {
  std::uint16_t index;
  std::string_view name;  // the ASCII command
  bool read_only;
  std::int64_t low;
  std::int64_t high;
  std::int64_t default_value;
  std::uint32_t format;
  std::uint32_t check;
  Origin origin;
};

constexpr std::array<Parameter, 5> kParameters = {{
    {0x3500, "MAXCMD", true, 0, 0x400, 0x35EF - 0x3500, kFormatFunction, kCheckReadOnly,
     Origin::maxcmd},
    {0x3504, "ACTIVE", true, 0, 1, 0, kFormatUnsigned8, kCheckReadOnly, Origin::power_stage},
    {0x3505, "ADDR", true, 1, 127, 0, kFormatUnsigned8, kCheckReadOnly, Origin::node_id},
    {0x3548, "GV", false, 0, 1000000, 1, kFormatInteger32, kCheckEeprom, Origin::stored},
    {0x35EF, "SERIALNO", true, 0, kInt32Max, 0, kFormatUnsigned32, kCheckReadOnly,
     Origin::serial_number},
}};
static_assert(kParameters.back().index - kParameters.front().index ==
                  kParameters.front().default_value,
              "MAXCMD is the offset of the last object of the channel");

// 1002h bits (002 §5.2.1.3 L1300-1344).
constexpr std::uint32_t kStatusInitialised = 1U << 10;
constexpr std::uint32_t kStatusPowerStage = 1U << 14;
constexpr std::uint32_t kStatusError = 1U << 15;
constexpr std::uint32_t kStatusHardwareEnable = 1U << 29;

std::string upper(std::string_view text) {
  std::string out(text);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return out;
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t'))
    text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t'))
    text.remove_suffix(1);
  return text;
}

cia301::EntryDefinition signed_entry(std::uint8_t sub, std::string name, cia301::AccessType access,
                                     std::int64_t value) {
  return cia301::EntryDefinition::make(sub, std::move(name), cia301::DataType::integer32, access,
                                       cia301::Value::of_signed(value), false);
}

cia301::EntryDefinition unsigned_entry(std::uint8_t sub, std::string name, std::uint64_t value) {
  return cia301::EntryDefinition::make(sub, std::move(name), cia301::DataType::unsigned32,
                                       cia301::AccessType::ro, cia301::Value::of_unsigned(value),
                                       false);
}

}  // namespace

Expected<void, std::string> KollmorgenObjects::add_objects(cia301::ObjectDictionary& od) {
  // 1002h manufacturer status register: VAR UNSIGNED32 ro, mappable.
  {
    cia301::ObjectDefinition def{
        kStatusIndex,
        "Manufacturer status register",
        cia301::ObjectCode::var,
        {cia301::EntryDefinition::make(0, "Manufacturer status register",
                                       cia301::DataType::unsigned32, cia301::AccessType::ro,
                                       cia301::Value::of_unsigned(0), true)}};
    if (auto added = od.add_object(std::move(def)); !added) return Unexpected(added.error());
  }
  // 1026h OS prompt: ARRAY, sub 1 StdIn, sub 2 StdOut.
  {
    cia301::ObjectDefinition def{
        kOsPromptIndex,
        "OS prompt",
        cia301::ObjectCode::array,
        {cia301::EntryDefinition::highest_sub_index(2),
         cia301::EntryDefinition::make(kStdInSub, "StdIn", cia301::DataType::unsigned8,
                                       cia301::AccessType::rw, cia301::Value::of_unsigned(0),
                                       false),
         cia301::EntryDefinition::make(kStdOutSub, "StdOut", cia301::DataType::unsigned8,
                                       cia301::AccessType::ro, cia301::Value::of_unsigned(0),
                                       false)}};
    if (auto added = od.add_object(std::move(def)); !added) return Unexpected(added.error());
  }
  // The object channel.
  for (const Parameter& p : kParameters) {
    cia301::EntryDefinition value = signed_entry(
        kValueSub, "Value", p.read_only ? cia301::AccessType::ro : cia301::AccessType::rw,
        p.default_value);
    if (!p.read_only) {
      value.low_limit = cia301::Value::of_signed(p.low);
      value.high_limit = cia301::Value::of_signed(p.high);
    }
    cia301::ObjectDefinition def{
        p.index,
        fmt::format("ASCII command {}", p.name),
        cia301::ObjectCode::record,
        {cia301::EntryDefinition::highest_sub_index(8), std::move(value),
         signed_entry(2, "Lower limit", cia301::AccessType::ro, p.low),
         signed_entry(3, "Upper limit", cia301::AccessType::ro, p.high),
         signed_entry(4, "Default value", cia301::AccessType::ro, p.default_value),
         unsigned_entry(5, "Parameter format", p.format),
         unsigned_entry(6, "Parameter check data", p.check), unsigned_entry(7, "Reserved", 0),
         unsigned_entry(8, "Reserved", 0)}};
    if (auto added = od.add_object(std::move(def)); !added) return Unexpected(added.error());
  }

  // Hooks (after every add_object: entry references stay valid from here on).
  od.find(kStatusIndex, 0)
      ->set_read_hook([this](cia301::ObjectDictionary& dict,
                             cia301::Entry& e) -> Expected<void, cia301::SdoAbort> {
        (void)dict;
        e.assign_unsigned(manufacturer_status());
        return {};
      });
  cia301::Entry* std_in = od.find(kOsPromptIndex, kStdInSub);
  std_in->set_write_validator(
      [this](const cia301::ObjectDictionary&, const cia301::Entry&,
             std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
        const bool ends_line = !data.empty() && (data[0] == '\r' || data[0] == '\n');
        if (!ends_line && line_.size() >= kLineCapacity) {
          return Unexpected(cia301::SdoAbort::kollmorgen_command_buffer_full);
        }
        return {};
      });
  std_in->set_write_observer([this](cia301::ObjectDictionary& dict, cia301::Entry& e) {
    receive(dict, static_cast<std::uint8_t>(e.as_unsigned()));
  });
  od.find(kOsPromptIndex, kStdOutSub)
      ->set_read_hook(
          [this](cia301::ObjectDictionary&, cia301::Entry& e) -> Expected<void, cia301::SdoAbort> {
            if (read_ < answer_.size()) {
              e.assign_unsigned(static_cast<unsigned char>(answer_[read_++]));
            } else {
              e.assign_unsigned(0);
            }
            if (read_ >= answer_.size()) {
              answer_.clear();
              read_ = 0;
            }
            return {};
          });
  for (std::size_t row = 0; row < kParameters.size(); ++row) {
    if (kParameters[row].origin == Origin::stored) continue;
    od.find(kParameters[row].index, kValueSub)
        ->set_read_hook([this, row](cia301::ObjectDictionary& dict,
                                    cia301::Entry& e) -> Expected<void, cia301::SdoAbort> {
          if (auto v = parameter_value(dict, row)) {
            e.assign_unsigned(static_cast<std::uint32_t>(*v));
          }
          return {};
        });
  }
  refresh(od);
  return {};
}

void KollmorgenObjects::on_reset() {
  line_.clear();
  answer_.clear();
  read_ = 0;
}

void KollmorgenObjects::refresh(cia301::ObjectDictionary& od) const {
  if (cia301::Entry* status = od.find(kStatusIndex, 0)) {
    status->assign_unsigned(manufacturer_status());
  }
  for (std::size_t row = 0; row < kParameters.size(); ++row) {
    if (kParameters[row].origin == Origin::stored) continue;
    cia301::Entry* e = od.find(kParameters[row].index, kValueSub);
    if (e == nullptr) continue;
    if (auto v = parameter_value(od, row)) e->assign_unsigned(static_cast<std::uint32_t>(*v));
  }
}

std::uint32_t KollmorgenObjects::manufacturer_status() const {
  const PowerDriveSystem& pds = application_.pds();
  std::uint32_t bits = 0;
  switch (pds.state()) {
    case cia402::State::not_ready_to_switch_on:
      break;
    case cia402::State::switch_on_disabled:
    case cia402::State::ready_to_switch_on:
      bits |= kStatusInitialised;
      break;
    case cia402::State::switched_on:
    case cia402::State::operation_enabled:
    case cia402::State::quick_stop_active:
      bits |= kStatusInitialised | kStatusPowerStage;
      break;
    case cia402::State::fault_reaction_active:
    case cia402::State::fault:
      bits |= kStatusInitialised | kStatusError;
      break;
  }
  if (pds.hardware_enable()) bits |= kStatusHardwareEnable;
  return bits;
}

std::optional<std::int64_t> KollmorgenObjects::parameter_value(const cia301::ObjectDictionary& od,
                                                               std::size_t row) const {
  const Parameter& p = kParameters[row];
  switch (p.origin) {
    case Origin::maxcmd:
      return p.default_value;
    case Origin::stored: {
      const cia301::Entry* e = od.find(p.index, kValueSub);
      if (e == nullptr) return std::nullopt;
      return e->as_signed();
    }
    case Origin::power_stage:
      return (manufacturer_status() & kStatusPowerStage) != 0 ? 1 : 0;
    case Origin::node_id:
      return od.node_id();
    case Origin::serial_number: {
      const cia301::Entry* e = od.find(kIdentityIndex, kSerialSub);
      if (e == nullptr) return std::nullopt;
      return static_cast<std::int64_t>(e->as_unsigned());
    }
  }
  return std::nullopt;
}

void KollmorgenObjects::receive(cia301::ObjectDictionary& od, std::uint8_t character) {
  if (character == '\r' || character == '\n') {
    const std::string line = std::exchange(line_, {});
    if (!trim(line).empty()) execute(od, trim(line));
    return;
  }
  line_.push_back(static_cast<char>(character));
}

void KollmorgenObjects::execute(cia301::ObjectDictionary& od, std::string_view line) {
  const std::size_t space = line.find_first_of(" \t");
  const std::string name = upper(line.substr(0, space));
  const std::string_view argument =
      space == std::string_view::npos ? std::string_view{} : trim(line.substr(space));
  const auto* found = std::find_if(kParameters.begin(), kParameters.end(),
                                   [&](const Parameter& p) { return p.name == name; });
  if (found == kParameters.end()) return;  // unknown command: no answer (see the header)
  const auto row = static_cast<std::size_t>(found - kParameters.begin());
  if (argument.empty()) {
    if (auto v = parameter_value(od, row)) answer_ += fmt::format("{}\r\n", *v);
    return;
  }
  std::int64_t value = 0;
  const auto [end, error] =
      std::from_chars(argument.data(), argument.data() + argument.size(), value);
  if (error != std::errc{} || end != argument.data() + argument.size()) return;
  if (found->read_only || value < found->low || value > found->high) return;
  if (cia301::Entry* e = od.find(found->index, kValueSub)) {
    (void)e->assign(cia301::Value::of_signed(value));
  }
}

}  // namespace drivecheck::reference_drive

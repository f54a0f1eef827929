#include "conformance/capabilities.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::conformance {
namespace {

using profile::ObjectNeed;

// CiA 301 §7.2.4.3.17: the two codes that say "not there".
constexpr std::uint32_t kObjectDoesNotExist = 0x06020000;
constexpr std::uint32_t kSubIndexDoesNotExist = 0x06090011;

// CiA 402-2 §6502h supported drive modes: bit -> mode feature.
struct ModeBit {
  unsigned bit;
  std::string_view feature;
};
constexpr std::array<ModeBit, 9> kModeBits{{{0, "mode.pp"},
                                            {1, "mode.vl"},
                                            {2, "mode.pv"},
                                            {3, "mode.tq"},
                                            {5, "mode.hm"},
                                            {6, "mode.ip"},
                                            {7, "mode.csp"},
                                            {8, "mode.csv"},
                                            {9, "mode.cst"}}};

// Features decided by the presence of one object that CiA 301 makes mandatory with them
// (object_requirements.inc: the row conditional on that feature).
struct ObjectFeature {
  std::string_view feature;
  std::uint16_t index;
  std::optional<std::uint8_t> sub;
};
constexpr std::array<ObjectFeature, 14> kObjectFeatures{{
    {"heartbeat.consumer", 0x1016, std::nullopt},
    {"emcy", 0x1014, std::nullopt},
    {"emcy.inhibit", 0x1015, std::nullopt},
    {"emcy.history", 0x1003, std::nullopt},
    {"sync", 0x1005, std::nullopt},
    {"sync.producer", 0x1006, std::nullopt},
    {"sync.counter", 0x1019, std::nullopt},
    {"time", 0x1012, std::nullopt},
    {"pdo", 0x1800, std::nullopt},
    {"pdo.event-timer", 0x1800, 5},
    {"pdo.inhibit", 0x1800, 3},
    {"pdo.sync-window", 0x1007, std::nullopt},
    {"store", 0x1010, 1},
    {"restore", 0x1011, 1},
}};

std::string abort_text(std::uint32_t code) {
  return fmt::format("{:08X}h", code);
}

std::string describe_answer(const DeviceProbe::Answer& answer) {
  if (answer.ok) return "answered";
  if (answer.abort) return fmt::format("answered {}", abort_text(*answer.abort));
  return "no answer";
}

std::uint32_t u32(const std::vector<std::uint8_t>& data) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < data.size() && i < 4; ++i)
    value |= static_cast<std::uint32_t>(data[i]) << (8 * i);
  return value;
}

std::array<std::uint8_t, 4> bytes_of(std::uint32_t value) {
  return {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
          static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)};
}

}  // namespace

std::string_view to_string(Presence presence) {
  constexpr std::array<std::string_view, 3> kNames{"present", "absent", "unknown"};
  return kNames[static_cast<std::size_t>(presence)];
}

ProfileChoice choose_generic_profile(std::optional<std::uint32_t> device_type) {
  if (!device_type)
    return {"cia301-device",
            "no --profile; 1000h could not be read, so the plain CiA 301 device profile"};
  const unsigned number = *device_type & 0xFFFF;
  if (number == 402)
    return {"cia402-device",
            fmt::format("no --profile; 1000h = {:08X}h: device profile 402, a CiA 402 drive",
                        *device_type)};
  return {"cia301-device",
          fmt::format("no --profile; 1000h = {:08X}h: device profile {}, not 402, so a plain "
                      "CiA 301 device",
                      *device_type, number)};
}

Capabilities::Capabilities(const cia301::ObjectDictionary* eds) : eds_(eds) {}

Finding Capabilities::find_object(DeviceProbe& device, const ObjectNeed& need) {
  if (auto it = objects_.find(need); it != objects_.end()) return it->second;
  Finding finding;
  if (eds_ != nullptr) {
    const bool there =
        need.sub ? eds_->find(need.index, *need.sub) != nullptr : eds_->find(need.index) != nullptr;
    finding = there ? Finding{Presence::present, "in the EDS"}
                    : Finding{Presence::absent, "not in the EDS"};
  } else {
    const auto answer = device.upload(need.index, need.sub.value_or(0));
    if (answer.abort &&
        (*answer.abort == kObjectDoesNotExist || *answer.abort == kSubIndexDoesNotExist)) {
      finding = {Presence::absent, fmt::format("upload answered {}", abort_text(*answer.abort))};
    } else if (answer.ok || answer.abort) {
      finding = {Presence::present, fmt::format("upload {}", describe_answer(answer))};
    } else {
      finding = {Presence::unknown, "no answer to the upload"};
    }
  }
  objects_.emplace(need, finding);
  return finding;
}

Finding Capabilities::present_if(DeviceProbe& device, std::uint16_t index,
                                 std::optional<std::uint8_t> sub) {
  const ObjectNeed need{index, sub};
  const auto finding = find_object(device, need);
  return {finding.presence, fmt::format("{}: {}", profile::describe(need), finding.how)};
}

Finding Capabilities::probe_feature(DeviceProbe& device, std::string_view name,
                                    std::optional<std::uint32_t> device_type) {
  for (const auto& row : kObjectFeatures)
    if (row.feature == name) return present_if(device, row.index, row.sub);

  if (name == "cia402") {
    if (!device_type) return {Presence::unknown, "1000h could not be read"};
    const bool drive = (*device_type & 0xFFFF) == 402;
    return {drive ? Presence::present : Presence::absent,
            fmt::format("1000h = {:08X}h: device profile {}", *device_type, *device_type & 0xFFFF)};
  }
  if (name.starts_with("mode.")) {
    if (!modes_finding_) {
      const auto answer = device.upload(0x6502, 0);
      if (answer.ok) {
        supported_modes_ = static_cast<std::uint16_t>(u32(answer.data) & 0xFFFF);
        modes_finding_ =
            Finding{Presence::present, fmt::format("6502h = {:08X}h", u32(answer.data))};
      } else if (answer.abort) {
        modes_finding_ =
            Finding{Presence::absent, fmt::format("6502h upload {}", describe_answer(answer))};
      } else {
        modes_finding_ = Finding{Presence::unknown, "6502h: no answer"};
      }
    }
    if (!supported_modes_) return *modes_finding_;
    for (const auto& bit : kModeBits) {
      if (bit.feature != name) continue;
      const bool set = (*supported_modes_ >> bit.bit & 1U) != 0;
      return {set ? Presence::present : Presence::absent,
              fmt::format("{} bit {} {}", modes_finding_->how, bit.bit, set ? "set" : "clear")};
    }
    return {Presence::unknown, "no 6502h bit for this mode"};
  }
  if (name == "heartbeat.producer") {
    const auto read = device.upload(0x1017, 0);
    if (!read.ok) {
      if (read.abort &&
          (*read.abort == kObjectDoesNotExist || *read.abort == kSubIndexDoesNotExist))
        return {Presence::absent, fmt::format("1017h upload {}", describe_answer(read))};
      return {Presence::unknown, fmt::format("1017h upload {}", describe_answer(read))};
    }
    const auto written = device.download(0x1017, 0, read.data);
    if (written.ok)
      return {Presence::present, fmt::format("1017h read {} ms, written back", u32(read.data))};
    return {written.abort ? Presence::absent : Presence::unknown,
            fmt::format("1017h read {} ms, writing it back {}", u32(read.data),
                        describe_answer(written))};
  }
  if (name == "nmt.guarding") {
    const auto object = present_if(device, 0x100C, std::nullopt);
    if (object.presence == Presence::present) return object;
    const auto answered = device.guarding_answered();
    if (!answered) return {Presence::absent, object.how + "; no node guarding on this transport"};
    return {*answered ? Presence::present : Presence::absent,
            fmt::format("{}; a remote frame on 700h+N {}", object.how,
                        *answered ? "was answered" : "was not answered")};
  }
  if (name == "pdo.rtr") {
    const auto cob = device.upload(0x1800, 1);
    if (!cob.ok)
      return {cob.abort ? Presence::absent : Presence::unknown,
              fmt::format("1800h sub 1 upload {}", describe_answer(cob))};
    const std::uint32_t value = u32(cob.data);
    const bool rtr = (value & 0x40000000U) == 0;
    return {rtr ? Presence::present : Presence::absent,
            fmt::format("1800h sub 1 = {:08X}h: bit 30 {} (CiA 301 §7.5.2.37)", value,
                        rtr ? "clear, RTR allowed" : "set, no RTR")};
  }
  if (name == "pdo.dynamic-mapping") {
    const auto cob = device.upload(0x1800, 1);
    if (!cob.ok)
      return {cob.abort ? Presence::absent : Presence::unknown,
              fmt::format("1800h sub 1 upload {}", describe_answer(cob))};
    const std::uint32_t original = u32(cob.data);
    const bool was_valid = (original & 0x80000000U) == 0;
    if (was_valid) {
      const auto invalid = device.download(0x1800, 1, bytes_of(original | 0x80000000U));
      if (!invalid.ok)
        return {Presence::unknown, fmt::format("TPDO1 could not be made invalid: 1800h sub 1 {}",
                                               describe_answer(invalid))};
    }
    Finding finding;
    const auto count = device.upload(0x1A00, 0);
    if (!count.ok || count.data.empty()) {
      finding = {count.abort ? Presence::absent : Presence::unknown,
                 fmt::format("1A00h sub 0 upload {}", describe_answer(count))};
    } else {
      const std::array<std::uint8_t, 1> same{count.data[0]};
      const auto write = device.download(0x1A00, 0, same);
      finding =
          write.ok
              ? Finding{Presence::present,
                        fmt::format("1A00h sub 0 := {} with TPDO1 invalid accepted", count.data[0])}
          : write.abort ? Finding{Presence::absent,
                                  fmt::format("1A00h sub 0 := {} with TPDO1 invalid {} (static)",
                                              count.data[0], describe_answer(write))}
                        : Finding{Presence::unknown,
                                  fmt::format("1A00h sub 0 write: {}", describe_answer(write))};
    }
    if (was_valid) {
      const auto back = device.download(0x1800, 1, bytes_of(original));
      if (!back.ok)
        finding.how += fmt::format("; 1800h sub 1 could NOT be put back to {:08X}h ({})", original,
                                   describe_answer(back));
      else
        finding.how += fmt::format("; 1800h sub 1 put back to {:08X}h", original);
    }
    return finding;
  }
  if (name == "sdo.block") {
    const auto answer = device.block_upload(0x1000, 0);
    if (answer.ok) return {Presence::present, "block upload of 1000h completed"};
    return {answer.abort ? Presence::absent : Presence::unknown,
            fmt::format("block upload of 1000h {}", describe_answer(answer))};
  }
  if (name == "sdo.segmented") {
    for (const std::uint16_t index : {0x1008, 0x1009, 0x100A}) {
      const auto answer = device.upload(index, 0);
      if (answer.ok && answer.data.size() > 4)
        return {Presence::present,
                fmt::format("{:04X}h uploaded {} bytes (segmented)", index, answer.data.size())};
    }
    return {Presence::unknown, "no object of more than 4 bytes among 1008h, 1009h, 100Ah"};
  }
  return {Presence::unknown, "no probe for this feature"};
}

void Capabilities::learn_mappable(DeviceProbe& device) {
  std::vector<std::string> names;
  if (eds_ != nullptr) {
    for (const auto& object : eds_->objects()) {
      for (const auto& entry : object.entries()) {
        if (!entry.pdo_mappable()) continue;
        names.push_back(entry.sub_index() == 0
                            ? fmt::format("{:04X}h", entry.index())
                            : fmt::format("{:04X}h sub {}", entry.index(), entry.sub_index()));
      }
    }
    mappable_ = names.empty() ? "mappable (EDS): none"
                              : fmt::format("mappable (EDS): {}", fmt::join(names, ", "));
    return;
  }
  for (const std::uint16_t mapping : {0x1600, 0x1A00}) {
    const auto count = device.upload(mapping, 0);
    if (!count.ok || count.data.empty()) continue;
    for (std::uint8_t sub = 1; sub <= count.data[0] && sub <= 64; ++sub) {
      const auto entry = device.upload(mapping, sub);
      if (!entry.ok) break;
      const std::uint32_t value = u32(entry.data);
      names.push_back(fmt::format("{:04X}h sub {}", value >> 16, value >> 8 & 0xFF));
    }
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  if (!names.empty())
    mappable_ = fmt::format("mappable (default RPDO1/TPDO1 mappings): {}", fmt::join(names, ", "));
}

void Capabilities::probe(DeviceProbe& device, const std::set<ObjectNeed>& needs,
                         const std::set<std::string>& detect,
                         std::optional<std::uint32_t> device_type) {
  probed_ = true;
  for (const auto& need : needs)
    (void)find_object(device, need);
  for (const auto& name : detect) {
    if (features_.contains(name)) continue;
    features_.emplace(name, probe_feature(device, name, device_type));
  }
  if (mappable_.empty() && (detect.contains("pdo") || detect.contains("pdo.dynamic-mapping")))
    learn_mappable(device);
}

Finding Capabilities::object(const ObjectNeed& need) const {
  if (auto it = objects_.find(need); it != objects_.end()) return it->second;
  return {Presence::unknown, "not probed"};
}

Finding Capabilities::feature(std::string_view name) const {
  if (auto it = features_.find(name); it != features_.end()) return it->second;
  return {Presence::unknown, "not probed"};
}

std::vector<std::string> Capabilities::describe() const {
  std::vector<std::string> lines;
  for (const auto& [name, finding] : features_)
    lines.push_back(fmt::format("{}: {} ({})", name, to_string(finding.presence), finding.how));
  for (const auto& [need, finding] : objects_)
    lines.push_back(fmt::format("object {}: {} ({})", profile::describe(need),
                                to_string(finding.presence), finding.how));
  if (!mappable_.empty()) lines.push_back(mappable_);
  return lines;
}

std::vector<std::string> Capabilities::notes() const {
  std::vector<std::string> lines;
  for (const auto& [name, finding] : features_) {
    if (finding.presence == Presence::unknown)
      lines.push_back(
          fmt::format("feature {} could not be probed ({}): the vectors that need it "
                      "ran as if it were present",
                      name, finding.how));
  }
  for (const auto& [need, finding] : objects_) {
    if (finding.presence == Presence::unknown)
      lines.push_back(
          fmt::format("object {} could not be probed ({}): the vectors that need it "
                      "ran as if it were present",
                      profile::describe(need), finding.how));
  }
  return lines;
}

}  // namespace drivecheck::conformance

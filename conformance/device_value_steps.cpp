// How the engine finds the `$dut.<name>` values (device_values.hpp) on the DUT: from the EDS,
// by reading the DUT's objects right after the setup of the first vector that uses them.
#include <fmt/format.h>

#include <algorithm>
#include <set>

#include "conformance/device_values.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::conformance {
namespace {

// A mapping entry for a TPDO from the EDS: mappable, readable, 8..32 bits; 1001h first.
std::optional<std::uint32_t> eds_tpdo_object(const cia301::ObjectDictionary& eds) {
  std::optional<std::uint32_t> first;
  for (const auto& object : eds.objects()) {
    for (const auto& entry : object.entries()) {
      if (!entry.pdo_mappable() || entry.access() == cia301::AccessType::wo) continue;
      const auto bits = 8 * cia301::info(entry.type()).size;
      if (bits < 8 || bits > 32) continue;
      const auto mapping = static_cast<std::uint32_t>(object.index()) << 16 |
                           static_cast<std::uint32_t>(entry.sub_index()) << 8 |
                           static_cast<std::uint32_t>(bits);
      if (object.index() == 0x1001) return mapping;
      if (!first) first = mapping;
    }
  }
  return first;
}

std::uint32_t le32(const std::vector<std::uint8_t>& data) {
  std::uint32_t value = 0;
  for (std::size_t i = 0; i < std::min<std::size_t>(data.size(), 4); ++i)
    value |= static_cast<std::uint32_t>(data[i]) << (8 * i);
  return value;
}

}  // namespace

StepStatus VectorRun::resolve_device_values() {
  std::set<std::string> names;
  const auto use = [&](const ValueSpec& spec) {
    if (is_device_value(spec.saved)) names.insert(spec.saved);
  };
  for (const auto& step : vector_.steps) {
    if (const auto* write = std::get_if<SdoWriteStep>(&step.action); write && write->value)
      use(*write->value);
    if (const auto* read = std::get_if<SdoReadStep>(&step.action);
        read && read->expect.kind == SdoExpect::Kind::value)
      use(read->expect.value);
    if (const auto* read = std::get_if<SdoReadStep>(&step.action);
        read && read->expect.kind == SdoExpect::Kind::range) {
      use(read->expect.low);
      use(read->expect.high);
    }
    if (const auto* poll = std::get_if<PollStep>(&step.action); poll && poll->range) {
      use(poll->range->first);
      use(poll->range->second);
    }
  }
  for (const auto& name : names) {
    if (const auto it = context_.device_values.find(name); it != context_.device_values.end()) {
      saved_[name] = it->second;
      continue;
    }
    std::int64_t value = 0;
    if (name == "dut.tpdo_object") {
      std::optional<std::uint32_t> mapping;
      std::string how;
      if (context_.options.eds != nullptr) {
        mapping = eds_tpdo_object(*context_.options.eds);
        how = "the EDS (PDOMapping=1)";
      }
      for (std::uint16_t index = 0x1A00; !mapping && index < 0x1A04; ++index) {
        const auto count = sdo_upload({index, 0});
        if (!count.ok || count.data.empty() || count.data[0] == 0) continue;
        const auto entry = sdo_upload({index, 1});
        if (entry.ok && entry.data.size() == 4 && le32(entry.data) != 0) {
          mapping = le32(entry.data);
          how = fmt::format("the DUT's default mapping {:04X}h sub 1", index);
        }
      }
      if (!mapping) {
        mapping = 0x10010008;
        how = "no EDS and no default TPDO mapping: 1001h error register";
      }
      value = *mapping;
      check("device value", "$dut.tpdo_object: an object the DUT maps into a TPDO",
            fmt::format("{:08X}h from {}", *mapping, how), true);
    } else if (name == "dut.unsupported_mode") {
      const auto read = sdo_upload({0x6502, 0});
      if (!read.ok || read.data.empty())
        return harness_error("device value", fmt::format("$dut.unsupported_mode: reading 6502h: {}",
                                                         read.describe()));
      const auto supported = le32(read.data);
      const auto mode = unsupported_mode(supported);
      if (mode == 0) {
        message_ = fmt::format(
            "$dut.unsupported_mode: 6502h = {:08X}h lists every mode of CiA 402-2, so there is "
            "no unsupported mode to try",
            supported);
        return StepStatus::not_applicable;
      }
      value = mode;
      check("device value", "$dut.unsupported_mode: a mode 6502h does not list",
            fmt::format("mode {} (6502h = {:08X}h)", mode, supported), true);
    } else if (name == "dut.node_id") {
      value = node();
      check("device value", "$dut.node_id: the DUT's node-ID",
            fmt::format("{} ({:02X}h, the node-ID the run addresses the DUT with)", value, value),
            true);
    }
    context_.device_values[name] = value;
    saved_[name] = value;
  }
  return StepStatus::ok;
}

}  // namespace drivecheck::conformance

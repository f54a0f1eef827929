#include "reference_drive/ethercat/process_data.hpp"

#include <fmt/format.h>

#include "protocol/cia301/pdo.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

constexpr std::uint16_t kRxPdoAssign = 0x1C12;
constexpr std::uint16_t kTxPdoAssign = 0x1C13;

std::uint64_t read_bits(std::span<const std::uint8_t> image, unsigned offset, unsigned bits) {
  std::uint64_t value = 0;
  for (unsigned i = 0; i < bits; ++i) {
    const unsigned bit = offset + i;
    if ((image[bit / 8u] >> (bit % 8u)) & 1u) value |= std::uint64_t{1} << i;
  }
  return value;
}

void write_bits(std::span<std::uint8_t> image, unsigned offset, unsigned bits,
                std::uint64_t value) {
  for (unsigned i = 0; i < bits; ++i) {
    const unsigned bit = offset + i;
    const auto mask = static_cast<std::uint8_t>(1u << (bit % 8u));
    if ((value >> i) & 1u) {
      image[bit / 8u] |= mask;
    } else {
      image[bit / 8u] &= static_cast<std::uint8_t>(~mask);
    }
  }
}

}  // namespace

Expected<ProcessDataLayout, std::string> read_process_data_layout(
    const cia301::ObjectDictionary& od, ProcessDataDirection direction) {
  const std::uint16_t assign =
      direction == ProcessDataDirection::outputs ? kRxPdoAssign : kTxPdoAssign;
  ProcessDataLayout layout;
  const cia301::Entry* count = od.find(assign, 0);
  if (count == nullptr) return Unexpected(fmt::format("{:04X}h:00 does not exist", assign));
  for (unsigned n = 1; n <= count->as_unsigned(); ++n) {
    const cia301::Entry* assigned = od.find(assign, static_cast<std::uint8_t>(n));
    if (assigned == nullptr) {
      return Unexpected(fmt::format("{:04X}h:{:02X} does not exist", assign, n));
    }
    const auto pdo = static_cast<std::uint16_t>(assigned->as_unsigned());
    const cia301::Entry* entries = od.find(pdo, 0);
    if (entries == nullptr) {
      return Unexpected(
          fmt::format("{:04X}h:{:02X} assigns {:04X}h, which does not exist", assign, n, pdo));
    }
    layout.pdos.push_back(pdo);
    for (unsigned e = 1; e <= entries->as_unsigned(); ++e) {
      const cia301::Entry* raw = od.find(pdo, static_cast<std::uint8_t>(e));
      if (raw == nullptr) {
        return Unexpected(fmt::format("{:04X}h:{:02X} does not exist", pdo, e));
      }
      const auto value = static_cast<std::uint32_t>(raw->as_unsigned());
      ProcessDataEntry entry;
      entry.index = static_cast<std::uint16_t>(value >> 16);
      entry.sub_index = static_cast<std::uint8_t>(value >> 8);
      entry.bits = static_cast<std::uint8_t>(value);
      entry.bit_offset = layout.bits;
      entry.dummy = cia301::dummy_bits(entry.index).has_value() && entry.sub_index == 0;
      if (entry.bits == 0 || entry.bits > 64) {
        return Unexpected(
            fmt::format("{:04X}h:{:02X} = {:08X}h maps {} bits", pdo, e, value, entry.bits));
      }
      if (!entry.dummy && od.find(entry.index, entry.sub_index) == nullptr) {
        return Unexpected(fmt::format("{:04X}h:{:02X} maps {:04X}h:{:02X}, which does not exist",
                                      pdo, e, entry.index, entry.sub_index));
      }
      layout.bits += entry.bits;
      layout.entries.push_back(entry);
    }
  }
  return layout;
}

std::size_t apply_outputs(cia301::ObjectDictionary& od, const ProcessDataLayout& layout,
                          std::span<const std::uint8_t> image) {
  if (image.size() < layout.bytes()) return layout.entries.size();
  std::size_t refused = 0;
  for (const ProcessDataEntry& entry : layout.entries) {
    if (entry.dummy) continue;
    const std::uint64_t value = read_bits(image, entry.bit_offset, entry.bits);
    std::vector<std::uint8_t> bytes((entry.bits + 7u) / 8u);
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      bytes[i] = static_cast<std::uint8_t>(value >> (8 * i));
    }
    if (!od.write(entry.index, entry.sub_index, bytes)) ++refused;
  }
  return refused;
}

std::vector<std::uint8_t> collect_inputs(const cia301::ObjectDictionary& od,
                                         const ProcessDataLayout& layout) {
  std::vector<std::uint8_t> image(layout.bytes());
  for (const ProcessDataEntry& entry : layout.entries) {
    std::uint64_t value = 0;
    if (const cia301::Entry* object = od.find(entry.index, entry.sub_index)) {
      const auto bytes = object->bytes();
      for (std::size_t i = 0; i < bytes.size() && i < 8; ++i) {
        value |= std::uint64_t{bytes[i]} << (8 * i);
      }
    }
    write_bits(image, entry.bit_offset, entry.bits, value);
  }
  return image;
}

}  // namespace drivecheck::reference_drive::ethercat

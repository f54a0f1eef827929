#include "protocol/cia301/sdo_server_parameter.hpp"

#include <fmt/format.h>

#include <utility>
#include <vector>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::cia301 {
namespace {

constexpr std::uint32_t kCanIdBits = 0x7FFu;
constexpr std::uint32_t kFrameBit = 0x20000000u;      // bit 29: 29-bit CAN-ID
constexpr std::uint32_t kReservedBits = 0x1FFFF800u;  // bits 28..11 (11-bit CAN-ID)

bool valid(std::uint32_t cob_id) {
  return (cob_id & kSdoCobIdNotValid) == 0;
}

// sub 01h/02h: an 11-bit CAN-ID only, and no new CAN-ID while the COB-ID is valid.
WriteValidator cob_id_validator() {
  return [](const ObjectDictionary&, const Entry& self,
            std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    const auto before = static_cast<std::uint32_t>(self.as_unsigned());
    const auto after = static_cast<std::uint32_t>(load_unsigned(data));
    if ((after & (kFrameBit | kReservedBits)) != 0) return Unexpected(SdoAbort::invalid_value);
    if (valid(before) && valid(after) && ((before ^ after) & kCanIdBits) != 0) {
      return Unexpected(SdoAbort::invalid_value);
    }
    return {};
  };
}

// sub 03h as the server's own node-ID (ESR): the COB-IDs follow it at once.
void apply_server_node_id(ObjectDictionary& od, Entry& self) {
  const auto node = static_cast<std::uint32_t>(self.as_unsigned());
  Entry* request = od.find(self.index(), sdo_server_sub::kRequestCobId);
  Entry* response = od.find(self.index(), sdo_server_sub::kResponseCobId);
  if (request == nullptr || response == nullptr) return;
  request->assign_unsigned(node == 0 ? kSdoCobIdNotValid : kSdoRequestBase + node);
  response->assign_unsigned(node == 0 ? kSdoCobIdNotValid : kSdoResponseBase + node);
}

}  // namespace

Expected<void, std::string> add_sdo_server_parameter(ObjectDictionary& od, std::uint16_t index,
                                                     SdoNodeIdSub node_id_sub) {
  if (index <= kSdoServerParameterFirst || index > kSdoServerParameterLast) {
    return Unexpected(fmt::format("SDO server parameter {:04X}h is outside 1201h..127Fh", index));
  }
  ObjectDefinition record;
  record.index = index;
  record.name = fmt::format("SDO server parameter {}", index - kSdoServerParameterFirst + 1);
  record.code = ObjectCode::record;
  const bool has_node_id = node_id_sub != SdoNodeIdSub::none;
  record.entries.push_back(EntryDefinition::highest_sub_index(has_node_id ? 3 : 2));
  record.entries.push_back(
      EntryDefinition::unsigned_entry(sdo_server_sub::kRequestCobId, "COB-ID client to server (rx)",
                                      DataType::unsigned32, AccessType::rw, kSdoCobIdNotValid));
  record.entries.push_back(EntryDefinition::unsigned_entry(
      sdo_server_sub::kResponseCobId, "COB-ID server to client (tx)", DataType::unsigned32,
      AccessType::rw, kSdoCobIdNotValid));
  if (has_node_id) {
    EntryDefinition node = EntryDefinition::unsigned_entry(sdo_server_sub::kNodeId,
                                                           node_id_sub == SdoNodeIdSub::server
                                                               ? "Node-ID of the SDO server"
                                                               : "Node-ID of the SDO client",
                                                           DataType::unsigned8, AccessType::rw, 0);
    node.low_limit = Value::of_unsigned(0);
    node.high_limit = Value::of_unsigned(kMaxNodeId);
    record.entries.push_back(std::move(node));
  }
  auto added = od.add_object(std::move(record));
  if (!added) return Unexpected(added.error());
  Object& object = **added;
  object.find(sdo_server_sub::kRequestCobId)->set_write_validator(cob_id_validator());
  object.find(sdo_server_sub::kResponseCobId)->set_write_validator(cob_id_validator());
  if (node_id_sub == SdoNodeIdSub::server) {
    object.find(sdo_server_sub::kNodeId)->set_write_observer(apply_server_node_id);
  }
  return {};
}

std::optional<SdoServerChannel> read_sdo_server_channel(const ObjectDictionary& od,
                                                        std::uint16_t index) {
  const Entry* request = od.find(index, sdo_server_sub::kRequestCobId);
  const Entry* response = od.find(index, sdo_server_sub::kResponseCobId);
  if (request == nullptr || response == nullptr) return std::nullopt;
  const auto rx = static_cast<std::uint32_t>(request->as_unsigned());
  const auto tx = static_cast<std::uint32_t>(response->as_unsigned());
  return SdoServerChannel{rx & kCanIdBits, tx & kCanIdBits, valid(rx) && valid(tx)};
}

}  // namespace drivecheck::cia301

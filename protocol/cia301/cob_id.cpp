#include "protocol/cia301/cob_id.hpp"

#include <array>

namespace drivecheck::cia301 {
namespace {

struct NodeBase {
  std::uint16_t base;
  CobFunction function;
};

// Node-specific objects, ordered by base (CiA 301 §7.3.5, Table "Pre-defined connection set").
constexpr std::array<NodeBase, 14> kNodeBases{{
    {0x080, CobFunction::emcy},
    {0x180, CobFunction::tpdo1},
    {0x200, CobFunction::rpdo1},
    {0x280, CobFunction::tpdo2},
    {0x300, CobFunction::rpdo2},
    {0x380, CobFunction::tpdo3},
    {0x400, CobFunction::rpdo3},
    {0x480, CobFunction::tpdo4},
    {0x500, CobFunction::rpdo4},
    {0x580, CobFunction::sdo_tx},
    {0x600, CobFunction::sdo_rx},
    {0x680, CobFunction::unassigned},
    {0x700, CobFunction::nmt_error_control},
    {0x780, CobFunction::unassigned},
}};

// CiA 301 §7.3.5, Table "Restricted CAN-IDs".
constexpr std::array<RestrictedCobIdRange, 8> kRestricted{{
    {0x000, 0x000, "NMT"},
    {0x001, 0x07F, "reserved"},
    {0x101, 0x180, "reserved"},
    {0x581, 0x5FF, "default SDO (tx)"},
    {0x601, 0x67F, "default SDO (rx)"},
    {0x6E0, 0x6FF, "reserved"},
    {0x701, 0x77F, "NMT error control"},
    {0x780, 0x7FF, "reserved (incl. LSS 7E4h/7E5h)"},
}};

}  // namespace

CobIdClass classify_cob_id(std::uint32_t can_id) {
  if (can_id > can::kMaxStandardId) return {};
  switch (can_id) {
    case 0x000:
      return {CobFunction::nmt, 0};
    case 0x080:
      return {CobFunction::sync, 0};
    case 0x100:
      return {CobFunction::time, 0};
    case 0x7E4:
      return {CobFunction::lss_slave_to_master, 0};
    case 0x7E5:
      return {CobFunction::lss_master_to_slave, 0};
    default:
      break;
  }
  const auto base = static_cast<std::uint16_t>(can_id & 0x780);
  const auto node = static_cast<std::uint8_t>(can_id & 0x7F);
  if (node == 0) return {};
  for (const NodeBase& entry : kNodeBases) {
    if (entry.base == base) {
      if (entry.function == CobFunction::unassigned) return {};
      return {entry.function, node};
    }
  }
  return {};  // 101h..17Fh
}

CobIdClass classify_cob_id(const can::Frame& frame) {
  if (frame.is_error() || frame.is_extended()) return {};
  return classify_cob_id(frame.id);
}

bool is_node_specific(CobFunction function) {
  for (const NodeBase& entry : kNodeBases) {
    if (entry.function == function && function != CobFunction::unassigned) return true;
  }
  return false;
}

std::optional<std::uint16_t> default_cob_id(CobFunction function, std::uint8_t node) {
  switch (function) {
    case CobFunction::nmt:
      return 0x000;
    case CobFunction::sync:
      return 0x080;
    case CobFunction::time:
      return 0x100;
    case CobFunction::lss_slave_to_master:
      return 0x7E4;
    case CobFunction::lss_master_to_slave:
      return 0x7E5;
    case CobFunction::unassigned:
      return std::nullopt;
    default:
      break;
  }
  if (!is_valid_node_id(node)) return std::nullopt;
  for (const NodeBase& entry : kNodeBases) {
    if (entry.function == function) return static_cast<std::uint16_t>(entry.base + node);
  }
  return std::nullopt;
}

std::string_view to_string(CobFunction function) {
  switch (function) {
    case CobFunction::nmt:
      return "NMT";
    case CobFunction::sync:
      return "SYNC";
    case CobFunction::emcy:
      return "EMCY";
    case CobFunction::time:
      return "TIME";
    case CobFunction::tpdo1:
      return "TPDO1";
    case CobFunction::rpdo1:
      return "RPDO1";
    case CobFunction::tpdo2:
      return "TPDO2";
    case CobFunction::rpdo2:
      return "RPDO2";
    case CobFunction::tpdo3:
      return "TPDO3";
    case CobFunction::rpdo3:
      return "RPDO3";
    case CobFunction::tpdo4:
      return "TPDO4";
    case CobFunction::rpdo4:
      return "RPDO4";
    case CobFunction::sdo_tx:
      return "SDO tx";
    case CobFunction::sdo_rx:
      return "SDO rx";
    case CobFunction::nmt_error_control:
      return "NMT EC";
    case CobFunction::lss_slave_to_master:
      return "LSS tx";
    case CobFunction::lss_master_to_slave:
      return "LSS rx";
    case CobFunction::unassigned:
      return "-";
  }
  return "-";
}

std::span<const RestrictedCobIdRange> restricted_cob_ids() {
  return kRestricted;
}

std::optional<RestrictedCobIdRange> find_restricted_cob_id(std::uint32_t can_id) {
  for (const RestrictedCobIdRange& range : kRestricted) {
    if (can_id >= range.first && can_id <= range.last) return range;
  }
  return std::nullopt;
}

bool is_restricted_cob_id(std::uint32_t can_id) {
  return find_restricted_cob_id(can_id).has_value();
}

}  // namespace drivecheck::cia301

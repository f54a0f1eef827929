#include "reference_drive/ethercat/esi_image.hpp"

#include <fmt/format.h>

#include <map>

#include "protocol/cia301/data_type.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"
#include "reference_drive/ethercat/sii_image.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

using cia301::AccessType;
using cia301::DataType;
using drivecheck::ethercat::SiiSyncManagerType;

std::string escape(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// The ESI (IEC 61131-3 style) name of a CoE data type.
std::string esi_type(DataType type, std::size_t bytes) {
  switch (type) {
    case DataType::boolean:
      return "BOOL";
    case DataType::integer8:
      return "SINT";
    case DataType::integer16:
      return "INT";
    case DataType::integer24:
      return "INT24";
    case DataType::integer32:
      return "DINT";
    case DataType::integer40:
      return "INT40";
    case DataType::integer48:
      return "INT48";
    case DataType::integer56:
      return "INT56";
    case DataType::integer64:
      return "LINT";
    case DataType::unsigned8:
      return "USINT";
    case DataType::unsigned16:
      return "UINT";
    case DataType::unsigned24:
      return "UINT24";
    case DataType::unsigned32:
      return "UDINT";
    case DataType::unsigned40:
      return "UINT40";
    case DataType::unsigned48:
      return "UINT48";
    case DataType::unsigned56:
      return "UINT56";
    case DataType::unsigned64:
      return "ULINT";
    case DataType::real32:
      return "REAL";
    case DataType::real64:
      return "LREAL";
    case DataType::visible_string:
      return fmt::format("STRING({})", bytes);
    case DataType::octet_string:
      return fmt::format("OCTET_STRING({})", bytes);
    case DataType::unicode_string:
      return fmt::format("UNICODE_STRING({})", bytes);
    case DataType::time_of_day:
      return "TIME_OF_DAY";
    case DataType::time_difference:
      return "TIME_DIFFERENCE";
    case DataType::domain:
      return "DOMAIN";
  }
  return "USINT";
}

std::string_view esi_access(AccessType access) {
  switch (access) {
    case AccessType::ro:
    case AccessType::constant:
      return "ro";
    case AccessType::wo:
      return "wo";
    case AccessType::rw:
    case AccessType::rwr:
    case AccessType::rww:
      return "rw";
  }
  return "ro";
}

// Flags/PdoMapping: the directions the drive lets a mapping take the entry in, as its PDO
// service checks a mapping entry (cia301::check_pdo_mapping_entry: an RxPDO maps a writable
// entry, a TxPDO a readable one); "" for an entry that no PDO maps.
std::string pdo_mapping(const cia301::Entry& entry) {
  if (!entry.pdo_mappable() || cia301::is_variable_length(entry.type())) return "";
  std::string out;
  if (cia301::is_writable(entry.access())) out += 'R';
  if (cia301::is_readable(entry.access())) out += 'T';
  return out;
}

std::string flags(const cia301::Entry& entry) {
  const std::string mapping = pdo_mapping(entry);
  return fmt::format(
      "<Flags><Access>{}</Access>{}</Flags>", esi_access(entry.access()),
      mapping.empty() ? std::string() : fmt::format("<PdoMapping>{}</PdoMapping>", mapping));
}

// The entry's size in bits: the type's, else (strings, domains) its present length.
std::size_t bit_size(const cia301::Entry& entry) {
  const auto& info = cia301::info(entry.type());
  if (entry.type() == DataType::boolean) return 1;
  if (info.size != 0) return 8 * info.size;
  return 8 * entry.bytes().size();
}

// Whether the ESI gives the entry's DefaultData (the header comment).
bool has_default(const cia301::Object& object, const cia301::Entry& entry) {
  const auto& info = cia301::info(entry.type());
  if (!cia301::is_integer(entry.type()) || info.size == 0 || info.size > 8) return false;
  const bool structured =
      object.code() == cia301::ObjectCode::array || object.code() == cia301::ObjectCode::record;
  if (structured && entry.sub_index() == 0) return true;
  return entry.access() == AccessType::constant || cia301::is_writable(entry.access());
}

std::string default_data(const cia301::Entry& entry) {
  std::string out;
  for (const std::uint8_t b : entry.bytes())
    out += fmt::format("{:02X}", b);
  return out;
}

std::string hex(std::uint32_t value, int digits) {
  return fmt::format("#x{:0{}X}", value, digits);
}

void write_pdos(std::string& out, const cia301::ObjectDictionary& od, bool rx,
                const std::vector<std::uint16_t>& assigned) {
  const std::uint16_t first = rx ? 0x1600 : 0x1A00;
  const std::uint16_t last = rx ? 0x17FF : 0x1BFF;
  const char* element = rx ? "RxPdo" : "TxPdo";
  for (const cia301::Object& object : od.objects()) {
    if (object.index() < first || object.index() > last) continue;
    const cia301::Entry* count = object.find(0);
    bool is_assigned = false;
    for (std::uint16_t a : assigned)
      is_assigned = is_assigned || a == object.index();
    out += fmt::format("        <{}{}>\n", element,
                       is_assigned ? fmt::format(" Sm=\"{}\"", rx ? 2 : 3) : std::string());
    out += fmt::format("          <Index>{}</Index>\n", hex(object.index(), 4));
    out += fmt::format("          <Name>{}</Name>\n", escape(object.name()));
    const auto n = count != nullptr ? count->as_unsigned() : 0;
    for (std::uint64_t s = 1; s <= n; ++s) {
      const cia301::Entry* raw = object.find(static_cast<std::uint8_t>(s));
      if (raw == nullptr) continue;
      const auto value = static_cast<std::uint32_t>(raw->as_unsigned());
      const auto index = static_cast<std::uint16_t>(value >> 16);
      const auto sub = static_cast<std::uint8_t>(value >> 8);
      const auto bits = static_cast<std::uint8_t>(value);
      out += "          <Entry>\n";
      out += fmt::format("            <Index>{}</Index>\n", hex(index, 4));
      out += fmt::format("            <SubIndex>{}</SubIndex>\n", sub);
      out += fmt::format("            <BitLen>{}</BitLen>\n", bits);
      if (const cia301::Entry* mapped = od.find(index, sub)) {
        out += fmt::format("            <Name>{}</Name>\n", escape(mapped->name()));
        out += fmt::format("            <DataType>{}</DataType>\n",
                           esi_type(mapped->type(), mapped->bytes().size()));
      }
      out += "          </Entry>\n";
    }
    out += fmt::format("        </{}>\n", element);
  }
}

std::vector<std::uint16_t> assignment(const cia301::ObjectDictionary& od, std::uint16_t index) {
  std::vector<std::uint16_t> out;
  const cia301::Entry* count = od.find(index, 0);
  for (std::uint64_t s = 1; count != nullptr && s <= count->as_unsigned(); ++s) {
    if (const cia301::Entry* e = od.find(index, static_cast<std::uint8_t>(s)))
      out.push_back(static_cast<std::uint16_t>(e->as_unsigned()));
  }
  return out;
}

std::string_view sm_text(SiiSyncManagerType type) {
  switch (type) {
    case SiiSyncManagerType::mailbox_out:
      return "MBoxOut";
    case SiiSyncManagerType::mailbox_in:
      return "MBoxIn";
    case SiiSyncManagerType::outputs:
      return "Outputs";
    case SiiSyncManagerType::inputs:
      return "Inputs";
    case SiiSyncManagerType::unused:
      break;
  }
  return "";
}

std::string_view flag(bool on) {
  return on ? "true" : "false";
}

}  // namespace

Expected<std::string, std::string> drive_esi_text(const cia301::ObjectDictionary& od,
                                                  const drivecheck::ethercat::SiiImage& sii) {
  const auto string_at = [&sii](std::uint8_t i) {
    return i >= 1 && i <= sii.strings.size() ? sii.strings[i - 1u] : std::string();
  };
  const drivecheck::ethercat::SiiGeneral general =
      sii.general.value_or(drivecheck::ethercat::SiiGeneral{});
  std::string out;
  out += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  out += "<!-- The ESI (ETG.2000) of the drivecheck reference drive as an EtherCAT slave.\n";
  out += "     Generated by reference_drive_esi from the standard EthercatDrive's object\n";
  out += "     dictionary and SII (reference_drive/ethercat/esi_image.hpp): do not edit. -->\n";
  out += "<EtherCATInfo Version=\"1.6\">\n";
  out += "  <Vendor>\n";
  out += fmt::format("    <Id>{}</Id>\n", hex(sii.header.vendor_id, 8));
  out += "    <Name>drivecheck</Name>\n";
  out += "  </Vendor>\n";
  out += "  <Descriptions>\n";
  out += "    <Groups>\n";
  out += "      <Group>\n";
  out += fmt::format("        <Type>{}</Type>\n", escape(string_at(general.group_index)));
  out += fmt::format("        <Name>{}</Name>\n", escape(string_at(general.group_index)));
  out += "      </Group>\n";
  out += "    </Groups>\n";
  out += "    <Devices>\n";
  out += "      <Device Physics=\"YY\">\n";
  out += fmt::format("        <Type ProductCode=\"{}\" RevisionNo=\"{}\">{}</Type>\n",
                     hex(sii.header.product_code, 8), hex(sii.header.revision, 8),
                     escape(string_at(general.order_index)));
  out +=
      fmt::format("        <Name LcId=\"1033\">{}</Name>\n", escape(string_at(general.name_index)));
  out += fmt::format("        <GroupType>{}</GroupType>\n", escape(string_at(general.group_index)));
  out += "        <Profile>\n";
  out +=
      fmt::format("          <ProfileNo>{}</ProfileNo>\n",
                  od.find(0x1000, 0) != nullptr ? od.find(0x1000, 0)->as_unsigned() & 0xFFFF : 0);
  out += "          <Dictionary>\n";
  // The structured objects' DataTypes first, then the objects.
  out += "            <DataTypes>\n";
  for (const cia301::Object& object : od.objects()) {
    const bool structured =
        object.code() == cia301::ObjectCode::array || object.code() == cia301::ObjectCode::record;
    if (!structured) continue;
    std::size_t offset = 0;
    std::string items;
    for (const cia301::Entry& entry : object.entries()) {
      const std::size_t bits = bit_size(entry);
      items += "                <SubItem>\n";
      items += fmt::format("                  <SubIdx>{}</SubIdx>\n", entry.sub_index());
      items += fmt::format("                  <Name>{}</Name>\n", escape(entry.name()));
      items += fmt::format("                  <Type>{}</Type>\n",
                           esi_type(entry.type(), entry.bytes().size()));
      items += fmt::format("                  <BitSize>{}</BitSize>\n", bits);
      items += fmt::format("                  <BitOffs>{}</BitOffs>\n", offset);
      items += fmt::format("                  {}\n", flags(entry));
      items += "                </SubItem>\n";
      // Sub 0 takes 16 bits of the structure (ETG.2000 convention: an UNSIGNED8 and a pad).
      offset += entry.sub_index() == 0 ? 16 : bits;
    }
    out += "              <DataType>\n";
    out += fmt::format("                <Name>DT{:04X}</Name>\n", object.index());
    out += fmt::format("                <BitSize>{}</BitSize>\n", offset);
    out += items;
    out += "              </DataType>\n";
  }
  out += "            </DataTypes>\n";
  out += "            <Objects>\n";
  for (const cia301::Object& object : od.objects()) {
    const bool structured =
        object.code() == cia301::ObjectCode::array || object.code() == cia301::ObjectCode::record;
    out += "              <Object>\n";
    out += fmt::format("                <Index>{}</Index>\n", hex(object.index(), 4));
    out += fmt::format("                <Name>{}</Name>\n", escape(object.name()));
    if (structured) {
      std::size_t offset = 0;
      for (const cia301::Entry& entry : object.entries())
        offset += entry.sub_index() == 0 ? 16 : bit_size(entry);
      out += fmt::format("                <Type>DT{:04X}</Type>\n", object.index());
      out += fmt::format("                <BitSize>{}</BitSize>\n", offset);
      out += "                <Info>\n";
      for (const cia301::Entry& entry : object.entries()) {
        out += "                  <SubItem>\n";
        out += fmt::format("                    <Name>{}</Name>\n", escape(entry.name()));
        if (has_default(object, entry)) {
          out += fmt::format("                    <Info><DefaultData>{}</DefaultData></Info>\n",
                             default_data(entry));
        }
        out += "                  </SubItem>\n";
      }
      out += "                </Info>\n";
    } else {
      const cia301::Entry* entry = object.find(0);
      if (entry == nullptr) return Unexpected(fmt::format("{:04X}h has no sub 0", object.index()));
      out += fmt::format("                <Type>{}</Type>\n",
                         esi_type(entry->type(), entry->bytes().size()));
      out += fmt::format("                <BitSize>{}</BitSize>\n", bit_size(*entry));
      if (has_default(object, *entry)) {
        out += fmt::format("                <Info><DefaultData>{}</DefaultData></Info>\n",
                           default_data(*entry));
      }
      out += fmt::format("                {}\n", flags(*entry));
    }
    out += "              </Object>\n";
  }
  out += "            </Objects>\n";
  out += "          </Dictionary>\n";
  out += "        </Profile>\n";
  out += "        <Fmmu>Outputs</Fmmu>\n";
  out += "        <Fmmu>Inputs</Fmmu>\n";
  out += "        <Fmmu>MBoxState</Fmmu>\n";
  for (const auto& sm : sii.sync_managers) {
    out += fmt::format(
        "        <Sm DefaultSize=\"{}\" StartAddress=\"{}\" ControlByte=\"{}\" "
        "Enable=\"{}\">{}</Sm>\n",
        sm.length, hex(sm.start, 4), hex(sm.control, 2), sm.enable, sm_text(sm.type));
  }
  write_pdos(out, od, true, assignment(od, 0x1C12));
  write_pdos(out, od, false, assignment(od, 0x1C13));
  out += "        <Mailbox DataLinkLayer=\"true\">\n";
  out += fmt::format(
      "          <CoE SdoInfo=\"{}\" PdoAssign=\"{}\" PdoConfig=\"{}\" CompleteAccess=\"{}\"/>\n",
      flag((general.coe_details & 0x02) != 0), flag((general.coe_details & 0x04) != 0),
      flag((general.coe_details & 0x08) != 0), flag((general.coe_details & 0x20) != 0));
  out += "        </Mailbox>\n";
  out += "      </Device>\n";
  out += "    </Devices>\n";
  out += "  </Descriptions>\n";
  out += "</EtherCATInfo>\n";
  return out;
}

Expected<std::string, std::string> standard_drive_esi_text() {
  drivecheck::ethercat::SimSegment segment;
  auto drive = EthercatDrive::create(segment);
  if (!drive) return Unexpected(drive.error());
  auto image = drivecheck::ethercat::parse_sii((*drive)->sii());
  if (!image) return Unexpected(fmt::format("SII: {}", image.error().message()));
  return drive_esi_text((*drive)->dictionary(), *image);
}

}  // namespace drivecheck::reference_drive::ethercat

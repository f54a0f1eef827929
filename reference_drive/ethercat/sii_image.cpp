#include "reference_drive/ethercat/sii_image.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "protocol/cia301/pdo.hpp"
#include "reference_drive/ethercat/process_data.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

using drivecheck::ethercat::SiiGeneral;
using drivecheck::ethercat::SiiImage;
using drivecheck::ethercat::SiiPdo;
using drivecheck::ethercat::SiiPdoEntry;
using drivecheck::ethercat::SiiSyncManager;
using drivecheck::ethercat::SiiSyncManagerType;

constexpr std::uint16_t kIdentity = 0x1018;
constexpr std::uint16_t kDeviceName = 0x1008;
constexpr std::uint8_t kFmmuOutputs = 1;
constexpr std::uint8_t kFmmuInputs = 2;
constexpr std::uint8_t kFmmuSyncMStatus = 3;
// General category, CoE details bits (sii.hpp).
constexpr std::uint8_t kCoeSdo = 0x01;
constexpr std::uint8_t kCoeSdoInfo = 0x02;
constexpr std::uint8_t kCoePdoAssign = 0x04;
constexpr std::uint8_t kCoePdoConfig = 0x08;
constexpr std::uint8_t kCoeCompleteAccess = 0x20;

Expected<std::uint32_t, std::string> identity(const cia301::ObjectDictionary& od,
                                              std::uint8_t sub) {
  const cia301::Entry* entry = od.find(kIdentity, sub);
  if (entry == nullptr) return Unexpected(fmt::format("1018h:{:02X} does not exist", sub));
  return static_cast<std::uint32_t>(entry->as_unsigned());
}

// The SII PDO descriptions of the PDOs the assignment names now (the defaults at power on).
Expected<std::vector<SiiPdo>, std::string> pdos(const cia301::ObjectDictionary& od,
                                                ProcessDataDirection direction) {
  auto layout = read_process_data_layout(od, direction);
  if (!layout) return Unexpected(layout.error());
  std::vector<SiiPdo> out;
  std::size_t next = 0;
  for (std::uint16_t index : layout->pdos) {
    SiiPdo pdo;
    pdo.index = index;
    pdo.sync_manager = direction == ProcessDataDirection::outputs ? 2 : 3;
    const cia301::Entry* count = od.find(index, 0);
    const auto n = static_cast<std::size_t>(count != nullptr ? count->as_unsigned() : 0);
    for (std::size_t i = 0; i < n && next < layout->entries.size(); ++i, ++next) {
      const ProcessDataEntry& e = layout->entries[next];
      SiiPdoEntry entry;
      entry.index = e.index;
      entry.subindex = e.sub_index;
      entry.bit_length = e.bits;
      if (e.dummy) {
        entry.data_type = static_cast<std::uint8_t>(e.index);
      } else if (const cia301::Entry* object = od.find(e.index, e.sub_index)) {
        entry.data_type = static_cast<std::uint8_t>(object->type());
      }
      pdo.entries.push_back(entry);
    }
    out.push_back(std::move(pdo));
  }
  return out;
}

std::string device_name(const cia301::ObjectDictionary& od) {
  if (const cia301::Entry* entry = od.find(kDeviceName, 0)) {
    const auto bytes = entry->bytes();
    std::string name(bytes.begin(), bytes.end());
    if (name.size() > 255) name.resize(255);
    if (!name.empty()) return name;
  }
  return "drivecheck reference drive";
}

}  // namespace

Expected<SiiImage, std::string> drive_sii_image(const cia301::ObjectDictionary& od,
                                                const DriveSiiOptions& options) {
  SiiImage image;
  // 1018h sub 1 (vendor-ID) is mandatory; subs 2-4 are optional (CiA 301 §7.5.2.21): a drive
  // without them (cia301-minimal) has no product code, revision or serial number to give, and
  // its SII words 0Ah-0Fh are 0.
  auto vendor = identity(od, 1);
  if (!vendor) return Unexpected(vendor.error());
  const auto optional_identity = [&od](std::uint8_t sub) -> std::uint32_t {
    const cia301::Entry* entry = od.find(kIdentity, sub);
    return entry != nullptr ? static_cast<std::uint32_t>(entry->as_unsigned()) : 0;
  };
  image.header.vendor_id = *vendor;
  image.header.product_code = optional_identity(2);
  image.header.revision = optional_identity(3);
  image.header.serial = optional_identity(4);
  image.header.standard_receive = {kMailboxOutStart, kMailboxSize};
  image.header.standard_send = {kMailboxInStart, kMailboxSize};
  image.header.mailbox_protocols = drivecheck::ethercat::kSiiMailboxCoe;
  image.header.version = 1;

  image.strings = {device_name(od), "Drives", "drivecheck-reference-drive"};
  SiiGeneral general;
  general.name_index = 1;
  general.group_index = 2;
  general.order_index = 3;
  general.coe_details = kCoeSdo;
  if (options.sdo_information) general.coe_details |= kCoeSdoInfo;
  if (options.pdo_assignment) general.coe_details |= kCoePdoAssign;
  if (options.pdo_configuration) general.coe_details |= kCoePdoConfig;
  if (options.complete_access) general.coe_details |= kCoeCompleteAccess;
  general.ds402_channels = 1;
  image.general = general;
  image.fmmus = {kFmmuOutputs, kFmmuInputs, kFmmuSyncMStatus};

  auto rx = pdos(od, ProcessDataDirection::outputs);
  if (!rx) return Unexpected(rx.error());
  auto tx = pdos(od, ProcessDataDirection::inputs);
  if (!tx) return Unexpected(tx.error());
  auto rx_layout = read_process_data_layout(od, ProcessDataDirection::outputs);
  auto tx_layout = read_process_data_layout(od, ProcessDataDirection::inputs);
  const auto rx_bytes = static_cast<std::uint16_t>(rx_layout->bytes());
  const auto tx_bytes = static_cast<std::uint16_t>(tx_layout->bytes());
  if (rx_bytes > kProcessDataMax || tx_bytes > kProcessDataMax) {
    return Unexpected(fmt::format("default process data too long: {} / {} octets (at most {})",
                                  rx_bytes, tx_bytes, kProcessDataMax));
  }
  image.sync_managers = {
      {kMailboxOutStart, kMailboxSize, kSm0Control, 0, 1, SiiSyncManagerType::mailbox_out},
      {kMailboxInStart, kMailboxSize, kSm1Control, 0, 1, SiiSyncManagerType::mailbox_in},
      {kOutputsStart, rx_bytes, kSm2Control, 0, 1, SiiSyncManagerType::outputs},
      {kInputsStart, tx_bytes, kSm3Control, 0, 1, SiiSyncManagerType::inputs},
  };
  image.rx_pdos = std::move(*rx);
  image.tx_pdos = std::move(*tx);

  // EEPROM size word 3Eh: size in kbit - 1 (at least 2 kbit: 256 octets).
  auto bytes = drivecheck::ethercat::build_sii(image);
  if (!bytes) return Unexpected(fmt::format("SII image: {}", bytes.error().message()));
  const std::size_t kbits = std::max<std::size_t>(2, (bytes->size() * 8 + 1023) / 1024);
  image.header.size = static_cast<std::uint16_t>(kbits - 1);
  return image;
}

Expected<std::vector<std::uint8_t>, std::string> drive_sii_bytes(const cia301::ObjectDictionary& od,
                                                                 const DriveSiiOptions& options) {
  auto image = drive_sii_image(od, options);
  if (!image) return Unexpected(image.error());
  auto bytes = drivecheck::ethercat::build_sii(*image);
  if (!bytes) return Unexpected(fmt::format("SII image: {}", bytes.error().message()));
  return std::move(*bytes);
}

}  // namespace drivecheck::reference_drive::ethercat

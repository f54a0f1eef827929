// Internal to protocol/cia306: the key tables of [FileInfo], [DeviceInfo] and
// [DeviceComissioning], shared by the reader and the writer so that both use one spelling
// and one order (the order of CiA 306 §4.2-§4.4, which is the order the writer uses).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "protocol/cia306/eds.hpp"

namespace drivecheck::cia306::detail {

enum class NumberStyle : std::uint8_t { decimal, hex };

template <class S>
struct Field {
  std::string_view key;  // CiA 306 spelling
  std::variant<std::optional<std::string> S::*, std::optional<std::uint32_t> S::*,
               std::optional<bool> S::*>
      member;
  NumberStyle style = NumberStyle::decimal;
};

inline constexpr Field<FileInfo> kFileInfoFields[] = {
    {"FileName", &FileInfo::file_name},
    {"FileVersion", &FileInfo::file_version},
    {"FileRevision", &FileInfo::file_revision},
    {"LastEDS", &FileInfo::last_eds},
    {"EDSVersion", &FileInfo::eds_version},
    {"Description", &FileInfo::description},
    {"CreationTime", &FileInfo::creation_time},
    {"CreationDate", &FileInfo::creation_date},
    {"CreatedBy", &FileInfo::created_by},
    {"ModificationTime", &FileInfo::modification_time},
    {"ModificationDate", &FileInfo::modification_date},
    {"ModifiedBy", &FileInfo::modified_by},
};

inline constexpr Field<DeviceInfo> kDeviceInfoFields[] = {
    {"VendorName", &DeviceInfo::vendor_name},
    {"VendorNumber", &DeviceInfo::vendor_number, NumberStyle::hex},
    {"ProductName", &DeviceInfo::product_name},
    {"ProductNumber", &DeviceInfo::product_number, NumberStyle::hex},
    {"RevisionNumber", &DeviceInfo::revision_number, NumberStyle::hex},
    {"OrderCode", &DeviceInfo::order_code},
    {"BaudRate_10", &DeviceInfo::baud_rate_10},
    {"BaudRate_20", &DeviceInfo::baud_rate_20},
    {"BaudRate_50", &DeviceInfo::baud_rate_50},
    {"BaudRate_125", &DeviceInfo::baud_rate_125},
    {"BaudRate_250", &DeviceInfo::baud_rate_250},
    {"BaudRate_500", &DeviceInfo::baud_rate_500},
    {"BaudRate_800", &DeviceInfo::baud_rate_800},
    {"BaudRate_1000", &DeviceInfo::baud_rate_1000},
    {"SimpleBootUpMaster", &DeviceInfo::simple_boot_up_master},
    {"SimpleBootUpSlave", &DeviceInfo::simple_boot_up_slave},
    {"Granularity", &DeviceInfo::granularity},
    {"DynamicChannelsSupported", &DeviceInfo::dynamic_channels_supported},
    {"GroupMessaging", &DeviceInfo::group_messaging},
    {"NrOfRXPDO", &DeviceInfo::nr_of_rxpdo},
    {"NrOfTXPDO", &DeviceInfo::nr_of_txpdo},
    {"LSS_Supported", &DeviceInfo::lss_supported},
    {"CompactPDO", &DeviceInfo::compact_pdo, NumberStyle::hex},
};

inline constexpr Field<DeviceCommissioning> kCommissioningFields[] = {
    {"NodeID", &DeviceCommissioning::node_id},
    {"NodeName", &DeviceCommissioning::node_name},
    {"Baudrate", &DeviceCommissioning::baudrate},
    {"NetNumber", &DeviceCommissioning::net_number},
    {"NetworkName", &DeviceCommissioning::network_name},
    {"CANopenManager", &DeviceCommissioning::canopen_manager},
    {"LSS_SerialNumber", &DeviceCommissioning::lss_serial_number, NumberStyle::hex},
};

// Lower-case ASCII copy.
std::string to_lower(std::string_view text);
bool iequals(std::string_view a, std::string_view b);

}  // namespace drivecheck::cia306::detail

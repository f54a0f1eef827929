#include "reference_drive/dictionary.hpp"

#include <fmt/format.h>

#include <utility>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/device_services.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/cia301/store_restore.hpp"

namespace drivecheck::reference_drive {
namespace {

using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;
using cia301::ObjectDefinition;
using cia301::Value;

EntryDefinition u32(std::uint8_t sub, std::string name, std::uint32_t value,
                    AccessType access = AccessType::ro) {
  return EntryDefinition::unsigned_entry(sub, std::move(name), DataType::unsigned32, access, value);
}

EntryDefinition u8(std::uint8_t sub, std::string name, std::uint8_t value) {
  return EntryDefinition::unsigned_entry(sub, std::move(name), DataType::unsigned8, AccessType::ro,
                                         value);
}

Expected<void, std::string> add(cia301::ObjectDictionary& od, ObjectDefinition definition) {
  auto added = od.add_object(std::move(definition));
  if (!added) return Unexpected(added.error());
  return {};
}

Expected<void, std::string> add_string(cia301::ObjectDictionary& od, std::uint16_t index,
                                       std::string name, const std::string& text) {
  EntryDefinition e;
  e.sub_index = 0;
  e.name = name;
  e.type = DataType::visible_string;
  e.access = AccessType::constant;
  e.default_value = Value::of_string(text);
  return add(od, {index, std::move(name), ObjectCode::var, {std::move(e)}});
}

}  // namespace

Expected<cia301::ObjectDictionary, std::string> build_dictionary(const DictionaryOptions& options) {
  if (!cia301::is_valid_node_id(options.node_id)) {
    return Unexpected(fmt::format("node-ID {} is outside 1..127", options.node_id));
  }
  cia301::ObjectDictionary od(options.node_id);
  const Identity& id = options.identity;

  if (auto ok = add(od, {kDeviceTypeIndex,
                         "Device type",
                         ObjectCode::var,
                         {u32(0, "Device type", id.device_type)}});
      !ok) {
    return Unexpected(ok.error());
  }
  for (const auto& [index, name, text] :
       {std::tuple{kDeviceNameIndex, "Manufacturer device name", &id.device_name},
        std::tuple{kHardwareVersionIndex, "Manufacturer hardware version", &id.hardware_version},
        std::tuple{kSoftwareVersionIndex, "Manufacturer software version", &id.software_version}}) {
    if (auto ok = add_string(od, index, name, *text); !ok) return Unexpected(ok.error());
  }

  cia301::DeviceObjectsOptions services;
  services.producer_heartbeat_ms = options.producer_heartbeat_ms;
  services.heartbeat_consumer_entries = options.heartbeat_consumer_entries;
  services.error_history_size = options.error_history_size;
  services.node_guarding = true;
  services.sync_producer_supported = true;
  if (auto ok = cia301::DeviceServices::add_objects(od, services); !ok) {
    return Unexpected(ok.error());
  }
  if (auto ok = cia301::add_store_restore_objects(od); !ok) return Unexpected(ok.error());

  if (auto ok =
          add(od, {kIdentityIndex,
                   "Identity object",
                   ObjectCode::record,
                   {u8(0, "Highest sub-index supported", 4), u32(1, "Vendor-ID", id.vendor_id),
                    u32(2, "Product code", id.product_code), u32(3, "Revision number", id.revision),
                    u32(4, "Serial number", id.serial)}});
      !ok) {
    return Unexpected(ok.error());
  }

  if (options.verify_configuration) {
    if (auto ok = add(od, {kVerifyConfigurationIndex,
                           "Verify configuration",
                           ObjectCode::array,
                           {u8(0, "Highest sub-index supported", 2),
                            u32(1, "Configuration date", 0, AccessType::rw),
                            u32(2, "Configuration time", 0, AccessType::rw)}});
        !ok) {
      return Unexpected(ok.error());
    }
  }

  EntryDefinition request = u32(1, "COB-ID client to server (rx)", cia301::kSdoRequestBase);
  request.default_adds_node_id = true;
  EntryDefinition response = u32(2, "COB-ID server to client (tx)", cia301::kSdoResponseBase);
  response.default_adds_node_id = true;
  if (auto ok = add(
          od, {kSdoServerParameterIndex,
               "SDO server parameter",
               ObjectCode::record,
               {u8(0, "Highest sub-index supported", 2), std::move(request), std::move(response)}});
      !ok) {
    return Unexpected(ok.error());
  }

  if (options.extra_sdo_servers > 127) {
    return Unexpected(fmt::format("{} further SDO servers: at most 127 (1201h..127Fh)",
                                  options.extra_sdo_servers));
  }
  for (unsigned i = 1; i <= options.extra_sdo_servers; ++i) {
    if (auto ok = cia301::add_sdo_server_parameter(
            od, static_cast<std::uint16_t>(kSdoServerParameterIndex + i), options.sdo_node_id_sub);
        !ok) {
      return Unexpected(ok.error());
    }
  }

  if (options.time_consumer) {
    if (auto ok = add(od, {kTimeCobIdIndex,
                           "COB-ID time stamp object",
                           ObjectCode::var,
                           {u32(0, "COB-ID time stamp object", 0x80000100, AccessType::rw)}});
        !ok) {
      return Unexpected(ok.error());
    }
  }
  if (options.sdo_client) {
    if (auto ok =
            add(od, {kSdoClientParameterIndex,
                     "SDO client parameter",
                     ObjectCode::record,
                     {u8(0, "Highest sub-index supported", 3),
                      u32(1, "COB-ID client to server (tx)", 0x80000000, AccessType::rw),
                      u32(2, "COB-ID server to client (rx)", 0x80000000, AccessType::rw),
                      EntryDefinition::unsigned_entry(3, "Node-ID of the SDO server",
                                                      DataType::unsigned8, AccessType::rw, 0)}});
        !ok) {
      return Unexpected(ok.error());
    }
  }

  if (auto ok = cia301::add_pdo_objects(od, options.pdo); !ok) return Unexpected(ok.error());

  // Manufacturer-specific objects of the CiA 301 part (the file comment of dictionary.hpp).
  if (options.sdo_client) {
    EntryDefinition data;
    data.sub_index = 2;
    data.name = "Data";
    data.type = DataType::octet_string;
    data.access = AccessType::rw;
    data.max_size = 64;
    data.default_value = Value::of_bytes({});
    EntryDefinition command =
        EntryDefinition::unsigned_entry(3, "Command", DataType::unsigned8, AccessType::rw, 0);
    command.high_limit = Value::of_unsigned(3);
    EntryDefinition timeout = EntryDefinition::unsigned_entry(
        6, "Timeout (ms)", DataType::unsigned16, AccessType::rw, 1000);
    timeout.low_limit = Value::of_unsigned(1);
    if (auto ok =
            add(od, {kSdoClientRequestIndex,
                     "SDO client request",
                     ObjectCode::record,
                     {u8(0, "Highest sub-index supported", 6),
                      u32(1, "Multiplexer", 0, AccessType::rw), std::move(data), std::move(command),
                      u8(4, "Status", 0), u32(5, "Abort code", 0), std::move(timeout)}});
        !ok) {
      return Unexpected(ok.error());
    }
  }
  if (options.time_consumer) {
    if (auto ok = add(
            od, {kTimeReceivedIndex,
                 "TIME received",
                 ObjectCode::record,
                 {u8(0, "Highest sub-index supported", 3), u32(1, "Milliseconds after midnight", 0),
                  EntryDefinition::unsigned_entry(2, "Days since 1 January 1984",
                                                  DataType::unsigned16, AccessType::ro, 0),
                  u32(3, "TIME frames consumed", 0)}});
        !ok) {
      return Unexpected(ok.error());
    }
  }
  for (const std::uint16_t index : {kSdoClientRequestIndex, kTimeReceivedIndex}) {
    if (cia301::Object* object = od.find(index)) {
      for (cia301::Entry& entry : object->entries())
        entry.set_store_group(cia301::kStoreNone);
    }
  }
  return od;
}

cia306::Eds reference_eds(const cia301::ObjectDictionary& od, const Identity& identity) {
  cia306::FileInfo file;
  file.file_name = "reference_drive.eds";
  file.file_version = "1";
  file.file_revision = "0";
  file.eds_version = "4.0";
  file.description = "drivecheck reference drive (CiA 301 part; CiA 402 objects follow)";
  // Fixed, so that the generated text is reproducible: the date of the dictionary's design.
  file.creation_time = "12:00PM";
  file.creation_date = "01-01-2025";
  file.created_by = "reference_drive_eds (generated from reference_drive/dictionary.cpp)";

  cia306::DeviceInfo device;
  device.vendor_name = identity.vendor_name;
  device.vendor_number = identity.vendor_id;
  device.product_name = "drivecheck reference drive";
  device.product_number = identity.product_code;
  device.revision_number = identity.revision;
  device.order_code = "drivecheck-reference-drive";
  for (auto* rate : {&device.baud_rate_10, &device.baud_rate_20, &device.baud_rate_50,
                     &device.baud_rate_125, &device.baud_rate_250, &device.baud_rate_500,
                     &device.baud_rate_800, &device.baud_rate_1000}) {
    *rate = true;
  }
  device.simple_boot_up_master = false;
  device.simple_boot_up_slave = true;
  device.granularity = 8;
  device.dynamic_channels_supported = 0;
  device.group_messaging = false;
  device.lss_supported = false;
  device.compact_pdo = 0;

  cia306::Eds eds = cia306::from_object_dictionary(od, std::move(file), std::move(device));
  eds.dummy_usage[1] = false;  // 0001h BOOLEAN: no dummy
  for (std::size_t i = 2; i <= 7; ++i)
    eds.dummy_usage[i] = true;
  eds.comments = {
      "Generated by reference_drive_eds from the object dictionary defined in",
      "reference_drive/dictionary.cpp. Do not edit: regenerate (reference_drive_tests check it)."};
  return eds;
}

Expected<std::string, std::string> reference_eds_text() {
  const DictionaryOptions options;
  auto od = build_dictionary(options);
  if (!od) return Unexpected(od.error());
  return cia306::write_eds(reference_eds(*od, options.identity));
}

}  // namespace drivecheck::reference_drive

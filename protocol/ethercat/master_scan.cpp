#include "protocol/ethercat/master_scan.hpp"

#include <fmt/format.h>

#include "protocol/ethercat/esc.hpp"

namespace drivecheck::ethercat {

Expected<std::size_t, MasterError> count_slaves(MasterPort& port) {
  auto back = port.exchange(Datagram::physical(Command::brd, 0, 0, reg::kType, {0}));
  if (!back) return Unexpected(back.error());
  return static_cast<std::size_t>(back->working_counter);
}

Expected<std::vector<SlaveInfo>, MasterError> scan_segment(MasterPort& port,
                                                           const ScanOptions& options) {
  auto count = count_slaves(port);
  if (!count) return Unexpected(count.error());
  if (*count == 0) {
    return master_error(MasterErrc::slave_count, "no slave answered BRD 0000h (working counter 0)");
  }
  if (options.expected_slaves && *count != *options.expected_slaves) {
    return master_error(
        MasterErrc::slave_count,
        fmt::format("BRD 0000h counted {} slave(s), the configuration expects {} ({})", *count,
                    *options.expected_slaves,
                    *count < *options.expected_slaves ? "slave missing" : "extra slave"));
  }
  std::vector<SlaveInfo> slaves;
  for (std::size_t k = 0; k < *count; ++k) {
    const auto station = static_cast<std::uint16_t>(options.first_station + k);
    const auto adp = static_cast<std::uint16_t>(0 - k);
    if (auto written = port.write(Command::apwr, adp, reg::kStationAddress, le16(station));
        !written) {
      return Unexpected(written.error());
    }
  }
  for (std::size_t k = 0; k < *count; ++k) {
    const auto station = static_cast<std::uint16_t>(options.first_station + k);
    auto info = port.read(Command::fprd, station, reg::kType, 0x14);
    if (!info) {
      MasterError error = info.error();
      if (error.code == MasterErrc::working_counter) {
        error.code = MasterErrc::station_address;
        error.detail = fmt::format(
            "station address {:04X}h written at position {} does not "
            "answer: {}",
            station, k, error.detail);
      }
      return Unexpected(std::move(error));
    }
    const auto& b = *info;
    SlaveInfo slave;
    slave.position = k;
    slave.station = get_le16(b, reg::kStationAddress);
    slave.alias = get_le16(b, reg::kStationAlias);
    slave.esc_type = b[0];
    slave.esc_revision = b[1];
    slave.esc_build = get_le16(b, 2);
    slave.fmmus = b[4];
    slave.sync_managers = b[5];
    slave.ram_kbytes = b[6];
    if (slave.station != station) {
      return master_error(MasterErrc::station_address,
                          fmt::format("position {}: station address reads {:04X}h after "
                                      "writing {:04X}h",
                                      k, slave.station, station),
                          station);
    }
    slaves.push_back(slave);
  }
  return slaves;
}

}  // namespace drivecheck::ethercat

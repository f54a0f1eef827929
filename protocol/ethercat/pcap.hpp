// pcap capture files of EtherCAT frames for Wireshark/tshark: LINKTYPE_ETHERNET (1), Ethernet
// frames without FCS, nanosecond timestamps (the same file layout as protocol/can/pcap.hpp
// but another link type and variable record lengths).
//
// File header (24 bytes, little-endian): magic A1B23C4Dh (ns), version 2.4, thiszone 0,
// sigfigs 0, snaplen 65535, network 1 (LINKTYPE_ETHERNET).
// Record: ts_sec u32 (Unix), ts_nsec u32, incl_len u32, orig_len u32, then incl_len bytes.
//
// PcapWriter records a SimSegment's frames as its monitor sees them (sent and received):
//
//   PcapWriter pcap("run.pcap", segment.unix_offset());
//   segment.add_monitor([&](const TimedFrame& f, FrameDirection) { pcap.write(f); });
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/common/expected.hpp"
#include "protocol/ethercat/link.hpp"

namespace drivecheck::ethercat {

inline constexpr std::uint32_t kLinktypeEthernet = 1;

struct EthernetPcapRecord {
  std::chrono::nanoseconds timestamp{0};  // Unix time
  std::vector<std::uint8_t> bytes;
  friend bool operator==(const EthernetPcapRecord&, const EthernetPcapRecord&) = default;
};

std::vector<std::uint8_t> ethernet_pcap_file_header();
// One record; timestamps before 1970 or after 2106 are an error.
Expected<std::vector<std::uint8_t>, std::string> encode_ethernet_pcap_record(
    const EthernetPcapRecord& record);
// Reads a whole file image (either byte order, µs or ns); errors name the byte offset.
Expected<std::vector<EthernetPcapRecord>, std::string> parse_ethernet_pcap(
    std::span<const std::uint8_t> bytes);
// As parse_ethernet_pcap, but keeps the records before a damaged or cut-off one (a capture
// whose writer was killed mid-record): `error` says where reading stopped; a bad file header
// gives no records.
struct EthernetPcapRead {
  std::vector<EthernetPcapRecord> records;
  std::optional<std::string> error;
};
EthernetPcapRead read_ethernet_pcap(std::span<const std::uint8_t> bytes);

class PcapWriter {
 public:
  // Opens (truncates) `path` and writes the file header; ok() says whether that worked.
  PcapWriter(const std::filesystem::path& path, Duration unix_offset);
  ~PcapWriter();
  PcapWriter(const PcapWriter&) = delete;
  PcapWriter& operator=(const PcapWriter&) = delete;

  bool ok() const { return file_ != nullptr && error_.empty(); }
  const std::string& error() const { return error_; }
  // Writes the frame at its link timestamp + the unix offset.
  void write(const TimedFrame& frame);
  void flush();

 private:
  std::FILE* file_ = nullptr;
  Duration unix_offset_;
  std::string error_;
};

}  // namespace drivecheck::ethercat

// pcap capture files of CAN frames, for Wireshark/tshark: LINKTYPE_CAN_SOCKETCAN (227).
//
// File header (24 bytes, written little-endian; the reader takes either byte order):
//   0..3   magic 0xA1B23C4D: nanosecond timestamps (the reader also takes 0xA1B2C3D4, µs)
//   4..5   version major 2
//   6..7   version minor 4
//   8..11  thiszone 0 (timestamps are UTC)
//   12..15 sigfigs 0
//   16..19 snaplen 16 (a classic CAN frame; the reader takes any)
//   20..23 network 227 = LINKTYPE_CAN_SOCKETCAN
//
// Record header (16 bytes, file byte order):
//   0..3   ts_sec   Unix time, seconds (unsigned 32 bits: 1970..2106)
//   4..7   ts_nsec  nanoseconds 0..999999999 (microseconds with the 0xA1B2C3D4 magic)
//   8..11  incl_len bytes stored: 16
//   12..15 orig_len bytes on the wire: 16
//
// Record data: the Linux `struct can_frame`, except that can_id is big-endian:
//   0..3   can_id, NETWORK byte order: bits 0..28 identifier, bit 29 CAN_ERR_FLAG (error
//          frame: bits 0..28 are the error class), bit 30 CAN_RTR_FLAG, bit 31 CAN_EFF_FLAG
//   4      len: data length 0..8 (for a remote frame: the requested DLC)
//   5      padding / CAN FD flags: 0
//   6      reserved: 0
//   7      len8_dlc: the DLC 9..15 of an 8-byte frame whose DLC is above 8, else 0
//   8..15  data, zero beyond len
// A reader accepts records shortened to 8 + len bytes (as some capture tools store them)
// and rejects CAN FD (len above 8 or more than 16 bytes) with a clear message.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::can {

inline constexpr std::uint32_t kPcapMagicNanoseconds = 0xA1B23C4D;
inline constexpr std::uint32_t kPcapMagicMicroseconds = 0xA1B2C3D4;
inline constexpr std::uint32_t kLinktypeCanSocketcan = 227;
inline constexpr std::size_t kPcapFileHeaderSize = 24;
inline constexpr std::size_t kPcapRecordHeaderSize = 16;
inline constexpr std::size_t kSocketcanFrameSize = 16;
inline constexpr std::size_t kPcapRecordSize = kPcapRecordHeaderSize + kSocketcanFrameSize;

struct PcapRecord {
  std::chrono::nanoseconds timestamp{0};  // Unix time
  Frame frame;

  friend bool operator==(const PcapRecord&, const PcapRecord&) = default;
};

// The 24-byte file header above (nanosecond magic, snaplen 16, link type 227).
std::array<std::uint8_t, kPcapFileHeaderSize> pcap_file_header();

// One record (header + frame). Fails when the timestamp is outside what pcap can hold
// (negative, or past 2106-02-07).
Expected<std::array<std::uint8_t, kPcapRecordSize>, std::string> encode_pcap_record(
    const PcapRecord& record);

// A whole capture in memory. Errors name the record number (1-based) and byte offset.
Expected<std::vector<PcapRecord>, std::string> parse_pcap(std::span<const std::uint8_t> bytes);

// A capture file; errors are "path: message" (TextError with line 0).
Expected<std::vector<PcapRecord>, TextError> read_pcap_file(const std::filesystem::path& path);

// Writes a capture file record by record. The header is written and flushed at create(),
// and with `flush_each_record` (the default) each record is handed to the kernel (fflush,
// not fsync) before write() returns: the file is a valid capture after every frame.
class PcapWriter {
 public:
  static Expected<PcapWriter, std::string> create(const std::filesystem::path& path,
                                                  bool flush_each_record = true);

  Expected<void, std::string> write(const PcapRecord& record);
  Expected<void, std::string> flush();

  const std::filesystem::path& path() const { return path_; }

 private:
  struct FileCloser {
    void operator()(std::FILE* file) const { std::fclose(file); }
  };
  PcapWriter(std::filesystem::path path, std::FILE* file, bool flush_each_record)
      : path_(std::move(path)), file_(file), flush_each_record_(flush_each_record) {}

  std::filesystem::path path_;
  std::unique_ptr<std::FILE, FileCloser> file_;
  bool flush_each_record_ = true;
};

}  // namespace drivecheck::can

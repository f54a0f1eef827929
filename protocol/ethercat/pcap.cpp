#include "protocol/ethercat/pcap.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

namespace drivecheck::ethercat {
namespace {

constexpr std::uint32_t kMagicNs = 0xA1B23C4D;
constexpr std::uint32_t kMagicUs = 0xA1B2C3D4;
constexpr std::size_t kFileHeader = 24;
constexpr std::size_t kRecordHeader = 16;

void put32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

std::uint32_t get32(std::span<const std::uint8_t> b, std::size_t at, bool swap) {
  const std::uint32_t le =
      b[at] | (b[at + 1] << 8) | (b[at + 2] << 16) | (static_cast<std::uint32_t>(b[at + 3]) << 24);
  return swap ? __builtin_bswap32(le) : le;
}

}  // namespace

std::vector<std::uint8_t> ethernet_pcap_file_header() {
  std::vector<std::uint8_t> out;
  put32(out, kMagicNs);
  out.insert(out.end(), {2, 0, 4, 0});
  put32(out, 0);
  put32(out, 0);
  put32(out, 65535);
  put32(out, kLinktypeEthernet);
  return out;
}

Expected<std::vector<std::uint8_t>, std::string> encode_ethernet_pcap_record(
    const EthernetPcapRecord& record) {
  const std::int64_t ns = record.timestamp.count();
  if (ns < 0 || ns / 1'000'000'000 > 0xFFFFFFFFll) {
    return Unexpected(fmt::format("timestamp {} ns is outside 1970..2106", ns));
  }
  std::vector<std::uint8_t> out;
  out.reserve(kRecordHeader + record.bytes.size());
  put32(out, static_cast<std::uint32_t>(ns / 1'000'000'000));
  put32(out, static_cast<std::uint32_t>(ns % 1'000'000'000));
  put32(out, static_cast<std::uint32_t>(record.bytes.size()));
  put32(out, static_cast<std::uint32_t>(record.bytes.size()));
  out.insert(out.end(), record.bytes.begin(), record.bytes.end());
  return out;
}

Expected<std::vector<EthernetPcapRecord>, std::string> parse_ethernet_pcap(
    std::span<const std::uint8_t> bytes) {
  auto read = read_ethernet_pcap(bytes);
  if (read.error) return Unexpected(std::move(*read.error));
  return std::move(read.records);
}

EthernetPcapRead read_ethernet_pcap(std::span<const std::uint8_t> bytes) {
  EthernetPcapRead read;
  const auto fail = [&](std::string why) {
    read.error = std::move(why);
    return std::move(read);
  };
  if (bytes.size() < kFileHeader) {
    return fail(fmt::format("pcap: {} bytes, the file header needs 24", bytes.size()));
  }
  const std::uint32_t magic = get32(bytes, 0, false);
  bool swap = false;
  bool nanoseconds = true;
  if (magic == kMagicNs || magic == kMagicUs) {
    nanoseconds = magic == kMagicNs;
  } else if (__builtin_bswap32(magic) == kMagicNs || __builtin_bswap32(magic) == kMagicUs) {
    swap = true;
    nanoseconds = __builtin_bswap32(magic) == kMagicNs;
  } else {
    return fail(fmt::format("pcap: byte 0: magic {:08X}h is not a pcap file", magic));
  }
  const std::uint32_t network = get32(bytes, 20, swap);
  if (network != kLinktypeEthernet) {
    return fail(fmt::format("pcap: byte 20: link type {} is not Ethernet (1)", network));
  }
  auto& records = read.records;
  std::size_t at = kFileHeader;
  while (at < bytes.size()) {
    if (bytes.size() - at < kRecordHeader) {
      return fail(fmt::format("pcap: byte {}: record header cut off", at));
    }
    const std::uint32_t sec = get32(bytes, at, swap);
    const std::uint32_t frac = get32(bytes, at + 4, swap);
    const std::uint32_t length = get32(bytes, at + 8, swap);
    // The fraction of a second must be below one second: a larger one would also put the time
    // past what a record can hold (1970..2106), so the capture could not be written back.
    if (frac >= (nanoseconds ? 1'000'000'000U : 1'000'000U)) {
      return fail(fmt::format("pcap: byte {}: timestamp fraction {} {} is not below one second",
                              at + 4, frac, nanoseconds ? "ns" : "us"));
    }
    if (length > bytes.size() - at - kRecordHeader) {
      return fail(fmt::format("pcap: byte {}: record of {} bytes runs past the end", at, length));
    }
    EthernetPcapRecord record;
    record.timestamp = std::chrono::nanoseconds(static_cast<std::int64_t>(sec) * 1'000'000'000 +
                                                (nanoseconds ? frac : frac * std::int64_t{1000}));
    const auto data = bytes.subspan(at + kRecordHeader, length);
    record.bytes.assign(data.begin(), data.end());
    records.push_back(std::move(record));
    at += kRecordHeader + length;
  }
  return read;
}

PcapWriter::PcapWriter(const std::filesystem::path& path, Duration unix_offset)
    : file_(std::fopen(path.c_str(), "wb")), unix_offset_(unix_offset) {
  if (file_ == nullptr) {
    error_ = fmt::format("{}: {}", path.string(), std::strerror(errno));
    return;
  }
  const auto header = ethernet_pcap_file_header();
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) {
    error_ = fmt::format("{}: write failed", path.string());
  }
}

PcapWriter::~PcapWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void PcapWriter::write(const TimedFrame& frame) {
  if (!ok()) return;
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
      frame.timestamp.time_since_epoch() + unix_offset_);
  const auto record = encode_ethernet_pcap_record({ns, frame.bytes});
  if (!record) {
    error_ = record.error();
    return;
  }
  if (std::fwrite(record->data(), 1, record->size(), file_) != record->size()) {
    error_ = "pcap: write failed";
  }
}

void PcapWriter::flush() {
  if (file_ != nullptr) std::fflush(file_);
}

}  // namespace drivecheck::ethercat

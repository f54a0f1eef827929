#include "protocol/can/pcap.hpp"

#include <fmt/compile.h>

#include <algorithm>
#include <cerrno>
#include <iterator>
#include <limits>
#include <system_error>

#include "protocol/can/bus.hpp"

namespace drivecheck::can {
namespace {

constexpr std::int64_t kNanosPerSecond = 1'000'000'000;
constexpr std::uint32_t kPcapngMagic = 0x0A0D0D0A;
constexpr std::uint32_t kVersionMajor = 2;
constexpr std::uint32_t kVersionMinor = 4;

std::string system_error_text(int error) {
  return std::error_code(error, std::generic_category()).message();
}

void put_le16(std::uint8_t* out, std::uint16_t v) {
  out[0] = static_cast<std::uint8_t>(v);
  out[1] = static_cast<std::uint8_t>(v >> 8);
}
void put_le32(std::uint8_t* out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    out[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
void put_be32(std::uint8_t* out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i)
    out[i] = static_cast<std::uint8_t>(v >> (8 * (3 - i)));
}
std::uint32_t get_le32(const std::uint8_t* in) {
  return static_cast<std::uint32_t>(in[0]) | static_cast<std::uint32_t>(in[1]) << 8 |
         static_cast<std::uint32_t>(in[2]) << 16 | static_cast<std::uint32_t>(in[3]) << 24;
}
std::uint32_t get_be32(const std::uint8_t* in) {
  return static_cast<std::uint32_t>(in[3]) | static_cast<std::uint32_t>(in[2]) << 8 |
         static_cast<std::uint32_t>(in[1]) << 16 | static_cast<std::uint32_t>(in[0]) << 24;
}
std::uint16_t get16(const std::uint8_t* in, bool big_endian) {
  return big_endian ? static_cast<std::uint16_t>(in[0] << 8 | in[1])
                    : static_cast<std::uint16_t>(in[1] << 8 | in[0]);
}

// The 16-byte can_frame of a record (data.size() is 8..16) -> Frame.
Expected<Frame, std::string> decode_can_frame(std::span<const std::uint8_t> data) {
  const std::uint32_t can_id = get_be32(data.data());
  const std::uint8_t len = data[4];
  const std::uint8_t len8_dlc = data[7];
  if (len > 8) {
    return Unexpected(fmt::format(
        FMT_COMPILE("payload length {} is above 8: CAN FD frames are not supported (drivecheck is "
                    "classic CAN)"),
        len));
  }
  const bool err = (can_id & Filter::kErrFlag) != 0;
  const bool rtr = (can_id & Filter::kRtrFlag) != 0;
  const bool eff = (can_id & Filter::kEffFlag) != 0;
  Frame frame;
  frame.id = can_id & kMaxExtendedId;
  if (err) {
    if (rtr)
      return Unexpected(
          fmt::format(FMT_COMPILE("can_id {:08X}: both ERR and RTR flags set"), can_id));
    frame.kind = FrameKind::error;
    frame.format = IdFormat::extended;
  } else if (eff) {
    frame.format = IdFormat::extended;
  } else if (frame.id > kMaxStandardId) {
    return Unexpected(fmt::format(
        FMT_COMPILE("can_id {:08X}: 11-bit frame (no EFF flag) with identifier bits above 7FF"),
        can_id));
  }
  if (rtr) {
    frame.kind = FrameKind::remote;
    frame.dlc = len;
    return frame;
  }
  if (data.size() < 8u + len) {
    return Unexpected(fmt::format(FMT_COMPILE("payload length {} but only {} data bytes stored"),
                                  len, data.size() - 8));
  }
  frame.dlc = len;
  std::copy_n(data.begin() + 8, len, frame.data.begin());
  if (len == 8 && len8_dlc > 8 && len8_dlc <= 15) frame.dlc = len8_dlc;
  return frame;
}

}  // namespace

std::array<std::uint8_t, kPcapFileHeaderSize> pcap_file_header() {
  std::array<std::uint8_t, kPcapFileHeaderSize> header{};
  put_le32(&header[0], kPcapMagicNanoseconds);
  put_le16(&header[4], kVersionMajor);
  put_le16(&header[6], kVersionMinor);
  // thiszone and sigfigs stay 0
  put_le32(&header[16], static_cast<std::uint32_t>(kSocketcanFrameSize));
  put_le32(&header[20], kLinktypeCanSocketcan);
  return header;
}

Expected<std::array<std::uint8_t, kPcapRecordSize>, std::string> encode_pcap_record(
    const PcapRecord& record) {
  const std::int64_t ns = record.timestamp.count();
  if (ns < 0) {
    return Unexpected(fmt::format("timestamp {} ns is before 1970: pcap cannot store it", ns));
  }
  const std::int64_t seconds = ns / kNanosPerSecond;
  if (seconds > std::numeric_limits<std::uint32_t>::max()) {
    return Unexpected(fmt::format("timestamp {} s is after 2106: pcap cannot store it", seconds));
  }
  std::array<std::uint8_t, kPcapRecordSize> out{};
  put_le32(&out[0], static_cast<std::uint32_t>(seconds));
  put_le32(&out[4], static_cast<std::uint32_t>(ns % kNanosPerSecond));
  put_le32(&out[8], static_cast<std::uint32_t>(kSocketcanFrameSize));
  put_le32(&out[12], static_cast<std::uint32_t>(kSocketcanFrameSize));
  std::uint8_t* can = &out[kPcapRecordHeaderSize];
  const Frame& frame = record.frame;
  put_be32(can, socketcan_id(frame));
  const bool data_frame = !frame.is_remote();
  can[4] = data_frame ? static_cast<std::uint8_t>(frame.length()) : frame.dlc;
  can[7] = data_frame && frame.dlc > 8 ? frame.dlc : std::uint8_t{0};
  std::copy_n(frame.data.begin(), frame.length(), can + 8);
  return out;
}

Expected<std::vector<PcapRecord>, std::string> parse_pcap(std::span<const std::uint8_t> bytes) {
  // Messages use compile-time format strings: most inputs a fuzzer gives are refused, and
  // runtime-parsed ones were ~9 % of the pcap fuzz target's profile.
  if (bytes.size() < kPcapFileHeaderSize) {
    return Unexpected(fmt::format(FMT_COMPILE("truncated file header: {} of {} bytes"),
                                  bytes.size(), kPcapFileHeaderSize));
  }
  const std::uint32_t magic = get_le32(bytes.data());
  bool big_endian = false;
  bool nanoseconds = false;
  if (magic == kPcapMagicNanoseconds || magic == kPcapMagicMicroseconds) {
    nanoseconds = magic == kPcapMagicNanoseconds;
  } else if (get_be32(bytes.data()) == kPcapMagicNanoseconds ||
             get_be32(bytes.data()) == kPcapMagicMicroseconds) {
    big_endian = true;
    nanoseconds = get_be32(bytes.data()) == kPcapMagicNanoseconds;
  } else if (magic == kPcapngMagic) {
    return Unexpected(
        std::string("this is a pcapng file; drivecheck reads pcap (convert: editcap -F pcap "
                    "in.pcapng out.pcap)"));
  } else {
    return Unexpected(fmt::format(FMT_COMPILE("not a pcap file: magic number {:08X}"), magic));
  }
  const auto get32 = [big_endian](const std::uint8_t* in) {
    return big_endian ? get_be32(in) : get_le32(in);
  };
  const std::uint16_t major = get16(&bytes[4], big_endian);
  const std::uint16_t minor = get16(&bytes[6], big_endian);
  if (major != kVersionMajor) {
    return Unexpected(
        fmt::format(FMT_COMPILE("pcap version {}.{} is not supported (2.x is)"), major, minor));
  }
  const std::uint32_t linktype = get32(&bytes[20]) & 0xFFFF;  // upper bits: FCS info
  if (linktype != kLinktypeCanSocketcan) {
    return Unexpected(fmt::format(FMT_COMPILE("link type {} is not LINKTYPE_CAN_SOCKETCAN ({})"),
                                  linktype, kLinktypeCanSocketcan));
  }
  const std::uint32_t fraction_limit = nanoseconds ? 1'000'000'000 : 1'000'000;
  const std::int64_t fraction_scale = nanoseconds ? 1 : 1000;

  std::vector<PcapRecord> records;
  std::size_t offset = kPcapFileHeaderSize;
  for (std::size_t number = 1; offset < bytes.size(); ++number) {
    // "record <n> at byte <offset>: " and the message, in one string.
    const auto fail = [&](const auto& format, const auto&... args) {
      std::string text = fmt::format(FMT_COMPILE("record {} at byte {}: "), number, offset);
      fmt::format_to(std::back_inserter(text), format, args...);
      return Unexpected(std::move(text));
    };
    const std::size_t left = bytes.size() - offset;
    if (left < kPcapRecordHeaderSize) {
      return fail(FMT_COMPILE("truncated record header: {} of {} bytes"), left,
                  kPcapRecordHeaderSize);
    }
    const std::uint8_t* header = &bytes[offset];
    const std::uint32_t seconds = get32(header);
    const std::uint32_t fraction = get32(header + 4);
    const std::uint32_t incl_len = get32(header + 8);
    const std::uint32_t orig_len = get32(header + 12);
    if (fraction >= fraction_limit) {
      return fail(FMT_COMPILE("timestamp fraction {} is not below {}"), fraction, fraction_limit);
    }
    if (incl_len > left - kPcapRecordHeaderSize) {
      return fail(FMT_COMPILE("truncated: {} bytes stored but only {} left in the file"), incl_len,
                  left - kPcapRecordHeaderSize);
    }
    if (incl_len < 8) {
      return fail(FMT_COMPILE("{} bytes is shorter than the 8-byte can_frame header"), incl_len);
    }
    if (incl_len > kSocketcanFrameSize) {
      return fail(
          FMT_COMPILE(
              "{} bytes is longer than a classic can_frame (16): CAN FD frames are not supported"),
          incl_len);
    }
    if (orig_len < incl_len) {
      return fail(FMT_COMPILE("orig_len {} is below incl_len {}"), orig_len, incl_len);
    }
    auto frame = decode_can_frame(bytes.subspan(offset + kPcapRecordHeaderSize, incl_len));
    if (!frame) return fail(FMT_COMPILE("{}"), frame.error());
    records.push_back(PcapRecord{std::chrono::nanoseconds(std::int64_t{seconds} * kNanosPerSecond +
                                                          std::int64_t{fraction} * fraction_scale),
                                 *frame});
    offset += kPcapRecordHeaderSize + incl_len;
  }
  return records;
}

Expected<std::vector<PcapRecord>, TextError> read_pcap_file(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(name.c_str(), "rb"),
                                                       &std::fclose);
  if (!file) return Unexpected(TextError{name, 0, "cannot open: " + system_error_text(errno)});
  std::vector<std::uint8_t> bytes;
  std::uint8_t buffer[1 << 16];
  for (;;) {
    const std::size_t n = std::fread(buffer, 1, sizeof buffer, file.get());
    bytes.insert(bytes.end(), buffer, buffer + n);
    if (n < sizeof buffer) break;
  }
  if (std::ferror(file.get())) {
    return Unexpected(TextError{name, 0, "cannot read: " + system_error_text(errno)});
  }
  auto records = parse_pcap(bytes);
  if (!records) return Unexpected(TextError{name, 0, std::move(records).error()});
  return std::move(*records);
}

Expected<PcapWriter, std::string> PcapWriter::create(const std::filesystem::path& path,
                                                     bool flush_each_record) {
  std::FILE* file = std::fopen(path.string().c_str(), "wb");
  if (file == nullptr) {
    return Unexpected(
        fmt::format("{}: cannot create: {}", path.string(), system_error_text(errno)));
  }
  PcapWriter writer(path, file, flush_each_record);
  const auto header = pcap_file_header();
  if (std::fwrite(header.data(), 1, header.size(), file) != header.size() ||
      std::fflush(file) != 0) {
    return Unexpected(fmt::format("{}: write failed: {}", path.string(), system_error_text(errno)));
  }
  return writer;
}

Expected<void, std::string> PcapWriter::write(const PcapRecord& record) {
  const auto bytes = encode_pcap_record(record);
  if (!bytes) return Unexpected(fmt::format("{}: {}", path_.string(), bytes.error()));
  if (std::fwrite(bytes->data(), 1, bytes->size(), file_.get()) != bytes->size()) {
    return Unexpected(
        fmt::format("{}: write failed: {}", path_.string(), system_error_text(errno)));
  }
  if (flush_each_record_) return flush();
  return {};
}

Expected<void, std::string> PcapWriter::flush() {
  if (std::fflush(file_.get()) != 0) {
    return Unexpected(
        fmt::format("{}: write failed: {}", path_.string(), system_error_text(errno)));
  }
  return {};
}

}  // namespace drivecheck::can

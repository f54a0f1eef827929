// Fuzz target: EtherCAT frames into the frame/datagram decoder (protocol/ethercat/frame.hpp)
// and through two emulated ESCs in a line (protocol/ethercat/esc.hpp), one frame per
// millisecond of simulated time.
//
// Input: frames back to back, each a u16 little-endian length then that many bytes (cut to
// what is left; an input without a complete length is one frame of all its bytes). At most 64
// frames per input. Frames are raw Ethernet frames without FCS: anything, EtherCAT or not.
//
// Oracles:
//  - decoding is total: decode_frame returns a frame or a DecodeError whose offset lies within
//    the input; a decoded untagged frame re-encodes to exactly its first 16 + length bytes
//    (the header's length, ETG.1000.4 / ESC Section I §2.2);
//  - an ESC changes a frame only where the datagram rules allow (ESC Section I §2.3-2.5):
//    length unchanged; Ethernet header unchanged but for bit 1 of the source MAC; a frame the
//    decoder's walk refuses passes unchanged; per datagram the command, index, length field
//    and IRQ stay, ADP grows by exactly one for position and broadcast commands and stays for
//    the others (the logical address stays), NOP and unknown commands stay untouched, and the
//    working counter grows by 0 or 1 (read or write commands, ARMW/FRMW) or 0..3 (read-write
//    commands, Table 5);
//  - a frame of only read commands (APRD, FPRD, BRD, LRD; NOP and unknown ones) changes no
//    byte of an ESC's address space but SyncManager status bytes (a read empties a mailbox:
//    ESC Section I §8);
//  - ECAT cannot write what is read-only from ECAT (ESC Section II): type, revision, build,
//    feature bytes (0000h..0009h), AL status and AL status code (0130h..0135h) are unchanged
//    by any frame.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz/support/fuzz_check.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"

namespace {

using namespace drivecheck::ethercat;
using Bytes = std::vector<std::uint8_t>;

constexpr std::size_t kMaxFrames = 64;

std::vector<Bytes> split(std::span<const std::uint8_t> input) {
  std::vector<Bytes> frames;
  std::size_t at = 0;
  if (input.size() < 2) {
    frames.emplace_back(input.begin(), input.end());
    return frames;
  }
  while (at + 2 <= input.size() && frames.size() < kMaxFrames) {
    const std::size_t length = input[at] | (input[at + 1] << 8);
    at += 2;
    const std::size_t take = std::min(length, input.size() - at);
    frames.emplace_back(input.begin() + static_cast<std::ptrdiff_t>(at),
                        input.begin() + static_cast<std::ptrdiff_t>(at + take));
    at += take;
  }
  return frames;
}

void check_decoder(const Bytes& frame) {
  const auto decoded = decode_frame(frame);
  if (!decoded) {
    DRIVECHECK_FUZZ_CHECK(decoded.error().offset <= frame.size(),
                          "decode error offset past the end of the frame");
    DRIVECHECK_FUZZ_CHECK(!decoded.error().message().empty(), "decode error without a message");
    return;
  }
  const bool vlan = frame[12] == 0x81 && frame[13] == 0x00;
  if (vlan) return;
  const auto encoded = encode_frame(*decoded);
  DRIVECHECK_FUZZ_CHECK(encoded.has_value(), "a decoded frame does not encode");
  const std::size_t content = kEthernetHeaderSize + kEthercatHeaderSize +
                              static_cast<std::size_t>((frame[14] | (frame[15] << 8)) & 0x7FF);
  DRIVECHECK_FUZZ_CHECK(encoded->size() >= content, "re-encoded frame is shorter");
  DRIVECHECK_FUZZ_CHECK(
      std::equal(frame.begin(), frame.begin() + static_cast<std::ptrdiff_t>(content),
                 encoded->begin()),
      "decode/encode round trip changed the frame");
}

using ReadOnly = std::array<std::uint8_t, 16>;

ReadOnly read_only(const Esc& esc) {
  ReadOnly r{};
  for (std::uint16_t i = 0; i < 10; ++i)
    r[i] = esc.peek(i);
  for (std::uint16_t i = 0; i < 6; ++i)
    r[10 + i] = esc.peek(static_cast<std::uint16_t>(0x0130 + i));
  return r;
}

// `after` is `before` having passed one ESC.
DRIVECHECK_FUZZ_ORACLE_CODE void check_processing(const Bytes& before, const Bytes& after) {
  DRIVECHECK_FUZZ_CHECK(before.size() == after.size(), "an ESC changed the frame's length");
  for (std::size_t i = 0; i < std::min<std::size_t>(before.size(), kEthernetHeaderSize); ++i) {
    const std::uint8_t mask = i == 6 ? 0xFD : 0xFF;
    DRIVECHECK_FUZZ_CHECK((before[i] & mask) == (after[i] & mask),
                          "an ESC changed the Ethernet header");
  }
  const auto layout = parse_frame_layout(before);
  std::vector<DatagramSpan> spans;
  const bool valid = layout && !walk_datagrams(std::span(before).subspan(layout->payload_offset,
                                                                         layout->payload_length),
                                               layout->payload_offset, spans);
  if (!valid) {
    DRIVECHECK_FUZZ_CHECK(
        std::equal(before.begin() +
                       std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(before.size()), 14),
                   before.end(),
                   after.begin() +
                       std::min<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(after.size()), 14)),
        "an ESC changed a malformed frame");
    return;
  }
  for (const DatagramSpan& span : spans) {
    const std::size_t at = layout->payload_offset + span.offset;
    const std::uint8_t command = before[at];
    const auto info = find_command(command);
    const auto same = [&](std::size_t from, std::size_t to) {
      return std::equal(before.begin() + static_cast<std::ptrdiff_t>(at + from),
                        before.begin() + static_cast<std::ptrdiff_t>(at + to),
                        after.begin() + static_cast<std::ptrdiff_t>(at + from));
    };
    const std::size_t total = kDatagramOverhead + span.data_length;
    if (!info || info->addressing == Addressing::none) {
      DRIVECHECK_FUZZ_CHECK(same(0, total), "an ESC changed a NOP or unknown datagram");
      continue;
    }
    DRIVECHECK_FUZZ_CHECK(same(0, 2) && same(6, 10),
                          "an ESC changed command, index, length or IRQ");
    const auto adp_before = static_cast<std::uint16_t>(before[at + 2] | (before[at + 3] << 8));
    const auto adp_after = static_cast<std::uint16_t>(after[at + 2] | (after[at + 3] << 8));
    if (info->addressing == Addressing::position || info->addressing == Addressing::broadcast) {
      DRIVECHECK_FUZZ_CHECK(adp_after == static_cast<std::uint16_t>(adp_before + 1),
                            "ADP did not grow by one");
      DRIVECHECK_FUZZ_CHECK(same(4, 6), "an ESC changed ADO");
    } else {
      DRIVECHECK_FUZZ_CHECK(same(2, 6), "an ESC changed a station or logical address");
    }
    const std::size_t w = at + kDatagramHeaderSize + span.data_length;
    const auto wkc_before = static_cast<std::uint16_t>(before[w] | (before[w + 1] << 8));
    const auto wkc_after = static_cast<std::uint16_t>(after[w] | (after[w + 1] << 8));
    const auto grew = static_cast<std::uint16_t>(wkc_after - wkc_before);
    const unsigned per_esc = info->wkc == WkcRule::read_write ? 3 : 1;
    DRIVECHECK_FUZZ_CHECK_DETAIL(grew <= per_esc, "working counter grew more than Table 5 allows",
                                 fmt::format("{} grew by {}", command_name(info->command), grew));
  }
}

// Whether every datagram of a well-formed frame only reads (or is NOP / unknown).
bool only_reads(const Bytes& frame) {
  const auto layout = parse_frame_layout(frame);
  if (!layout) return false;
  std::vector<DatagramSpan> spans;
  const auto payload = std::span(frame).subspan(layout->payload_offset, layout->payload_length);
  if (walk_datagrams(payload, layout->payload_offset, spans)) return false;
  for (const DatagramSpan& span : spans) {
    const auto info = find_command(payload[span.offset]);
    if (info && info->access != Access::read && info->access != Access::none) return false;
  }
  return true;
}

DRIVECHECK_FUZZ_ORACLE_CODE void check_unchanged_but_sm_status(
    const Bytes& before, std::span<const std::uint8_t> after) {
  for (std::size_t a = 0; a < before.size(); ++a) {
    const bool sm_status =
        a >= reg::kSyncManager && a < reg::kSyncManager + 128u && (a - reg::kSyncManager) % 8 == 5;
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        sm_status || before[a] == after[a], "a frame of read commands changed the ESC",
        fmt::format("address {:04X}h: {:02X}h -> {:02X}h", a, before[a], after[a]));
  }
}

// The frame passes `esc` at `t`; with `reads_only`, checks that it changed nothing.
void pass(Esc& esc, Bytes& frame, drivecheck::ethercat::TimePoint t, bool reads_only) {
  esc.advance(t);  // time-dependent registers settle first (system time, watchdog, SII busy)
  Bytes before;
  if (reads_only) before.assign(esc.memory().begin(), esc.memory().end());
  esc.process_frame(frame, t);
  if (reads_only) check_unchanged_but_sm_status(before, esc.memory());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::vector<Bytes> frames = split({data, size});
  Esc first;
  Esc second;
  const ReadOnly first_read_only = read_only(first);
  const ReadOnly second_read_only = read_only(second);
  drivecheck::ethercat::TimePoint t{};
  for (const Bytes& frame : frames) {
    check_decoder(frame);
    const bool reads_only = only_reads(frame);
    Bytes once = frame;
    pass(first, once, t, reads_only);
    check_processing(frame, once);
    Bytes twice = once;
    pass(second, twice, t + std::chrono::nanoseconds(700), reads_only);
    check_processing(once, twice);
    t += std::chrono::milliseconds(1);
  }
  DRIVECHECK_FUZZ_CHECK(
      first_read_only == read_only(first) && second_read_only == read_only(second),
      "ECAT changed a register that is read-only from ECAT");
  return 0;
}

#include "protocol/can/frame_timing.hpp"

#include <array>

namespace drivecheck::can {
namespace {

constexpr std::uint16_t kCrc15Generator = 0x4599;
constexpr std::uint32_t kFixedTailBits = 1 + 1 + 1 + 7 + 3;  // CRC del, ACK, ACK del, EOF, IFS
constexpr std::uint32_t kBaseHeaderBits = 19;                // SOF .. DLC, base format
constexpr std::uint32_t kExtendedHeaderBits = 39;            // SOF .. DLC, extended format
constexpr std::uint32_t kCrcBits = 15;
constexpr std::uint32_t kErrorFrameBits = 6 + 8 + 3;
constexpr std::uint32_t kWorstErrorFrameBits = 12 + 8 + 3;

// The CRC register after feeding byte `i` (MSB first) into a register whose top 8 bits are
// zero: crc' = ((crc << 8) & 0x7FFF) ^ table[((crc >> 7) ^ byte) & 0xFF].
constexpr std::array<std::uint16_t, 256> make_crc_table() {
  std::array<std::uint16_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    unsigned crc = i << 7;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x4000) != 0 ? (crc << 1) ^ kCrc15Generator : crc << 1;
      crc &= 0x7FFF;
    }
    table[i] = static_cast<std::uint16_t>(crc);
  }
  return table;
}
constexpr auto kCrcTable = make_crc_table();

std::uint16_t crc_update(std::uint16_t crc, std::uint8_t byte) {
  const unsigned index = ((crc >> 7) ^ byte) & 0xFFu;
  return static_cast<std::uint16_t>(((crc << 8) & 0x7FFF) ^ kCrcTable[index]);
}

// Bit-stuffing state after a bit: the bit's value (bit 2) and the length of the run of equal
// bits it ends, 1..4 (bits 0..1 hold run - 1). A run never reaches 5: the fifth equal bit is
// followed by a stuff bit of the opposite value, which starts a new run of 1.
struct StuffStep {
  std::uint8_t state;
  std::uint8_t stuffed;
};

constexpr StuffStep stuff_bit(std::uint8_t state, unsigned bit) {
  const unsigned value = state >> 2;
  const unsigned run = (state & 3u) + 1;
  if (bit != value) return {static_cast<std::uint8_t>(bit << 2), 0};
  if (run + 1 == 5) return {static_cast<std::uint8_t>((bit ^ 1u) << 2), 1};
  return {static_cast<std::uint8_t>((value << 2) | run), 0};
}

// The state and stuff-bit count after feeding a whole byte (MSB first) in each state.
constexpr std::array<std::array<StuffStep, 256>, 8> make_stuff_table() {
  std::array<std::array<StuffStep, 256>, 8> table{};
  for (unsigned state = 0; state < 8; ++state) {
    for (unsigned byte = 0; byte < 256; ++byte) {
      StuffStep step{static_cast<std::uint8_t>(state), 0};
      for (int bit = 7; bit >= 0; --bit) {
        const StuffStep next = stuff_bit(step.state, (byte >> bit) & 1u);
        step = {next.state, static_cast<std::uint8_t>(step.stuffed + next.stuffed)};
      }
      table[state][byte] = step;
    }
  }
  return table;
}
constexpr auto kStuffTable = make_stuff_table();

class StuffCounter {
 public:
  // Starts right after SOF: one dominant bit.
  void bit(unsigned value) {
    const StuffStep step = stuff_bit(state_, value);
    state_ = step.state;
    stuffed_ += step.stuffed;
  }
  void byte(std::uint8_t value) {
    const StuffStep step = kStuffTable[state_][value];
    state_ = step.state;
    stuffed_ += step.stuffed;
  }
  std::uint32_t stuffed() const { return stuffed_; }

 private:
  std::uint8_t state_ = 0;  // value 0, run 1: the SOF bit
  std::uint32_t stuffed_ = 0;
};

// SOF..data of a data or remote frame, packed MSB first into whole bytes with leading zero
// padding, so that the last data bit ends byte 'size - 1'. Leading zeros leave a CRC with
// initial value 0 unchanged, so the CRC can run bytewise.
struct PackedFrame {
  std::array<std::uint8_t, 5 + 8> bytes{};
  std::uint32_t size = 0;
  std::uint32_t header_bits = 0;     // SOF .. DLC
  std::uint32_t bits_after_sof = 0;  // header bits after SOF that share byte 0 with it
};

PackedFrame pack(const Frame& frame) {
  PackedFrame packed;
  const std::uint32_t rtr = frame.is_remote() ? 1 : 0;
  const std::uint32_t dlc = frame.dlc & 0xFu;
  std::uint32_t at = 0;
  if (frame.is_extended()) {
    // bit 38 SOF, 37..27 ID-A, 26 SRR, 25 IDE, 24..7 ID-B, 6 RTR, 5 r1, 4 r0, 3..0 DLC
    const std::uint64_t id = frame.id & kMaxExtendedId;
    const std::uint64_t header = (id >> 18) << 27 | 1ull << 26 | 1ull << 25 | (id & 0x3FFFF) << 7 |
                                 std::uint64_t{rtr} << 6 | dlc;
    for (int shift = 32; shift >= 0; shift -= 8) {
      packed.bytes[at++] = static_cast<std::uint8_t>(header >> shift);
    }
    packed.header_bits = kExtendedHeaderBits;
    packed.bits_after_sof = 6;
  } else {
    // bit 18 SOF, 17..7 ID, 6 RTR, 5 IDE, 4 r0, 3..0 DLC
    const std::uint32_t header = (frame.id & kMaxStandardId) << 7 | rtr << 6 | dlc;
    for (int shift = 16; shift >= 0; shift -= 8) {
      packed.bytes[at++] = static_cast<std::uint8_t>(header >> shift);
    }
    packed.header_bits = kBaseHeaderBits;
    packed.bits_after_sof = 2;
  }
  for (std::uint8_t byte : frame.payload())
    packed.bytes[at++] = byte;
  packed.size = at;
  return packed;
}

std::uint16_t packed_crc(const PackedFrame& packed) {
  return crc15_can(std::span<const std::uint8_t>(packed.bytes.data(), packed.size));
}

std::uint32_t exact_bits(const Frame& frame) {
  const PackedFrame packed = pack(frame);
  const std::uint16_t crc = packed_crc(packed);
  StuffCounter stuff;
  for (int bit = static_cast<int>(packed.bits_after_sof) - 1; bit >= 0; --bit) {
    stuff.bit((packed.bytes[0] >> bit) & 1u);
  }
  for (std::uint32_t i = 1; i < packed.size; ++i)
    stuff.byte(packed.bytes[i]);
  stuff.byte(static_cast<std::uint8_t>(crc >> 7));
  for (int bit = 6; bit >= 0; --bit)
    stuff.bit((crc >> bit) & 1u);
  const std::uint32_t stuffable =
      packed.header_bits + 8 * static_cast<std::uint32_t>(frame.length()) + kCrcBits;
  return stuffable + stuff.stuffed() + kFixedTailBits;
}

std::uint32_t worst_case_bits(const Frame& frame) {
  const std::uint32_t header = frame.is_extended() ? kExtendedHeaderBits : kBaseHeaderBits;
  const std::uint32_t stuffable =
      header + 8 * static_cast<std::uint32_t>(frame.length()) + kCrcBits;
  return stuffable + (stuffable - 1) / 4 + kFixedTailBits;
}

}  // namespace

std::uint16_t crc15_can(std::span<const std::uint8_t> bytes) {
  std::uint16_t crc = 0;
  for (std::uint8_t byte : bytes)
    crc = crc_update(crc, byte);
  return crc;
}

std::uint16_t frame_crc15(const Frame& frame) {
  if (frame.is_error()) return 0;
  return packed_crc(pack(frame));
}

std::uint32_t frame_bits(const Frame& frame, BitStuffing stuffing) {
  if (frame.is_error()) {
    return stuffing == BitStuffing::exact ? kErrorFrameBits : kWorstErrorFrameBits;
  }
  return stuffing == BitStuffing::exact ? exact_bits(frame) : worst_case_bits(frame);
}

Duration bit_duration(std::uint64_t bits, std::uint32_t bitrate) {
  if (bitrate == 0) return Duration::max();
  // bits <= 2^32 in practice; 2^32 * 1e9 still fits in 64 bits unsigned.
  return Duration(static_cast<Duration::rep>(bits * 1'000'000'000ull / bitrate));
}

Duration frame_duration(const Frame& frame, std::uint32_t bitrate, BitStuffing stuffing) {
  return bit_duration(frame_bits(frame, stuffing), bitrate);
}

std::string wire_bit_string(const Frame& frame) {
  if (frame.is_error()) return {};
  const PackedFrame packed = pack(frame);
  const std::uint32_t total_bits = packed.size * 8;
  const std::uint32_t first = total_bits - packed.header_bits -
                              8 * static_cast<std::uint32_t>(frame.length());  // SOF position
  std::string raw;
  for (std::uint32_t i = first; i < total_bits; ++i) {
    raw += ((packed.bytes[i / 8] >> (7 - i % 8)) & 1u) != 0 ? '1' : '0';
  }
  const std::uint16_t crc = packed_crc(packed);
  for (int bit = 14; bit >= 0; --bit)
    raw += ((crc >> bit) & 1u) != 0 ? '1' : '0';

  std::string wire;
  char last = 'x';
  int run = 0;
  for (char bit : raw) {
    wire += bit;
    run = bit == last ? run + 1 : 1;
    last = bit;
    if (run == 5) {
      last = bit == '0' ? '1' : '0';
      wire += last;
      run = 1;
    }
  }
  wire += "1";        // CRC delimiter
  wire += "0";        // ACK slot, driven dominant by the receivers
  wire += "1";        // ACK delimiter
  wire += "1111111";  // EOF
  wire += "111";      // intermission
  return wire;
}

}  // namespace drivecheck::can

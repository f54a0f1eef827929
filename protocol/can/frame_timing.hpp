// How long a classic CAN frame (ISO 11898-1) occupies the wire: bit counts with bit stuffing,
// the CRC-15 that is part of the stuffed bit stream, and durations at a bit rate.
//
// Bits of a data or remote frame, in transmission order (0 = dominant, 1 = recessive):
//
//   11-bit identifier ("base format"):
//     SOF(1)=0  ID(11)  RTR(1)  IDE(1)=0  r0(1)=0  DLC(4)  DATA(8 x n)  CRC(15)
//   29-bit identifier ("extended format"):
//     SOF(1)=0  ID-A(11, id bits 28..18)  SRR(1)=1  IDE(1)=1  ID-B(18, id bits 17..0)  RTR(1)
//     r1(1)=0  r0(1)=0  DLC(4)  DATA(8 x n)  CRC(15)
//   then, in both formats, the fixed-form tail (never stuffed):
//     CRC delimiter(1)=1  ACK slot(1)=0 (driven by the receivers)  ACK delimiter(1)=1  EOF(7)=1..1
//     and the intermission IFS(3)=111 before the next frame may start.
//
// RTR is 1 in remote frames, whose DLC field carries the requested length but which carry no
// data (n = 0). A data frame with DLC 9..15 carries 8 bytes. The CRC-15 (generator 0x4599,
// initial value 0) covers SOF through the last data bit. Bit stuffing applies from SOF through
// the last CRC bit: after five equal bits the transmitter inserts one bit of the opposite
// value, which itself counts towards the next run of five.
//
// Frame lengths including the 3 intermission bits, 8 data bytes:
//   base format:     exact 111 + stuff bits, worst case 135 (98 stuffable + 24 stuff + 13)
//   extended format: exact 131 + stuff bits, worst case 160 (118 stuffable + 29 stuff + 13)
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"

namespace drivecheck::can {

enum class BitStuffing : std::uint8_t {
  worst_case,  // the upper bound: one stuff bit per 4 stuffable bits after the first
  exact,       // the stuff bits the frame's real bit stream needs
};

// Bits a frame occupies on the wire, SOF to the end of the 3-bit intermission. An error frame
// (FrameKind::error) counts as error flag (6) + error delimiter (8) + intermission (3) = 17
// bits exact, and 23 worst case (a second node's superposed flag adds up to 6 bits).
std::uint32_t frame_bits(const Frame& frame, BitStuffing stuffing);

// `bits` bit times at `bitrate` bit/s, rounded down to whole nanoseconds.
// A bitrate of 0 gives Duration::max().
Duration bit_duration(std::uint64_t bits, std::uint32_t bitrate);

// frame_bits() as time on the wire at `bitrate` bit/s.
Duration frame_duration(const Frame& frame, std::uint32_t bitrate, BitStuffing stuffing);

// CRC-15/CAN over whole bytes, most significant bit first (generator 0x4599, initial 0, no
// final XOR). Its check value, over the ASCII bytes "123456789", is 0x059E.
std::uint16_t crc15_can(std::span<const std::uint8_t> bytes);

// The CRC field of a data or remote frame (over SOF..data, see above). 0 for error frames.
std::uint16_t frame_crc15(const Frame& frame);

// The frame's bits on the wire as '0'/'1' text, SOF through intermission, stuff bits
// included, ACK slot dominant (as acknowledged by a receiver). Computed bit by bit, slowly:
// for tests and diagnostics. Empty for error frames.
std::string wire_bit_string(const Frame& frame);

}  // namespace drivecheck::can

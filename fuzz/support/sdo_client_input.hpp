// The input format of the sdo_client fuzz target, shared with the seed generator
// (fuzz/generate_corpus.cpp) so that both read and write the same bytes.
//
// Header (11 bytes; missing bytes read as 0):
//   byte 0     bit 0 upload (else download); bits 2..1 mode: 0 automatic, 1 segmented,
//              2-3 block; bit 3 offer CRC; bit 4 block fallback; bit 5 max_upload_size 100
//              (else the default 16 MiB); bits 7..6 timeout: 1 ms, 100 ms, 1 s, 30 s
//   byte 1     client blksize option (bits 6..0; 0 is invalid and must fail a block upload)
//   byte 2     protocol switch threshold (pst)
//   bytes 3-4  object index (LE)       byte 5  sub-index
//   bytes 6-7  object size (LE) modulo 1200: the server's object (upload) or the data (download)
//   byte 8     seed of the object's bytes
//   byte 9     server model: bit 0 CRC, bit 1 upload size indicated, bit 2 expedited upload,
//              bit 3 expedited size indicated, bit 4 refuse block (abort 05040001h),
//              bit 5 protocol switch
//   byte 10    server blksize in block download (raw: 0 or above 127 is nonconforming)
// Then operations until the input ends; an operation byte holds the operation in bits 2..0
// and a parameter p in bits 7..3 (SdoClientOp below).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz/support/fuzz_input.hpp"

namespace drivecheck::fuzz {

inline constexpr std::size_t kSdoClientHeaderSize = 11;
inline constexpr std::size_t kSdoClientMaxObjectSize = 1200;

struct SdoClientSetup {
  bool upload = true;
  std::uint8_t mode = 0;  // 0 automatic, 1 segmented, 2 block
  bool crc = true;
  bool fallback = true;
  bool small_max_upload = false;
  std::uint8_t timeout = 2;  // index: 1 ms, 100 ms, 1 s, 30 s
  std::uint8_t block_size = 127;
  std::uint8_t pst = 0;
  std::uint16_t index = 0x1008;
  std::uint8_t sub_index = 0;
  std::uint16_t size = 0;
  std::uint8_t seed = 0;
  // Server model.
  bool server_crc = true;
  bool upload_size_indicated = true;
  bool expedited_upload = true;
  bool expedited_size_indicated = true;
  bool refuse_block = false;
  bool protocol_switch = true;
  std::uint8_t server_block_size = 127;

  static SdoClientSetup read(FuzzInput& in) {
    SdoClientSetup s;
    const std::uint8_t b0 = in.u8();
    s.upload = (b0 & 0x01) != 0;
    s.mode = static_cast<std::uint8_t>(((b0 >> 1) & 0x3) >= 2 ? 2 : (b0 >> 1) & 0x3);
    s.crc = (b0 & 0x08) != 0;
    s.fallback = (b0 & 0x10) != 0;
    s.small_max_upload = (b0 & 0x20) != 0;
    s.timeout = static_cast<std::uint8_t>(b0 >> 6);
    s.block_size = in.u8() & 0x7F;
    s.pst = in.u8();
    s.index = in.u16();
    s.sub_index = in.u8();
    s.size = static_cast<std::uint16_t>(in.u16() % kSdoClientMaxObjectSize);
    s.seed = in.u8();
    const std::uint8_t server = in.u8();
    s.server_crc = (server & 0x01) != 0;
    s.upload_size_indicated = (server & 0x02) != 0;
    s.expedited_upload = (server & 0x04) != 0;
    s.expedited_size_indicated = (server & 0x08) != 0;
    s.refuse_block = (server & 0x10) != 0;
    s.protocol_switch = (server & 0x20) != 0;
    s.server_block_size = in.u8();
    return s;
  }

  std::array<std::uint8_t, kSdoClientHeaderSize> bytes() const {
    const auto bit = [](bool value, unsigned shift) {
      return static_cast<std::uint8_t>(value ? 1u << shift : 0u);
    };
    return {
        static_cast<std::uint8_t>(bit(upload, 0) | (mode & 0x3) << 1 | bit(crc, 3) |
                                  bit(fallback, 4) | bit(small_max_upload, 5) |
                                  (timeout & 0x3) << 6),
        static_cast<std::uint8_t>(block_size & 0x7F),
        pst,
        static_cast<std::uint8_t>(index & 0xFF),
        static_cast<std::uint8_t>(index >> 8),
        sub_index,
        static_cast<std::uint8_t>(size & 0xFF),
        static_cast<std::uint8_t>(size >> 8),
        seed,
        static_cast<std::uint8_t>(bit(server_crc, 0) | bit(upload_size_indicated, 1) |
                                  bit(expedited_upload, 2) | bit(expedited_size_indicated, 3) |
                                  bit(refuse_block, 4) | bit(protocol_switch, 5)),
        server_block_size,
    };
  }
};

// Operation bytes (bits 2..0; the parameter p is bits 7..3).
enum class SdoClientOp : std::uint8_t {
  deliver = 0,       // the model's next answer
  drain = 1,         // answers until the model is quiet
  time_step = 2,     // p%4: 0 +((p/4)+1) ms, 1 to 1 ns before the deadline, 2 to the
                     // deadline, 3 + next u16 ms
  inject = 3,        // the next 13-byte frame record; p%4: 0 on the response COB-ID, 1 as is,
                     // 2 on the request COB-ID, 3 on the response COB-ID as 8-byte data frame
  mutate = 4,        // the next answer with byte p%8 XORed with the next input byte
  lose_answer = 5,   // the next answer is lost
  duplicate = 6,     // the next answer arrives twice
  lose_request = 7,  // the next (p%4)+1 frames of the client are lost
};

inline constexpr std::uint8_t op_byte(SdoClientOp op, unsigned p = 0) {
  return static_cast<std::uint8_t>(static_cast<unsigned>(op) | (p & 0x1F) << 3);
}

// The object's bytes (download data or the server's object) from the seed.
inline std::vector<std::uint8_t> sdo_client_object(std::size_t size, std::uint8_t seed) {
  std::vector<std::uint8_t> bytes(size);
  std::uint32_t state = 0x9E3779B9u ^ seed;
  for (auto& byte : bytes) {
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    byte = static_cast<std::uint8_t>(state);
  }
  return bytes;
}

}  // namespace drivecheck::fuzz

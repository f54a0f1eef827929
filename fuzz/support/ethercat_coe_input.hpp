// The input format of fuzz/ethercat_coe_fuzzer.cpp, shared by the target and the seed
// generator (fuzz/generate_corpus.cpp) so that a seed means what its name says.
//
// Records until the end: op (1 octet), length (1 octet), that many octets (see the target's
// header for what each op does).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace drivecheck::fuzz {

inline constexpr std::size_t kEthercatCoeMailboxSize = 64;  // SM0 and SM1 of the fuzzed slave

enum class EthercatCoeOp : std::uint8_t {
  sm0_write = 0,   // octets into the slave's write mailbox
  sm1_read = 1,    // octets as the master's read of SM1
  client_coe = 2,  // octets as a CoE message into the SDO client
  control = 3,     // bit 2 repeat request, bit 3 client timeout, bit 4 reset, bit 5 PREOP toggle
};
inline constexpr std::uint8_t kEthercatCoeRepeat = 0x04;
inline constexpr std::uint8_t kEthercatCoeTimeout = 0x08;
inline constexpr std::uint8_t kEthercatCoeReset = 0x10;
inline constexpr std::uint8_t kEthercatCoeTogglePreop = 0x20;
inline constexpr std::uint8_t kEthercatCoeStartTransfer = 0x40;  // before the op
inline constexpr std::uint8_t kEthercatCoeDownload = 0x80;       // with kEthercatCoeStartTransfer

// Appends one record (the octets are cut at 255).
inline void add_ethercat_coe_record(std::vector<std::uint8_t>& out, std::uint8_t op,
                                    std::span<const std::uint8_t> octets) {
  const std::size_t n = octets.size() < 255 ? octets.size() : 255;
  out.push_back(op);
  out.push_back(static_cast<std::uint8_t>(n));
  out.insert(out.end(), octets.begin(), octets.begin() + static_cast<std::ptrdiff_t>(n));
}

}  // namespace drivecheck::fuzz

// Reading a fuzz input: a cursor over the bytes that never fails. Past the end every read
// gives zeros, so that a target can read a fixed header from any input, short ones included
// (libFuzzer starts from the empty input).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace drivecheck::fuzz {

class FuzzInput {
 public:
  FuzzInput(const std::uint8_t* data, std::size_t size) : bytes_(data, size) {}
  explicit FuzzInput(std::span<const std::uint8_t> bytes) : bytes_(bytes) {}

  bool empty() const { return offset_ >= bytes_.size(); }
  std::size_t remaining() const { return empty() ? 0 : bytes_.size() - offset_; }

  std::uint8_t u8() { return empty() ? 0 : bytes_[offset_++]; }
  std::uint16_t u16() {  // little-endian
    const std::uint16_t low = u8();
    return static_cast<std::uint16_t>(low | (std::uint16_t{u8()} << 8));
  }
  std::uint32_t u32() {  // little-endian
    const std::uint32_t low = u16();
    return low | (std::uint32_t{u16()} << 16);
  }
  bool flag() { return (u8() & 1) != 0; }

  // Up to n bytes (fewer at the end of the input).
  std::span<const std::uint8_t> bytes(std::size_t n) {
    const std::size_t count = n < remaining() ? n : remaining();
    const auto out = bytes_.subspan(empty() ? bytes_.size() : offset_, count);
    offset_ += count;
    return out;
  }
  std::span<const std::uint8_t> rest() { return bytes(remaining()); }

 private:
  std::span<const std::uint8_t> bytes_;
  std::size_t offset_ = 0;
};

inline std::string_view as_text(std::span<const std::uint8_t> bytes) {
  return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

}  // namespace drivecheck::fuzz

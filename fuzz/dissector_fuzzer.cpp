// Fuzz target: the CANopen dissector (protocol/cia301/dissector.hpp): any frame, one line.
//
// Input: byte 0 options: bit 0 configured nodes (a 16-byte bitset follows), bit 1 an object
// name lookup (a length byte and up to 32 bytes of name follow; names are made printable),
// bit 2 PDO mappings (a count byte & 3, then per mapping: u16 CAN-ID, a count byte & 7, and
// 4 bytes per entry: u16 index, sub-index, bits - raw, so invalid mappings occur), bit 3 SYNC
// and TIME CAN-IDs (two u16); then 13-byte frame records (fuzz/support/frame_record.hpp).
// Oracles, per frame, for the stateful dissector and the stateless dissect_frame():
//   - the line is never empty, is ONE line of printable text (no control characters: a
//     frame's bytes must not be able to forge transcript lines), and starts with the
//     identifier as candump prints it (error frames: the class bits only), then a blank;
//   - the summary of every dissection is non-empty.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/support/frame_record.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/dissector.hpp"

namespace {

using namespace drivecheck;
using namespace drivecheck::cia301;

void check_line(const std::string& line, const can::Frame& frame) {
  DRIVECHECK_FUZZ_CHECK(!line.empty(), "empty dissector line");
  for (const char c : line) {
    const auto byte = static_cast<unsigned char>(c);
    DRIVECHECK_FUZZ_CHECK_DETAIL(byte >= 0x20 && byte != 0x7F,
                                 "dissector line holds a control character",
                                 fmt::format("{} -> {:?}", frame, line));
  }
  // Every line starts with the identifier exactly as candump prints it (error frames with
  // CAN_ERR_FLAG, so they cannot be mistaken for 29-bit data frames).
  const std::string candump = can::to_candump(frame);
  const std::string id = candump.substr(0, candump.find('#')) + " ";
  DRIVECHECK_FUZZ_CHECK_DETAIL(line.starts_with(id),
                               "dissector line does not start with the candump identifier",
                               fmt::format("{} -> {}", frame, line));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  const std::uint8_t flags = in.u8();
  DissectorOptions options;
  if ((flags & 0x01) != 0) {
    for (std::size_t byte = 0; byte < 16; ++byte) {
      const std::uint8_t bits = in.u8();
      for (std::size_t bit = 0; bit < 8; ++bit)
        options.nodes[byte * 8 + bit] = ((bits >> bit) & 1) != 0;
    }
  }
  if ((flags & 0x02) != 0) {
    std::string name;
    for (const std::uint8_t byte : in.bytes(in.u8() % 33))
      name += (byte >= 0x20 && byte < 0x7F) ? static_cast<char>(byte) : '?';
    options.object_name = [name](std::uint16_t index,
                                 std::uint8_t sub_index) -> std::optional<std::string> {
      if (((index ^ sub_index) & 1) != 0) return std::nullopt;  // half known, half not
      return name;
    };
  }
  if ((flags & 0x04) != 0) {
    const unsigned mappings = in.u8() & 0x3;
    for (unsigned m = 0; m < mappings; ++m) {
      const std::uint32_t cob_id = in.u16() & can::kMaxStandardId;
      PdoMapping mapping;
      const unsigned entries = in.u8() & 0x7;
      for (unsigned e = 0; e < entries; ++e) {
        PdoMappingEntry entry;
        entry.index = in.u16();
        entry.sub_index = in.u8();
        entry.bits = in.u8();
        mapping.entries.push_back(entry);
      }
      options.pdo_mappings[cob_id] = mapping;
    }
  }
  if ((flags & 0x08) != 0) {
    options.sync_cob_id = in.u16() & can::kMaxStandardId;
    options.time_cob_id = in.u16() & can::kMaxStandardId;
  }

  Dissector dissector(options);
  while (!in.empty()) {
    const can::Frame frame = fuzz::decode_frame_record(in);
    check_line(dissector.line(frame), frame);
    const Dissection stateless = dissect_frame(frame, options);
    DRIVECHECK_FUZZ_CHECK(!stateless.summary().empty() && !stateless.function.empty(),
                          "empty stateless dissection");
  }
  return 0;
}

// Fuzz target: EMCY (CiA 301 §7.2.7): decode_emcy, the EMCY consumer, the EMCY code table,
// the 1014h COB-ID entry and the dissector's EMCY lines.
//
// Input: byte 0 history depth; byte 1 bits 1..0: number of COB-ID settings, each 5 bytes
// (node & 7Fh, 0 read as 1; then u32 LE: bit 31 restore 80h + node, bit 30 29-bit, the rest
// the CAN-ID); then 13-byte frame records (fuzz/support/frame_record.hpp) until the end.
// Oracles, per frame:
//   - decoding is total: a data frame with DLC 8 decodes, anything else is refused with a
//     reason; re-encoding a decoded EMCY on the frame's CAN-ID gives the same frame;
//   - the code table is consistent: the row found matches the code, and is the most specific
//     row of the hierarchy; descriptions are never empty;
//   - the consumer reports exactly the frames on a node's EMCY COB-ID, with that node; a
//     valid EMCY enters the node's history (bounded by the depth) and its counters;
//   - the dissector explains an EMCY on 081h..0FFh as EMCY of that node, valid iff it decodes;
//   - a 1014h value that decodes encodes to a value that decodes to the same entry.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "fuzz/support/frame_record.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/cia301/dissector.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/emcy_consumer.hpp"

namespace {

using namespace drivecheck;
using namespace drivecheck::cia301;

struct NodeId {
  std::uint32_t cob_id = 0;
  bool extended = false;
};

void check_code_table(std::uint16_t code) {
  const auto found = find_emcy_code(code);
  const auto hierarchy = emcy_code_hierarchy(code);
  DRIVECHECK_FUZZ_CHECK(found.has_value() == !hierarchy.empty(),
                        "find_emcy_code and emcy_code_hierarchy disagree");
  if (found) {
    DRIVECHECK_FUZZ_CHECK(found->matches(code), "found EMCY row does not match the code");
    DRIVECHECK_FUZZ_CHECK(hierarchy.back().code == found->code,
                          "the most specific row is not the last of the hierarchy");
    for (const EmcyCodeInfo& row : hierarchy)
      DRIVECHECK_FUZZ_CHECK(row.matches(code), "hierarchy row does not match the code");
  }
  DRIVECHECK_FUZZ_CHECK(!describe_emcy_code(code).empty(), "empty EMCY code description");
}

// The nodes whose EMCY COB-ID the frame is on, into `nodes`; returns how many. Oracle
// bookkeeping (127 comparisons per frame), not the code under test: not instrumented.
DRIVECHECK_FUZZ_ORACLE_CODE std::size_t nodes_on_cob_id(const std::array<NodeId, 128>& ids,
                                                        const can::Frame& frame,
                                                        std::array<std::uint8_t, 128>& nodes) {
  std::size_t count = 0;
  if (frame.is_error()) return 0;
  for (std::uint8_t node = 1; node < ids.size(); ++node) {
    if (ids[node].cob_id == frame.id && ids[node].extended == frame.is_extended()) {
      nodes[count++] = node;
    }
  }
  return count;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  const std::size_t depth = in.u8();
  EmcyConsumer consumer(depth);
  const std::size_t effective_depth = depth == 0 ? 1 : depth;

  std::array<NodeId, 128> ids{};
  for (std::uint32_t node = 1; node < ids.size(); ++node)
    ids[node] = {kEmcyBase + node, false};
  const unsigned settings = in.u8() & 0x3;
  for (unsigned i = 0; i < settings; ++i) {
    std::uint8_t node = in.u8() & 0x7F;
    if (node == 0) node = 1;
    const std::uint32_t value = in.u32();
    if ((value & 0x80000000u) != 0) {
      consumer.set_cob_id(node, std::nullopt);
      ids[node] = {std::uint32_t{kEmcyBase} + node, false};
    } else {
      const bool extended = (value & 0x40000000u) != 0;
      const std::uint32_t cob_id = value & (extended ? can::kMaxExtendedId : can::kMaxStandardId);
      consumer.set_cob_id(node, cob_id, extended);
      ids[node] = {cob_id, extended};
    }
  }

  Dissector dissector;
  can::TimePoint now{};
  while (!in.empty()) {
    const can::Frame frame = fuzz::decode_frame_record(in);
    now += std::chrono::microseconds(100);

    // decode_emcy: total, and re-encodes to the same frame.
    const auto emcy = decode_emcy(frame);
    const bool valid = frame.kind == can::FrameKind::data && frame.dlc == 8;
    DRIVECHECK_FUZZ_CHECK_EQ(emcy.has_value(), valid,
                             "decode_emcy accepts exactly the 8-byte data frames");
    if (emcy) {
      const can::Frame encoded = encode(*emcy, frame.id, frame.format);
      DRIVECHECK_FUZZ_CHECK_EQ(encoded.id, frame.id, "re-encoded EMCY has another CAN-ID");
      DRIVECHECK_FUZZ_CHECK(
          encoded.payload().size() == 8 &&
              std::equal(encoded.data.begin(), encoded.data.end(), frame.data.begin()),
          "re-encoded EMCY has other data bytes");
      DRIVECHECK_FUZZ_CHECK_EQ(encoded, frame, "re-encoded EMCY differs from the frame");
      check_code_table(emcy->error_code);
      DRIVECHECK_FUZZ_CHECK(!describe_error_register(emcy->error_register).empty(),
                            "empty error register description");
    } else {
      DRIVECHECK_FUZZ_CHECK(!emcy.error().reason.empty(), "EMCY refused without a reason");
    }

    // The consumer: exactly the frames on a node's COB-ID.
    std::array<std::uint8_t, 128> candidates{};
    const std::size_t candidate_count = nodes_on_cob_id(ids, frame, candidates);
    const auto event = consumer.on_frame(frame, now);
    DRIVECHECK_FUZZ_CHECK_EQ(event.has_value(), candidate_count != 0,
                             "consumer reports a frame iff it is on a node's EMCY COB-ID");
    if (event) {
      const std::uint8_t node = event->record.node;
      DRIVECHECK_FUZZ_CHECK(std::find(candidates.begin(), candidates.begin() + candidate_count,
                                      node) != candidates.begin() + candidate_count,
                            "consumer names a node whose COB-ID the frame is not on");
      if (emcy) {
        DRIVECHECK_FUZZ_CHECK(event->kind == (emcy->is_error_reset() ? EmcyEventKind::error_reset
                                                                     : EmcyEventKind::error),
                              "consumer event kind does not fit the error code");
        DRIVECHECK_FUZZ_CHECK(event->record.emcy == *emcy, "consumer decoded another EMCY");
        const auto& history = consumer.history(node);
        DRIVECHECK_FUZZ_CHECK(!history.empty() && history.size() <= effective_depth &&
                                  history.back().emcy == *emcy && history.back().time == now,
                              "the EMCY is not the last of a bounded history");
        DRIVECHECK_FUZZ_CHECK_EQ(consumer.error_active(node), !emcy->is_error_reset(),
                                 "error_active does not follow the last EMCY");
        DRIVECHECK_FUZZ_CHECK_EQ(consumer.error_register(node), emcy->error_register,
                                 "error_register does not follow the last EMCY");
        DRIVECHECK_FUZZ_CHECK(consumer.count(node) >= 1, "a valid EMCY was not counted");
      } else {
        DRIVECHECK_FUZZ_CHECK(event->kind == EmcyEventKind::invalid_frame && !event->reason.empty(),
                              "an invalid EMCY frame is not reported as invalid with a reason");
      }
    }

    // The dissector on the predefined EMCY COB-IDs.
    const Dissection dissection = dissector.dissect(frame);
    if (!frame.is_error() && !frame.is_extended() && frame.id > kEmcyBase && frame.id <= 0xFF) {
      DRIVECHECK_FUZZ_CHECK_EQ(dissection.function, std::string("EMCY"),
                               "dissector does not call 081h..0FFh EMCY");
      DRIVECHECK_FUZZ_CHECK(dissection.node == static_cast<std::uint8_t>(frame.id - kEmcyBase),
                            "dissector names another node for an EMCY");
      DRIVECHECK_FUZZ_CHECK_EQ(dissection.valid, valid,
                               "dissector's validity of an EMCY differs from decode_emcy");
    }
    DRIVECHECK_FUZZ_CHECK(!dissection.summary().empty(), "empty dissection");

    // 1014h COB-ID EMCY entry from the first four data bytes.
    const std::uint32_t entry_value = static_cast<std::uint32_t>(frame.data[0]) |
                                      static_cast<std::uint32_t>(frame.data[1]) << 8 |
                                      static_cast<std::uint32_t>(frame.data[2]) << 16 |
                                      static_cast<std::uint32_t>(frame.data[3]) << 24;
    if (const auto entry = decode_emcy_cob_id_entry(entry_value)) {
      const auto again = decode_emcy_cob_id_entry(entry->encode());
      DRIVECHECK_FUZZ_CHECK(again.has_value() && *again == *entry,
                            "1014h entry changed in an encode/decode round trip");
    }
  }
  return 0;
}

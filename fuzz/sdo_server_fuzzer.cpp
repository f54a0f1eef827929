// Fuzz target: the SDO server (protocol/cia301/sdo_server.hpp, CiA 301 §7.2.4) over the
// reference drive's object dictionary, fed any sequence of frames and time steps.
//
// Input (fuzz/support/fuzz_input.hpp reads past the end as zeros):
//   byte 0   configuration: bit 0 block transfer, bit 1 block CRC, bit 2 pad short frames
//   byte 1   timeout: 1 ms << (byte % 11)
//   byte 2   block size the server asks for
//   then operations, one byte each (op % 5) and its operands:
//     0 raw request      u8 DLC (% 9), 8 data bytes, on the request COB-ID
//     1 entry request    u8 command byte, u16 entry ordinal (% entries), 4 data bytes: the
//                        command with the index/sub-index of an existing entry
//     2 time step        u16 milliseconds
//     3 foreign frame    u16 identifier (11 bit), 8 data bytes: not for this server
//     4 remote frame     an RTR on the request COB-ID (CiA 301: SDOs are data frames)
//
// Oracles (CiA 301 §7.2.4, on every call):
//   - every frame the server sends has the response COB-ID, 8 data bytes, is a data frame,
//     and decodes (command framing, or block-segment framing inside a block upload);
//   - at most one response per request outside block uploads (a sub-block is the exception);
//   - a client's abort is never answered; frames that are not requests change nothing;
//   - an open transfer never outlives its timeout: at or after its deadline on_time() closes
//     it, and every deadline is at most one timeout after the last activity;
//   - the object dictionary changes only when a download completes (the confirming response
//     goes out in the same call and the server is idle), and only in the transfer's entry;
//     an expedited download with its size indicated stores exactly the bytes sent;
//   - an expedited upload response carries exactly the entry's bytes.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/cia301/sdo_server.hpp"
#include "reference_drive/dictionary.hpp"

namespace {

using namespace drivecheck;
using namespace drivecheck::cia301;
using drivecheck::fuzz::FuzzInput;

constexpr std::uint8_t kNode = 5;

struct EntryRef {
  std::uint16_t index;
  std::uint8_t sub;
};

// Whether two byte ranges are equal (a loop: no memcmp interceptor call per entry).
DRIVECHECK_FUZZ_ORACLE_CODE bool same_bytes(std::span<const std::uint8_t> a,
                                            std::span<const std::uint8_t> b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i] != b[i]) return false;
  }
  return true;
}

// Every entry's bytes and revision (ObjectDictionary change tracking), in the dictionary's
// order, as of the last check. After every request and time step update() finds what changed:
// nothing when the dictionary's revision() did not move, else the entries whose revision()
// moved, compared byte by byte (a store of the same bytes is no change). Once per input,
// verify() compares every entry's bytes, whatever its revision says: a change made through a
// path that bypassed the revision counters still fails the input it happened in. The shadow
// also remembers which entries changed since reset(), so that the next input's dictionary is
// restored by putting back those entries only.
class Shadow {
 public:
  explicit Shadow(const ObjectDictionary& od) : revision_(od.revision()) {
    for (const Object& object : od.objects()) {
      for (const Entry& entry : object.entries()) {
        const auto bytes = entry.bytes();
        // Room for the longest value a variable-length entry accepts (longer ones move to
        // the end of the buffer).
        const std::size_t room =
            std::max(bytes.size(), std::min<std::size_t>(entry.definition().max_size, 64));
        slots_.push_back({flat_.size(), bytes.size(), room, entry.revision()});
        flat_.insert(flat_.end(), bytes.begin(), bytes.end());
        flat_.resize(flat_.size() + (room - bytes.size()));
      }
    }
  }

  // The ordinals of the entries whose bytes differ from the copy; the copy takes them over.
  // Looks only at entries whose revision moved.
  DRIVECHECK_FUZZ_ORACLE_CODE const std::vector<std::size_t>& update(const ObjectDictionary& od) {
    changed_.clear();
    if (od.revision() == revision_) return changed_;
    revision_ = od.revision();
    std::size_t at = 0;
    for (const Object& object : od.objects()) {
      for (const Entry& entry : object.entries()) {
        Slot& slot = slots_[at];
        if (entry.revision() != slot.revision) {
          slot.revision = entry.revision();
          take(at, entry.bytes());
        }
        ++at;
      }
    }
    return changed_;
  }

  // The ordinals of the entries whose bytes differ from the copy, every entry compared
  // regardless of its revision (empty when the change tracking saw everything).
  DRIVECHECK_FUZZ_ORACLE_CODE std::vector<std::size_t> verify(const ObjectDictionary& od) const {
    std::vector<std::size_t> differ;
    std::size_t at = 0;
    for (const Object& object : od.objects()) {
      for (const Entry& entry : object.entries()) {
        const Slot& slot = slots_[at];
        if (!same_bytes(entry.bytes(), std::span(flat_).subspan(slot.offset, slot.size))) {
          differ.push_back(at);
        }
        ++at;
      }
    }
    return differ;
  }

  // Puts `od` (which this shadow follows) back to `pristine_od`, and the shadow to `pristine`
  // (that dictionary's shadow), in every entry that changed since the last reset; then takes
  // over `od`'s revisions. Harness work between inputs: not instrumented.
  DRIVECHECK_FUZZ_ORACLE_CODE void reset(ObjectDictionary& od, const ObjectDictionary& pristine_od,
                                         const Shadow& pristine,
                                         const std::vector<EntryRef>& entries) {
    for (const std::size_t at : dirty_) {
      Entry* entry = od.find(entries[at].index, entries[at].sub);
      const Entry* original = pristine_od.find(entries[at].index, entries[at].sub);
      DRIVECHECK_FUZZ_CHECK(entry != nullptr && original != nullptr &&
                                entry->assign_bytes(original->bytes()).has_value(),
                            "a changed entry could not be restored for the next input");
    }
    dirty_.clear();
    flat_ = pristine.flat_;
    slots_ = pristine.slots_;
    std::size_t at = 0;
    for (const Object& object : od.objects()) {
      for (const Entry& entry : object.entries())
        slots_[at++].revision = entry.revision();
    }
    revision_ = od.revision();
  }

 private:
  DRIVECHECK_FUZZ_ORACLE_CODE void take(std::size_t at, std::span<const std::uint8_t> bytes) {
    Slot& slot = slots_[at];
    if (same_bytes(bytes, std::span(flat_).subspan(slot.offset, slot.size))) return;
    changed_.push_back(at);
    if (std::find(dirty_.begin(), dirty_.end(), at) == dirty_.end()) dirty_.push_back(at);
    if (bytes.size() > slot.room) {
      slot.offset = flat_.size();
      slot.room = bytes.size();
      flat_.resize(flat_.size() + bytes.size());
    }
    slot.size = bytes.size();
    std::copy(bytes.begin(), bytes.end(), flat_.begin() + static_cast<std::ptrdiff_t>(slot.offset));
  }

  struct Slot {
    std::size_t offset;      // into flat_
    std::size_t size;        // the entry's length
    std::size_t room;        // bytes reserved at offset
    std::uint64_t revision;  // the entry's revision() when its bytes were taken
  };
  std::vector<std::uint8_t> flat_;  // every entry's bytes, one after the other
  std::vector<Slot> slots_;         // per entry, in the dictionary's order
  std::uint64_t revision_ = 0;      // the dictionary's revision() at the last update
  std::vector<std::size_t> changed_;
  std::vector<std::size_t> dirty_;  // ordinals changed since the last reset
};

std::vector<EntryRef> entry_list(const ObjectDictionary& od) {
  std::vector<EntryRef> out;
  for (const Object& object : od.objects()) {
    for (const Entry& entry : object.entries())
      out.push_back({object.index(), entry.sub_index()});
  }
  return out;
}

bool in_block_upload(SdoServer::State state) {
  return state == SdoServer::State::block_upload_start ||
         state == SdoServer::State::block_upload_ack || state == SdoServer::State::block_upload_end;
}

class Harness {
 public:
  // `shadow` holds `od`'s bytes; `entries` lists `od`'s entries in its order.
  Harness(ObjectDictionary& od, Shadow& shadow, const std::vector<EntryRef>& entries,
          SdoServerConfig config)
      : od_(od), shadow_(shadow), entries_(entries), server_(od, config) {}

  const std::vector<EntryRef>& entries() const { return entries_; }
  const SdoServerConfig& config() const { return server_.config(); }

  void request(const can::Frame& frame) {
    const SdoServer::State before = server_.state();
    const std::uint64_t completed_before = server_.statistics().completed;
    const bool is_request = server_.is_request(frame);
    // What the server reads: in pad mode a short request is read with its missing bytes as 00h.
    can::Frame read = frame;
    if (config().short_frames == ShortFramePolicy::pad && read.kind == can::FrameKind::data &&
        read.dlc < 8) {
      read.dlc = 8;
    }
    const SdoClientMessage message = decode_client_message(
        read, before == SdoServer::State::block_download_sub_block ? SdoFraming::block_segment
                                                                   : SdoFraming::command);

    const auto sent = server_.on_frame(frame, now_);
    const SdoServer::State after = server_.state();
    check_frames(sent, before, after);

    if (!is_request) {
      DRIVECHECK_FUZZ_CHECK(sent.empty(), "a frame that is not a request was answered");
      DRIVECHECK_FUZZ_CHECK(after == before, "a frame that is not a request changed the state");
    }
    if (std::holds_alternative<AbortTransfer>(message)) {
      DRIVECHECK_FUZZ_CHECK(sent.empty(), "a client's abort transfer was answered (§7.2.4.3.17)");
    }
    if (!in_block_upload(before) && !in_block_upload(after)) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(sent.size() <= 1, "more than one response to one request",
                                   fmt::format("{} responses to {}", sent.size(), frame));
    }
    if (server_.busy()) {
      DRIVECHECK_FUZZ_CHECK(server_.next_deadline() <= now_ + config().timeout,
                            "an open transfer's deadline is beyond one timeout from now");
    }
    check_dictionary(frame, message, sent, completed_before);
    check_upload(sent);
  }

  void advance(can::Duration step) {
    now_ += step;
    const SdoServer::State before = server_.state();
    const bool due = server_.busy() && now_ >= server_.next_deadline();
    const auto sent = server_.on_time(now_);
    check_frames(sent, before, server_.state());
    if (due) {
      DRIVECHECK_FUZZ_CHECK(!server_.busy(), "a transfer outlived its timeout");
      DRIVECHECK_FUZZ_CHECK(sent.size() == 1, "a timeout did not send exactly one abort");
      const SdoServerMessage abort = decode_server_message(sent.front());
      DRIVECHECK_FUZZ_CHECK(std::holds_alternative<AbortTransfer>(abort) &&
                                std::get<AbortTransfer>(abort).code ==
                                    static_cast<std::uint32_t>(SdoAbort::protocol_timed_out),
                            "a timeout is not aborted with 05040000h");
    } else {
      DRIVECHECK_FUZZ_CHECK(sent.empty(), "the server sent a frame before any deadline");
    }
    DRIVECHECK_FUZZ_CHECK(shadow_.update(od_).empty(), "time alone changed the dictionary");
  }

 private:
  void check_frames(std::span<const can::Frame> sent, SdoServer::State before,
                    SdoServer::State after) const {
    const bool block_upload = in_block_upload(before) || in_block_upload(after);
    for (const can::Frame& frame : sent) {
      DRIVECHECK_FUZZ_CHECK_EQ(frame.id, config().tx_cob_id, "response on a wrong COB-ID");
      DRIVECHECK_FUZZ_CHECK_EQ(std::size_t{frame.dlc}, std::size_t{8},
                               "an SDO response without 8 data bytes");
      DRIVECHECK_FUZZ_CHECK(frame.kind == can::FrameKind::data, "the server sent a non-data frame");
      bool decodes =
          !std::holds_alternative<SdoInvalid>(decode_server_message(frame, SdoFraming::command));
      if (!decodes && block_upload) {
        decodes = !std::holds_alternative<SdoInvalid>(
            decode_server_message(frame, SdoFraming::block_segment));
      }
      DRIVECHECK_FUZZ_CHECK_DETAIL(decodes, "the server sent a malformed SDO frame",
                                   fmt::format("{}", frame));
    }
  }

  void check_dictionary(const can::Frame& frame, const SdoClientMessage& message,
                        std::span<const can::Frame> sent, std::uint64_t completed_before) {
    const std::vector<std::size_t>& changed = shadow_.update(od_);
    if (changed.empty()) return;
    const std::string where = fmt::format("request {}", frame);
    DRIVECHECK_FUZZ_CHECK_DETAIL(!server_.busy(), "the dictionary changed mid-transfer", where);
    DRIVECHECK_FUZZ_CHECK_DETAIL(server_.statistics().completed == completed_before + 1,
                                 "the dictionary changed without a completed transfer", where);
    DRIVECHECK_FUZZ_CHECK_DETAIL(sent.size() == 1, "the dictionary changed without a response",
                                 where);
    const SdoServerMessage response = decode_server_message(sent.front());
    const bool confirms = std::holds_alternative<InitiateDownloadResponse>(response) ||
                          std::holds_alternative<DownloadSegmentResponse>(response) ||
                          std::holds_alternative<BlockDownloadEndResponse>(response);
    DRIVECHECK_FUZZ_CHECK_DETAIL(confirms, "the dictionary changed without a download response",
                                 where);
    if (std::holds_alternative<InitiateDownloadResponse>(response)) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(std::holds_alternative<InitiateDownloadRequest>(message) &&
                                       std::get<InitiateDownloadRequest>(message).expedited,
                                   "only an expedited initiate may change the dictionary", where);
    }

    // Only the transfer's entry changed.
    const Multiplexer mux = server_.multiplexer();
    for (const std::size_t ordinal : changed) {
      const EntryRef entry = entries_[ordinal];
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          entry.index == mux.index && entry.sub == mux.sub_index,
          "a download changed another entry",
          fmt::format("{:04X}h sub {} changed by a transfer to {}", entry.index, entry.sub, mux));
    }
    if (const auto* request = std::get_if<InitiateDownloadRequest>(&message);
        request != nullptr && request->expedited && request->size_indicated) {
      const Entry* entry = od_.find(mux.index, mux.sub_index);
      DRIVECHECK_FUZZ_CHECK(entry != nullptr, "a download changed an entry that does not exist");
      const auto data = request->expedited_data();
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          std::equal(entry->bytes().begin(), entry->bytes().end(), data.begin(), data.end()),
          "an expedited download stored other bytes than it sent", where);
    }
  }

  void check_upload(std::span<const can::Frame> sent) const {
    if (sent.size() != 1) return;
    const SdoServerMessage response = decode_server_message(sent.front());
    const auto* upload = std::get_if<InitiateUploadResponse>(&response);
    if (upload == nullptr || !upload->expedited) return;
    const Entry* entry = od_.find(upload->mux.index, upload->mux.sub_index);
    DRIVECHECK_FUZZ_CHECK(entry != nullptr, "an upload of an entry that does not exist");
    if (!upload->size_indicated) return;
    const auto data = upload->expedited_data();
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        std::equal(entry->bytes().begin(), entry->bytes().end(), data.begin(), data.end()),
        "an expedited upload does not carry the entry's bytes", fmt::format("{}", sent.front()));
  }

  ObjectDictionary& od_;
  Shadow& shadow_;
  const std::vector<EntryRef>& entries_;
  SdoServer server_;
  can::TimePoint now_ = can::TimePoint(std::chrono::seconds(1));
};

// A data frame with `dlc`; bytes past the DLC stay zero (Frame's invariant).
can::Frame make_frame(std::uint32_t id, std::span<const std::uint8_t> data, std::uint8_t dlc) {
  can::Frame frame;
  frame.id = id;
  frame.dlc = dlc;
  for (std::size_t i = 0; i < data.size() && i < frame.length(); ++i)
    frame.data[i] = data[i];
  return frame;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzInput in(data, size);
  const std::uint8_t flags = in.u8();
  SdoServerConfig config = SdoServerConfig::for_node(kNode);
  config.block_transfer = (flags & 0x01) != 0;
  config.block_crc = (flags & 0x02) != 0;
  config.short_frames = (flags & 0x04) != 0 ? ShortFramePolicy::pad : ShortFramePolicy::ignore;
  config.timeout = std::chrono::milliseconds(1) * (1 << (in.u8() % 11));
  config.block_size = in.u8();
  config.max_download_size = 4096;

  // Built once. The dictionary the inputs run on is a copy of it; before each input the
  // entries the previous input changed are put back. Every entry is back: the previous input
  // ended with a full comparison (verify) of the dictionary with its shadow, the shadow differs
  // from the pristine one only in the entries it lists as changed, and those are restored from
  // the pristine dictionary (each input starts from the same dictionary).
  static const auto kDictionary = [] {
    reference_drive::DictionaryOptions options;
    options.node_id = kNode;
    auto built = reference_drive::build_dictionary(options);
    DRIVECHECK_FUZZ_CHECK_DETAIL(built.has_value(), "the reference dictionary does not build",
                                 built ? std::string() : built.error());
    return std::move(*built);
  }();
  static const Shadow kShadow(kDictionary);
  static const std::vector<EntryRef> kEntries = entry_list(kDictionary);
  static ObjectDictionary od = kDictionary;
  static Shadow shadow = kShadow;
  shadow.reset(od, kDictionary, kShadow, kEntries);
  DRIVECHECK_FUZZ_CHECK(od.node_id() == kNode, "the dictionary was not restored for this input");
  Harness harness(od, shadow, kEntries, config);

  while (!in.empty()) {
    switch (in.u8() % 5) {
      case 0: {
        const std::uint8_t dlc = static_cast<std::uint8_t>(in.u8() % 9);
        harness.request(make_frame(config.rx_cob_id, in.bytes(8), dlc));
        break;
      }
      case 1: {
        const std::uint8_t command = in.u8();
        const EntryRef entry = harness.entries()[in.u16() % harness.entries().size()];
        std::array<std::uint8_t, 8> bytes{command, static_cast<std::uint8_t>(entry.index & 0xFF),
                                          static_cast<std::uint8_t>(entry.index >> 8), entry.sub};
        const auto value = in.bytes(4);
        std::copy(value.begin(), value.end(), bytes.begin() + 4);
        harness.request(make_frame(config.rx_cob_id, bytes, 8));
        break;
      }
      case 2:
        harness.advance(std::chrono::milliseconds(in.u16()));
        break;
      case 3: {
        const std::uint32_t id = in.u16() & 0x7FFu;
        harness.request(make_frame(id, in.bytes(8), 8));
        break;
      }
      default: {
        harness.request(can::Frame::remote(config.rx_cob_id, 8));
        break;
      }
    }
  }
  // Every change went through the revision counters: the byte-by-byte comparison of the whole
  // dictionary agrees with what update() saw after each call.
  const std::vector<std::size_t> untracked = shadow.verify(od);
  DRIVECHECK_FUZZ_CHECK_DETAIL(untracked.empty(), "an entry changed without its revision()",
                               fmt::format("{:04X}h sub {} and {} more",
                                           untracked.empty() ? 0 : kEntries[untracked[0]].index,
                                           untracked.empty() ? 0 : kEntries[untracked[0]].sub,
                                           untracked.empty() ? 0 : untracked.size() - 1));
  return 0;
}

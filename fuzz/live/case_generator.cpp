#include "fuzz/live/case_generator.hpp"

#include <algorithm>
#include <array>
#include <string_view>
#include <utility>

#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::fuzz_live {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kNmtId = 0x000;
constexpr std::uint32_t kSyncId = 0x080;
constexpr std::uint32_t kTimeId = 0x100;
constexpr std::uint32_t kErrorControlBase = 0x700;
constexpr std::uint32_t kSdoRequestBase = 0x600;

constexpr std::array<std::string_view, 10> kKinds = {
    "sdo-expedited-upload",
    "sdo-expedited-download",
    "sdo-segmented-upload",
    "sdo-segmented-download",
    "sdo-block-download",
    "sdo-block-upload",
    "sdo-raw",
    "pdo-mapping",
    "nmt",
    "error-control",
};
// Relative weights of the kinds above (sdo-raw twice: it reaches the most server states).
constexpr std::array<unsigned, 10> kWeights = {1, 1, 1, 1, 1, 1, 2, 1, 1, 1};

std::uint64_t mix(std::uint64_t seed, std::uint64_t number) {
  Prng p(seed ^ (number * 0x9E3779B97F4A7C15ULL));
  (void)p.next();
  return p.next();
}

using Bytes = std::array<std::uint8_t, 8>;

void put_le(Bytes& bytes, std::size_t at, std::uint64_t value, std::size_t count) {
  for (std::size_t i = 0; i < count && at + i < bytes.size(); ++i)
    bytes[at + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

struct Mux {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
};

// Builds one case: frames with their gaps, then the safety filter.
class Builder {
 public:
  Builder(const GeneratorOptions& options, const std::vector<FuzzObject>& objects, Prng& rng)
      : options_(options), objects_(objects), rng_(rng) {
    for (const auto& object : objects_) {
      if (object.writable && allowed_write(object.index)) writable_.push_back(&object);
    }
    gap_ = rng_.chance(10) ? 0ms : options_.gap;
  }

  std::uint32_t sdo_id() const { return kSdoRequestBase + options_.node; }

  void add(const can::Frame& frame, std::optional<can::Duration> delay = std::nullopt) {
    steps_.push_back({frame, delay.value_or(gap_)});
  }
  void sdo(const Bytes& bytes, std::size_t length = 8) {
    add(can::Frame::standard(sdo_id(), std::span<const std::uint8_t>(bytes.data(), length)));
  }

  const FuzzObject& any_object() { return objects_[rng_.below(objects_.size())]; }
  const FuzzObject& write_object() {
    if (writable_.empty() || rng_.chance(15)) return any_object();
    return *writable_[rng_.below(writable_.size())];
  }

  // The object's own multiplexer, or a neighbour: a missing sub-index, the next index, any.
  Mux mutate_mux(const FuzzObject& object) {
    Mux mux{object.index, object.sub};
    switch (rng_.below(10)) {
      case 0:
        mux.sub = static_cast<std::uint8_t>(object.sub + 1 + rng_.below(3));
        break;
      case 1:
        mux.sub = rng_.byte();
        break;
      case 2:
        mux.index = static_cast<std::uint16_t>(object.index + 1);
        break;
      case 3:
        mux.index = static_cast<std::uint16_t>(rng_.next());
        break;
      default:
        break;
    }
    return mux;
  }

  // A value at or past the object's limits, `size` bytes little-endian.
  std::uint64_t boundary_value(const FuzzObject& object, std::size_t size) {
    const std::uint64_t all_ones = size >= 8 ? ~0ULL : ((1ULL << (8 * size)) - 1);
    const std::uint64_t top = size == 0 ? 0 : (1ULL << (8 * size - 1));
    switch (rng_.below(9)) {
      case 0:
        return 0;
      case 1:
        return 1;
      case 2:
        return all_ones;
      case 3:
        return top;
      case 4:
        return top - 1;
      case 5:
        return static_cast<std::uint64_t>(object.min.value_or(0));
      case 6:
        return static_cast<std::uint64_t>(object.max.value_or(0));
      case 7:
        return static_cast<std::uint64_t>(object.min.value_or(0) - 1);
      case 8:
        return static_cast<std::uint64_t>(object.max.value_or(0) + 1);
      default:
        return rng_.next();
    }
  }

  Bytes initiate(std::uint8_t command, Mux mux) {
    Bytes bytes{};
    bytes[0] = command;
    put_le(bytes, 1, mux.index, 2);
    bytes[3] = mux.sub;
    return bytes;
  }

  // ---- the kinds ----

  void expedited_upload() { sdo(initiate(0x40, mutate_mux(any_object()))); }

  void expedited_download() {
    const FuzzObject& object = write_object();
    std::size_t size = object.size >= 1 && object.size <= 4 ? object.size : 4;
    std::size_t indicated = size;
    if (rng_.chance(20)) indicated = 1 + rng_.below(4);  // size mismatch
    // ccs=1 e=1 s=1 n=4-size: 2Fh (1 byte) 2Bh (2) 27h (3) 23h (4)
    auto command = static_cast<std::uint8_t>(0x23 | ((4 - indicated) << 2));
    if (rng_.chance(10)) command = 0x22;  // e=1 s=0: size not indicated
    Bytes bytes = initiate(command, mutate_mux(object));
    put_le(bytes, 4, boundary_value(object, size), size);
    sdo(bytes);
  }

  void segmented_upload() {
    const FuzzObject& object = any_object();
    sdo(initiate(0x40, mutate_mux(object)));
    const std::size_t segments = 1 + rng_.below(5);
    const std::size_t wrong_at = rng_.chance(25) ? rng_.below(segments) : segments;
    for (std::size_t i = 0; i < segments; ++i) {
      // ccs=3 upload segment request: 0 1 1 t 0 0 0 0
      unsigned toggle = (i % 2) ^ (i == wrong_at ? 1U : 0U);
      Bytes bytes{};
      bytes[0] = static_cast<std::uint8_t>(0x60 | (toggle << 4));
      if (rng_.chance(5)) bytes[0] = rng_.byte();
      sdo(bytes);
    }
  }

  std::vector<std::uint8_t> payload(const FuzzObject& object, std::size_t min_length) {
    std::size_t length = object.size > 4 ? object.size : min_length + rng_.below(16);
    if (rng_.chance(20)) length = rng_.below(24);
    std::vector<std::uint8_t> data(length);
    for (auto& byte : data)
      byte = rng_.chance(50) ? 0 : rng_.byte();
    return data;
  }

  void segmented_download() {
    const FuzzObject& object = write_object();
    const auto data = payload(object, 5);
    std::uint32_t indicated = static_cast<std::uint32_t>(data.size());
    if (rng_.chance(20)) indicated = static_cast<std::uint32_t>(rng_.below(32));
    // ccs=1 e=0 s=1: 21h idx sub size(4); 20h: size not indicated
    Bytes init = initiate(rng_.chance(10) ? 0x20 : 0x21, mutate_mux(object));
    put_le(init, 4, indicated, 4);
    sdo(init);
    const std::size_t segments = std::max<std::size_t>(1, (data.size() + 6) / 7);
    const bool drop_last = rng_.chance(15);
    const std::size_t wrong_toggle = rng_.chance(20) ? rng_.below(segments) : segments;
    for (std::size_t i = 0; i < segments; ++i) {
      if (drop_last && i + 1 == segments) break;
      // ccs=0 download segment: 0 0 0 t n n n c (n: bytes without data, c: last)
      const std::size_t from = i * 7;
      const std::size_t count = std::min<std::size_t>(7, data.size() - std::min(from, data.size()));
      const bool last = i + 1 == segments;
      unsigned toggle = (i % 2) ^ (i == wrong_toggle ? 1U : 0U);
      Bytes bytes{};
      bytes[0] = static_cast<std::uint8_t>((toggle << 4) | ((7 - count) << 1) | (last ? 1 : 0));
      for (std::size_t k = 0; k < count; ++k)
        bytes[1 + k] = data[from + k];
      sdo(bytes);
    }
  }

  void block_download() {
    const FuzzObject& object = write_object();
    const auto data = payload(object, 1);
    std::uint32_t indicated = static_cast<std::uint32_t>(data.size());
    if (rng_.chance(15)) indicated = static_cast<std::uint32_t>(rng_.below(64));
    // ccs=6 cc=1 s=1 cs=0: C6h idx sub size(4)
    Bytes init = initiate(0xC6, mutate_mux(object));
    put_le(init, 4, indicated, 4);
    sdo(init);
    const std::size_t segments = std::max<std::size_t>(1, (data.size() + 6) / 7);
    const std::size_t bad_seq = rng_.chance(20) ? rng_.below(segments) : segments;
    const bool truncate = rng_.chance(10);
    for (std::size_t i = 0; i < segments; ++i) {
      if (truncate && i + 1 == segments) break;
      // c seqno(7), then 7 data bytes
      const bool last = i + 1 == segments;
      std::size_t seqno = i + 1;
      if (i == bad_seq) seqno = rng_.chance(50) ? 0 : i + 2 + rng_.below(3);
      Bytes bytes{};
      bytes[0] = static_cast<std::uint8_t>((last ? 0x80 : 0) | (seqno & 0x7F));
      for (std::size_t k = 0; k < 7 && i * 7 + k < data.size(); ++k)
        bytes[1 + k] = data[i * 7 + k];
      sdo(bytes);
    }
    if (rng_.chance(10)) return;  // no end
    const std::size_t tail = data.empty() ? 0 : data.size() - (segments - 1) * 7;
    std::size_t unused = 7 - std::min<std::size_t>(7, tail);
    if (rng_.chance(15)) unused = rng_.below(8);
    std::uint16_t crc = cia301::crc16_ccitt(data);
    if (rng_.chance(20)) crc = static_cast<std::uint16_t>(crc ^ (1U << rng_.below(16)));
    // ccs=6 n(3) cs=1: C1h | n << 2, CRC(2)
    Bytes end{};
    end[0] = static_cast<std::uint8_t>(0xC1 | (unused << 2));
    put_le(end, 1, crc, 2);
    sdo(end);
  }

  void block_upload() {
    const FuzzObject& object = any_object();
    // ccs=5 cc=1 cs=0: A4h idx sub blksize pst
    Bytes init = initiate(0xA4, mutate_mux(object));
    std::uint8_t blksize = static_cast<std::uint8_t>(1 + rng_.below(127));
    if (rng_.chance(15))
      blksize = rng_.chance(50) ? 0 : static_cast<std::uint8_t>(0x80 | rng_.byte());
    init[4] = blksize;
    init[5] = rng_.chance(20) ? rng_.byte() : 0;  // pst
    sdo(init);
    if (rng_.chance(10)) return;
    sdo(Bytes{0xA3});  // start upload (cs=3)
    // ack: A2h ackseq blksize
    Bytes ack{0xA2};
    ack[1] = rng_.chance(70) ? 1 : rng_.byte();
    ack[2] = rng_.chance(80) ? blksize : rng_.byte();
    sdo(ack);
    if (rng_.chance(70)) sdo(Bytes{0xA1});  // end response
  }

  void raw() {
    const FuzzObject& object = any_object();
    static constexpr std::array<std::uint8_t, 6> kRequests = {0x40, 0x23, 0x21, 0xC6, 0xA4, 0x60};
    Bytes bytes = initiate(kRequests[rng_.below(kRequests.size())], mutate_mux(object));
    put_le(bytes, 4, boundary_value(object, 4), 4);
    std::size_t length = 8;
    switch (rng_.below(4)) {
      case 0:
      case 1: {
        // a command specifier 0..7 with random low bits (ccs 4 = abort, 7 = reserved)
        const auto ccs = static_cast<std::uint8_t>(rng_.below(8));
        bytes[0] = static_cast<std::uint8_t>((ccs << 5) | (rng_.byte() & 0x1F));
        break;
      }
      case 2:
        length = rng_.below(8);
        break;  // truncated DLC
      default:
        bytes[1 + rng_.below(7)] = rng_.byte();
        break;
    }
    sdo(bytes, length);
  }

  void download_u32(Mux mux, std::uint32_t value) {
    Bytes bytes = initiate(0x23, mux);
    put_le(bytes, 4, value, 4);
    sdo(bytes);
  }
  void download_u8(Mux mux, std::uint8_t value) {
    Bytes bytes = initiate(0x2F, mux);
    bytes[4] = value;
    sdo(bytes);
  }

  void pdo_mapping() {
    const bool rpdo = rng_.chance(50);
    const auto n = static_cast<std::uint16_t>(rng_.below(4));
    const std::uint16_t comm = static_cast<std::uint16_t>((rpdo ? 0x1400 : 0x1800) + n);
    const std::uint16_t map = static_cast<std::uint16_t>((rpdo ? 0x1600 : 0x1A00) + n);
    const std::uint32_t cob = (rpdo ? 0x200U : 0x180U) + 0x100U * n + options_.node;
    // Flags only (bit 31 valid, 30 RTR, 29 frame): never another identifier, which on a real
    // bus could make the drive send NMT or SYNC frames.
    const auto cob_value = [&](bool disabled) {
      std::uint32_t v = cob | (disabled ? 0x80000000U : 0U);
      if (rng_.chance(10)) v ^= 1U << (29 + rng_.below(3));
      return v;
    };
    struct Write {
      Mux mux;
      std::uint32_t value;
      bool u8;
    };
    std::vector<Write> writes;
    writes.push_back({{comm, 1}, cob_value(true), false});
    writes.push_back({{map, 0}, 0, true});
    const std::size_t entries = 1 + rng_.below(4);
    for (std::size_t i = 0; i < entries; ++i) {
      const FuzzObject& object = any_object();
      std::uint32_t bits = object.size >= 1 && object.size <= 8 ? object.size * 8U : 8U;
      if (rng_.chance(15)) bits = static_cast<std::uint32_t>(rng_.below(0x48));
      const std::uint32_t entry = (static_cast<std::uint32_t>(object.index) << 16) |
                                  (std::uint32_t{object.sub} << 8) | bits;
      writes.push_back({{map, static_cast<std::uint8_t>(1 + i)}, entry, false});
    }
    std::uint8_t count = static_cast<std::uint8_t>(entries);
    if (rng_.chance(15)) count = static_cast<std::uint8_t>(rng_.below(0x42));
    writes.push_back({{map, 0}, count, true});
    static constexpr std::array<std::uint8_t, 6> kTypes = {0, 1, 2, 0xF0, 0xFE, 0xFF};
    writes.push_back({{comm, 2}, kTypes[rng_.below(kTypes.size())], true});
    writes.push_back({{comm, 1}, cob_value(false), false});
    // Wrong orders: a swap, a dropped step.
    if (rng_.chance(30)) {
      std::swap(writes[rng_.below(writes.size())], writes[rng_.below(writes.size())]);
    }
    if (rng_.chance(20))
      writes.erase(writes.begin() + static_cast<std::ptrdiff_t>(rng_.below(writes.size())));
    for (const auto& w : writes) {
      if (w.u8) {
        download_u8(w.mux, static_cast<std::uint8_t>(w.value));
      } else {
        download_u32(w.mux, w.value);
      }
    }
    // NMT start node, then SYNC frames to trigger synchronous TPDOs.
    add(can::Frame::standard(kNmtId, {0x01, options_.node}));
    const std::size_t syncs = rng_.below(4);
    for (std::size_t i = 0; i < syncs; ++i)
      add(can::Frame::standard(kSyncId, std::span<const std::uint8_t>{}));
    if (rpdo && options_.allow_motion) {
      Bytes data{};
      for (auto& byte : data)
        byte = rng_.byte();
      add(can::Frame::standard(cob, std::span<const std::uint8_t>(data.data(), rng_.below(9))));
    }
  }

  void nmt() {
    const std::size_t commands = 1 + rng_.below(4);
    static constexpr std::array<std::uint8_t, 5> kKnown = {0x01, 0x02, 0x80, 0x81, 0x82};
    for (std::size_t i = 0; i < commands; ++i) {
      std::uint8_t cs = kKnown[rng_.below(kKnown.size())];
      if (rng_.chance(30)) {
        do {
          cs = rng_.byte();
        } while (std::find(kKnown.begin(), kKnown.end(), cs) != kKnown.end());
      }
      std::uint8_t target = options_.node;
      switch (rng_.below(10)) {
        case 0:
        case 1:
          target = 0;
          break;
        case 2:
        case 3:
          target = static_cast<std::uint8_t>(options_.node % 127 + 1);
          break;
        case 4:
          target = rng_.byte();
          break;
        default:
          break;
      }
      Bytes bytes{cs, target};
      std::size_t length = rng_.chance(10) ? rng_.below(9) : 2;
      // A reset takes the node through initialisation: give it time for its boot-up.
      const bool reset = cs == 0x81 || cs == 0x82;
      add(can::Frame::standard(kNmtId, std::span<const std::uint8_t>(bytes.data(), length)),
          reset ? std::optional<can::Duration>(50ms) : std::nullopt);
    }
  }

  void error_control() {
    const std::size_t frames = 1 + rng_.below(6);
    for (std::size_t i = 0; i < frames; ++i) {
      Bytes bytes{};
      switch (rng_.below(4)) {
        case 0: {  // SYNC: no data, or a counter 1..240, or a wrong length
          const std::size_t length = rng_.chance(60) ? 0 : (rng_.chance(60) ? 1 : rng_.below(9));
          bytes[0] = static_cast<std::uint8_t>(1 + rng_.below(240));
          if (rng_.chance(10)) bytes[0] = rng_.byte();
          add(can::Frame::standard(kSyncId, std::span<const std::uint8_t>(bytes.data(), length)));
          break;
        }
        case 1: {  // heartbeat of another node: 1 byte NMT state
          static constexpr std::array<std::uint8_t, 4> kStates = {0x00, 0x04, 0x05, 0x7F};
          std::uint8_t other = static_cast<std::uint8_t>(1 + rng_.below(127));
          if (other == options_.node) other = static_cast<std::uint8_t>(other % 127 + 1);
          bytes[0] = rng_.chance(80) ? kStates[rng_.below(kStates.size())] : rng_.byte();
          const std::size_t length = rng_.chance(85) ? 1 : rng_.below(9);
          add(can::Frame::standard(kErrorControlBase + other,
                                   std::span<const std::uint8_t>(bytes.data(), length)));
          break;
        }
        case 2: {  // node guarding request: RTR 700h+N, DLC 1 (or wrong)
          const auto dlc = static_cast<std::uint8_t>(rng_.chance(80) ? 1 : rng_.below(9));
          add(can::Frame::remote(kErrorControlBase + options_.node, dlc));
          break;
        }
        default: {  // TIME: 6 bytes (ms after midnight, days since 1984)
          for (auto& byte : bytes)
            byte = rng_.byte();
          const std::size_t length = rng_.chance(80) ? 6 : rng_.below(9);
          add(can::Frame::standard(kTimeId, std::span<const std::uint8_t>(bytes.data(), length)));
          break;
        }
      }
    }
  }

  std::vector<CaseStep> finish() {
    std::vector<CaseStep> steps;
    for (auto& step : steps_) {
      if (is_allowed_frame(step.frame, options_.node, options_.allow_motion)) steps.push_back(step);
    }
    return steps;
  }

  bool allowed_write(std::uint16_t index) const {
    return is_allowed_write(index, options_.allow_motion);
  }

 private:
  const GeneratorOptions& options_;
  const std::vector<FuzzObject>& objects_;
  Prng& rng_;
  std::vector<const FuzzObject*> writable_;
  std::vector<CaseStep> steps_;
  can::Duration gap_{};
};

bool is_download_initiate(const can::Frame& frame) {
  if (frame.length() < 1) return false;
  const std::uint8_t command = frame.data[0];
  const unsigned ccs = command >> 5;
  return ccs == 1 || (ccs == 6 && (command & 0x01) == 0);
}

}  // namespace

std::uint64_t Prng::next() {
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

bool is_allowed_write(std::uint16_t index, bool allow_motion) {
  if (index == 0x1010 || index == 0x1011) return false;  // store / restore parameters
  if (index >= 0x1F50 && index <= 0x1F5F) return false;  // program download and control
  if (index == 0x6040 && !allow_motion) return false;    // controlword
  return true;
}

bool is_allowed_frame(const can::Frame& frame, std::uint8_t node, bool allow_motion) {
  if (frame.is_extended() || frame.is_error()) return false;
  if (frame.id == kSdoRequestBase + node && !frame.is_remote() && is_download_initiate(frame) &&
      frame.length() >= 3) {
    const auto index = static_cast<std::uint16_t>(frame.data[1] | (frame.data[2] << 8));
    if (!is_allowed_write(index, allow_motion)) return false;
  }
  // PDO identifiers (default RPDOs 200h..57Fh carry the controlword on a CiA 402 drive).
  if (!allow_motion && frame.id >= 0x180 && frame.id <= 0x57F) return false;
  return true;
}

bool needs_communication_reset(std::span<const can::Frame> frames) {
  for (const auto& frame : frames) {
    if (frame.is_extended() || frame.is_error()) continue;
    if (frame.id == kNmtId) return true;
    if (frame.id > kSdoRequestBase && frame.id <= kSdoRequestBase + 127 && !frame.is_remote() &&
        is_download_initiate(frame) && frame.length() >= 3 && (frame.data[2] & 0xF0) == 0x10) {
      return true;
    }
  }
  return false;
}

bool resets_node(std::span<const can::Frame> frames, std::uint8_t node) {
  return std::any_of(frames.begin(), frames.end(), [node](const can::Frame& frame) {
    return !frame.is_extended() && !frame.is_remote() && frame.id == kNmtId &&
           frame.length() >= 2 && (frame.data[0] == 0x81 || frame.data[0] == 0x82) &&
           (frame.data[1] == 0 || frame.data[1] == node);
  });
}

CaseGenerator::CaseGenerator(GeneratorOptions options, std::vector<FuzzObject> objects)
    : options_(options), objects_(std::move(objects)) {
  if (objects_.empty()) objects_ = builtin_objects();
}

std::span<const std::string_view> CaseGenerator::kinds() {
  return kKinds;
}

FuzzCase CaseGenerator::generate(std::uint64_t number) const {
  Prng rng(mix(options_.seed, number));
  unsigned total = 0;
  for (unsigned weight : kWeights)
    total += weight;
  auto pick = static_cast<unsigned>(rng.below(total));
  std::size_t kind = 0;
  while (pick >= kWeights[kind]) {
    pick -= kWeights[kind];
    ++kind;
  }
  Builder builder(options_, objects_, rng);
  switch (kind) {
    case 0:
      builder.expedited_upload();
      break;
    case 1:
      builder.expedited_download();
      break;
    case 2:
      builder.segmented_upload();
      break;
    case 3:
      builder.segmented_download();
      break;
    case 4:
      builder.block_download();
      break;
    case 5:
      builder.block_upload();
      break;
    case 6:
      builder.raw();
      break;
    case 7:
      builder.pdo_mapping();
      break;
    case 8:
      builder.nmt();
      break;
    default:
      builder.error_control();
      break;
  }
  return FuzzCase{number, std::string(kKinds[kind]), builder.finish()};
}

std::vector<FuzzObject> builtin_objects() {
  // CiA 301 §7.5.2: device type, error register, device name, identity object, heartbeat.
  return {
      {0x1000, 0, 4, false, {}, {}},  {0x1001, 0, 1, false, {}, {}}, {0x1008, 0, 0, false, {}, {}},
      {0x1017, 0, 2, true, 0, 65535}, {0x1018, 0, 1, false, {}, {}}, {0x1018, 1, 4, false, {}, {}},
      {0x1018, 2, 4, false, {}, {}},  {0x1018, 3, 4, false, {}, {}}, {0x1018, 4, 4, false, {}, {}},
      {0x1005, 0, 4, true, {}, {}},   {0x1014, 0, 4, true, {}, {}},  {0x1003, 0, 1, true, 0, 0},
  };
}

}  // namespace drivecheck::fuzz_live

// The live fuzzer's case generator: protocol-aware, stateful sequences of frames for one
// CANopen node, from a seeded generator (same seed, same case number => same case).
//
// A case is a short script the harness sends with fixed gaps (CaseStep::delay_after): a valid
// session of one service with one or more fields mutated. Kinds (FuzzCase::kind):
//   sdo-expedited-upload    600h+N  40h idx sub 00000000            (ccs=2 initiate upload)
//   sdo-expedited-download  600h+N  2Fh/2Bh/27h/23h idx sub value   (ccs=1 e=1 s=1 n=4-len)
//   sdo-segmented-upload    600h+N  40h idx sub, then 60h/70h       (ccs=3 upload segment, t)
//   sdo-segmented-download  600h+N  21h idx sub size(4), then segments 0tnnnc + 7 bytes
//   sdo-block-download      600h+N  C6h idx sub size (ccs=6 cc=1 s=1), segments seqno|c<<7,
//                                   end C1h|n<<2 crc(2)
//   sdo-block-upload        600h+N  A4h idx sub blksize pst, start A3h, ack A2h ackseq blksize,
//                                   end A1h
//   sdo-raw                 any SDO request with a random command byte, a truncated DLC or a
//                                   random byte changed
//   pdo-mapping             the 1400h/1600h (RPDO) or 1800h/1A00h (TPDO) procedure of CiA 301
//                                   §7.5.2.36: COB-ID bit 31 := 1, mapping sub 0 := 0, entries,
//                                   sub 0 := n, COB-ID bit 31 := 0, with steps dropped, swapped
//                                   or given wrong values; then NMT start and SYNC frames
//   nmt                     000h    cs node: 1-4 commands, cs from {01 02 80 81 82, any}, node
//                                   from {N, 0, another, any}
//   error-control           SYNC (080h, 0-1 byte counter, wrong DLC), heartbeats of other nodes
//                                   (700h+x, 1 byte state), guarding requests (RTR 700h+N), TIME
// Mutated fields: command byte, index/sub-index (neighbours and missing subs), sizes, toggle
// bit, sequence numbers, CRC, DLC truncation, values at and past the dictionary's limits.
//
// Safety (DESIGN.md "Safety on real drives"): the generator never writes the controlword
// (6040h) unless allow_motion, never sends RPDO data frames unless allow_motion, and never
// writes store/restore (1010h/1011h) or program control (1F50h..1F5Fh), whatever the mutation:
// every frame passes is_allowed_frame() before it goes into a case.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"

namespace drivecheck::fuzz_live {

// A small seeded generator (SplitMix64): the same on every platform and standard library,
// unlike std::uniform_int_distribution.
class Prng {
 public:
  explicit Prng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  // Uniform in [0, bound) (bound 0 gives 0).
  std::uint64_t below(std::uint64_t bound) { return bound == 0 ? 0 : next() % bound; }
  bool chance(unsigned percent) { return below(100) < percent; }
  std::uint8_t byte() { return static_cast<std::uint8_t>(next()); }

 private:
  std::uint64_t state_;
};

// One dictionary entry the generator may address.
struct FuzzObject {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint8_t size = 0;  // bytes (0: variable length, e.g. VISIBLE_STRING)
  bool writable = false;
  std::optional<std::int64_t> min;
  std::optional<std::int64_t> max;
};

struct CaseStep {
  can::Frame frame;
  can::Duration delay_after{};  // wait this long (collecting answers) before the next step
};

struct FuzzCase {
  std::uint64_t number = 0;
  std::string kind;
  std::vector<CaseStep> steps;
};

struct GeneratorOptions {
  std::uint8_t node = 1;
  std::uint64_t seed = 1;
  bool allow_motion = false;
  can::Duration gap = std::chrono::milliseconds(5);  // default delay between steps
};

// Whether the harness may write (SDO download, any transport) to object `index`: never
// store/restore (1010h/1011h) or program control (1F50h..1F5Fh), the controlword (6040h) only
// with allow_motion. The one place of these rules (CAN: is_allowed_frame; EtherCAT CoE:
// ethercat_cases.hpp).
bool is_allowed_write(std::uint16_t index, bool allow_motion);

// Whether the harness may send `frame` to node `node` (the safety rules above).
bool is_allowed_frame(const can::Frame& frame, std::uint8_t node, bool allow_motion);

// Whether a sequence of frames can change the node's communication state so that the
// harness must reset it (NMT reset communication) before judging liveness: any NMT command,
// any SDO download initiate to 1000h..1FFFh.
bool needs_communication_reset(std::span<const can::Frame> frames);

// Whether the frames include an NMT reset (node or communication) addressed to `node` or to
// all nodes: a boot-up after them is expected.
bool resets_node(std::span<const can::Frame> frames, std::uint8_t node);

class CaseGenerator {
 public:
  // `objects` must not be empty; a built-in list of CiA 301 objects is used if it is.
  CaseGenerator(GeneratorOptions options, std::vector<FuzzObject> objects);

  // Case `number` of the run: a pure function of (options, objects, number).
  FuzzCase generate(std::uint64_t number) const;

  const std::vector<FuzzObject>& objects() const { return objects_; }
  // The kinds generate() produces, in the order of the table above.
  static std::span<const std::string_view> kinds();

 private:
  GeneratorOptions options_;
  std::vector<FuzzObject> objects_;
};

// The objects every CiA 301 device has or commonly has, for a device without EDS or profile.
std::vector<FuzzObject> builtin_objects();

}  // namespace drivecheck::fuzz_live

// The EtherCAT live fuzzer's case generator: mailbox and CoE cases for one slave, from a seeded
// generator (same seed, same case number => same case), as case_generator.hpp is for CAN.
//
// A case is an AL state to run it in (PREOP, SAFEOP or OP: the harness requests it first and
// keeps the process data cycle running in SAFEOP/OP) and a short script of write-mailbox (SM0)
// contents. Each step is mailbox data (after the 6-octet header) plus how the harness builds
// the header: the Type, the counter (next of the master's sequence, the previous step's again,
// 0, or one skipped), and optional Length, Channel and Priority values that lie. Kinds
// (EthercatCase::kind):
//   coe-upload               SDO upload initiate (40h, C bit 10%) of an object or a neighbour
//                            (sub +1, a missing index), then 0-3 upload segment requests
//                            (60h/70h, toggles right or wrong)
//   coe-download             SDO download initiate: expedited (s=1 n=4-len, s=0) or normal
//                            (complete size) of a writable object, values at and past its
//                            limits, sizes right and wrong
//   coe-segmented-download   normal initiate announcing 8..300 octets, then download segments
//                            (000t nnnc): cut short (the transfer left open), a wrong toggle,
//                            more data than announced
//   coe-raw                  a valid SDO request with a random command byte, one random octet
//                            changed, or cut to 2..9 octets (shorter than an SDO message)
//   coe-service              CoE header services that do not exist (0, 9..15) or that a master
//                            does not send (emergency 1, SDO response 3, PDO services 4..7)
//   mailbox-header           a valid SDO upload request under a lying header: Length 0, too
//                            short, too long, past SM0, FFFFh; Channel 1..63; Priority 1..3;
//                            a reserved Type (0 ERR, 6..14)
//   mailbox-counter          the same SDO upload request sent again with the same counter
//                            (1..3 repeats: ETG.1000.4, a repeat is not executed again),
//                            counter 0 twice, or a counter that skips one
//
// Safety (as the CAN fuzzer, DESIGN.md "Safety on real drives"): every step passes
// is_allowed_mailbox(): no CoE SDO download initiate (whatever its other bits) to 1010h/1011h,
// 1F50h..1F5Fh, or 6040h without allow_motion (is_allowed_write, case_generator.hpp), and none
// to the PDO and SyncManager configuration (1600h..17FFh, 1A00h..1BFFh, 1C00h..1CFFh: the master
// plans the process data from the SII, so a changed assignment would make SAFEOP refuse, which
// the standard allows). Only CoE and the reserved mailbox types are sent: never EoE, AoE, FoE
// (a firmware download), SoE or VoE. The process data outputs stay 0 (controlword 0).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/live/case_generator.hpp"
#include "protocol/ethercat/al_state_machine.hpp"

namespace drivecheck::fuzz_live {

enum class CounterMode : std::uint8_t {
  next,    // the master's next counter (MailboxMaster::request)
  repeat,  // the previous step's buffer again, unchanged (same counter)
  zero,    // counter 0 ("not used")
  skip,    // the master's counter after next (one left out)
};
std::string_view to_string(CounterMode mode);

struct MailboxStep {
  std::vector<std::uint8_t> data;  // mailbox data after the header (CoE header first)
  std::uint8_t type = 3;           // mailbox Type (3 = CoE)
  CounterMode counter = CounterMode::next;
  std::optional<std::uint16_t> length;  // the Length field; nullopt: data.size()
  std::uint8_t channel = 0;
  std::uint8_t priority = 0;
};

struct EthercatCase {
  std::uint64_t number = 0;
  std::string kind;
  ethercat::AlState state = ethercat::AlState::preop;
  std::vector<MailboxStep> steps;
};

struct EthercatGeneratorOptions {
  std::uint64_t seed = 1;
  bool allow_motion = false;
  std::size_t write_size = 128;  // the slave's SM0 length (header included)
  // The states cases may ask for (the harness drops the ones the slave does not reach).
  std::vector<ethercat::AlState> states{ethercat::AlState::preop, ethercat::AlState::safeop,
                                        ethercat::AlState::op};
};

// Whether the harness may write object `index` over CoE (is_allowed_write plus the PDO and
// SyncManager configuration, see above).
bool is_allowed_coe_write(std::uint16_t index, bool allow_motion);
// Whether the harness may send `step` (the safety rules above), judged on the octets the slave
// can see whatever the Length says.
bool is_allowed_mailbox(const MailboxStep& step, bool allow_motion);

class EthercatCaseGenerator {
 public:
  // `objects` empty: builtin_objects() (case_generator.hpp).
  EthercatCaseGenerator(EthercatGeneratorOptions options, std::vector<FuzzObject> objects);

  EthercatCase generate(std::uint64_t number) const;
  static std::span<const std::string_view> kinds();
  const EthercatGeneratorOptions& options() const { return options_; }

 private:
  EthercatGeneratorOptions options_;
  std::vector<FuzzObject> objects_;
};

// One line per step for the reproducer's text: "Cnt next Type 3 Length 10: CoE cnt 0: SDO
// upload initiate 1018h:01 | 00 20 40 18 10 01 00 00 00 00".
std::string describe_step(const MailboxStep& step);

}  // namespace drivecheck::fuzz_live

// The CoE communication objects a slave adds to its dictionary (ETG.1000.6 CoE; ETG.1020
// synchronisation; as public in the Festo CoE chapter and Beckhoff's device documentation), and
// the rules that guard them, installed as write validators.
//
//   1C00h  Sync manager communication type, ARRAY of UNSIGNED8, ro: sub 0 = number of SMs,
//          sub n = type of SM n-1: 1 mailbox receive (master → slave), 2 mailbox send
//          (slave → master), 3 process data output (RxPDO), 4 process data input (TxPDO)
//          (Beckhoff "Sync manager type": 1 Mailbox Write, 2 Mailbox Read, 3 Process Data
//          Write (Outputs), 4 Process Data Read (Inputs)). ⚠ Festo 000 §4.6.2 L1901-1915 prints
//          "2: Mailbox Transmit (Master => Slave)" for channel 0 as well: read as a misprint of 1.
//   1C12h  RxPDO assign (SM2), ARRAY of UNSIGNED16 rw: sub 0 = number assigned, sub n = index of
//          an RxPDO mapping object 1600h..17FFh (Festo 000 L1954-2000: 1600h..1603h)
//   1C13h  TxPDO assign (SM3), the same with TxPDO mapping objects 1A00h..1BFFh
//   1C32h  SM output parameter, RECORD, sub 0 = 32 (Beckhoff "1C32 SM output parameter"):
//            01 sync mode UNSIGNED16 rw (coe_sync_modes.inc)   02 cycle time UNSIGNED32 rw, ns
//            03 shift time UNSIGNED32 ro, ns                    04 sync modes supported UNSIGNED16
//            ro 05 minimum cycle time UNSIGNED32 ro, ns            06 calc and copy time UNSIGNED32
//            ro 07 minimum delay time UNSIGNED32 ro                08 get cycle time / command
//            UNSIGNED16 rw 09 maximum delay time UNSIGNED32 ro                0B SM event missed
//            counter UNSIGNED16 ro 0C cycle exceeded counter UNSIGNED16 ro            0D shift too
//            short counter UNSIGNED16 ro 20 sync error BOOLEAN ro
//   1C33h  SM input parameter: the same entries
//
// Rules (install_coe_object_rules), each an abort code of the one table:
//   - 1C12h, 1C13h, 1600h..17FFh, 1A00h..1BFFh and 1C32h/1C33h:01/02 are written only while
//     configurable() (PREOP: Festo 000 §4.6.1 L1849 "The Sync channels can only be set and the
//     PDOs only configured in the 'Pre-Operational' status", §4.9 L2150; ETG.6010 for CiA 402
//     slaves); otherwise 08000022h (present device state)
//   - 1C12h/1C13h sub 1..n only while sub 0 is 0, else 06010003h ("SI0 must be 0 for write
//     access", ETG.1000.6): the master sets the count to 0, writes the indices, then the count
//   - an assigned index outside the direction's mapping range or of a mapping object the
//     dictionary lacks → 06090030h (invalid value); a count above the entries → 06090031h; a
//     count that would assign an entry holding such an index → 06090030h
//   - a sync mode that 1C32h/1C33h does not take, or whose bits sub 04 does not have → 06090030h;
//     a cycle time below a non-zero minimum cycle time (sub 05) → 06090032h
// A manual may relax them, each on its own (CoeObjectRuleOptions): Festo's 1C12h/1C13h are
// stored as written, "not evaluated further by the firmware" (000 §4.6.2 L1931), while its PDO
// configuration is still "only in the Pre-Operational status" (000 §4.6.1 L1774, §4.9 L2161).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::ethercat {

enum class SyncMode : std::uint16_t {
#define DRIVECHECK_COE_SYNC_MODE(name, value, outputs, inputs, mask, bits, text) name = value,
#include "protocol/ethercat/coe_sync_modes.inc"
#undef DRIVECHECK_COE_SYNC_MODE
};

struct SyncModeInfo {
  SyncMode mode;
  std::string_view name;
  bool outputs;  // valid in 1C32h:01
  bool inputs;   // valid in 1C33h:01
  std::uint16_t supported_mask;
  std::uint16_t supported_value;  // (1C3xh:04 & mask) == value when the mode is supported
  std::string_view text;
};
std::span<const SyncModeInfo> sync_mode_table();
std::optional<SyncModeInfo> find_sync_mode(std::uint16_t value);

inline constexpr std::uint16_t kRxPdoAssign = 0x1C12;
inline constexpr std::uint16_t kTxPdoAssign = 0x1C13;
inline constexpr std::uint16_t kSmOutputParameter = 0x1C32;
inline constexpr std::uint16_t kSmInputParameter = 0x1C33;

struct SyncParameters {
  SyncMode mode = SyncMode::free_run;
  std::uint32_t cycle_time_ns = 1'000'000;
  std::uint16_t supported = 0x0003;  // free run and SM-synchronous
  std::uint32_t minimum_cycle_time_ns = 0;
};

struct CoeObjectsConfig {
  std::uint8_t sync_managers = 4;  // 1C00h: SM0..3 mailbox write/read, outputs, inputs
  std::uint8_t rx_capacity = 4;    // entries of 1C12h
  std::uint8_t tx_capacity = 4;    // entries of 1C13h
  std::vector<std::uint16_t> rx_assigned{0x1600};
  std::vector<std::uint16_t> tx_assigned{0x1A00};
  bool assignment_writable = true;  // false: a fixed assignment (1C12h/1C13h ro)
  SyncParameters outputs;
  SyncParameters inputs;
};

// 1C00h, 1C12h, 1C13h, 1C32h, 1C33h as definitions for ObjectDictionary::add_object.
std::vector<cia301::ObjectDefinition> coe_object_definitions(const CoeObjectsConfig& config);

struct CoeObjectRuleOptions {
  // 1C12h/1C13h, 1600h+/1A00h+, 1C32h/1C33h:01/02 written only while configurable()
  // (08000022h otherwise). false: in any state.
  bool configuration_only_when_configurable = true;
  // The content of 1C12h/1C13h checked (sub 0 = 0 before sub 1..n, the mapping indices, the
  // count). false: any value is stored (only the state rule above applies).
  bool assignment_evaluated = true;
};

// Installs the rules of the file comment as write validators, in front of any validator an
// entry has. `configurable` says whether the slave is in PREOP. Errors: an object missing.
Expected<void, std::string> install_coe_object_rules(cia301::ObjectDictionary& od,
                                                     std::function<bool()> configurable,
                                                     CoeObjectRuleOptions options = {});

}  // namespace drivecheck::ethercat

// A personality: how the reference drive impersonates one manual's drive. The `personality:`
// section of a drive profile parses into this (drive_profile.hpp); what each key does to the
// drive is documented, key by key, in reference_drive/personality.hpp, which applies it. The
// engine never reads a personality (it learns about a drive only from the bus).
//
// Keys not given take the standard value (the CiA 301/402 reading); `identity`, `modes` and
// `option_codes` default to the profile's own sections of the same name.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/sdo_server_parameter.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::profile {

// 1000h, 1008h-100Ah, 1018h. Every field optional: a profile says what it knows.
struct Identity {
  std::optional<std::uint32_t> device_type;      // 1000h
  std::optional<std::uint32_t> vendor_id;        // 1018h:01
  std::optional<std::uint32_t> product_code;     // 1018h:02
  std::optional<std::uint32_t> revision_number;  // 1018h:03
  std::optional<std::uint32_t> serial_number;    // 1018h:04
  std::optional<std::string> device_name;        // 1008h
  std::optional<std::string> hardware_version;   // 1009h
  std::optional<std::string> software_version;   // 100Ah
  friend bool operator==(const Identity&, const Identity&) = default;
};

// How the reference drive runs a manufacturer mode. behaves-as: the logic of the standard mode
// `behaves_as` (0: none, the axis holds). irtsa-mpp: IRTSA's manual profile position mode
// (controlword bits 5/6 jog through the trajectory generator, 003_111f14ab1c37c28a.txt §4.5.4).
enum class ManufacturerModeLogic : std::uint8_t { behaves_as, irtsa_mpp };

// A manufacturer-specific mode of operation (6060h value < 0) the drive accepts.
struct ManufacturerMode {
  int value = 0;       // -128..-1
  int behaves_as = 0;  // the standard mode it moves like (1..10), 0: none (no motion)
  ManufacturerModeLogic logic = ManufacturerModeLogic::behaves_as;
  std::string name;  // the manual's name for it
  friend bool operator==(const ManufacturerMode&, const ManufacturerMode&) = default;
};

// 603Fh error code format. standard: the CiA 402 / CiA 301 EMCY error code (e.g. 2310h).
// error-number: the manufacturer's error number n as n * 256 + 80h (IRTSA: error 5 -> 0580h).
enum class ErrorCodeFormat : std::uint8_t { standard, error_number };
// Which input the drive needs before it can be switched on. none: no hardware enable input
// (or it is ignored). transition-2: SWITCH ON DISABLED -> READY TO SWITCH ON needs it (Festo,
// DIN4/DIN5). transition-3: READY TO SWITCH ON -> SWITCHED ON needs it (Kollmorgen).
enum class HardwareEnable : std::uint8_t { none, transition_2, transition_3 };
// Whose manufacturer homing methods (6098h < 0) the drive runs; none: CiA 402 methods only.
enum class HomingTable : std::uint8_t { none, festo, kollmorgen, irtsa };
// How homing works. standard: 6098h methods run on the axis. set-position: no homing run; a
// homing start sets the actual position to the home offset at once (IRTSA).
enum class HomingStyle : std::uint8_t { standard, set_position };
// DLC of the SDO server's responses. always-8: every response 8 bytes (CiA 301). minimal: an
// expedited upload response carries 4 + n bytes, download/abort responses 8 (Festo prints only
// the significant bytes and leaves it open).
enum class SdoDlc : std::uint8_t { always_8, minimal };
// SDO requests with fewer than 8 data bytes. ignore: no SDO frame (CiA 301). pad: the missing
// bytes read as 00h (Festo's examples print only the significant bytes, L744-756).
enum class SdoShortRequests : std::uint8_t { ignore, pad };
// What the drive does when its CAN controller goes bus-off (ReferenceDrive::set_bus_off).
// cia301: 1029h:01's communication error reaction, and EMCY 8140h (recovered from bus off) at
// recovery. kollmorgen-f23 (002 §2.9 L206-212): error F23 (EMCY code 8182h, a fault: with the
// power stage enabled the drive stops on the emergency ramp and disables), only when a frame of
// the drive reached the wire before; no 8140h at recovery. esr-8180 (004 §11.4 L789-795,
// App. D L1812-1814): fault 8180h (quick stop, then the fault), pre-operational (1029h:01 as
// guarding_loss sets it), no 8140h at recovery ("processed in the CAN system only").
enum class BusOffReaction : std::uint8_t { cia301, kollmorgen_f23, esr_8180 };
// Manufacturer objects with behaviour of their own (reference_drive/kollmorgen_objects.hpp).
// none: none. kollmorgen (002): 1002h manufacturer status, the OS prompt 1026h (ASCII commands)
// and the object channel from 3500h.
enum class ManufacturerObjects : std::uint8_t { none, kollmorgen };
// Position sampling at a digital input (reference_drive/festo_position_sampling.hpp). none: no
// such input. festo (000 §5.15 L4705-4816): 204Ah sample_data, the `sample-input` simulated
// input, the actual position latched at its edges, statusword bit 15 through the status mask.
enum class PositionSampling : std::uint8_t { none, festo };

// 607Bh position range limit (reference_drive Cia402ApplicationConfig::position_range): none
// (no 607Bh), cia402 (in effect as set, the direction from 60F2h bits 7..6), festo (in effect
// only while 6510h sub 20h selects a round axis, which also gives the direction).
enum class PositionRangeLimit : std::uint8_t { none, cia402, festo };
// What a node guarding (life guarding) or heartbeat consumer event does to the NMT state.
// error-behaviour: what 1029h:01 says (CiA 301 default: Operational -> Pre-operational).
// pre-operational: always Pre-operational (ESR), also from Stopped. no-nmt-change: the NMT state
// stays (Kollmorgen: warning N04 and a quick stop instead; 1029h:01 = 1).
enum class GuardingLoss : std::uint8_t { error_behaviour, pre_operational, no_nmt_change };

// How a PDO's mapping may change. dynamic: the mapping records are writable with CiA 301's
// procedure (§7.5.2.36, §7.5.2.38). static: the mapping is the device's default and the mapping
// records are read-only (CiA 301 §7.5.2.36/38 let a device support static mapping only; a write
// of any sub-index aborts as a write to a read-only object, 06010002h).
enum class PdoMapping : std::uint8_t { dynamic, fixed };
// A PDO COB-ID written valid (bit 31 = 0) while the PDO has no mapped object (sub 00h of its
// mapping record = 0). accept: valid, neither sent nor received. refuse: the write aborts
// 06090030h (invalid value); CiA 301 §7.5.2.35 does not say what a device does then, and
// refusing is a permitted choice (issue 17 §6; CTT has no case for it).
enum class EmptyPdoValid : std::uint8_t { accept, refuse };
// Which SYNC counts as the first of a TPDO of transmission type n (2..240) when no SYNC start
// value applies (1800h sub 06h = 0, or SYNC without counter). CiA 301 §7.2.2.2 / §7.5.2.37 only
// say "every n-th SYNC"; which SYNC starts the count is the device's. nth-sync: the first
// transmission at the n-th SYNC after entering Operational. first-sync: at the first SYNC after
// entering Operational, then at every n-th.
enum class TpdoSyncPhase : std::uint8_t { nth_sync, first_sync };
// 6080h max motor speed: UNSIGNED32 in the velocity units of the factor group (CiA 402-2), or
// UNSIGNED16 in min^-1 (Festo 000 §7.5.2 L6939-6948: UINT16, 0..32768 min^-1, default 32768).
enum class MaxMotorSpeed : std::uint8_t { velocity_u32, rpm_u16 };

// Indices first..last (inclusive) of objects the drive does not have (personality key
// `absent_objects`).
struct ObjectRange {
  std::uint16_t first = 0;
  std::uint16_t last = 0;
  friend bool operator==(const ObjectRange&, const ObjectRange&) = default;
};

// When the SDO server's responses leave after the request (personality key
// `sdo_response_delay`): a delay in [min, max], each response its own (a pseudo-random sequence
// fixed per drive, so runs repeat), never reordering responses. Zero: at once.
struct ResponseDelay {
  can::Duration min{};
  can::Duration max{};
  friend bool operator==(const ResponseDelay&, const ResponseDelay&) = default;
};

// An object whose type differs from CiA 402 (ESR 6060h/6061h are INTEGER16).
struct ObjectType {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  cia301::DataType type = cia301::DataType::integer8;
  friend bool operator==(const ObjectType&, const ObjectType&) = default;
};

// What a write of an object the personality adds does (personality key `objects`).
// none: the value is stored and nothing else happens (only for objects whose effect concerns
// something the reference drive does not have; recorded as not applied). set-actual-position:
// the actual position (6064h) becomes the written value, user units, no motion (Festo 2030h).
enum class ObjectAction : std::uint8_t { none, set_actual_position };

// An object the personality adds to the reference drive's dictionary, or an entry of the
// dictionary it restricts, as the manual documents it. `type` given and the drive has no
// object at `index`: the object is added (sub 0: a VAR; subs 1..n: a RECORD with sub 0 = n).
// Otherwise the entry must exist and only access, limits and accepted values change.
struct ObjectRule {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::optional<cia301::DataType> type;       // added objects only
  std::optional<cia301::AccessType> access;   // ro: writes abort 06010002h, wo: reads 06010001h
  std::optional<std::int64_t> default_value;  // existing entries: at each application reset
  std::optional<std::int64_t> min;            // below: abort 06090032h
  std::optional<std::int64_t> max;            // above: abort 06090031h
  std::vector<std::int64_t> values;           // non-empty: any other value aborts 06090030h
  ObjectAction action = ObjectAction::none;
  std::string source;  // the manual lines (for the reader; not used)
  friend bool operator==(const ObjectRule&, const ObjectRule&) = default;
};

// A unit of the drive as a fraction of the reference drive's axis unit (increments/s for
// velocities, increments/s² for accelerations): numerator / divisor, both 1..2^32-1.
struct UnitFraction {
  std::uint32_t numerator = 1;
  std::uint32_t divisor = 1;
  friend bool operator==(const UnitFraction&, const UnitFraction&) = default;
};

// The drive's internal units, into which 6094h and 6097h convert (Festo: 1/4096 min^-1 and
// 1/256 min^-1/s, 000 §5.3 L2709, L2789). Standard: 1/1 (increments/s, increments/s²).
struct InternalUnits {
  UnitFraction velocity;
  UnitFraction acceleration;
  friend bool operator==(const InternalUnits&, const InternalUnits&) = default;
};

struct Personality {
  std::optional<Identity> identity;       // none: the profile's identity
  std::optional<std::vector<int>> modes;  // none: the profile's modes
  std::vector<ManufacturerMode> manufacturer_modes;
  std::optional<std::map<OptionCode, std::vector<int>>> option_codes;  // none: the profile's
  std::map<OptionCode, int> option_defaults;  // the default value of each option-code object
  HardwareEnable hardware_enable = HardwareEnable::none;
  bool emcy_follow_up = false;  // Kollmorgen: each EMCY followed by an error-state EMCY
  ErrorCodeFormat error_code_format = ErrorCodeFormat::standard;
  HomingStyle homing = HomingStyle::standard;
  HomingTable manufacturer_homing = HomingTable::none;
  std::optional<int> homing_default_method;  // 6098h default; none: the drive's (17)
  bool homing_halt_sets_error = false;       // halt ends homing with bit 13 (Festo)
  std::vector<ObjectType> object_types;
  std::vector<ObjectRule> objects;        // objects added or restricted (ObjectRule)
  bool pdo_mapping_while_valid = false;   // Kollmorgen: mapping written while the PDO is valid
  bool pdo_cob_id_enable_only = false;    // PDO COB-IDs: only bit 31 changes (CiA 301 §7.5.2.37)
  std::uint16_t tpdo_transmit_masks = 0;  // Festo: index of TPDO1's transmit mask (2014h); 0 none
  bool parameters_internal = false;       // Festo: parameters kept in internal units (L2594)
  InternalUnits internal_units;           // Festo: 6094h/6097h convert into its units
  // Increments per motor revolution (608Fh, the index pulse once per revolution); none: the
  // reference drive's 4096. Festo: 65536 (000 §5.3 L2601, L2617).
  std::optional<std::uint32_t> encoder_resolution;
  bool pp_change_on_set_point = true;  // pp controlword bit 9; false: reserved, ignored (Festo)
  std::int16_t ip_submode = 0;         // 60C0h: the one value accepted and its default (Festo -2)
  bool power_stage_in_switched_on = false;  // SWITCHED ON holds the motor (Kollmorgen)
  can::Duration nmt_min_spacing{};  // an NMT frame closer to the previous one is lost (Festo)
  GuardingLoss guarding_loss = GuardingLoss::error_behaviour;
  unsigned ack_latency_cycles = 1;  // pp: control cycles from new set-point to acknowledge
  std::optional<can::Duration> control_cycle;  // none: the drive's default (1 ms)
  SdoDlc sdo_dlc = SdoDlc::always_8;
  SdoShortRequests sdo_short_requests = SdoShortRequests::ignore;
  std::optional<std::uint16_t> heartbeat_time_ms;  // 1017h default
  std::optional<std::uint16_t> guard_time_ms;      // 100Ch default
  std::optional<std::uint8_t> life_time_factor;    // 100Dh default
  std::uint8_t extra_sdo_servers = 0;              // further SDO server channels 1201h.. (0..127)
  bool sdo_client = false;     // SDO client 1280h with its request object 2F00h (reference drive)
  bool time_consumer = false;  // TIME consumer 1012h with 2F01h (reference drive)
  cia301::SdoNodeIdSub sdo_server_node_id = cia301::SdoNodeIdSub::client;  // their sub 03h
  BusOffReaction bus_off = BusOffReaction::cia301;
  ManufacturerObjects manufacturer_objects = ManufacturerObjects::none;
  // Festo 204Ah sample_data with its behaviour (PositionSampling above).
  PositionSampling position_sampling = PositionSampling::none;
  // 607Bh and the rotary axis (PositionRangeLimit above); a profile's drive: none unless it
  // says so (the standard drive: cia402).
  PositionRangeLimit position_range_limit = PositionRangeLimit::none;
  // false: a plain CiA 301 device: no CiA 402 application (no 6000h-9FFFh objects, no PDS, no
  // motion). 1000h comes from `identity.device_type`.
  bool cia402 = true;
  // Objects the drive does not have (their SDO access aborts 06020000h, the EDS omits them).
  std::vector<ObjectRange> absent_objects;
  // The SDO abort codes the drive answers in place of the standard drive's, by the standard
  // code (sdo_abort_codes.inc): e.g. 06010002h -> 06010000h. Both codes must be in the table.
  std::map<std::uint32_t, std::uint32_t> abort_codes;
  ResponseDelay sdo_response_delay;
  PdoMapping pdo_mapping = PdoMapping::dynamic;
  EmptyPdoValid empty_pdo_valid = EmptyPdoValid::accept;
  TpdoSyncPhase tpdo_sync_phase = TpdoSyncPhase::nth_sync;
  // pp: how many set-points the drive buffers behind the running one (CiA 402-2 pp: a set of
  // set-points; the depth is the device's). 1..8.
  unsigned setpoint_buffer = 1;
  // 6060h/6061h after power on (0: no mode). Festo: 3 (6061h default, 000 §7.1.2 L5996-6005).
  std::int8_t initial_mode = 0;
  // ip: 60C4h sub 01h max_buffer_size, 0..16; 0: no buffer (the last record written is taken at
  // the next SYNC; Festo 000 §7.4.2 L6620-6638). Standard: 16.
  unsigned ip_max_buffer = 16;
  MaxMotorSpeed max_motor_speed = MaxMotorSpeed::velocity_u32;
  // 1011h "load" only with the output stage off, else abort 08000022h (Festo 000 §5.1 L2501).
  bool restore_output_stage_off = false;
  std::string note;  // free text (why these values)

  friend bool operator==(const Personality&, const Personality&) = default;
};

std::string_view to_string(HardwareEnable enable);        // "none", "transition-2", "transition-3"
std::string_view to_string(HomingTable table);            // "none", "festo", "kollmorgen", "irtsa"
std::string_view to_string(ErrorCodeFormat format);       // "standard", "error-number"
std::string_view to_string(HomingStyle style);            // "standard", "set-position"
std::string_view to_string(ObjectAction action);          // "none", "set-actual-position"
std::string_view to_string(SdoDlc dlc);                   // "always-8", "minimal"
std::string_view to_string(SdoShortRequests policy);      // "ignore", "pad"
std::string_view to_string(BusOffReaction reaction);      // "cia301", "kollmorgen-f23", "esr-8180"
std::string_view to_string(cia301::SdoNodeIdSub sub);     // "none", "client", "server"
std::string_view to_string(ManufacturerObjects objects);  // "none", "kollmorgen"
std::string_view to_string(ManufacturerModeLogic logic);  // "behaves-as", "irtsa-mpp"
std::string_view to_string(PositionSampling sampling);    // "none", "festo"
std::string_view to_string(PositionRangeLimit limit);     // "none", "cia402", "festo"
std::string_view to_string(PdoMapping mapping);           // "dynamic", "static"
std::string_view to_string(EmptyPdoValid policy);         // "accept", "refuse"
std::string_view to_string(MaxMotorSpeed speed);          // "velocity-u32", "rpm-u16"
std::string_view to_string(TpdoSyncPhase phase);          // "nth-sync", "first-sync"
std::string_view to_string(
    GuardingLoss loss);  // "error-behaviour", "pre-operational", "no-nmt-change"

// 603Fh of a manufacturer error number in the error-number format: n * 256 + 80h.
constexpr std::uint16_t error_number_code(std::uint8_t number) {
  return static_cast<std::uint16_t>(number * 256U + 0x80U);
}

}  // namespace drivecheck::profile

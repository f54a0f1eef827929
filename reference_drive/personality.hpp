// Personalities: how the reference drive impersonates the drive of one manual. A drive profile
// (vectors/drives/<name>.yaml) carries a `personality:` section; protocol/profile parses it into
// profile::Personality (typed); plan_personality() turns it, with the profile's lists, into the
// configuration ServoDrive (servo_drive.hpp) composes the drive from. The standard drive (no
// profile) is the plan of standard_personality().
//
// Every key, what it does to the reference drive, and the standard value:
//
//   identity: {device_type, vendor_id, product_code, revision_number, serial_number,
//              device_name, hardware_version, software_version}
//       1000h, 1018h:01..04, 1008h, 1009h, 100Ah. Keys not given keep the reference drive's
//       identity (dictionary.hpp). Default: the profile's `identity:`.
//   modes: [6060h values]
//       6502h and the modes hosted: 1 pp, 3 pv, 4 tq, 6 hm, 7 ip, 8 csp, 9 csv, 10 cst.
//       2 (vl) has no implementation in the reference drive: ignored (not_applied). Negative
//       values must be manufacturer_modes. Default: the profile's `modes:`.
//   manufacturer_modes: [{value: -128..-1, behaves_as: 0|1..10, logic, name}]
//       Cia402ApplicationConfig::manufacturer_modes: 6060h accepts the value, 6061h shows it.
//       logic: behaves-as (default): the logic of the standard mode behaves_as runs under
//       the manufacturer value (modes/manufacturer_mode.hpp); 0 moves nothing (the axis
//       holds: e.g. a set-point from an analogue input); 2 (vl) and 6 (hm) have no such logic:
//       not_applied. irtsa-mpp: IRTSA's manual profile position
//       (modes/manual_profile_position.hpp).
//   option_codes: {quick-stop: [..], shutdown, disable-operation, halt, fault-reaction,
//                  abort-connection}
//       The values 605Ah..605Eh and 6007h accept (PowerDriveConfig::option_code_support; any
//       other value: abort 06090030h). Objects not listed accept CiA 402's values. Negative
//       values (Festo 605Ch = -1) cannot be shown: not_applied. Default: the profile's.
//   option_defaults: {object: value}
//       The option code's value after each reset while it holds the CiA 402 default (stored
//       parameters win). Standard: the CiA 402 defaults (6007h 1, 605Ah 2, 605Bh 0, 605Ch 1,
//       605Dh 1, 605Eh 2).
//   hardware_enable: none | transition-2 | transition-3
//       PowerDriveConfig::hardware_enable: which transition waits for the hardware enable input
//       (`simulate: {input: hardware-enable}`). The input is present at power on. Standard:
//       transition-3 (the reference drive has the input, so the hardware-enable vectors run).
//   emcy_follow_up: true | false
//       Kollmorgen (002 §4.4.4 L768-777): after every EMCY with a code other than 0000h the
//       drive sends a second EMCY: 0000h, byte 2 the error register of the first, bytes 3-7 0
//       (the error category byte is 0: the category table is not simulated). Standard: false.
//   error_code_format: standard | error-number
//       603Fh (Cia402ApplicationConfig::error_code_format): error-number shows IRTSA's
//       n * 256 + 80h. Standard: standard.
//   homing: standard | set-position
//       set-position (IRTSA): homing may start in every state but FAULT REACTION ACTIVE and
//       FAULT, and statusword bit 13 is never set (HomingConfig). The methods themselves come
//       from manufacturer_homing (IRTSA -127/-126 move nothing). Standard: standard.
//   manufacturer_homing: none | festo | kollmorgen | irtsa
//       Whose negative 6098h methods the homing mode runs (HomingConfig::vendor). The methods
//       6098h accepts are the profile's homing_methods that the homing table has (others:
//       not_applied). Standard: none (CiA 402 methods).
//   homing_default_method: -128..127
//       6098h after power on (HomingConfig::default_method). Standard: 17 (or the first
//       supported method when 17 is not).
//   homing_halt_sets_error: true | false
//       Festo (L5584-5589): halt ends homing with bit 13. Standard: false.
//   object_types: [{index, sub, type}]
//       Only 6060h/6061h as INTEGER16 (ESR) are possible (ModeObjectWidth::bits16); any other
//       entry is an error.
//   guarding_loss: error-behaviour | pre-operational | no-nmt-change
//       1029h:01 after each reset (while at its default 0): pre-operational -> 0 (CiA 301:
//       Operational -> Pre-operational; ESR's "also from Stopped" is not simulated),
//       no-nmt-change -> 1. A personality without 1029h (absent_objects) reacts the same way
//       (DriveConfig::communication_error_without_1029: no-nmt-change -> 1, else CiA 301
//       §7.5.2.32's default 0). Standard: error-behaviour (1029h as the dictionary has it).
//   ack_latency_cycles: 1..1000
//       pp: control cycles from the new set-point edge to set-point acknowledge
//       (Cia402ApplicationConfig::acknowledge_latency_cycles; 0 is refused). Standard: 1.
//   control_cycle: duration
//       DriveConfig::control_cycle. Standard: 1 ms.
//   sdo_dlc: always-8 | minimal
//       always-8 only: the SDO server sends every response with 8 bytes; minimal is recorded
//       as not_applied.
//   sdo_short_requests: ignore | pad
//       DriveConfig::sdo_short_frames: an SDO request with fewer than 8 bytes is ignored (CiA
//       301) or read with the missing bytes as 00h. Standard: ignore.
//   heartbeat_time_ms: 0..65535
//       1017h default (DictionaryOptions::producer_heartbeat_ms). Standard: 0.
//   guard_time_ms: 0..65535, life_time_factor: 0..255
//       100Ch / 100Dh after each reset while at their default 0. Standard: 0, 0.
//   objects: [{index, sub, type, access, default, min, max, values, action, source}]
//       Objects the manual documents that the reference drive adds or restricts
//       (apply_object_rules, at dictionary build time). With `type` and no object at `index`:
//       added (sub 0 only: a VAR; subs 1..n: a RECORD, sub 0 = n UNSIGNED8 ro), access default
//       rw, default value `default` (else 0), store group: none for objects with an action,
//       else the dictionary's. Otherwise the entry must exist (else an error) and keeps its
//       type; `default` becomes its value after each reset while it holds the dictionary's
//       default (as option_defaults); the rule restricts it: access ro -> an SDO write aborts
//       06010002h, wo -> an SDO read aborts 06010001h; a written value below min -> 06090032h,
//       above max -> 06090031h, not in `values` -> 06090030h; the drive's own checks run after
//       these. `action` (added objects): set-actual-position makes 6064h the written value (user
//       units, the factor group applied, no motion); none stores the value and does nothing else
//       (not_applied names the object). Standard: none.
//   pdo_mapping_while_valid: true | false
//       PdoObjectOptions::mapping_while_valid: the mapping records may be written while their
//       PDO is valid (Kollmorgen). Standard: false (CiA 301: abort 06010000h).
//   pdo_cob_id_enable_only: true | false
//       PdoObjectOptions::cob_id_enable_only: the PDO COB-IDs can only be enabled and disabled
//       (bit 31); another CAN-ID is refused with 06090030h (CiA 301 §7.5.2.37). Standard: false.
//   tpdo_transmit_masks: 0x2000..0x5FFF
//       PdoObjectOptions::change_mask_index (pdo_service.hpp): TPDO n's transmit mask record
//       at this index + n - 1; a TPDO sent on change compares only the masked bits (Festo
//       2014h-2017h). Standard: none.
//   parameters_internal: true | false
//       Festo (000 §5.3 L2594): user-unit parameters are kept in internal units and converted
//       when read or written (InternalUnitParameters): a factor group or polarity change
//       re-expresses 607Ah, 607Ch, 607Dh, 6065h, 6067h, 606Dh, 606Fh, 607Fh, 6081h, 60FFh,
//       6083h-6085h, 6099h, 609Ah in the new units (rounded half away from zero, so the
//       rounding shows), where the standard drive keeps the numbers. Standard: false.
//   extra_sdo_servers: 0..127, sdo_server_node_id: none | client | server
//       DictionaryOptions::extra_sdo_servers / sdo_node_id_sub: further SDO server channels
//       1201h.. (protocol/cia301/sdo_server_parameter.hpp), not valid until configured; sub 03h
//       is the client's node-ID (CiA 301), the server's own node-ID (ESR: writing it moves the
//       channel to 600h/580h + it at once, 0 disables it), or absent. Standard: 0, client.
//   sdo_client: true | false, time_consumer: true | false
//       DictionaryOptions::sdo_client / time_consumer (dictionary.hpp): the SDO client 1280h
//       with the remote read/write request object 2F00h, and the TIME consumer 1012h with the
//       received time 2F01h. Only the standard drive has them (the complete CiA 301 device);
//       none of the four manuals lists 1280h, and Kollmorgen and Dunker say TIME is not
//       supported. Standard: true, true; a profile's personality: false unless it says true.
//   bus_off: cia301 | kollmorgen-f23 | esr-8180
//       What the drive does when its CAN controller goes bus-off (device.hpp): cia301 = 1029h:01
//       reaction and EMCY 8140h at recovery; kollmorgen-f23 (002 §2.9 L206-212) = fault 8182h
//       (F23; the PDS's fault reaction stops and disables the drive) when a frame of the drive
//       reached the wire before, the cause gone at recovery, no 8140h; esr-8180 (004 §11.4
//       L789-795) = fault 8180h at once, no 8140h. Standard: cia301.
//   manufacturer_objects: none | kollmorgen
//       kollmorgen: KollmorgenObjects (kollmorgen_objects.hpp) adds 1002h (manufacturer status,
//       the bits the reference drive can show), the OS prompt 1026h (ASCII commands over SDO)
//       and the manufacturer object channel from 3500h (a few ASCII parameters, none
//       PDO-mappable). Standard: none.
//   position_sampling: none | festo
//       festo: FestoPositionSampling (festo_position_sampling.hpp) adds 204Ah sample_data
//       (000 §5.15 L4705-4816) with its behaviour: the simulated input `sample-input`, the
//       actual position latched at its edges, sample_status, statusword bit 15 through
//       sample_status_mask, autolock released by sample_control. Standard: none.
//   internal_units: {velocity: [n, d], acceleration: [n, d]}
//       The drive's internal units into which 6094h and 6097h convert, in increments/s and
//       increments/s² of the axis (Cia402ApplicationConfig::internal_velocity_unit): the axis
//       runs at user value x 6094h x n/d. Festo: 1/4096 min^-1 and 1/256 min^-1/s at 65536
//       increments per revolution = [4, 15] and [64, 15], so that its defaults 4096/1 and
//       256/1 mean min^-1 and min^-1/s and its commissioning 15/4, 15/64 increments/s (/s²).
//       Standard: [1, 1] both.
//   encoder_resolution: 4..2^31-1
//       Increments per motor revolution (AxisConfig::encoder_increments): 608Fh sub 1 (sub 2 =
//       1), the index pulse once per revolution (unless `simulate: index-period` sets another
//       period), and 6093h as 6091h/6092h writes recompute it. Positions, windows and speeds in
//       increments keep their numbers (the axis runs in increments). Festo: 65536 (000 §5.3
//       L2601, L2617; 2024h:01 'always 65536' L4016-4030). Standard: 4096.
//   pp_change_on_set_point: true | false
//       false: controlword bit 9 is reserved and ignored in profile position, each set-point
//       ends at its target (ModeContext::change_on_set_point; Festo L5326-5424). Standard: true.
//   ip_submode: -32768..0
//       The one 60C0h value accepted, also its default (InterpolatedPositionMode); the
//       reference drive runs it as its linear interpolation. Festo: -2. Standard: 0.
//   power_stage_in_switched_on: true | false
//       PowerDriveConfig::power_stage_in_switched_on: in SWITCHED ON (after transition 3 or 5)
//       the axis holds its position with the power stage on; the mode's set-points stay
//       disabled (Kollmorgen L3057-3061, L3099-3107). Standard: false.
//   nmt_min_spacing: duration (0..1s)
//       An NMT frame (000h, any node) received less than this after the previous NMT frame is
//       not processed (servo_drive.hpp, the personality port; Festo L1403-1405: 2 x 500 us).
//       Standard: 0 (every NMT frame is processed).
//   cia402: true | false
//       false: a plain CiA 301 device (CiA 301 §7.5.1: 1000h bits 0-15 = 0 or another profile;
//       the device profile is optional). The Cia402Application is not the drive's application:
//       no 6000h-9FFFh objects, no PDS, no motion, no 402 EMCYs; `simulate` inputs reach an
//       application that is not attached and change nothing on the bus. The profile's
//       identity.device_type gives 1000h. Standard: true.
//   absent_objects: [index | [first, last]]
//       Objects the device does not have (ObjectDictionary::remove_objects, after every other
//       object is in the dictionary, before the services bind; DriveConfig::absent_objects).
//       An SDO access aborts 06020000h (CiA 301 §7.2.4.3.17), the EDS omits them, and the
//       services whose objects are gone are off (device_services.hpp: no 100Ch/100Dh: no
//       guarding answers; no 1016h: no consumer; no 1005h: SYNC on 080h, no producer; no
//       1014h: no EMCY); without 1010h/1011h no store/restore (each reset applies the
//       defaults). 1000h, 1001h and 1018h are mandatory (CiA 301 §7.5.1 table of the
//       communication profile objects) and refused. An object a CiA 402 mode needs (6040h,
//       6041h, 6060h, 6061h, 6502h, ...) must stay; the drive does not check that: the
//       profile cites CiA 402-2 for each. Standard: none.
//   abort_codes: {standard code or name: code}
//       The SDO abort codes the drive answers in place of the standard drive's (the personality
//       port rewrites bytes 4-7 of each abort frame it sends on its SDO response COB-ID). Both
//       must be rows of protocol/cia301/sdo_abort_codes.inc; the profile cites, for each, the
//       clause or CTT case that accepts it (shared/notes/ctt-catalogue.md). Standard: none.
//   sdo_response_delay: duration | [min, max]
//       Each SDO response (and abort) leaves min..max after the drive produced it (a fixed
//       pseudo-random sequence per drive; never reordered); pending responses are dropped when
//       the drive sends its boot-up message (a reset loses them). CiA 301 gives no response
//       time; the default $timing.sdo_response is 100 ms: keep max below it. Standard: 0.
//   pdo_mapping: dynamic | static
//       static: every sub-index of the mapping records 1600h-17FFh and 1A00h-1BFFh refuses
//       SDO writes with 06010002h (CiA 301 §7.5.2.36, §7.5.2.38: a device with static mapping
//       has read-only mapping entries); the default mappings (pdo_defaults) stay. Standard:
//       dynamic.
//   empty_pdo_valid: accept | refuse
//       refuse: writing a PDO COB-ID (1400h-15FFh, 1800h-19FFh sub 01h) with bit 31 = 0
//       while its mapping record's sub 00h is 0 aborts 06090030h (CiA 301 §7.5.2.35 names
//       no reaction: refusing is permitted). accept: valid and silent (pdo_service.hpp).
//       Standard: accept.
//   tpdo_sync_phase: nth-sync | first-sync
//       A TPDO of type n (1..240) without a SYNC start value: its first transmission at the
//       n-th SYNC after entering Operational (nth-sync) or at the first (first-sync), then
//       every n-th (CiA 301 §7.5.2.37 leaves the phase open; PdoService::set_first_sync_phase).
//       Standard: nth-sync.
//   setpoint_buffer: 1..8
//       pp: the set-points a set of set-points (controlword bit 5 = 0) buffers behind the
//       running one (CiA 402-2 profile position: the buffer depth is the device's). Set-point
//       acknowledge clears once bit 4 is 0 and the buffer has room. Standard: 1.
//   initial_mode: -128..127
//       PowerDriveConfig::initial_mode: 6060h and 6061h after power on (and each reset). The
//       value must be 0 or one of the modes. Festo: 3 (6061h default 3, 000 §7.1.2
//       L5996-6005; 6060h default '-', L5967-5975). Standard: 0.
//   ip_max_buffer: 0..16
//       InterpolatedPositionMode: 60C4h sub 01h max_buffer_size and sub 02h's default; 0: no
//       buffer (60C4h sub 02h accepts 0 only; a 60C1h record replaces the one not yet taken and
//       is taken at the next SYNC). Festo: 0 (linear interpolation without buffer, 000 §7.4.2
//       L6606-6638). Standard: 16.
//   max_motor_speed: velocity-u32 | rpm-u16
//       6080h: UNSIGNED32 in velocity units (CiA 402-2), or UNSIGNED16 in min^-1 with default
//       32768, converted with encoder_resolution and capped by the simulated motor's own limit
//       (Festo 000 §7.5.2 L6939-6948). Standard: velocity-u32.
//   restore_output_stage_off: true | false
//       A 1011h "load" while the power stage is on (SWITCHED ON, OPERATION ENABLED, QUICK STOP
//       ACTIVE, FAULT REACTION ACTIVE) aborts 08000022h and restores nothing (Festo 000 §5.1
//       L2450, L2501; the output stage is switched on by transition 3, Tab. 6.2 L5219).
//       Standard: false.
//   position_range_limit: none | cia402 | festo
//       Cia402ApplicationConfig::position_range: 607Bh position range limit (CiA 402-2,
//       optional; axis/position_range.hpp). cia402: 607Bh with the whole INTEGER32 range by
//       default; a narrower range wraps 6062h/6064h and pp takes 60F2h bits 7..6 (rotary axis
//       direction option). festo (000 §5.7 L3821-3867): the range is in effect only while
//       6510h sub 20h (the profile's objects file adds it) selects a round axis, which gives the
//       direction (1, 2 shortest, 4 positive, 5 negative); 60F2h refuses bits 7..6. none: no
//       607Bh (a profile's objects file may add it as a plain stored value). Standard: cia402;
//       a profile's personality: none unless it says so.
//   note: text
//       Why the values are what they are; not used.
//
// The profile's pdo_defaults become the dictionary's PDO defaults (DictionaryOptions::pdo):
// PDOs 1-4 with the pre-defined COB-ID base (+N); bit 31 gives `valid`, bit 30 `rtr_allowed`;
// other bases cannot be shown (not_applied).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "protocol/cia301/nmt.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/cia402_application.hpp"
#include "reference_drive/device.hpp"
#include "reference_drive/modes/homing.hpp"

namespace drivecheck::reference_drive {

// A value the personality puts into an entry at each reset of its group, in place of the
// dictionary's default: only while the entry holds that default (stored parameters win).
struct DefaultOverride {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::int64_t value = 0;
  cia301::ResetKind reset = cia301::ResetKind::application;  // the reset that applies it
  friend bool operator==(const DefaultOverride&, const DefaultOverride&) = default;
};

// What a personality makes of the reference drive.
struct PersonalityPlan {
  std::string name;   // the profile's name; "standard" without a profile
  DriveConfig drive;  // dictionary (identity, heartbeat, PDO defaults), control cycle
  Cia402ApplicationConfig application;
  bool host_homing = true;  // 6 is among the modes
  HomingConfig homing;
  std::vector<DefaultOverride> overrides;
  std::vector<profile::ObjectRule> objects;  // apply_object_rules
  bool parameters_internal = false;          // InternalUnitParameters
  bool emcy_follow_up = false;
  profile::BusOffReaction bus_off = profile::BusOffReaction::cia301;  // ServoDrive applies it
  profile::ManufacturerObjects manufacturer_objects = profile::ManufacturerObjects::none;
  profile::PositionSampling position_sampling = profile::PositionSampling::none;
  bool hardware_enable_present = true;  // the input's state at power on
  // An NMT frame (COB-ID 000h) received less than this after the previous one is lost (Festo
  // nmt_min_spacing); zero: every NMT frame is processed.
  can::Duration nmt_min_spacing{};
  // false: no CiA 402 application (personality key cia402: false).
  bool cia402 = true;
  // SDO abort codes answered in place of the standard drive's (abort_codes) and the delay of
  // the SDO responses (sdo_response_delay): ServoDrive's personality port applies them.
  std::map<std::uint32_t, std::uint32_t> abort_codes;
  profile::ResponseDelay sdo_response_delay;
  bool static_pdo_mapping = false;  // pdo_mapping: static
  bool refuse_empty_pdo = false;    // empty_pdo_valid: refuse
  // restore_output_stage_off: ServoDrive sets DriveConfig::restore_guard (08000022h while the
  // PDS has the power stage on: SWITCHED ON, OPERATION ENABLED, QUICK STOP / FAULT REACTION
  // ACTIVE).
  bool restore_output_stage_off = false;
  // What the personality asks for that the reference drive cannot show (one line each).
  std::vector<std::string> not_applied;
};

// The standard drive's personality: every key at its standard value (above), the modes the
// reference drive hosts (1, 3, 4, 6, 7, 8, 9, 10). vectors/drives/cia402-reference.yaml says
// the same.
profile::Personality standard_personality();

// The plan of a profile's personality (profile->effective_personality() with its
// homing_methods, timing and pdo_defaults); nullptr: the standard drive. Errors: a value the
// reference drive cannot take at all (a mode value 5 or above 10, an option default the option
// codes refuse, an object type other than 6060h/6061h INTEGER16, ack_latency_cycles 0).
// `link`: the link the drive is reached over; a mode the profile has on another link only
// (modes_only_on) is left out (not in 6502h, 6060h refuses it).
Expected<PersonalityPlan, std::string> plan_personality(const profile::DriveProfile* profile,
                                                        profile::Link link = profile::Link::can);

// Festo's parameters in internal units (`parameters_internal` above). attach() chains write
// observers onto the parameters and the factor objects (6091h-6094h, 6097h, 607Eh) of `od`:
// a parameter write stores user value x factor (rounded to a whole internal unit); a factor
// write rewrites every parameter as internal / factor (polarity applied as FactorGroup does).
// resync() takes the internal values from the entries again (after a reset or a load).
class InternalUnitParameters {
 public:
  void attach(cia301::ObjectDictionary& od);
  void resync(const cia301::ObjectDictionary& od);

 private:
  enum class Kind : std::uint8_t { position, distance, velocity, speed, acceleration };
  struct Parameter {
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    Kind kind = Kind::position;
    double internal = 0.0;
  };
  static FactorGroup read_factors(const cia301::ObjectDictionary& od);
  static double to_internal(const FactorGroup& f, Kind kind, double user);
  static double to_user(const FactorGroup& f, Kind kind, double internal);
  void store(const cia301::ObjectDictionary& od, Parameter& p);
  void re_express(cia301::ObjectDictionary& od);

  std::vector<Parameter> parameters_;
};

// Adds and restricts the objects of `rules` (the `objects` key above) in `od`, after every
// other object is in it. `application` carries out the actions (set-actual-position); it must
// outlive `od`. Errors: a rule for an entry the dictionary lacks without `type`, a type for an
// index the dictionary has, a default or limit that does not fit the type.
Expected<void, std::string> apply_object_rules(cia301::ObjectDictionary& od,
                                               const std::vector<profile::ObjectRule>& rules,
                                               Cia402Application& application);

}  // namespace drivecheck::reference_drive

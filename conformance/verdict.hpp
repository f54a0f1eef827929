// Whether a vector applies to the selected drive, and how the outcome of its steps becomes a
// verdict (vectors/FORMAT.md "Verdicts"). Pure functions: the engine calls them, tests call
// them directly.
#pragma once

#include <cstdint>
#include <string>

#include "conformance/capabilities.hpp"
#include "conformance/dut_port.hpp"
#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::conformance {

struct ApplicabilityContext {
  bool simulation = false;      // a SimulationControl is present (embedded drive)
  bool motion_allowed = false;  // simulated bus, or --allow-motion on a real bus
  bool bus_off = false;         // the DUT's controller can be put bus-off (simulated bus)
  // What the DUT has (object needs, detected features); null: nothing probed, so object needs
  // count as met and detected features as unknown (present).
  const Capabilities* capabilities = nullptr;
  // A factory restore (setup restore-defaults, or a step writing 1011h) wipes the DUT's stored
  // parameters, a real drive's commissioning with them: allowed on the simulated bus, on a real
  // bus only with --allow-factory-restore.
  bool factory_restore_allowed = false;
  std::uint8_t node = 1;  // the DUT's node-ID (to decode the SDO downloads of `send:` frames)
  LinkKind link = LinkKind::can;  // the DUT port's link (dut_port.hpp)
};

// The first step (in `steps:` or `finally:`) that needs the CAN link itself: frames (send,
// expect_frame, expect_silence, expect_periodic, measure with frames:), NMT frames, boot-up,
// heartbeat, bus-off, a block SDO transfer. Empty: the vector's steps are services that every
// link has (SDO, controlword, statusword, poll, wait, simulate, mark, EMCY: CoE emergencies on
// EtherCAT).
std::string can_only_step(const Vector& vector);

// Whether the vector would restore the DUT's factory defaults: `setup: restore-defaults`, or a
// step (`steps:` or `finally:`) that writes 1011h (an sdo_write, or an SDO download a `send:`
// frame makes to 600h + node).
bool restores_factory_defaults(const Vector& vector, std::uint8_t node);

// A vector's result before it runs: what it is (id, family, title, sources, level, file:line).
VectorResult result_for(const Vector& vector);

// The reason a vector that would factory-restore is not applicable without the opt-in.
inline constexpr const char* kFactoryRestoreNotAllowed =
    "would restore factory defaults and wipe the device's stored parameters; pass "
    "--allow-factory-restore";

// "" when the vector applies; else the reason it is not applicable, e.g.
// kFactoryRestoreNotAllowed (a factory restore without context.factory_restore_allowed),
// "requires mode.hm (profile festo-cmmp lacks it)", "only for profile festo-cmmp",
// "needs object 1029h: absent (upload answered 06020000h)",
// "requires heartbeat.producer (probed: absent, 1017h: upload answered 06020000h)".
// A feature the profile detects (`detect:`) is supported unless the probe found it absent; an
// object need is met unless the EDS or the probe found the object absent.
std::string not_applicable_reason(const Vector& vector, const profile::DriveProfile& profile,
                                  const ApplicabilityContext& context);

// The object needs of a vector's `requires:` (object.IIII / object.IIII.SS).
std::vector<profile::ObjectNeed> object_needs(const Vector& vector);

// What running the steps gave.
enum class Outcome : std::uint8_t { pass, fail, harness_error };

// Whether the failing check shows the observation a deviation documents (abort code, value,
// nothing, accepted, state or statusword from Check::observed; text from its Actual, where a
// node-relative COB-ID "580+N#..." matches the frame from any node-ID 1..127).
bool observation_matches(const profile::DeviationObservation& documented, const Check& check);
// The failing check's observation in words: "abort 06090030h", "value -1000", "nothing in
// time", or its Actual quoted when it has no typed observation.
std::string describe(const Check& check);

// Sets verdict, message, deviation and warning of `result` from the outcome:
//   pass → pass; harness_error → error (message as given);
//   fail → deviation when a profile deviation lists the vector id and the first failing check
//          of result.checks shows the observation it documents (message: its description,
//          deviation_id/source set; the failure's Expected/Actual kept after it); else fail,
//          and each deviation that listed the id but documents another observation is named in
//          the message with what it documents and what the DUT showed; a should/may fail (not
//          a deviation) is a warning unless `strict`.
void decide_verdict(VectorResult& result, const Vector& vector,
                    const profile::DriveProfile& profile, Outcome outcome,
                    const std::string& message, bool strict);

}  // namespace drivecheck::conformance

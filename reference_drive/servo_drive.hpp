// ServoDrive: the composition root of the reference drive as a complete CiA 301 + CiA 402 servo
// drive on one Bus port: ReferenceDrive (device.hpp, the CiA 301 device) + Cia402Application
// (cia402_application.hpp: power drive system, axis, modes) + the homing mode
// (modes/homing.hpp) + a personality (personality.hpp: null profile = the standard drive) +
// named deviations (deviations.hpp). `drivecheck drive`, the embedded default of
// `drivecheck run` and the tests build drives through here and nowhere else.
//
// Wiring (what create() does, in order):
//   1. plan_personality(profile): DriveConfig, Cia402ApplicationConfig, HomingConfig, default
//      overrides, EMCY follow-up;
//   2. the deviations go to DriveConfig (CiA 301 ones), Cia402ApplicationConfig and its
//      PowerDriveConfig (CiA 402 ones);
//   3. Cia402Application + HomingOperationMode (when 6 is a mode), wrapped in the personality's
//      DriveApplication, which writes the default overrides into the dictionary at each reset
//      of their group before the application sees the reset (entries still at the dictionary's
//      default only: stored parameters win);
//   4. with emcy_follow_up, a port between the drive and `bus` that sends Kollmorgen's second
//      EMCY after each EMCY frame (byte 0-1 code != 0000h) the drive sends:
//        80h+N  [00 00 | ER | 00 00 00 00 00]   code 0000h, ER = byte 2 of the first EMCY
//      with nmt_min_spacing, the same port drops each NMT frame (000h) received less than that
//      after the previous one (Festo: such a burst is not processed);
//   5. ReferenceDrive::create on that port (or `bus`); the hardware enable input is present.
//      With a profile, its objects list (profile_objects.hpp) shapes the dictionary: the
//      objects the drive lacks are added last (after KollmorgenObjects), the listed defaults
//      of 6000h-9FFFh parameters join the default overrides, mapping records get the listed
//      number of entries. With position_sampling: festo, FestoPositionSampling
//      (festo_position_sampling.hpp) adds 204Ah before the profile's objects and takes the
//      simulated input `sample-input`.
// The drive is powered off after create(): power_on() starts it (boot-up message).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/store_restore.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/cia402_application.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/device.hpp"
#include "reference_drive/personality.hpp"

namespace drivecheck::reference_drive {

struct ServoDriveOptions {
  std::uint8_t node = 1;  // 1..127
  // The drive to impersonate (its personality and lists); nullptr: the standard drive. Only
  // read during create().
  const profile::DriveProfile* profile = nullptr;
  DeviationSet deviations;  // empty: conformant (apart from the personality)
  // Where 1010h saves to; nullptr: memory the drive owns. Must outlive the drive.
  cia301::ParameterStorage* storage = nullptr;
  // 1018h:04; 0: the node-ID (so that drives on one bus differ).
  std::uint32_t serial_number = 0;
  // The link the drive is reached over: the profile's modes of another link only
  // (modes_only_on) are left out.
  profile::Link link = profile::Link::can;
  // Called with the planned DriveConfig just before ReferenceDrive::create (empty: none): a
  // front end for another transport adjusts it (reference_drive/ethercat: default PDO
  // mappings of CoE, no CAN-only limits).
  std::function<void(DriveConfig&)> adjust_config;
};

class PersonalityPort;
class FestoPositionSampling;
class PersonalityApplication;

class ServoDrive {
 public:
  // Errors: the personality (plan_personality), the node-ID, the dictionary or storage
  // (ReferenceDrive::create).
  static Expected<std::unique_ptr<ServoDrive>, std::string> create(can::Bus& bus,
                                                                   ServoDriveOptions options);
  ~ServoDrive();
  ServoDrive(const ServoDrive&) = delete;
  ServoDrive& operator=(const ServoDrive&) = delete;

  // Power on: initialisation, boot-up message, Pre-operational, the PDS in SWITCH ON DISABLED
  // after its self-test.
  void power_on();

  // A simulated input (the vectors' `simulate` step; names and values as
  // Cia402Application::simulate documents: hardware-enable, limit-positive, fault:..., ...;
  // with `position_sampling: festo` also `sample-input` 0|1, festo_position_sampling.hpp).
  Expected<void, std::string> simulate(std::string_view input, std::int64_t value);
  // Festo's position sampling (personality key position_sampling: festo); null: none.
  FestoPositionSampling* position_sampling();

  ReferenceDrive& device() { return *drive_; }
  const ReferenceDrive& device() const { return *drive_; }
  Cia402Application& application() { return *application_; }
  const Cia402Application& application() const { return *application_; }
  const PersonalityPlan& plan() const { return plan_; }
  // The personality's wishes the reference drive cannot show (personality.hpp).
  const std::vector<std::string>& not_applied() const { return plan_.not_applied; }

 private:
  explicit ServoDrive(PersonalityPlan plan);

  PersonalityPlan plan_;
  std::unique_ptr<PersonalityPort> port_;
  std::unique_ptr<Cia402Application> application_;
  std::unique_ptr<PersonalityApplication> personality_;
  std::unique_ptr<ReferenceDrive> drive_;  // last: destroyed first
};

}  // namespace drivecheck::reference_drive

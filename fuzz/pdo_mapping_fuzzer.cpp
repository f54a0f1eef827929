// Fuzz target: PDO communication and mapping parameters written in any order (SDO), with NMT,
// SYNC, RPDO and RTR frames and time, into a whole reference drive (node 5) whose application
// has a few mappable objects. Each input runs on the bus reset to time 0 with the drive
// restarted on it (fuzz/support/drive_rig.hpp: as new, without building anything again).
//
// Input (fuzz/support/fuzz_input.hpp reads past the end as zeros): operations, one byte each
// (op % 7) and their operands; a frame is followed by bus time until it was on the wire (at
// most 100 ms) plus 1 ms:
//   0 SDO write       u8 target group {RPDO comm 1400h, RPDO mapping 1600h, TPDO comm 1800h,
//                     TPDO mapping 1A00h, application 2000h} by % 5, u8 PDO number (% 4), u8
//                     sub-index, u8 value kind, u32 value: kind % 4 = 0 the value as given,
//                     1 a mapping entry of an application object (value % 9 picks it), 2 a
//                     COB-ID of that PDO (bit 31 from the value), 3 a small number (value % 16)
//   1 NMT             u8 {start, pre-operational, stop, reset communication} by % 4
//   2 SYNC            u8: bit 0 with a counter byte, the rest the counter
//   3 RPDO            u8 PDO number (% 4), u8 DLC (% 9), 8 data bytes, on its current COB-ID
//   4 RTR             u8 TPDO number (% 4), on its current COB-ID
//   5 time step       u16 % 1000 milliseconds
//   6 application     u8 object (% 4): the application changes that input (TPDO sources)
//
// Oracles (CiA 301 §7.2.2 PDO, §7.5.2.35-38 mapping procedure):
//   - a PDO whose COB-ID is valid (bit 31 = 0) has a consistent mapping: at most 8 entries of
//     at most 64 bits together, each an existing, PDO-mappable entry of exactly that length,
//     readable for a TPDO, writable (or a dummy 0002h-0007h) for an RPDO;
//   - a TPDO the drive sent (the tester's own frames, e.g. its SYNC on a TPDO's COB-ID, are
//     not TPDOs) carries exactly the mapped objects' bytes (DLC = mapped length), when the
//     mapping did not change in the 5 ms before: for a synchronous transmission type (0..240,
//     252; §7.2.2.2) the values sampled at the last SYNC (or the one before, if its TPDO was
//     still queued), unless they changed within 5 ms before it or an RPDO came since the SYNC
//     before it (a synchronous RPDO is actuated at the SYNC); types 0..240 may also carry the
//     values when sent (an RTR answer: CiA 301 leaves its values open); for the others the
//     values when sent, unless they changed in the 5 ms before. A frame on the drive's EMCY
//     COB-ID (1014h) may be an EMCY and is not judged. When several valid TPDOs share the
//     frame's COB-ID, the frame may be any of them.
//   - the application objects change only by an SDO write to that object or through an RPDO
//     that maps them (RPDOs write only mapped objects).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "fuzz/support/drive_rig.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "reference_drive/device.hpp"

namespace {

using namespace drivecheck;
using namespace std::chrono_literals;
using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;
using cia301::ObjectDictionary;
using drivecheck::fuzz::DriveRig;
using drivecheck::fuzz::FuzzInput;

constexpr std::uint8_t kNode = 5;
constexpr can::Duration kQuiet = 5ms;

struct AppObject {
  std::uint16_t index;
  std::uint8_t sub;
  DataType type;
  AccessType access;
  bool mappable;
  std::uint8_t bits;
};
// 2003h is an input only the application changes (operation 6); 2005h is not mappable.
constexpr std::array<AppObject, 9> kAppObjects{{
    {0x2000, 0, DataType::unsigned16, AccessType::rw, true, 16},
    {0x2001, 0, DataType::unsigned32, AccessType::rw, true, 32},
    {0x2002, 0, DataType::unsigned8, AccessType::rw, true, 8},
    {0x2003, 0, DataType::unsigned16, AccessType::ro, true, 16},
    {0x2004, 0, DataType::unsigned16, AccessType::wo, true, 16},
    {0x2005, 0, DataType::unsigned16, AccessType::rw, false, 16},
    {0x2009, 0, DataType::unsigned64, AccessType::rw, true, 64},
    {0x200A, 1, DataType::integer16, AccessType::rw, true, 16},
    {0x200A, 2, DataType::integer16, AccessType::rw, true, 16},
}};

class FuzzApplication final : public reference_drive::DriveApplication {
 public:
  Expected<void, std::string> add_objects(ObjectDictionary& od) override {
    for (const AppObject& object : kAppObjects) {
      if (object.sub != 0) continue;
      auto added = od.add_object({object.index, "app", ObjectCode::var, {entry(object, 0)}});
      if (!added) return Unexpected(added.error());
    }
    EntryDefinition count = EntryDefinition::unsigned_entry(0, "Highest sub-index supported",
                                                            DataType::unsigned8, AccessType::ro, 2);
    auto added =
        od.add_object({0x200A,
                       "pair",
                       ObjectCode::array,
                       {std::move(count), entry(kAppObjects[7], 1), entry(kAppObjects[8], 2)}});
    if (!added) return Unexpected(added.error());
    return {};
  }

 private:
  static EntryDefinition entry(const AppObject& object, std::uint8_t sub) {
    EntryDefinition e;
    e.sub_index = sub;
    e.name = "app";
    e.type = object.type;
    e.access = object.access;
    e.pdo_mappable = object.mappable;
    return e;
  }
};

struct Mapped {
  std::uint16_t index;
  std::uint8_t sub;
  std::uint8_t bits;
};

// The drive lives across inputs: each input restarts it on the reset bus and releases it at
// its end (fuzz/support/drive_rig.hpp). The application has no state of its own (its objects'
// values are the dictionary's).
struct DriveSlot {
  FuzzApplication application;  // before drive: destroyed after it
  std::unique_ptr<reference_drive::ReferenceDrive> drive;

  // The PDO parameter entries (1400h, 1600h, 1800h, 1A00h + n, n < 4, sub 0..8; nullptr where
  // none) and the application objects, found once: the oracles read them after every step, and
  // entries stay where they are for the drive's lifetime.
  std::array<std::array<std::array<const cia301::Entry*, 9>, 4>, 4> pdo_entries{};
  std::array<cia301::Entry*, kAppObjects.size()> app_entries{};

  // The drive, created (and released) at the first call.
  reference_drive::ReferenceDrive& get(can::SimPort& port) {
    if (drive == nullptr) {
      reference_drive::DriveConfig config;
      config.dictionary.node_id = kNode;
      // No application cycle: nothing here needs one, and 1000 wake-ups per simulated second
      // would dominate the target's cost.
      config.control_cycle = can::Duration{0};
      config.application = &application;
      auto created = reference_drive::ReferenceDrive::create(port, config);
      DRIVECHECK_FUZZ_CHECK(created.has_value(), "the reference drive could not be created");
      drive = std::move(*created);
      drive->release_bus();
      static constexpr std::array<std::uint16_t, 4> kGroups{0x1400, 0x1600, 0x1800, 0x1A00};
      for (std::size_t g = 0; g < kGroups.size(); ++g) {
        for (std::uint16_t n = 0; n < 4; ++n) {
          for (std::uint8_t sub = 0; sub <= 8; ++sub)
            pdo_entries[g][n][sub] = drive->dictionary().find(kGroups[g] + n, sub);
        }
      }
      for (std::size_t i = 0; i < kAppObjects.size(); ++i)
        app_entries[i] = drive->dictionary().find(kAppObjects[i].index, kAppObjects[i].sub);
    }
    return *drive;
  }

  // od.find(index, sub) for a PDO parameter entry, from the table where it holds it.
  const cia301::Entry* pdo_entry(std::uint16_t index, std::uint8_t sub) const {
    const std::size_t group = index >= 0x1400 && index < 0x1404   ? 0
                              : index >= 0x1600 && index < 0x1604 ? 1
                              : index >= 0x1800 && index < 0x1804 ? 2
                              : index >= 0x1A00 && index < 0x1A04 ? 3
                                                                  : 4;
    if (group == 4 || sub > 8) return drive->dictionary().find(index, sub);
    return pdo_entries[group][index & 0x3u][sub];
  }
};

class Harness {
 public:
  Harness(DriveRig& rig, DriveSlot& slot)
      : slot_(slot),
        session_(
            rig, slot.get(*rig.drive_port), [](const can::TimedFrame&) {},
            [this](const can::TimedFrame& seen) { on_wire(seen); }),
        bus_(session_.bus()),
        tester_(&session_.tester()),
        drive_(&session_.drive()) {
    drive_->power_on();
    run(1ms);
  }

  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  ObjectDictionary& od() { return drive_->dictionary(); }

  // A frame from the tester, the bus run until it was on the wire (at most 100 ms) + 1 ms.
  void send(const can::Frame& frame, std::set<std::pair<std::uint16_t, std::uint8_t>> may_change) {
    observe();
    const std::uint64_t sent = session_.delivered();
    if (!tester_->send(frame)) {
      for (int waited = 0; session_.delivered() == sent && waited < 100; ++waited)
        bus_.run_for(1ms);
      bus_.run_for(1ms);
    }
    after_step(std::move(may_change));
  }

  void run(can::Duration duration) {
    observe();
    bus_.run_for(duration);
    after_step({});
  }

  // End of input: the values the oracle last took (by the dictionary's revision) are the
  // dictionary's, and every valid PDO is consistent, checked without the revision shortcut.
  DRIVECHECK_FUZZ_ORACLE_CODE void verify() {
    DRIVECHECK_FUZZ_CHECK(od().revision() != current_.revision ||
                              (app_values() == current_.app && rpdo_mapped() == current_.rpdo),
                          "the dictionary changed without its revision()");
    for (std::uint16_t n = 0; n < 4; ++n) {
      check_consistent(0x1400 + n, 0x1600 + n, false);
      check_consistent(0x1800 + n, 0x1A00 + n, true);
    }
  }

  void sdo_write(std::uint16_t index, std::uint8_t sub, std::uint32_t value) {
    const cia301::Entry* entry = od().find(index, sub);
    std::size_t size = entry != nullptr ? entry->bytes().size() : 4;
    if (size == 0 || size > 4) size = 4;
    const auto command = static_cast<std::uint8_t>(0x23 | ((4 - size) << 2));
    const std::array<std::uint8_t, 8> bytes{command,
                                            static_cast<std::uint8_t>(index),
                                            static_cast<std::uint8_t>(index >> 8),
                                            sub,
                                            static_cast<std::uint8_t>(value),
                                            static_cast<std::uint8_t>(value >> 8),
                                            static_cast<std::uint8_t>(value >> 16),
                                            static_cast<std::uint8_t>(value >> 24)};
    if (index >= 0x1400 && index < 0x1C00)
      last_config_change_ = bus_.now();
    else
      last_value_change_ = bus_.now();
    send(can::Frame::standard(0x600 + kNode, bytes), {{index, sub}});
    if (index >= 0x1400 && index < 0x1C00)
      last_config_change_ = bus_.now();
    else
      last_value_change_ = bus_.now();
  }

  void pdo_frame(const can::Frame& frame) {
    rpdo_since_sync_ = true;
    last_value_change_ = bus_.now();
    send(frame, {});
    last_value_change_ = bus_.now();
  }

  void application_changes(std::size_t which, std::uint16_t value) {
    cia301::Entry* entry = slot_.app_entries[which];
    if (entry == nullptr) return;
    last_value_change_ = bus_.now();
    entry->assign_unsigned(value);
    drive_->trigger_tpdo(1);
  }

  std::uint32_t cob_id(std::uint16_t comm_index) {
    const cia301::Entry* entry = slot_.pdo_entry(comm_index, 1);
    return entry != nullptr ? static_cast<std::uint32_t>(entry->as_unsigned()) : 0x80000000u;
  }

  void note_config_change() { last_config_change_ = bus_.now(); }

 private:
  using Key = std::pair<std::uint16_t, std::uint8_t>;

  DRIVECHECK_FUZZ_ORACLE_CODE std::vector<std::uint64_t> app_values() {
    std::vector<std::uint64_t> out;
    for (const cia301::Entry* entry : slot_.app_entries)
      out.push_back(entry != nullptr ? entry->as_unsigned() : 0);
    return out;
  }

  // The mapping of PDO `mapping_index`, or empty when its COB-ID is not valid.
  DRIVECHECK_FUZZ_ORACLE_CODE std::vector<Mapped> mapping_of(std::uint16_t comm_index,
                                                             std::uint16_t mapping_index,
                                                             bool* valid = nullptr) {
    std::vector<Mapped> out;
    const bool is_valid = (cob_id(comm_index) & 0x80000000u) == 0;
    if (valid != nullptr) *valid = is_valid;
    const cia301::Entry* count = slot_.pdo_entry(mapping_index, 0);
    if (count == nullptr) return out;
    const auto n = static_cast<std::uint8_t>(count->as_unsigned());
    for (std::uint8_t sub = 1; sub <= n; ++sub) {
      const cia301::Entry* e = slot_.pdo_entry(mapping_index, sub);
      if (e == nullptr) break;
      const auto word = static_cast<std::uint32_t>(e->as_unsigned());
      out.push_back({static_cast<std::uint16_t>(word >> 16), static_cast<std::uint8_t>(word >> 8),
                     static_cast<std::uint8_t>(word)});
    }
    return out;
  }

  DRIVECHECK_FUZZ_ORACLE_CODE std::set<Key> rpdo_mapped() {
    std::set<Key> out;
    for (std::uint16_t n = 0; n < 4; ++n) {
      bool valid = false;
      for (const Mapped& m : mapping_of(0x1400 + n, 0x1600 + n, &valid)) {
        if (valid) out.insert({m.index, m.sub});
      }
    }
    return out;
  }

  DRIVECHECK_FUZZ_ORACLE_CODE void check_consistent(std::uint16_t comm_index,
                                                    std::uint16_t mapping_index, bool tpdo) {
    bool valid = false;
    const std::vector<Mapped> mapping = mapping_of(comm_index, mapping_index, &valid);
    if (!valid) return;
    const std::string where =
        fmt::format("{:04X}h (valid) mapped by {:04X}h", comm_index, mapping_index);
    DRIVECHECK_FUZZ_CHECK_DETAIL(mapping.size() <= 8, "more than 8 mapping entries", where);
    unsigned total = 0;
    for (const Mapped& m : mapping) {
      total += m.bits;
      const bool dummy = m.index >= 0x0002 && m.index <= 0x0007 && m.sub == 0;
      if (dummy) {
        DRIVECHECK_FUZZ_CHECK_DETAIL(!tpdo, "a TPDO maps a dummy entry", where);
        continue;
      }
      const cia301::Entry* entry = od().find(m.index, m.sub);
      DRIVECHECK_FUZZ_CHECK_DETAIL(entry != nullptr,
                                   "a valid PDO maps an entry that does not exist",
                                   fmt::format("{}: {:04X}h sub {}", where, m.index, m.sub));
      DRIVECHECK_FUZZ_CHECK_DETAIL(entry->pdo_mappable(), "a valid PDO maps a non-mappable entry",
                                   fmt::format("{}: {:04X}h sub {}", where, m.index, m.sub));
      DRIVECHECK_FUZZ_CHECK_DETAIL(entry->bytes().size() * 8 == m.bits,
                                   "a valid PDO maps an entry with another length",
                                   fmt::format("{}: {:04X}h sub {} {} bits, entry {} bits", where,
                                               m.index, m.sub, m.bits, entry->bytes().size() * 8));
      const AccessType access = entry->access();
      if (tpdo) {
        DRIVECHECK_FUZZ_CHECK_DETAIL(access != AccessType::wo, "a TPDO maps a write-only entry",
                                     where);
      } else {
        DRIVECHECK_FUZZ_CHECK_DETAIL(
            access == AccessType::rw || access == AccessType::wo || access == AccessType::rww,
            "an RPDO maps an entry that cannot be written", where);
      }
    }
    DRIVECHECK_FUZZ_CHECK_DETAIL(total <= 64, "a valid PDO maps more than 64 bits", where);
  }

  // What the oracle knows of the dictionary: the application objects' values and the entries
  // valid RPDOs map, as of the dictionary's revision() (ObjectDictionary change tracking: the
  // same revision, the same values, so nothing to take or check again).
  struct Observed {
    std::uint64_t revision = 0;
    bool taken = false;
    std::vector<std::uint64_t> app;
    std::set<Key> rpdo;
  };

  DRIVECHECK_FUZZ_ORACLE_CODE void observe() {
    if (current_.taken && current_.revision == od().revision()) return;
    current_.revision = od().revision();
    current_.taken = true;
    current_.app = app_values();
    current_.rpdo = rpdo_mapped();
  }

  DRIVECHECK_FUZZ_ORACLE_CODE void after_step(std::set<Key> may_change) {
    // No value changed in this step: the PDOs are as consistent as after the last check and
    // no object changed (the first step is always checked).
    if (checked_ && od().revision() == current_.revision) return;
    checked_ = true;
    std::swap(previous_, current_);
    observe();
    const std::vector<std::uint64_t>& before = previous_.app;
    const std::set<Key>& rpdo_before = previous_.rpdo;
    for (std::uint16_t n = 0; n < 4; ++n) {
      check_consistent(0x1400 + n, 0x1600 + n, false);
      check_consistent(0x1800 + n, 0x1A00 + n, true);
    }
    const std::vector<std::uint64_t>& after = current_.app;
    std::set<Key> allowed = std::move(may_change);
    allowed.insert(rpdo_before.begin(), rpdo_before.end());
    const std::set<Key>& rpdo_after = current_.rpdo;
    allowed.insert(rpdo_after.begin(), rpdo_after.end());
    for (std::size_t i = 0; i < kAppObjects.size(); ++i) {
      if (before[i] == after[i]) continue;
      const Key key{kAppObjects[i].index, kAppObjects[i].sub};
      DRIVECHECK_FUZZ_CHECK_DETAIL(allowed.count(key) != 0,
                                   "an object changed that no write and no RPDO maps",
                                   fmt::format("{:04X}h sub {}: {:X}h -> {:X}h", key.first,
                                               key.second, before[i], after[i]));
    }
  }

  // The bytes TPDO n maps, from the dictionary now; nullopt when an entry is missing (caught by
  // check_consistent).
  DRIVECHECK_FUZZ_ORACLE_CODE std::optional<std::vector<std::uint8_t>> tpdo_bytes(std::uint16_t n) {
    std::vector<std::uint8_t> bytes;
    for (const Mapped& m : mapping_of(0x1800 + n, 0x1A00 + n)) {
      const cia301::Entry* entry = od().find(m.index, m.sub);
      if (entry == nullptr) return std::nullopt;
      bytes.insert(bytes.end(), entry->bytes().begin(), entry->bytes().end());
    }
    return bytes;
  }

  std::uint8_t transmission_type(std::uint16_t n) const {
    const cia301::Entry* entry = slot_.pdo_entry(0x1800 + n, 2);
    return entry != nullptr ? static_cast<std::uint8_t>(entry->as_unsigned()) : 255;
  }

  // The tester's SYNC: what each TPDO maps, as sampled now (CiA 301 §7.2.2.2).
  DRIVECHECK_FUZZ_ORACLE_CODE void sample_at_sync(can::TimePoint at) {
    // PDOs are processed in Operational only (CiA 301 §7.3.2.2, Table 49): a SYNC the drive sees
    // in another state samples nothing, and what a synchronous TPDO carries after the drive
    // comes back is not known from the SYNCs before (it may have dropped its samples).
    const bool operational = drive_->state() == cia301::NmtState::operational;
    const bool judgeable = operational && !rpdo_since_sync_ && at - last_value_change_ >= kQuiet;
    rpdo_since_sync_ = false;
    if (!operational) {
      forget_samples(at);
      return;
    }
    for (std::uint16_t n = 0; n < 4; ++n) {
      sampled_[n][1] = std::move(sampled_[n][0]);
      sampled_[n][0] = Sample{at, true, judgeable, tpdo_bytes(n)};
    }
  }

  // What the TPDOs sampled is unknown from `at` on: frames judged by these samples are skipped.
  DRIVECHECK_FUZZ_ORACLE_CODE void forget_samples(can::TimePoint at) {
    for (auto& samples : sampled_)
      for (Sample& sample : samples)
        sample = Sample{at, true, false, {}};
  }

  DRIVECHECK_FUZZ_ORACLE_CODE void on_wire(const can::TimedFrame& seen) {
    const can::Frame& frame = seen.frame;
    if (seen.own) {  // the tester's: never a TPDO of the drive
      if (!frame.is_remote() && !frame.is_error()) {
        // A SYNC for the drive: its SYNC COB-ID (1005h) with the length 1019h asks for (CiA 301
        // §7.2.5: a counter byte when 1019h > 0); a frame of another length is not processed.
        const cia301::Entry* cob_entry = od().find(0x1005, 0);
        const cia301::Entry* overflow = od().find(0x1019, 0);
        const auto cob =
            cob_entry != nullptr ? static_cast<std::uint32_t>(cob_entry->as_unsigned()) : 0x80u;
        const std::uint8_t length = overflow != nullptr && overflow->as_unsigned() != 0 ? 1 : 0;
        if (frame.id == (cob & 0x1FFFFFFFu) && frame.is_extended() == ((cob & 0x20000000u) != 0) &&
            frame.dlc == length)
          sample_at_sync(seen.timestamp);
      }
      // An NMT command: entering Operational starts every TPDO afresh (its SYNC sample gone,
      // CiA 301 §7.2.2.2 samples only in Operational), so no earlier SYNC tells what it carries.
      if (frame.id == 0x000 && !frame.is_extended() && !frame.is_remote())
        forget_samples(seen.timestamp);
      return;
    }
    if (frame.is_remote() || frame.is_error()) return;
    if (seen.timestamp - last_config_change_ < kQuiet) return;
    // A TPDO may share its COB-ID with the drive's EMCY (1014h): such a frame may be an EMCY.
    if (const cia301::Entry* emcy = od().find(0x1014, 0); emcy != nullptr) {
      const auto emcy_cob = static_cast<std::uint32_t>(emcy->as_unsigned());
      if ((emcy_cob & 0x80000000u) == 0 && frame.id == (emcy_cob & 0x1FFFFFFFu) &&
          frame.is_extended() == ((emcy_cob & 0x20000000u) != 0))
        return;
    }
    const auto payload = frame.payload();
    const auto carries = [&](const std::vector<std::uint8_t>& bytes) {
      return std::equal(payload.begin(), payload.end(), bytes.begin(), bytes.end());
    };
    std::string judged;  // the candidates the frame was judged against and did not match
    for (std::uint16_t n = 0; n < 4; ++n) {
      const std::uint32_t cob = cob_id(0x1800 + n);
      if ((cob & 0x80000000u) != 0) continue;
      const bool extended = (cob & 0x20000000u) != 0;
      if (frame.is_extended() != extended || frame.id != (cob & 0x1FFFFFFFu)) continue;
      const std::uint8_t type = transmission_type(n);
      if (type <= 240 || type == 252) {
        // The frame carries the values of one of the last two SYNCs (or, for 0..240 asked by
        // RTR, the values when sent: CiA 301 leaves an RTR answer's values open). When one of
        // those cannot be known (values changed just before, an RPDO came, the mapping
        // changed after it), the frame cannot be judged.
        for (const Sample& sample : sampled_[n]) {
          if (!sample.taken) continue;  // no SYNC that long ago
          if (!sample.bytes || !sample.judgeable || sample.at - last_config_change_ < kQuiet)
            return;
          if (carries(*sample.bytes)) return;
          judged +=
              fmt::format("; TPDO {} (type {}) sampled at the SYNC of {} ns: {:02X}", n + 1, type,
                          sample.at.time_since_epoch().count(), fmt::join(*sample.bytes, " "));
        }
        if (!sampled_[n][0].taken) return;  // no SYNC yet: nothing sampled to judge by
        if (type <= 240) {
          if (seen.timestamp - last_value_change_ < kQuiet) return;
          const auto now = tpdo_bytes(n);
          if (!now) return;
          if (carries(*now)) return;
          judged += fmt::format("; TPDO {} (type {}) when sent: {:02X}", n + 1, type,
                                fmt::join(*now, " "));
        }
        continue;
      }
      if (seen.timestamp - last_value_change_ < kQuiet) return;
      const auto now = tpdo_bytes(n);
      if (!now) return;
      if (carries(*now)) return;
      judged += fmt::format("; TPDO {} (type {}): {} bytes {:02X}", n + 1, type, now->size(),
                            fmt::join(*now, " "));
    }
    DRIVECHECK_FUZZ_CHECK_DETAIL(judged.empty(), "a TPDO does not carry its mapped objects",
                                 fmt::format("{}, expected{}", frame, judged));
  }

  const DriveSlot& slot_;
  fuzz::DriveSession session_;  // the bus reset, the drive restarted; released last
  can::SimBus& bus_;
  can::SimPort* tester_;
  reference_drive::ReferenceDrive* drive_;
  Observed previous_;  // the values before the last step that changed the dictionary
  Observed current_;   // the values now (as of current_.revision)
  bool checked_ = false;
  can::TimePoint last_config_change_{};
  can::TimePoint last_value_change_{};
  // What each TPDO mapped at the last two SYNCs of the tester ([0] the last).
  struct Sample {
    can::TimePoint at{};
    bool taken = false;
    bool judgeable = false;
    std::optional<std::vector<std::uint8_t>> bytes;
  };
  std::array<std::array<Sample, 2>, 4> sampled_{};
  bool rpdo_since_sync_ = false;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzInput in(data, size);
  static DriveSlot slot;
  static DriveRig rig;
  Harness harness(rig, slot);
  int operations = 0;
  while (!in.empty() && ++operations <= 256) {
    switch (in.u8() % 7) {
      case 0: {
        static constexpr std::array<std::uint16_t, 5> kGroups{0x1400, 0x1600, 0x1800, 0x1A00,
                                                              0x2000};
        const std::uint16_t group = kGroups[in.u8() % kGroups.size()];
        const std::uint8_t number = in.u8() % 4;
        std::uint8_t sub = in.u8();
        const std::uint8_t kind = in.u8() % 4;
        std::uint32_t value = in.u32();
        std::uint16_t index = static_cast<std::uint16_t>(group + number);
        if (group == 0x2000) {
          const AppObject& object = kAppObjects[sub % kAppObjects.size()];
          index = object.index;
          sub = object.sub;
        } else {
          sub = static_cast<std::uint8_t>(sub % 9);
        }
        if (kind == 1) {
          const AppObject& object = kAppObjects[value % kAppObjects.size()];
          value =
              (std::uint32_t{object.index} << 16) | (std::uint32_t{object.sub} << 8) | object.bits;
        } else if (kind == 2) {
          const bool rpdo = group == 0x1400 || group == 0x1600;
          const std::uint32_t base = rpdo ? 0x200u : 0x180u;
          value = (value & 0x80000000u) | (base + 0x100u * number + kNode);
        } else if (kind == 3) {
          value %= 16;
        }
        harness.sdo_write(index, sub, value);
        break;
      }
      case 1: {
        static constexpr std::array<std::uint8_t, 4> kCommands{0x01, 0x80, 0x02, 0x82};
        harness.note_config_change();  // reset communication restores the PDO defaults
        harness.send(can::Frame::standard(0x000, {kCommands[in.u8() % 4], kNode}), {});
        harness.note_config_change();
        break;
      }
      case 2: {
        const std::uint8_t sync = in.u8();
        harness.send((sync & 1) != 0
                         ? can::Frame::standard(0x080, {static_cast<std::uint8_t>(sync >> 1)})
                         : can::Frame::standard(0x080, {}),
                     {});
        break;
      }
      case 3: {
        const std::uint32_t cob = harness.cob_id(static_cast<std::uint16_t>(0x1400 + in.u8() % 4));
        const std::uint8_t dlc = static_cast<std::uint8_t>(in.u8() % 9);
        const auto bytes = in.bytes(8);
        if ((cob & 0x80000000u) != 0 || (cob & 0x20000000u) != 0 || (cob & 0x1FFFFFFFu) > 0x7FF)
          break;
        can::Frame frame = can::Frame::standard(
            cob & 0x7FFu, bytes.first(std::min<std::size_t>(dlc, bytes.size())));
        frame.dlc = dlc;
        harness.pdo_frame(frame);
        break;
      }
      case 4: {
        const std::uint32_t cob = harness.cob_id(static_cast<std::uint16_t>(0x1800 + in.u8() % 4));
        if ((cob & 0x80000000u) != 0 || (cob & 0x20000000u) != 0 || (cob & 0x1FFFFFFFu) > 0x7FF)
          break;
        harness.send(can::Frame::remote(cob & 0x7FFu, 0), {});
        break;
      }
      case 5:
        harness.run(std::chrono::milliseconds(in.u16() % 1000));
        break;
      default: {
        const std::size_t which = in.u8() % 4;
        harness.application_changes(which, in.u16());
        break;
      }
    }
  }
  harness.run(100ms);
  harness.verify();
  return 0;
}

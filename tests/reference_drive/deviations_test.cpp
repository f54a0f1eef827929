// The named deviations (reference_drive/deviations.inc): for every deviation the drive
// implements outside the mode logic, a scripted exchange that shows the standard drive doing
// what CiA 301/402 says and the deviant drive misbehaving in exactly the documented way.
// CiA 301 ones on the assembled drive (SimBus, node 5: SDO 605h/585h, EMCY 085h, heartbeat
// 705h, TPDO1 185h, RPDO1 205h); CiA 402 ones on the power drive system with a ramp axis.
// Plus the name table: parse, close names, the --help table.
#include "reference_drive/deviations.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/pdo.hpp"
#include "reference_drive/cia402_application.hpp"
#include "reference_drive/power_drive_system.hpp"
#include "reference_drive/ramp_axis.hpp"
#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;
using cia402::State;

constexpr std::uint8_t kStart = 0x01;
constexpr std::uint8_t kStop = 0x02;
constexpr std::uint8_t kResetNode = 0x81;
constexpr std::uint8_t kResetCommunication = 0x82;

DriveConfig deviant(Deviation deviation) {
  DriveConfig config;
  config.deviations.add(deviation);
  return config;
}

// Maps `entries` into TPDO/RPDO `number` (CiA 301 procedure), pre-defined CAN-ID, `type`.
void map_pdo(DriveRig& rig, cia301::PdoDirection direction, std::uint16_t number,
             const std::vector<std::uint32_t>& entries, std::uint8_t type) {
  const auto comm = cia301::pdo_communication_index(direction, number);
  const auto mapping = cia301::pdo_mapping_index(direction, number);
  const std::uint32_t base =
      (direction == cia301::PdoDirection::receive ? 0x200u : 0x180u) + 0x100u * (number - 1u);
  ASSERT_EQ(rig.write(comm, 1, 0x80000000u | (base + rig.node()), 4), 0u);
  ASSERT_EQ(rig.write(mapping, 0, 0, 1), 0u);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    ASSERT_EQ(rig.write(mapping, static_cast<std::uint8_t>(i + 1), entries[i], 4), 0u);
  }
  ASSERT_EQ(rig.write(mapping, 0, entries.size(), 1), 0u);
  ASSERT_EQ(rig.write(comm, 2, type, 1), 0u);
  ASSERT_EQ(rig.write(comm, 1, base + rig.node(), 4), 0u);
}

// The times of the frames whose candump text starts with `prefix`.
std::vector<can::TimePoint> times_of(const std::vector<can::TimedFrame>& frames,
                                     std::string_view prefix) {
  std::vector<can::TimePoint> times;
  for (const auto& timed : frames) {
    if (can::to_candump(timed.frame).rfind(prefix, 0) == 0) times.push_back(timed.timestamp);
  }
  return times;
}

std::size_t count_prefix(const Frames& frames, std::string_view prefix) {
  return static_cast<std::size_t>(std::count_if(
      frames.begin(), frames.end(), [&](const auto& f) { return f.rfind(prefix, 0) == 0; }));
}

// ---------------------------------------------------------------------------------------------
// The table and the set

TEST(DeviationTable, NamesAreUniqueKebabCaseAndEveryRowIsDescribed) {
  // Given the table generated from deviations.inc
  // When every row is checked
  // Then names are unique kebab-case, families are cia301/..., cia402/..., ethercat/... or
  //      eds/... (the generated EDS checks, run with the drive's own EDS), descriptions set,
  //      at least 45 rows, and at least one fatal deviation
  std::set<std::string_view> names;
  std::size_t fatal = 0;
  for (const DeviationInfo& info : kDeviations) {
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_TRUE(std::all_of(info.name.begin(), info.name.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
    })) << info.name;
    EXPECT_TRUE(info.family.starts_with("cia301/") || info.family.starts_with("cia402/") ||
                info.family.starts_with("ethercat/") || info.family.starts_with("eds/"))
        << info.family;
    EXPECT_GT(info.description.size(), 40u) << info.name;
    EXPECT_EQ(info_of(info.deviation).name, info.name);
    if (info.kind == DeviationKind::fatal) ++fatal;
  }
  EXPECT_GE(kDeviationCount, 45u);
  EXPECT_GE(fatal, 3u);
}

TEST(DeviationTable, LinkMarksAreSingleAndMatchTheFamilies) {
  // Given the DRIVECHECK_DEVIATION_ONLY_ON marks of deviations.inc
  // When every mark and every row is checked
  // Then each deviation is marked at most once with a reason, the ethercat/... rows act on
  //      EtherCAT only, and the SDO service rows act on both links (sdo_deviations.hpp)
  std::set<Deviation> marked;
  for (const DeviationOnlyOn& row : kDeviationsOnlyOn) {
    EXPECT_TRUE(marked.insert(row.deviation).second) << to_string(row.deviation);
    EXPECT_GT(row.why.size(), 5u) << to_string(row.deviation);
  }
  for (const DeviationInfo& info : kDeviations) {
    if (info.family.starts_with("ethercat/")) {
      EXPECT_FALSE(acts_on(info.deviation, DeviationLink::can)) << info.name;
      EXPECT_TRUE(acts_on(info.deviation, DeviationLink::ethercat)) << info.name;
    } else {
      EXPECT_TRUE(acts_on(info.deviation, DeviationLink::can)) << info.name;
    }
  }
  EXPECT_TRUE(acts_on(Deviation::sdo_read_only_wrong_abort, DeviationLink::ethercat));
  EXPECT_TRUE(only_on_why(Deviation::sdo_read_only_wrong_abort).empty());
  EXPECT_FALSE(acts_on(Deviation::sdo_block_sequence_ignored, DeviationLink::ethercat));
}

TEST(DeviationSetParse, NamesAndCommaListsParse) {
  // Given names as given on the command line, one of them a comma-separated list
  // When parsed
  // Then the set holds exactly those deviations
  const std::vector<std::string> names{"bootup-missing", "heartbeat-wrong-state, halt-ignored"};
  auto set = DeviationSet::parse(names);
  ASSERT_TRUE(set) << set.error();
  EXPECT_EQ(*set, (DeviationSet{Deviation::bootup_missing, Deviation::heartbeat_wrong_state,
                                Deviation::halt_ignored}));
  EXPECT_EQ(set->size(), 3u);
  EXPECT_EQ(set->names(), "bootup-missing, heartbeat-wrong-state, halt-ignored");
  EXPECT_FALSE(set->any_fatal());
  EXPECT_TRUE((DeviationSet{Deviation::fatal_babble_on_unknown_nmt}).any_fatal());
  EXPECT_EQ(DeviationSet{}.names(), "none");
  const std::vector<std::string> empty{"", " , ,", "halt-ignored,"};
  auto only_halt = DeviationSet::parse(empty);
  ASSERT_TRUE(only_halt) << only_halt.error();
  EXPECT_EQ(*only_halt, DeviationSet{Deviation::halt_ignored}) << "empty items are skipped";
}

TEST(DeviationSetParse, UnknownNameListsCloseNames) {
  // Given a misspelt name and a partial one
  // When parsed
  // Then the error names the input and suggests the close names
  const std::vector<std::string> typo{"bootup-mising"};
  auto set = DeviationSet::parse(typo);
  ASSERT_FALSE(set);
  EXPECT_NE(set.error().find("unknown deviation 'bootup-mising'"), std::string::npos);
  EXPECT_NE(set.error().find("did you mean: bootup-missing"), std::string::npos) << set.error();
  const auto close = close_deviation_names("toggle");
  EXPECT_FALSE(close.empty());
  for (std::string_view name : close)
    EXPECT_NE(name.find("toggle"), std::string_view::npos) << name;
  EXPECT_TRUE(close_deviation_names("zzzzzzzzzzzzzz").empty());
}

TEST(DeviationTableText, OneLinePerDeviation) {
  // Given the --help table
  // When it is printed
  // Then it has one line per deviation with name, family and kind
  const std::string table = deviation_table();
  EXPECT_EQ(static_cast<std::size_t>(std::count(table.begin(), table.end(), '\n')),
            kDeviationCount);
  EXPECT_NE(table.find("fatal-babble-on-unknown-nmt"), std::string::npos);
  EXPECT_NE(table.find("cia402/homing"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// cia301/sdo

TEST(DeviationSdo, ReadOnlyWrongAbort) {
  // Given the standard drive and one with sdo-read-only-wrong-abort
  // When 1000h (ro) is written
  // Then the standard aborts 06010002h, the deviant 06020000h
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_read_only_wrong_abort));
  // ccs=1 e=1 s=1 n=0, 1000h:00, 00000000h
  EXPECT_EQ(standard.exchange("605#2300100000000000"),
            Frames{sdo_abort_frame(5, 0x1000, 0, 0x06010002)});
  EXPECT_EQ(bad.exchange("605#2300100000000000"),
            Frames{sdo_abort_frame(5, 0x1000, 0, 0x06020000)});
}

TEST(DeviationSdo, ReadOnlyWriteAccepted) {
  // Given a drive with sdo-read-only-write-accepted
  // When 1000h (ro) is written
  // Then it confirms (60h) and the value is unchanged
  DriveRig bad(5, deviant(Deviation::sdo_read_only_write_accepted));
  // ccs=1 e=1 s=1 n=0, 1000h:00, 00000000h -> scs=3, 1000h:00
  EXPECT_EQ(bad.exchange("605#2300100000000000"), Frames{"585#6000100000000000"});
  EXPECT_EQ(bad.read(0x1000, 0).value, 0x00020192u);
}

TEST(DeviationSdo, NoObjectWrongAbort) {
  // Given the standard drive and one with sdo-no-object-wrong-abort
  // When 5FFFh (absent) is read
  // Then the standard aborts 06020000h, the deviant 06090011h (outside object-does-not-exist:
  // 08000000h would be a code the CTT accepts)
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_no_object_wrong_abort));
  EXPECT_EQ(standard.read(0x5FFF, 0).abort, 0x06020000u);
  EXPECT_EQ(bad.read(0x5FFF, 0).abort, 0x06090011u);
}

TEST(DeviationSdo, InvalidCommandIgnored) {
  // Given the standard drive and one with sdo-invalid-command-ignored
  // When a request with ccs 7 comes
  // Then the standard aborts 05040001h, the deviant says nothing
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_invalid_command_ignored));
  // ccs=7 (invalid), 1000h:00
  const Frames answer = standard.exchange("605#E000100000000000");
  ASSERT_EQ(answer.size(), 1u);
  EXPECT_EQ(answer[0].substr(0, 6), "585#80");
  EXPECT_EQ(answer[0].substr(12), "01000405");
  EXPECT_EQ(bad.exchange("605#E000100000000000"), Frames{});
  EXPECT_EQ(bad.read(0x1000, 0).value, 0x00020192u) << "the server still works";
}

TEST(DeviationSdo, DownloadResponseMissing) {
  // Given a drive with sdo-download-response-missing
  // When 2000h is written (expedited)
  // Then no response comes, though the value is written
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_download_response_missing));
  // ccs=1 n=2 e=1 s=1, 2000h:00, 1234h
  EXPECT_EQ(standard.exchange("605#2B00200034120000"), Frames{"585#6000200000000000"});
  EXPECT_EQ(bad.exchange("605#2B00200034120000"), Frames{});
  EXPECT_EQ(bad.read(0x2000, 0).value, 0x1234u);
}

TEST(DeviationSdo, ToggleNotAlternated) {
  // Given a segmented upload of 1008h (device name) on each drive
  // When the second segment (request toggle 1) is answered
  // Then the standard answers with toggle 1, the deviant with toggle 0
  for (const bool deviating : {false, true}) {
    DriveRig rig(5, deviating ? deviant(Deviation::sdo_toggle_not_alternated) : DriveConfig{});
    const Frames initiate = rig.exchange("605#4008100000000000");  // upload 1008h:00
    ASSERT_EQ(initiate.size(), 1u);
    ASSERT_EQ(initiate[0].substr(0, 6), "585#41") << "segmented (size indicated)";
    const Frames first = rig.exchange("605#6000000000000000");  // upload segment, t=0
    ASSERT_EQ(first.size(), 1u);
    EXPECT_EQ(first[0].substr(4, 1), "0") << "toggle 0 in the first segment";
    const Frames second = rig.exchange("605#7000000000000000");  // upload segment, t=1
    ASSERT_EQ(second.size(), 1u);
    EXPECT_EQ(second[0].substr(4, 1), deviating ? "0" : "1") << second[0];
  }
}

TEST(DeviationSdo, AbortWrongMultiplexer) {
  // Given a drive with sdo-abort-wrong-multiplexer
  // When 5FFFh:03 (absent) is read
  // Then the abort carries 0000h:00 instead of 5FFFh:03
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_abort_wrong_multiplexer));
  EXPECT_EQ(standard.exchange("605#40FF5F0300000000"),  // upload 5FFFh:03
            Frames{sdo_abort_frame(5, 0x5FFF, 3, 0x06020000)});
  EXPECT_EQ(bad.exchange("605#40FF5F0300000000"),
            Frames{sdo_abort_frame(5, 0x0000, 0, 0x06020000)});
}

TEST(DeviationSdo, UploadSizeWrong) {
  // Given a drive with sdo-upload-size-wrong
  // When 2000h (UNSIGNED16) is read
  // Then the response indicates 4 bytes (43h) instead of 2 (4Bh)
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_upload_size_wrong));
  // upload 2000h:00 -> scs=2 e=1 s=1 n=2 (4Bh) / n=0 (43h)
  EXPECT_EQ(standard.exchange("605#4000200000000000"), Frames{"585#4B00200000000000"});
  EXPECT_EQ(bad.exchange("605#4000200000000000"), Frames{"585#4300200000000000"});
}

TEST(DeviationSdo, LengthNotChecked) {
  // Given a drive with sdo-length-not-checked
  // When 4 bytes are written to 2000h (UNSIGNED16)
  // Then the standard aborts 06070012h, the deviant confirms, and nothing is written
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_length_not_checked));
  EXPECT_EQ(standard.write(0x2000, 0, 0x00010001, 4), 0x06070012u);
  // ccs=1 n=0 e=1 s=1, 2000h:00, 00010001h -> scs=3
  EXPECT_EQ(bad.exchange("605#2300200001000100"), Frames{"585#6000200000000000"});
  EXPECT_EQ(bad.read(0x2000, 0).value, 0u);
}

TEST(DeviationSdo, NoTimeout) {
  // Given a segmented upload of 1008h left open by the client
  // When 1.5 s pass (the drive's SDO timeout is 1 s)
  // Then the standard aborts 05040000h, the deviant never does
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_no_timeout));
  ASSERT_EQ(standard.exchange("605#4008100000000000").size(), 1u);  // upload 1008h:00
  ASSERT_EQ(bad.exchange("605#4008100000000000").size(), 1u);
  EXPECT_EQ(standard.run(1500ms), Frames{sdo_abort_frame(5, 0x1008, 0, 0x05040000)});
  EXPECT_EQ(bad.run(1500ms), Frames{});
}

// ---------------------------------------------------------------------------------------------
// cia301/nmt

TEST(DeviationNmt, BootupMissing) {
  // Given a drive with bootup-missing on a bus with a tester
  // When it is powered on and reset
  // Then no 705#00 ever appears, though the drive is pre-operational and answers SDO
  can::SimBus bus;
  auto tester = bus.attach("tester");
  auto port = bus.attach("drive");
  Frames seen;
  tester->set_frame_handler(
      [&](const can::TimedFrame& frame) { seen.push_back(can::to_candump(frame.frame)); });
  DriveConfig config = deviant(Deviation::bootup_missing);
  config.dictionary.node_id = 5;
  auto drive = ReferenceDrive::create(*port, std::move(config));
  ASSERT_TRUE(drive) << drive.error();
  (*drive)->power_on();
  bus.run_for(10ms);
  EXPECT_EQ((*drive)->state(), cia301::NmtState::pre_operational);
  ASSERT_FALSE(tester->send(*can::parse_candump("000#8105")));  // reset node 5
  bus.run_for(10ms);
  ASSERT_FALSE(tester->send(*can::parse_candump("000#8205")));  // reset communication 5
  bus.run_for(10ms);
  EXPECT_EQ(seen, Frames{}) << "no boot-up message";
  ASSERT_FALSE(tester->send(*can::parse_candump("605#4000100000000000")));  // upload 1000h
  bus.run_for(10ms);
  EXPECT_EQ(seen.back(), "585#4300100092010200");
}

TEST(DeviationNmt, BroadcastIgnored) {
  // Given the standard drive and one with nmt-broadcast-ignored
  // When NMT start goes to all nodes (0), then to node 5
  // Then the standard starts at once, the deviant only for its own node-ID
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::nmt_broadcast_ignored));
  standard.exchange("000#0100");  // start, all nodes
  bad.exchange("000#0100");
  EXPECT_EQ(standard.drive().state(), cia301::NmtState::operational);
  EXPECT_EQ(bad.drive().state(), cia301::NmtState::pre_operational);
  bad.exchange("000#0105");  // start, node 5
  EXPECT_EQ(bad.drive().state(), cia301::NmtState::operational);
}

TEST(DeviationNmt, StopIgnored) {
  // Given a drive with nmt-stop-ignored
  // When stop remote node comes
  // Then it stays pre-operational (the standard enters Stopped)
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::nmt_stop_ignored));
  standard.nmt(kStop);
  bad.nmt(kStop);
  EXPECT_EQ(standard.drive().state(), cia301::NmtState::stopped);
  EXPECT_EQ(bad.drive().state(), cia301::NmtState::pre_operational);
}

TEST(DeviationNmt, OtherNodeObeyed) {
  // Given a drive at node 5 with nmt-other-node-obeyed
  // When NMT start goes to node 6
  // Then it starts (the standard does not)
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::nmt_other_node_obeyed));
  standard.exchange("000#0106");  // start, node 6
  bad.exchange("000#0106");
  EXPECT_EQ(standard.drive().state(), cia301::NmtState::pre_operational);
  EXPECT_EQ(bad.drive().state(), cia301::NmtState::operational);
}

TEST(DeviationNmt, SdoInStopped) {
  // Given stopped drives
  // When 1000h is read
  // Then the standard is silent, the deviant answers
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sdo_in_stopped));
  standard.nmt(kStop);
  bad.nmt(kStop);
  EXPECT_EQ(bad.drive().state(), cia301::NmtState::stopped);
  EXPECT_EQ(standard.exchange("605#4000100000000000"), Frames{});  // upload 1000h:00
  EXPECT_EQ(bad.exchange("605#4000100000000000"), Frames{"585#4300100092010200"});
}

TEST(DeviationNmt, ResetCommunicationKeepsValues) {
  // Given 1017h written to 100 ms on both drives
  // When reset communication comes (then reset node)
  // Then the standard reads 1017h back at its default, the deviant keeps 100 until reset node
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::nmt_reset_communication_keeps_values));
  const std::uint64_t initial = standard.read(0x1017, 0).value;
  ASSERT_NE(initial, 100u);
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x1017, 0, 100, 2), 0u);
    rig->nmt(kResetCommunication);
  }
  EXPECT_EQ(standard.read(0x1017, 0).value, initial);
  EXPECT_EQ(bad.read(0x1017, 0).value, 100u);
  bad.nmt(kResetNode);
  EXPECT_EQ(bad.read(0x1017, 0).value, initial) << "reset node still resets everything";
}

// ---------------------------------------------------------------------------------------------
// cia301/heartbeat

TEST(DeviationHeartbeat, WrongState) {
  // Given heartbeat 10 ms on both drives
  // When they run pre-operational, then operational
  // Then the standard sends 7Fh then 05h, the deviant 05h then 7Fh
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::heartbeat_wrong_state));
  for (DriveRig* rig : {&standard, &bad})
    ASSERT_EQ(rig->write(0x1017, 0, 10, 2), 0u);
  EXPECT_EQ(standard.run(15ms), Frames{"705#7F"});
  EXPECT_EQ(bad.run(15ms), Frames{"705#05"});
  standard.nmt(kStart);
  bad.nmt(kStart);
  EXPECT_EQ(standard.run(10ms), Frames{"705#05"});
  EXPECT_EQ(bad.run(10ms), Frames{"705#7F"});
}

TEST(DeviationHeartbeat, PeriodLong) {
  // Given heartbeat 100 ms
  // When 1 s passes
  // Then the standard's heartbeats are 100 ms apart, the deviant's 110 ms
  for (const bool deviating : {false, true}) {
    DriveRig rig(5, deviating ? deviant(Deviation::heartbeat_period_long) : DriveConfig{});
    ASSERT_EQ(rig.write(0x1017, 0, 100, 2), 0u);
    rig.bus().run_for(1000ms);
    const auto times = times_of(rig.take(), "705#");
    ASSERT_GE(times.size(), 5u);
    for (std::size_t i = 1; i < times.size(); ++i) {
      const auto gap =
          std::chrono::duration_cast<std::chrono::microseconds>(times[i] - times[i - 1]);
      EXPECT_NEAR(static_cast<double>(gap.count()), deviating ? 110000.0 : 100000.0, 500.0);
    }
  }
}

TEST(DeviationHeartbeat, MissingInStopped) {
  // Given heartbeat 10 ms, drives stopped
  // When 30 ms pass
  // Then the standard sends 705#04, the deviant nothing
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::heartbeat_missing_in_stopped));
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x1017, 0, 10, 2), 0u);
    rig->nmt(kStop);
    rig->take();
  }
  EXPECT_EQ(count_prefix(standard.run(30ms), "705#04"), 3u);
  EXPECT_EQ(bad.run(30ms), Frames{});
  bad.nmt(0x80);
  EXPECT_EQ(count_prefix(bad.run(30ms), "705#7F"), 3u) << "pre-operational heartbeats go on";
}

TEST(DeviationHeartbeat, ConsumerTimeoutIgnored) {
  // Given each drive consumes node 10h's heartbeat at 100 ms, and node 10h sent one
  // When node 10h falls silent for 300 ms
  // Then the standard sends EMCY 8130h, the deviant nothing
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::heartbeat_consumer_timeout_ignored));
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x1016, 1, 0x00100064, 4), 0u);  // node 10h, 100 ms
    rig->exchange("710#05");                              // node 10h operational
  }
  EXPECT_EQ(count_prefix(standard.run(300ms), "085#3081"), 1u);
  EXPECT_EQ(bad.run(300ms), Frames{});
}

// ---------------------------------------------------------------------------------------------
// cia301/guarding

TEST(DeviationGuarding, ToggleNotAlternated) {
  // Given pre-operational drives without heartbeat
  // When two guarding requests (RTR 705h) come
  // Then the standard answers 7Fh then FFh, the deviant 7Fh twice
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::guarding_toggle_not_alternated));
  EXPECT_EQ(standard.exchange("705#R"), Frames{"705#7F"});
  EXPECT_EQ(standard.exchange("705#R"), Frames{"705#FF"});
  EXPECT_EQ(bad.exchange("705#R"), Frames{"705#7F"});
  EXPECT_EQ(bad.exchange("705#R"), Frames{"705#7F"});
}

TEST(DeviationGuarding, NoResponse) {
  // Given a drive with guarding-no-response
  // When a guarding request comes
  // Then it is not answered
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::guarding_no_response));
  EXPECT_EQ(standard.exchange("705#R"), Frames{"705#7F"});
  EXPECT_EQ(bad.exchange("705#R"), Frames{});
}

// ---------------------------------------------------------------------------------------------
// cia301/emcy

TEST(DeviationEmcy, InhibitIgnored) {
  // Given EMCY inhibit time 1015h = 100 ms
  // When two errors are raised at once
  // Then the standard sends the second 100 ms after the first, the deviant at once
  for (const bool deviating : {false, true}) {
    DriveRig rig(5, deviating ? deviant(Deviation::emcy_inhibit_ignored) : DriveConfig{});
    ASSERT_EQ(rig.write(0x1015, 0, 1000, 2), 0u);  // 1000 x 100 us
    rig.drive().raise_error(0x5000, 0);
    rig.drive().raise_error(0x6000, 0);
    rig.bus().run_for(300ms);
    const auto times = times_of(rig.take(), "085#");
    ASSERT_EQ(times.size(), 2u);
    const auto gap = times[1] - times[0];
    if (deviating) {
      EXPECT_LT(gap, 1ms);
    } else {
      EXPECT_GE(gap, 100ms);
    }
  }
}

TEST(DeviationEmcy, HistoryNotCleared) {
  // Given one error in the history (1003h:00 = 1)
  // When 0 is written to 1003h:00
  // Then both confirm; the standard reads 0 after, the deviant still 1
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::emcy_history_not_cleared));
  for (DriveRig* rig : {&standard, &bad}) {
    rig->drive().raise_error(0x5000, 0);
    rig->run(5ms);
    ASSERT_EQ(rig->read(0x1003, 0).value, 1u);
    EXPECT_EQ(rig->write(0x1003, 0, 0, 1), 0u);
  }
  EXPECT_EQ(standard.read(0x1003, 0).value, 0u);
  EXPECT_EQ(bad.read(0x1003, 0).value, 1u);
}

TEST(DeviationEmcy, ErrorResetMissing) {
  // Given one active error
  // When it is cleared
  // Then the standard sends EMCY 0000h, the deviant nothing
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::emcy_error_reset_missing));
  for (DriveRig* rig : {&standard, &bad}) {
    rig->drive().raise_error(0x5000, 0);
    EXPECT_EQ(count_prefix(rig->run(5ms), "085#005001"), 1u);  // 5000h, register 01h
    rig->drive().clear_error(0x5000);
  }
  EXPECT_EQ(standard.run(5ms), (Frames{emcy_frame(5, 0x0000, 0x00)}));
  EXPECT_EQ(bad.run(5ms), Frames{});
}

TEST(DeviationEmcy, RegisterZero) {
  // Given a drive with emcy-register-zero
  // When an error is raised
  // Then the EMCY's byte 2 is 00h instead of 01h (1001h, generic error)
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::emcy_register_zero));
  standard.drive().raise_error(0x5000, 0);
  bad.drive().raise_error(0x5000, 0);
  EXPECT_EQ(standard.run(5ms), (Frames{emcy_frame(5, 0x5000, 0x01)}));
  EXPECT_EQ(bad.run(5ms), (Frames{emcy_frame(5, 0x5000, 0x00)}));
}

TEST(DeviationEmcy, CobIdIgnored) {
  // Given 1014h set to 0A0h
  // When an error is raised
  // Then the standard sends on 0A0h, the deviant on 085h
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::emcy_cob_id_ignored));
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x1014, 0, 0x800000A0, 4), 0u);
    ASSERT_EQ(rig->write(0x1014, 0, 0x000000A0, 4), 0u);
    rig->drive().raise_error(0x5000, 0);
  }
  EXPECT_EQ(standard.run(5ms), (Frames{"0A0#0050010000000000"}));
  EXPECT_EQ(bad.run(5ms), (Frames{emcy_frame(5, 0x5000, 0x01)}));
}

// ---------------------------------------------------------------------------------------------
// cia301/sync, cia301/pdo

TEST(DeviationSync, CounterIgnored) {
  // Given 1019h = 10 and TPDO1 type 3 with SYNC start value 2, operational
  // When SYNCs with counters 1..10 come
  // Then the standard sends after counters 2, 5, 8; the deviant counts from the first SYNC
  //      (3, 6, 9), as if there were no start value
  for (const bool deviating : {false, true}) {
    DriveRig rig(5, deviating ? deviant(Deviation::sync_counter_ignored) : DriveConfig{});
    ASSERT_EQ(rig.write(0x1019, 0, 10, 1), 0u);
    ASSERT_EQ(rig.write(0x1800, 6, 2, 1), 0u);
    map_pdo(rig, cia301::PdoDirection::transmit, 1, {0x20020008}, 3);
    rig.nmt(kStart);
    std::vector<int> sent;
    for (std::uint8_t counter = 1; counter <= 10; ++counter) {
      if (rig.sync(counter).size() == 1) sent.push_back(counter);
    }
    EXPECT_EQ(sent, deviating ? (std::vector<int>{3, 6, 9}) : (std::vector<int>{2, 5, 8}));
  }
}

TEST(DeviationSync, TpdoMissing) {
  // Given TPDO1 type 1 (every SYNC) mapping 2000h, operational
  // When SYNCs come
  // Then the standard sends TPDO1 after each, the deviant never; its other services go on
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::sync_tpdo_missing));
  for (DriveRig* rig : {&standard, &bad}) {
    map_pdo(*rig, cia301::PdoDirection::transmit, 1, {0x20000010}, 1);
    rig->nmt(kStart);
  }
  EXPECT_EQ(standard.sync(), (Frames{"185#0000"}));
  EXPECT_EQ(bad.sync(), Frames{});
  EXPECT_EQ(bad.sync(), Frames{});
  EXPECT_EQ(bad.read(0x1000, 0).value, 0x00020192u);
}

TEST(DeviationPdo, PdoInPreOperational) {
  // Given TPDO1 type 1 mapping 2000h, drives pre-operational
  // When a SYNC comes
  // Then the standard sends nothing, the deviant TPDO1
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::pdo_in_pre_operational));
  for (DriveRig* rig : {&standard, &bad})
    map_pdo(*rig, cia301::PdoDirection::transmit, 1, {0x20000010}, 1);
  EXPECT_EQ(standard.sync(), Frames{});
  EXPECT_EQ(bad.sync(), (Frames{"185#0000"}));
}

TEST(DeviationPdo, MappingTooLongAccepted) {
  // Given TPDO1's mapping disabled and two 64-bit entries (2009h) written
  // When sub 00h := 2 (128 bits) is written
  // Then the standard aborts 06040042h, the deviant confirms; neither enables it
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::pdo_mapping_too_long_accepted));
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x1800, 1, 0x80000185, 4), 0u);
    ASSERT_EQ(rig->write(0x1A00, 0, 0, 1), 0u);
    ASSERT_EQ(rig->write(0x1A00, 1, 0x20090040, 4), 0u);
    ASSERT_EQ(rig->write(0x1A00, 2, 0x20090040, 4), 0u);
  }
  EXPECT_EQ(standard.write(0x1A00, 0, 2, 1), 0x06040042u);
  EXPECT_EQ(bad.write(0x1A00, 0, 2, 1), 0u);
  EXPECT_EQ(bad.read(0x1A00, 0).value, 0u);
}

TEST(DeviationPdo, RtrIgnored) {
  // Given TPDO1 type 253 (on RTR) mapping 2000h, operational
  // When an RTR on 185h comes
  // Then the standard answers with TPDO1, the deviant not
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::pdo_rtr_ignored));
  for (DriveRig* rig : {&standard, &bad}) {
    map_pdo(*rig, cia301::PdoDirection::transmit, 1, {0x20000010}, 253);
    rig->nmt(kStart);
    rig->take();
  }
  EXPECT_EQ(standard.exchange("185#R2"), (Frames{"185#0000"}));
  EXPECT_EQ(bad.exchange("185#R2"), Frames{});
}

TEST(DeviationPdo, RpdoLengthErrorNotReported) {
  // Given RPDO1 mapping 2000h (2 bytes), operational
  // When a 1-byte RPDO1 comes
  // Then the standard sends EMCY 8210h, the deviant nothing
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::rpdo_length_error_not_reported));
  for (DriveRig* rig : {&standard, &bad}) {
    map_pdo(*rig, cia301::PdoDirection::receive, 1, {0x20000010}, 255);
    rig->nmt(kStart);
    rig->take();
  }
  EXPECT_EQ(count_prefix(standard.exchange("205#01"), "085#1082"), 1u);
  EXPECT_EQ(bad.exchange("205#01"), Frames{});
}

TEST(DeviationPdo, TpdoWrongLength) {
  // Given TPDO1 type 1 mapping 2000h (2 bytes), operational
  // When a SYNC comes
  // Then the standard's TPDO1 has 2 bytes, the deviant's 8
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::tpdo_wrong_length));
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x2000, 0, 0x1234, 2), 0u);
    map_pdo(*rig, cia301::PdoDirection::transmit, 1, {0x20000010}, 1);
    rig->nmt(kStart);
  }
  EXPECT_EQ(standard.sync(), (Frames{"185#3412"}));
  EXPECT_EQ(bad.sync(), (Frames{"185#3412000000000000"}));
}

// ---------------------------------------------------------------------------------------------
// cia301/store, cia301/od

TEST(DeviationStore, SignatureIgnored) {
  // Given 1017h := 100
  // When 12345678h (not "save") is written to 1010h:01
  // Then the standard aborts 08000020h and stores nothing; the deviant stores
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::store_signature_ignored));
  for (DriveRig* rig : {&standard, &bad})
    ASSERT_EQ(rig->write(0x1017, 0, 100, 2), 0u);
  EXPECT_EQ(standard.write(0x1010, 1, 0x12345678, 4), 0x08000020u);
  EXPECT_EQ(bad.write(0x1010, 1, 0x12345678, 4), 0u);
  standard.nmt(kResetNode);
  bad.nmt(kResetNode);
  EXPECT_NE(standard.read(0x1017, 0).value, 100u);
  EXPECT_EQ(bad.read(0x1017, 0).value, 100u) << "stored without the signature";
}

TEST(DeviationStore, RestoreIgnored) {
  // Given 1017h := 100 saved ("save" to 1010h:01)
  // When "load" is written to 1011h:01 and the node is reset
  // Then both confirm; the standard has the default back, the deviant still 100
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::restore_ignored));
  const std::uint64_t initial = standard.read(0x1017, 0).value;
  for (DriveRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->write(0x1017, 0, 100, 2), 0u);
    ASSERT_EQ(rig->write(0x1010, 1, 0x65766173, 4), 0u);  // "save"
    EXPECT_EQ(rig->write(0x1011, 1, 0x64616F6C, 4), 0u);  // "load"
    rig->nmt(kResetNode);
  }
  EXPECT_EQ(standard.read(0x1017, 0).value, initial);
  EXPECT_EQ(bad.read(0x1017, 0).value, 100u);
}

TEST(DeviationOd, DeviceTypeWrong) {
  // Given a drive with device-type-wrong
  // When 1000h is read
  // Then it reads 0 instead of 00020192h
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::device_type_wrong));
  EXPECT_EQ(standard.read(0x1000, 0).value, 0x00020192u);
  // upload 1000h:00 -> scs=2 n=0 e=1 s=1, 00000000h
  EXPECT_EQ(bad.exchange("605#4000100000000000"), Frames{"585#4300100000000000"});
}

TEST(DeviationOd, ErrorRegisterNotSet) {
  // Given an active error
  // When 1001h is read
  // Then the standard reads bit 0 set, the deviant 00h
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::error_register_not_set));
  for (DriveRig* rig : {&standard, &bad}) {
    rig->drive().raise_error(0x5000, 0);
    rig->run(5ms);
  }
  EXPECT_EQ(standard.read(0x1001, 0).value, 0x01u);
  EXPECT_EQ(bad.read(0x1001, 0).value, 0x00u);
}

// ---------------------------------------------------------------------------------------------
// fatal

TEST(DeviationFatal, CrashOnInvalidCommand) {
  // Given a drive with fatal-crash-on-invalid-command and heartbeat 10 ms
  // When a request with ccs 7 comes
  // Then it falls silent for good: no abort, no heartbeat, no SDO, no NMT, no boot-up
  DriveRig bad(5, deviant(Deviation::fatal_crash_on_invalid_command));
  ASSERT_EQ(bad.write(0x1017, 0, 10, 2), 0u);
  EXPECT_EQ(count_prefix(bad.run(30ms), "705#7F"), 3u);
  EXPECT_EQ(bad.exchange("605#E000000000000000", 100ms), Frames{});  // ccs=7
  EXPECT_TRUE(bad.drive().deviation_port()->crashed());
  EXPECT_EQ(bad.read(0x1000, 0).answered, false);
  EXPECT_EQ(bad.nmt(kResetNode), Frames{});
  EXPECT_EQ(bad.run(100ms), Frames{});
}

TEST(DeviationFatal, SdoHangOnMissingSub) {
  // Given a drive with fatal-sdo-hang-on-missing-sub and heartbeat 10 ms
  // When 1000h:05 (no such sub-index) is read
  // Then no answer comes, no later SDO is answered, but heartbeat and NMT go on
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::fatal_sdo_hang_on_missing_sub));
  ASSERT_EQ(bad.write(0x1017, 0, 10, 2), 0u);
  EXPECT_EQ(standard.read(0x1000, 5).abort, 0x06090011u);
  EXPECT_EQ(bad.read(0x1000, 5).answered, false);
  EXPECT_TRUE(bad.drive().deviation_port()->sdo_hung());
  EXPECT_EQ(bad.read(0x1000, 0).answered, false);
  bad.nmt(kStart);
  EXPECT_EQ(bad.drive().state(), cia301::NmtState::operational);
  EXPECT_EQ(count_prefix(bad.run(30ms), "705#05"), 3u) << "heartbeat goes on";
}

TEST(DeviationFatal, BabbleOnUnknownNmt) {
  // Given a drive with fatal-babble-on-unknown-nmt
  // When NMT command 09h (unknown) comes to node 5
  // Then the drive sends 085h frames back to back (about one per 111 us at 1 Mbit/s)
  DriveRig standard;
  DriveRig bad(5, deviant(Deviation::fatal_babble_on_unknown_nmt));
  EXPECT_EQ(standard.exchange("000#0905"), Frames{});  // unknown NMT command, node 5
  const Frames flood = bad.exchange("000#0905", 10ms);
  EXPECT_GE(count_prefix(flood, "085#FFFFFFFFFFFFFFFF"), 80u);
  EXPECT_TRUE(bad.drive().deviation_port()->babbling());
}

// ---------------------------------------------------------------------------------------------
// cia402 (the power drive system)

class PdsRig {
 public:
  explicit PdsRig(DeviationSet deviations = {})
      : axis(axis_config()), pds(axis, config(deviations)) {
    pds.power_on(now);
    tick();
  }
  static RampAxisConfig axis_config() {
    RampAxisConfig config;
    config.acceleration = 0;
    return config;
  }
  static PowerDriveConfig config(DeviationSet deviations) {
    PowerDriveConfig config;
    config.slow_down_deceleration = 10000;
    config.quick_stop_deceleration = 50000;  // 20 ms from 1000 units/s
    config.deviations = deviations;
    return config;
  }
  void tick() {
    now += 1ms;
    axis.advance(1ms);
    pds.step(now);
  }
  void ticks(int n) {
    for (int i = 0; i < n; ++i)
      tick();
  }
  void command(std::uint16_t controlword) {
    pds.set_controlword(controlword);
    tick();
  }
  void to_operation_enabled(std::int32_t velocity = 1000) {
    command(0x0006);
    command(0x0007);
    axis.set_velocity_set_point(velocity);
    command(0x000F);
    tick();
  }

  can::TimePoint now{};
  RampAxis axis;
  PowerDriveSystem pds;
};

TEST(DeviationFsa, Transition16WhenForbidden) {
  // Given QUICK STOP ACTIVE with 605Ah = 2 (quick stop ramp, then SWITCH ON DISABLED), axis
  //       still decelerating
  // When enable operation (000Fh) comes
  // Then the standard ignores it, the deviant takes transition 16 to OPERATION ENABLED
  for (const bool deviating : {false, true}) {
    PdsRig rig(deviating ? DeviationSet{Deviation::transition_16_when_forbidden} : DeviationSet{});
    rig.to_operation_enabled();
    rig.command(0x000B);  // quick stop
    ASSERT_EQ(rig.pds.state(), State::quick_stop_active);
    rig.command(0x000F);  // enable operation
    EXPECT_EQ(rig.pds.state(), deviating ? State::operation_enabled : State::quick_stop_active);
  }
}

TEST(DeviationFsa, StatuswordBit5WrongSwitchedOn) {
  // Given SWITCHED ON
  // When the statusword is read
  // Then the standard shows 0233h, the deviant 0213h
  PdsRig standard;
  PdsRig bad(DeviationSet{Deviation::statusword_bit5_wrong_switched_on});
  for (PdsRig* rig : {&standard, &bad}) {
    rig->command(0x0006);
    rig->command(0x0007);
    ASSERT_EQ(rig->pds.state(), State::switched_on);
  }
  EXPECT_EQ(standard.pds.statusword(), 0x0233);
  EXPECT_EQ(bad.pds.statusword(), 0x0213);
  bad.command(0x000F);
  EXPECT_EQ(bad.pds.statusword(), 0x0237) << "only SWITCHED ON is wrong";
}

TEST(DeviationFsa, FaultResetOnLevel) {
  // Given FAULT with its cause present and controlword 0080h (the edge is consumed)
  // When the cause goes while bit 7 stays high
  // Then the standard stays in FAULT (no new edge), the deviant resets to SWITCH ON DISABLED
  for (const bool deviating : {false, true}) {
    PdsRig rig(deviating ? DeviationSet{Deviation::fault_reset_on_level} : DeviationSet{});
    rig.pds.raise_fault(faults::kOverCurrent);
    rig.ticks(3);
    ASSERT_EQ(rig.pds.state(), State::fault);
    rig.command(0x0080);
    rig.ticks(2);
    ASSERT_EQ(rig.pds.state(), State::fault) << "cause present";
    rig.pds.clear_fault_cause(faults::kOverCurrent.code);
    rig.ticks(2);
    EXPECT_EQ(rig.pds.state(), deviating ? State::switch_on_disabled : State::fault);
  }
}

TEST(DeviationFsa, QuickStopIgnored) {
  // Given OPERATION ENABLED
  // When quick stop (000Bh) comes
  // Then the standard enters QUICK STOP ACTIVE, the deviant stays
  PdsRig standard;
  PdsRig bad(DeviationSet{Deviation::quick_stop_ignored});
  for (PdsRig* rig : {&standard, &bad}) {
    rig->to_operation_enabled();
    rig->command(0x000B);
  }
  EXPECT_EQ(standard.pds.state(), State::quick_stop_active);
  EXPECT_EQ(bad.pds.state(), State::operation_enabled);
  bad.command(0x0000);
  EXPECT_EQ(bad.pds.state(), State::switch_on_disabled) << "disable voltage still works";
}

TEST(DeviationFsa, EnableOperationFromSwitchOnDisabled) {
  // Given SWITCH ON DISABLED
  // When 000Fh is written and the drive runs 5 cycles
  // Then the standard stays, the deviant ends in OPERATION ENABLED
  PdsRig standard;
  PdsRig bad(DeviationSet{Deviation::enable_operation_from_switch_on_disabled});
  for (PdsRig* rig : {&standard, &bad}) {
    ASSERT_EQ(rig->pds.state(), State::switch_on_disabled);
    rig->command(0x000F);
    rig->ticks(5);
  }
  EXPECT_EQ(standard.pds.state(), State::switch_on_disabled);
  EXPECT_EQ(bad.pds.state(), State::operation_enabled);
}

TEST(DeviationFsa, Transition16OnlyWithQuickStop6) {
  // Given QUICK STOP ACTIVE with 605Ah = 5, 6, 7 or 8 (stay in QUICK STOP ACTIVE)
  // When enable operation (000Fh) comes
  // Then the standard takes transition 16 with each, the deviant only with 6
  for (const bool deviating : {false, true}) {
    for (const std::int16_t option : {5, 6, 7, 8}) {
      PdsRig rig(deviating ? DeviationSet{Deviation::transition_16_only_with_quick_stop_6}
                           : DeviationSet{});
      ASSERT_TRUE(rig.pds.set_option_code(OptionCode::quick_stop, option));
      rig.to_operation_enabled();
      rig.command(0x0002);  // quick stop
      ASSERT_EQ(rig.pds.state(), State::quick_stop_active);
      rig.command(0x000F);  // enable operation
      EXPECT_EQ(rig.pds.state(),
                !deviating || option == 6 ? State::operation_enabled : State::quick_stop_active)
          << "605Ah = " << option;
    }
  }
}

TEST(DeviationFsa, FaultResetInStopStates) {
  // Given QUICK STOP ACTIVE (605Ah = 6), and FAULT REACTION ACTIVE (605Eh = 1, slow ramp)
  // When a fault reset edge comes (0082h there, 0080h here)
  // Then the standard keeps the state (the reaction ends in FAULT), the deviant goes to SWITCH
  //      ON DISABLED
  for (const bool deviating : {false, true}) {
    const DeviationSet deviations =
        deviating ? DeviationSet{Deviation::fault_reset_in_stop_states} : DeviationSet{};
    PdsRig quick_stop(deviations);
    ASSERT_TRUE(quick_stop.pds.set_option_code(OptionCode::quick_stop, 6));
    quick_stop.to_operation_enabled();
    quick_stop.command(0x0002);
    ASSERT_EQ(quick_stop.pds.state(), State::quick_stop_active);
    quick_stop.command(0x0082);
    quick_stop.ticks(2);
    EXPECT_EQ(quick_stop.pds.state(),
              deviating ? State::switch_on_disabled : State::quick_stop_active);

    PdsRig reaction(deviations);
    ASSERT_TRUE(reaction.pds.set_option_code(OptionCode::fault_reaction, 1));
    reaction.to_operation_enabled();
    reaction.ticks(200);                   // up to speed
    reaction.pds.on_communication_loss();  // 6007h = 1: fault
    reaction.tick();
    ASSERT_EQ(reaction.pds.state(), State::fault_reaction_active);
    reaction.command(0x0080);
    EXPECT_EQ(reaction.pds.state(),
              deviating ? State::switch_on_disabled : State::fault_reaction_active);
    reaction.ticks(500);
    EXPECT_EQ(reaction.pds.state(), deviating ? State::switch_on_disabled : State::fault);
  }
}

TEST(DeviationFsa, QuickStopTargetReachedMissing) {
  // Given a quick stop with 605Ah = 6 from 1000 units/s
  // When the axis has stopped in QUICK STOP ACTIVE
  // Then the standard shows bit 10 (0417h with voltage enabled), the deviant not; while the
  //      axis decelerates neither does
  for (const bool deviating : {false, true}) {
    PdsRig rig(deviating ? DeviationSet{Deviation::quick_stop_target_reached_missing}
                         : DeviationSet{});
    ASSERT_TRUE(rig.pds.set_option_code(OptionCode::quick_stop, 6));
    rig.to_operation_enabled();
    rig.ticks(200);
    rig.command(0x0002);
    ASSERT_EQ(rig.pds.state(), State::quick_stop_active);
    EXPECT_EQ(rig.pds.statusword() & 0x0400, 0) << "still decelerating";
    rig.ticks(100);
    ASSERT_TRUE(rig.axis.is_stopped());
    EXPECT_EQ(rig.pds.statusword() & 0x0400, deviating ? 0 : 0x0400);
  }
}

TEST(DeviationOptionCodes, AbortConnectionIgnored) {
  // Given OPERATION ENABLED with 6007h = 1 (fault)
  // When the communication is lost
  // Then the standard faults, the deviant keeps running
  PdsRig standard;
  PdsRig bad(DeviationSet{Deviation::abort_connection_ignored});
  for (PdsRig* rig : {&standard, &bad}) {
    rig->to_operation_enabled();
    rig->pds.on_communication_loss();
    rig->ticks(50);
  }
  EXPECT_EQ(standard.pds.state(), State::fault);
  EXPECT_EQ(bad.pds.state(), State::operation_enabled);
}

TEST(DeviationOptionCodes, InvalidValueAcceptedButNotApplied) {
  // Given the PDS objects in a dictionary
  // When 605Ah := 9 (reserved) is written as by SDO
  // Then the standard aborts 06090030h; the deviant stores 9 and keeps 2 in force
  for (const bool deviating : {false, true}) {
    const DeviationSet set =
        deviating ? DeviationSet{Deviation::option_code_invalid_accepted} : DeviationSet{};
    RampAxis axis;
    PowerDriveSystem pds(axis, PdsRig::config(set));
    cia301::ObjectDictionary od(5);
    ASSERT_TRUE(add_power_drive_objects(od, PdsRig::config(set)));
    PowerDriveObjects objects(od, pds);
    const std::uint8_t nine[] = {9, 0};
    const auto written = od.write(0x605A, 0, nine);
    if (deviating) {
      EXPECT_TRUE(written);
      objects.step(can::TimePoint{} + 1ms);
      EXPECT_EQ(od.find(0x605A, 0)->as_signed(), 9);
    } else {
      ASSERT_FALSE(written);
      EXPECT_EQ(written.error(), cia301::SdoAbort::invalid_value);
    }
    EXPECT_EQ(pds.option_code(OptionCode::quick_stop), 2);
  }
}

TEST(DeviationOptionCodes, HaltIgnored) {
  // Given OPERATION ENABLED at 1000 units/s
  // When halt (010Fh) comes
  // Then the standard halts the axis, the deviant keeps it moving
  PdsRig standard;
  PdsRig bad(DeviationSet{Deviation::halt_ignored});
  for (PdsRig* rig : {&standard, &bad}) {
    rig->to_operation_enabled();
    rig->command(0x010F);
    rig->ticks(200);
  }
  EXPECT_TRUE(standard.pds.halted());
  EXPECT_TRUE(standard.axis.is_stopped());
  EXPECT_FALSE(bad.pds.halted());
  EXPECT_FALSE(bad.axis.is_stopped());
}

TEST(DeviationModes, ModeDisplayNotFollowing) {
  // Given a PDS without a mode
  // When 6060h := 1 (pp) is requested
  // Then the standard shows 1 in 6061h at the next cycle, the deviant stays 0
  PdsRig standard;
  PdsRig bad(DeviationSet{Deviation::mode_display_not_following});
  for (PdsRig* rig : {&standard, &bad}) {
    ASSERT_TRUE(rig->pds.request_mode(1));
    rig->ticks(5);
  }
  EXPECT_EQ(standard.pds.mode_display(), 1);
  EXPECT_EQ(bad.pds.mode_display(), 0);
}

TEST(DeviationModes, UnsupportedModeAcceptedAndSupportedModesWrong) {
  // Given the PDS objects (6502h: pp, pv, tq, hm, csp, csv, cst)
  // When 6060h := 7 (ip, not supported) is written, and 6502h read
  // Then the standard aborts 06090030h; with unsupported-mode-accepted the write succeeds and
  //      6061h stays 0; with supported-modes-wrong 6502h claims vl and ip as well
  for (const bool deviating : {false, true}) {
    DeviationSet set;
    if (deviating) {
      set.add(Deviation::unsupported_mode_accepted);
      set.add(Deviation::supported_modes_wrong);
    }
    RampAxis axis;
    PowerDriveSystem pds(axis, PdsRig::config(set));
    cia301::ObjectDictionary od(5);
    ASSERT_TRUE(add_power_drive_objects(od, PdsRig::config(set)));
    PowerDriveObjects objects(od, pds);
    pds.power_on({});
    const std::uint8_t ip[] = {7};
    const auto written = od.write(0x6060, 0, ip);
    EXPECT_EQ(static_cast<bool>(written), deviating);
    objects.step(can::TimePoint{} + 1ms);
    EXPECT_EQ(od.find(0x6061, 0)->as_signed(), 0);
    EXPECT_EQ(od.find(0x6502, 0)->as_unsigned(), deviating ? 0x3EFu : 0x3ADu);
  }
}

// ---------------------------------------------------------------------------------------------
// The whole CiA 402 drive (Cia402Application on the reference drive): the deviation set reaches
// the PDS and the mode logic as the composition root passes it (ServoDrive: both copies).

class Cia402Rig {
 public:
  explicit Cia402Rig(DeviationSet deviations = {})
      : app_(std::make_unique<Cia402Application>(config(deviations))),
        rig_(std::make_unique<DriveRig>(5, drive_config(*app_, deviations))) {}

  static Cia402ApplicationConfig config(DeviationSet deviations) {
    Cia402ApplicationConfig config;
    config.deviations = deviations;
    config.pds.deviations = deviations;
    return config;
  }
  static DriveConfig drive_config(Cia402Application& app, DeviationSet deviations) {
    DriveConfig config;
    config.application = &app;
    config.deviations = deviations;
    return config;
  }

  DriveRig& rig() { return *rig_; }
  std::int64_t value(std::uint16_t index) {
    return rig_->drive().dictionary().find(index, 0)->as_signed();
  }
  std::uint16_t statusword() { return static_cast<std::uint16_t>(rig_->read(0x6041, 0).value); }
  void write(std::uint16_t index, std::int64_t value, unsigned size) {
    ASSERT_EQ(rig_->write(index, 0, static_cast<std::uint64_t>(value), size), 0u)
        << std::hex << index;
  }
  // 6060h := mode, then shutdown, switch on, enable operation.
  void enable(std::int8_t mode) {
    write(0x6060, mode, 1);
    write(0x6040, 0x0006, 2);
    write(0x6040, 0x0007, 2);
    write(0x6040, 0x000F, 2);
    ASSERT_EQ(statusword() & 0x006F, 0x0027) << "OPERATION ENABLED";
  }

 private:
  std::unique_ptr<Cia402Application> app_;
  std::unique_ptr<DriveRig> rig_;
};

TEST(DeviationCia402Drive, StatuswordBit5WrongSwitchedOnOverSdo) {
  // Given the whole drive switched on
  // When 6041h is read by SDO
  // Then the standard reads bit 5 set, the deviant clear
  Cia402Rig standard;
  Cia402Rig bad(DeviationSet{Deviation::statusword_bit5_wrong_switched_on});
  for (Cia402Rig* rig : {&standard, &bad}) {
    rig->write(0x6040, 0x0006, 2);
    rig->write(0x6040, 0x0007, 2);
  }
  EXPECT_EQ(standard.statusword() & 0x006F, 0x0023);
  EXPECT_EQ(bad.statusword() & 0x006F, 0x0003);
}

TEST(DeviationCia402Drive, ModeAndOptionCodeObjectsOverSdo) {
  // Given the whole drive (6502h: pp pv tq hm csp csv cst)
  // When 6060h := 7 (ip) and 605Ah := 9 (reserved) are written, and 6502h read
  // Then the standard aborts both 06090030h; the deviant confirms both, keeps 6061h = 0 and
  //      605Ah = 2 in force, and 6502h also claims vl and ip
  const DeviationSet set{Deviation::unsupported_mode_accepted,
                         Deviation::option_code_invalid_accepted, Deviation::supported_modes_wrong};
  Cia402Rig standard;
  Cia402Rig bad(set);
  EXPECT_EQ(standard.rig().write(0x6060, 0, 7, 1), 0x06090030u);
  EXPECT_EQ(standard.rig().write(0x605A, 0, 9, 2), 0x06090030u);
  EXPECT_EQ(standard.rig().read(0x6502, 0).value, 0x3ADu);
  EXPECT_EQ(bad.rig().write(0x6060, 0, 7, 1), 0u);
  EXPECT_EQ(bad.rig().write(0x605A, 0, 9, 2), 0u);
  bad.rig().run(5ms);
  EXPECT_EQ(bad.value(0x6061), 0);
  EXPECT_EQ(bad.rig().read(0x605A, 0).value, 9u) << "reads back as written";
  EXPECT_EQ(bad.rig().read(0x6502, 0).value, 0x3EFu);
}

TEST(DeviationCia402Drive, CsvAndCstFollowsBitNeverSet) {
  // Given csv (9) / cst (10) in OPERATION ENABLED with a set-point
  // When the drive follows it
  // Then bit 12 is set on the standard drive and stays 0 on the deviant one
  struct Case {
    std::int8_t mode;
    Deviation deviation;
    std::uint16_t target;
    std::int64_t value;
    unsigned size;
  };
  for (const Case& c : {Case{9, Deviation::csv_follows_bit_never_set, 0x60FF, 3000, 4},
                        Case{10, Deviation::cst_follows_bit_never_set, 0x6071, 100, 2}}) {
    Cia402Rig standard;
    Cia402Rig bad(DeviationSet{c.deviation});
    for (Cia402Rig* rig : {&standard, &bad}) {
      rig->enable(c.mode);
      rig->write(c.target, c.value, c.size);
      rig->rig().run(10ms);
    }
    EXPECT_NE(standard.statusword() & 0x1000, 0) << int{c.mode};
    EXPECT_EQ(bad.statusword() & 0x1000, 0) << int{c.mode};
  }
}

TEST(DeviationCia402Drive, FactorPolarityIgnored) {
  // Given a pp move to 1000 done
  // When 607Eh := 80h (position polarity)
  // Then the standard reads 6064h = -1000, the deviant still 1000
  Cia402Rig standard;
  Cia402Rig bad(DeviationSet{Deviation::factor_polarity_ignored});
  for (Cia402Rig* rig : {&standard, &bad}) {
    rig->enable(1);
    rig->write(0x607A, 1000, 4);
    rig->write(0x6040, 0x001F, 2);  // new set-point
    rig->write(0x6040, 0x000F, 2);
    rig->rig().run(2s);
    ASSERT_EQ(rig->value(0x6064), 1000);
    rig->write(0x607E, 0x80, 1);
    rig->rig().run(5ms);
  }
  EXPECT_EQ(standard.value(0x6064), -1000);
  EXPECT_EQ(bad.value(0x6064), 1000);
}

// ---------------------------------------------------------------------------------------------
// Robustness: every deviation, alone and all at once, on the whole drive under random traffic

// Frames a master and a fuzzer send: SDO requests, NMT, RTRs, SYNC, RPDOs, heartbeats, all
// with random bytes.
can::Frame random_frame(std::mt19937& random) {
  static constexpr std::uint32_t kIds[] = {0x000, 0x080, 0x605, 0x705, 0x185, 0x205,
                                           0x305, 0x710, 0x085, 0x585, 0x7E5, 0x123};
  std::uniform_int_distribution<int> byte(0, 255);
  const std::uint32_t id = kIds[static_cast<std::size_t>(byte(random)) % std::size(kIds)];
  if (byte(random) < 16) return can::Frame::remote(id, static_cast<std::uint8_t>(byte(random) % 9));
  std::array<std::uint8_t, 8> data{};
  for (auto& b : data)
    b = static_cast<std::uint8_t>(byte(random));
  if (id == 0x000 && byte(random) < 200) {
    // Mostly real NMT commands to this node or all.
    constexpr std::uint8_t kCommands[] = {0x01, 0x02, 0x80, 0x81, 0x82};
    data[0] = kCommands[static_cast<std::size_t>(byte(random)) % std::size(kCommands)];
    data[1] = byte(random) < 128 ? 0 : 5;
  }
  std::size_t length = static_cast<std::size_t>(byte(random)) % 9;
  if (id == 0x000) length = 2;
  if (id == 0x605 && byte(random) < 224) length = 8;  // mostly well-formed SDO requests
  return can::Frame::standard(id, std::span<const std::uint8_t>(data.data(), length));
}

// A whole CiA 402 drive with `deviations` on a fresh bus, fed `count` random frames 1 ms apart.
// Returns the frames the drive sent.
std::size_t run_random_traffic(const DeviationSet& deviations, std::uint32_t seed, int count) {
  can::SimBus bus;
  auto tester = bus.attach("tester");
  auto port = bus.attach("drive");
  std::size_t seen = 0;
  tester->set_frame_handler([&](const can::TimedFrame&) { ++seen; });
  Cia402Application app(Cia402Rig::config(deviations));
  DriveConfig config = Cia402Rig::drive_config(app, deviations);
  config.dictionary.node_id = 5;
  auto drive = ReferenceDrive::create(*port, std::move(config));
  EXPECT_TRUE(drive) << (drive ? std::string() : drive.error());
  if (!drive) return 0;
  (*drive)->power_on();
  bus.run_for(10ms);
  std::mt19937 random(seed);
  for (int i = 0; i < count; ++i) {
    EXPECT_FALSE(tester->send(random_frame(random)));
    bus.run_for(1ms);
  }
  return seen;
}

TEST(DeviationRobustness, EveryDeviationAloneSurvivesRandomTraffic) {
  // Given a drive with one deviation, for every deviation in the table
  // When 300 random frames come
  // Then it neither crashes nor hangs the simulation, and it sent something (boot-up or
  //      answers), except a crashed drive which may fall silent
  for (const DeviationInfo& info : kDeviations) {
    SCOPED_TRACE(std::string(info.name));
    const std::size_t sent = run_random_traffic(DeviationSet{info.deviation}, 7, 300);
    if (info.deviation != Deviation::bootup_missing &&
        info.deviation != Deviation::fatal_crash_on_invalid_command) {
      EXPECT_GT(sent, 0u);
    }
  }
}

TEST(DeviationRobustness, AllDeviationsAtOnceSurviveRandomTraffic) {
  // Given a drive with every deviation at once
  // When 3000 random frames come (several seeds)
  // Then nothing crashes, hangs or trips a sanitizer
  DeviationSet all;
  for (const DeviationInfo& info : kDeviations)
    all.add(info.deviation);
  for (std::uint32_t seed : {1u, 2u, 3u})
    run_random_traffic(all, seed, 1000);
  DeviationSet ordinary = all;
  for (const DeviationInfo& info : kDeviations) {
    if (info.kind == DeviationKind::fatal) ordinary.remove(info.deviation);
  }
  const std::size_t answers = run_random_traffic(ordinary, 4, 1000);
  EXPECT_GT(answers, 30u) << "the drive keeps answering";
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing

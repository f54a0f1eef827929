// The Kollmorgen personality's own objects (reference_drive/kollmorgen_objects.hpp): 1002h, the
// OS prompt 1026h and the object channel from 3500h, on the simulated bus as scripted SDO
// exchanges against ServoDrive with the kollmorgen-s300-s700 profile.
#include "reference_drive/kollmorgen_objects.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/servo_drive.hpp"
#include "tests/profile/servo_rig.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kCommandBufferFull = 0xFF030000;
constexpr std::uint32_t kNotMappable = 0x06040041;
constexpr std::uint32_t kWriteReadOnly = 0x06010002;
constexpr std::uint32_t kValueTooLow = 0x06090032;
constexpr std::uint32_t kNoObject = 0x06020000;

using testing::kNoAnswer;
using testing::kNode;

// The Kollmorgen drive (or the standard drive), with the OS prompt 1026h typed on.
class KollmorgenRig : public testing::ServoRig {
 public:
  explicit KollmorgenRig(bool kollmorgen = true)
      : ServoRig(kollmorgen ? "kollmorgen-s300-s700" : "") {}

  // Each character to 1026h sub 1 (StdIn): the first abort code, else 0.
  std::uint32_t type(std::string_view text) {
    for (char c : text) {
      const std::uint32_t r = write(0x1026, 1, static_cast<unsigned char>(c), 1);
      if (r != 0) return r;
    }
    return 0;
  }
  // 1026h sub 2 (StdOut) read until it gives 00h.
  std::string answer() {
    std::string out;
    for (int i = 0; i < 64; ++i) {
      const std::uint32_t c = read(0x1026, 2);
      if (c == 0 || c == kNoAnswer) break;
      out.push_back(static_cast<char>(c));
    }
    return out;
  }
};

TEST(KollmorgenOsPrompt, GvCommandSetsTheObjectChannel) {
  // Given the Kollmorgen drive, GV (3548h sub 1) at its default 1
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.read(0x3548, 1), 1U);
  // When 'G' 'V' ' ' '6' CR LF are written to 1026h sub 1 one by one (002 §6.3.10)
  const std::uint32_t result = rig.type("GV 6\r\n");
  // Then every write is confirmed and 3548h sub 1 reads 6, with no answer on StdOut
  EXPECT_EQ(result, 0U);
  EXPECT_EQ(rig.read(0x3548, 1), 6U);
  EXPECT_EQ(rig.answer(), "");
}

TEST(KollmorgenOsPrompt, QueryAnswersOnStdOut) {
  // Given GV set to 42 over the object channel
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(0x3548, 1, 42, 4), 0U);
  // When "gv" CR is typed (case-insensitive)
  ASSERT_EQ(rig.type("gv\r"), 0U);
  // Then StdOut gives "42" CR LF, then 00h
  EXPECT_EQ(rig.answer(), "42\r\n");
  EXPECT_EQ(rig.read(0x1026, 2), 0U);
}

TEST(KollmorgenOsPrompt, StdInReadsTheLastCharacter) {
  // Given the Kollmorgen drive
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  // When 'A' is written to StdIn
  ASSERT_EQ(rig.type("A"), 0U);
  // Then StdIn reads 41h (rw, as the profile's object table reads 'w')
  EXPECT_EQ(rig.read(0x1026, 1), 0x41U);
}

TEST(KollmorgenOsPrompt, FullLineAbortsCommandBufferFull) {
  // Given a command line of kLineCapacity characters
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.type(std::string(KollmorgenObjects::kLineCapacity, 'X')), 0U);
  // When one more character is written
  const std::uint32_t result = rig.type("Y");
  // Then it aborts FF030000h (OS command buffer full) and CR still ends the line
  EXPECT_EQ(result, kCommandBufferFull);
  EXPECT_EQ(rig.type("\r"), 0U);
  EXPECT_EQ(rig.type("GV\r"), 0U);
  EXPECT_EQ(rig.answer(), "1\r\n");
}

TEST(KollmorgenOsPrompt, ReadOnlyParameterIsNotSet) {
  // Given ADDR (3505h) = the node-ID 5
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.read(0x3505, 1), kNode);
  // When "ADDR 9" and an out-of-range "GV -1" are typed
  ASSERT_EQ(rig.type("ADDR 9\rGV -1\r"), 0U);
  // Then nothing changes and nothing is answered
  EXPECT_EQ(rig.read(0x3505, 1), kNode);
  EXPECT_EQ(rig.read(0x3548, 1), 1U);
  EXPECT_EQ(rig.answer(), "");
}

TEST(KollmorgenOsPrompt, ResetDiscardsTheLine) {
  // Given "GV" typed without CR
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.type("GV"), 0U);
  // When the node is reset (NMT reset node) and CR follows
  rig.send(can::Frame::standard(0x000, std::array<std::uint8_t, 2>{0x81, kNode}));
  rig.run(100ms);
  ASSERT_EQ(rig.type("\r"), 0U);
  // Then there is no answer: the line was discarded
  EXPECT_EQ(rig.answer(), "");
}

TEST(KollmorgenObjectChannel, MaxcmdNamesTheLastObject) {
  // Given the Kollmorgen drive
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  // When 3500h sub 0 and sub 1 are read
  const std::uint32_t entries = rig.read(0x3500, 0);
  const std::uint32_t maxcmd = rig.read(0x3500, 1);
  // Then 8 entries, and 3500h + MAXCMD is an object of the channel (SERIALNO 35EFh)
  EXPECT_EQ(entries, 8U);
  EXPECT_EQ(maxcmd, 0xEFU);
  EXPECT_EQ(rig.read(static_cast<std::uint16_t>(0x3500 + maxcmd), 0), 8U);
}

TEST(KollmorgenObjectChannel, ObjectsCannotBeMapped) {
  // Given TPDO1 and RPDO1 with their entries switched off
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(0x1A00, 0, 0, 1), 0U);
  ASSERT_EQ(rig.write(0x1600, 0, 0, 1), 0U);
  // When 3500h sub 1 is mapped into TPDO1 and GV 3548h sub 1 into RPDO1
  const std::uint32_t tpdo = rig.write(0x1A00, 1, 0x35000120, 4);
  const std::uint32_t rpdo = rig.write(0x1600, 1, 0x35480120, 4);
  // Then both abort 06040041h (002 §6.1.1 L5049)
  EXPECT_EQ(tpdo, kNotMappable);
  EXPECT_EQ(rpdo, kNotMappable);
}

TEST(KollmorgenObjectChannel, LimitsAndReadOnly) {
  // Given the Kollmorgen drive
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  // When GV is written below its lower limit, and ADDR and GV's limit entry are written
  const std::uint32_t low = rig.write(0x3548, 1, 0xFFFFFFFF, 4);  // -1
  const std::uint32_t addr = rig.write(0x3505, 1, 9, 4);
  const std::uint32_t limit = rig.write(0x3548, 2, 0, 4);
  // Then 06090032h, and 06010002h for the read-only entries; the limits read as declared
  EXPECT_EQ(low, kValueTooLow);
  EXPECT_EQ(addr, kWriteReadOnly);
  EXPECT_EQ(limit, kWriteReadOnly);
  EXPECT_EQ(rig.read(0x3548, 2), 0U);
  EXPECT_EQ(rig.read(0x3548, 3), 1000000U);
  EXPECT_EQ(rig.read(0x3548, 4), 1U);
  EXPECT_EQ(rig.read(0x3548, 5), 7U);           // format INTEGER32
  EXPECT_EQ(rig.read(0x3505, 6), 0x00200000U);  // check data: read-only
}

TEST(KollmorgenStatus, BitsFollowThePowerStage) {
  // Given the drive in SWITCH ON DISABLED with the hardware enable present
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  const std::uint32_t before = rig.read(0x1002, 0);
  const std::uint32_t active_before = rig.read(0x3504, 1);
  // When it is switched on (shutdown, switch on)
  rig.controlword(0x0006);
  rig.controlword(0x0007);
  // Then 1002h gains bit 14 (power stage enabled) and ACTIVE reads 1
  EXPECT_EQ(before, (1U << 10) | (1U << 29));
  EXPECT_EQ(active_before, 0U);
  EXPECT_EQ(rig.read(0x1002, 0), (1U << 10) | (1U << 14) | (1U << 29));
  EXPECT_EQ(rig.read(0x3504, 1), 1U);
}

TEST(KollmorgenStatus, StatusIsMappable) {
  // Given TPDO2's entries switched off
  KollmorgenRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(0x1A01, 0, 0, 1), 0U);
  // When 1002h (32 bit) is mapped, as the SYNC test of 002 §6.3.11 does
  const std::uint32_t result = rig.write(0x1A01, 1, 0x10020020, 4);
  // Then the write is confirmed
  EXPECT_EQ(result, 0U);
}

TEST(KollmorgenObjects, StandardDriveHasNone) {
  // Given the standard drive (no personality)
  KollmorgenRig rig(false);
  ASSERT_TRUE(rig.ok());
  // When 1026h and 3500h are read
  std::uint32_t prompt = 0;
  std::uint32_t channel = 0;
  rig.read(0x1026, 0, &prompt);
  rig.read(0x3500, 1, &channel);
  // Then both abort 06020000h (object does not exist)
  EXPECT_EQ(prompt, kNoObject);
  EXPECT_EQ(channel, kNoObject);
}

}  // namespace
}  // namespace drivecheck::reference_drive

#include "protocol/ethercat/coe_objects.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "protocol/ethercat/coe_sdo_server.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;
using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;

// A dictionary with the CoE objects, RxPDO mappings 1600h/1601h and TxPDO mapping 1A00h.
class CoeObjectsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (std::uint16_t index : {0x1600, 0x1601, 0x1A00}) {
      ASSERT_TRUE(od.add_object(
          {index,
           "mapping",
           ObjectCode::record,
           {EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 0),
            EntryDefinition::unsigned_entry(1, "entry 1", DataType::unsigned32, AccessType::rw,
                                            0)}}));
    }
    CoeObjectsConfig config;
    config.outputs.minimum_cycle_time_ns = 125'000;
    for (auto& def : coe_object_definitions(config))
      ASSERT_TRUE(od.add_object(std::move(def)));
    ASSERT_TRUE(install_coe_object_rules(od, [this] { return preop; }));
  }

  // An expedited SDO download through the CoE server; 0 when confirmed, else the abort code.
  std::uint32_t write(std::uint16_t index, std::uint8_t sub, Bytes data, bool ca = false) {
    CoeSdoServer server(od);
    const auto size = static_cast<std::uint32_t>(data.size());
    const auto reply = server.handle(encode(CoeSdoRequest{
        CoeDownloadInitiate{{index, sub}, ca, size <= 4, true, size, std::move(data)}}));
    const auto r = decode_sdo_response(*reply.coe);
    if (const auto* a = std::get_if<CoeAbort>(&*r)) return a->code;
    return 0;
  }

  cia301::ObjectDictionary od;
  bool preop = true;
};

TEST_F(CoeObjectsTest, DefinitionsFollowTheCoeLayout) {
  // Given the added CoE objects
  // When their entries are read
  // Then 1C00h lists SM types 1..4, 1C12h/1C13h assign 1600h/1A00h, 1C32h has 32 sub-indices
  EXPECT_EQ(od.find(0x1C00, 0)->as_unsigned(), 4u);
  for (std::uint8_t i = 1; i <= 4; ++i)
    EXPECT_EQ(od.find(0x1C00, i)->as_unsigned(), i);
  EXPECT_EQ(od.find(0x1C12, 0)->as_unsigned(), 1u);
  EXPECT_EQ(od.find(0x1C12, 1)->as_unsigned(), 0x1600u);
  EXPECT_EQ(od.find(0x1C13, 1)->as_unsigned(), 0x1A00u);
  EXPECT_EQ(od.find(0x1C32, 0)->as_unsigned(), 0x20u);
  ASSERT_NE(od.find(0x1C33, 0x20), nullptr);
  EXPECT_EQ(od.find(0x1C33, 0x20)->type(), DataType::boolean);
}

TEST_F(CoeObjectsTest, AssignmentFollowsTheCountFirstProcedure) {
  // Given PREOP and 1C12h assigning 1600h
  // When the master writes 1C12h:01 with the count still 1
  // Then 06010003h (SI0 must be 0)
  EXPECT_EQ(write(0x1C12, 1, {0x01, 0x16}), 0x06010003u);
  // When it sets the count 0, writes 1601h, sets the count 1
  // Then each step is confirmed and 1601h is assigned
  EXPECT_EQ(write(0x1C12, 0, {0x00}), 0u);
  EXPECT_EQ(write(0x1C12, 1, {0x01, 0x16}), 0u);
  EXPECT_EQ(write(0x1C12, 0, {0x01}), 0u);
  EXPECT_EQ(od.find(0x1C12, 1)->as_unsigned(), 0x1601u);
}

TEST_F(CoeObjectsTest, AssignmentRefusesWrongIndicesAndCounts) {
  // Given PREOP and the count set to 0
  ASSERT_EQ(write(0x1C12, 0, {0x00}), 0u);
  // When a TxPDO mapping, a missing RxPDO mapping, a count above the entries, and a count
  // covering an empty entry are written
  // Then 06090030h, 06090030h, 06090031h and 06090030h
  EXPECT_EQ(write(0x1C12, 1, {0x00, 0x1A}), 0x06090030u);
  EXPECT_EQ(write(0x1C12, 2, {0x02, 0x16}), 0x06090030u);
  EXPECT_EQ(write(0x1C12, 0, {0x05}), 0x06090031u);
  EXPECT_EQ(write(0x1C12, 0, {0x02}), 0x06090030u);
  // And a TxPDO assign takes 1A00h but not 1600h
  ASSERT_EQ(write(0x1C13, 0, {0x00}), 0u);
  EXPECT_EQ(write(0x1C13, 1, {0x00, 0x16}), 0x06090030u);
  EXPECT_EQ(write(0x1C13, 1, {0x00, 0x1A}), 0u);
}

TEST_F(CoeObjectsTest, ConfigurationOnlyInPreop) {
  // Given the slave in SAFEOP (not configurable)
  preop = false;
  // When the assignment, a mapping, a sync mode and a cycle time are written
  // Then each is refused with 08000022h (present device state); nothing changes
  EXPECT_EQ(write(0x1C12, 0, {0x00}), 0x08000022u);
  EXPECT_EQ(write(0x1600, 0, {0x00}), 0x08000022u);
  EXPECT_EQ(write(0x1C32, 1, {0x01, 0x00}), 0x08000022u);
  EXPECT_EQ(write(0x1C33, 2, {0x40, 0x42, 0x0F, 0x00}), 0x08000022u);
  EXPECT_EQ(od.find(0x1C12, 0)->as_unsigned(), 1u);
}

TEST_F(CoeObjectsTest, SyncModesMustBeSupported) {
  // Given 1C32h/1C33h supporting free run and SM-synchronous (sub 04 = 0003h), minimum 125 µs
  // When the modes are written
  // Then SM-synchronous is taken, DC SYNC0 is not supported, 34 is for inputs only, 7 is none
  EXPECT_EQ(write(0x1C32, 1, {0x01, 0x00}), 0u);
  EXPECT_EQ(write(0x1C32, 1, {0x02, 0x00}), 0x06090030u);
  EXPECT_EQ(write(0x1C32, 1, {0x22, 0x00}), 0x06090030u);
  EXPECT_EQ(write(0x1C33, 1, {0x22, 0x00}), 0u);
  EXPECT_EQ(write(0x1C33, 1, {0x07, 0x00}), 0x06090030u);
  // And a cycle time below the minimum is too low, one above it is taken
  EXPECT_EQ(write(0x1C32, 2, {0x10, 0x27, 0x00, 0x00}), 0x06090032u);
  EXPECT_EQ(write(0x1C32, 2, {0x40, 0x42, 0x0F, 0x00}), 0u);
}

TEST_F(CoeObjectsTest, CompleteAccessFollowsTheRules) {
  // Given PREOP
  // When 1C12h is written with complete access from 0: count 2, 1601h, 1600h
  // Then the server writes count 0, the entries, then the count, and the rules let it through
  EXPECT_EQ(write(0x1C12, 0, {0x02, 0x00, 0x01, 0x16, 0x00, 0x16}, true), 0u);
  EXPECT_EQ(od.find(0x1C12, 0)->as_unsigned(), 2u);
  EXPECT_EQ(od.find(0x1C12, 1)->as_unsigned(), 0x1601u);
  // And from sub-index 1 with the count 2 the first entry refuses: 06010003h, nothing changes
  EXPECT_EQ(write(0x1C12, 1, {0x00, 0x16, 0x01, 0x16}, true), 0x06010003u);
  EXPECT_EQ(od.find(0x1C12, 1)->as_unsigned(), 0x1601u);
}

TEST(CoeSyncModeTable, IsTheEtgList) {
  // Given the sync mode table
  // When it is read
  // Then it has 0..3 for both directions and 34 for inputs only
  ASSERT_EQ(sync_mode_table().size(), 5u);
  EXPECT_TRUE(find_sync_mode(3)->outputs);
  EXPECT_FALSE(find_sync_mode(34)->outputs);
  EXPECT_TRUE(find_sync_mode(34)->inputs);
  EXPECT_FALSE(find_sync_mode(4));
}

TEST(CoeObjectRuleOptionsTest, EachRuleSwitchesOnItsOwn) {
  // Given dictionaries with the CoE objects and the rules installed without the assignment's
  //       content check, and without the state rule
  // When 1C12h:01 is written while the count is 1, in and out of PREOP
  // Then without the content check: taken in PREOP, 08000022h outside (the state rule holds);
  //      without the state rule: 06010003h in either state (the content check holds)
  for (const bool content : {false, true}) {
    cia301::ObjectDictionary od;
    ASSERT_TRUE(od.add_object(
        {0x1600,
         "mapping",
         ObjectCode::record,
         {EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 0)}}));
    for (auto& def : coe_object_definitions(CoeObjectsConfig{}))
      ASSERT_TRUE(od.add_object(std::move(def)));
    bool preop = true;
    CoeObjectRuleOptions options;
    options.assignment_evaluated = content;
    options.configuration_only_when_configurable = !content;
    ASSERT_TRUE(install_coe_object_rules(
        od, [&preop] { return preop; }, options));
    auto write = [&od](std::uint16_t index, std::uint8_t sub, Bytes data) -> std::uint32_t {
      CoeSdoServer server(od);
      const auto size = static_cast<std::uint32_t>(data.size());
      const auto reply = server.handle(
          encode(CoeSdoRequest{CoeDownloadInitiate{{index, sub}, false, true, true, size, data}}));
      const auto r = decode_sdo_response(*reply.coe);
      if (const auto* a = std::get_if<CoeAbort>(&*r)) return a->code;
      return 0;
    };
    EXPECT_EQ(write(0x1C12, 1, {0x00, 0x16}), content ? 0x06010003u : 0u);
    preop = false;
    EXPECT_EQ(write(0x1C12, 1, {0x00, 0x16}), content ? 0x06010003u : 0x08000022u);
    EXPECT_EQ(write(0x1600, 0, {0}), content ? 0u : 0x08000022u);
  }
}

}  // namespace
}  // namespace drivecheck::ethercat

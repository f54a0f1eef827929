#include "protocol/cia301/cob_id.hpp"

#include <gtest/gtest.h>

namespace drivecheck::cia301 {
namespace {

TEST(CobIdClassify, PredefinedConnectionSetOfNode1) {
  // Given the identifiers of node 1 as the Festo identifier table prints them
  //   (000_33c1d912b8b6010a.txt §3.9.5 L1533-1553) and the Kollmorgen table (002 L513-558)
  // When each is classified
  // Then function and node are those of CiA 301 §7.3.5
  const std::pair<std::uint32_t, CobIdClass> cases[] = {
      {0x000, {CobFunction::nmt, 0}},
      {0x080, {CobFunction::sync, 0}},
      {0x081, {CobFunction::emcy, 1}},
      {0x100, {CobFunction::time, 0}},
      {0x181, {CobFunction::tpdo1, 1}},
      {0x201, {CobFunction::rpdo1, 1}},
      {0x281, {CobFunction::tpdo2, 1}},
      {0x301, {CobFunction::rpdo2, 1}},
      {0x381, {CobFunction::tpdo3, 1}},
      {0x401, {CobFunction::rpdo3, 1}},
      {0x481, {CobFunction::tpdo4, 1}},
      {0x501, {CobFunction::rpdo4, 1}},
      {0x581, {CobFunction::sdo_tx, 1}},
      {0x601, {CobFunction::sdo_rx, 1}},
      {0x701, {CobFunction::nmt_error_control, 1}},
      {0x7E4, {CobFunction::lss_slave_to_master, 0}},
      {0x7E5, {CobFunction::lss_master_to_slave, 0}},
  };
  for (const auto& [id, expected] : cases) {
    EXPECT_EQ(classify_cob_id(id), expected) << std::hex << id;
  }
}

TEST(CobIdClassify, NodeRangeEdges) {
  // Given the first and last node-IDs and base + 0
  // When classified
  // Then 1 and 127 are nodes, base + 0 is not a node's identifier
  EXPECT_EQ(classify_cob_id(0x0FF), (CobIdClass{CobFunction::emcy, 127}));
  EXPECT_EQ(classify_cob_id(0x77F), (CobIdClass{CobFunction::nmt_error_control, 127}));
  EXPECT_EQ(classify_cob_id(0x605), (CobIdClass{CobFunction::sdo_rx, 5}));
  for (std::uint32_t base : {0x180u, 0x200u, 0x580u, 0x600u, 0x700u}) {
    EXPECT_EQ(classify_cob_id(base).function, CobFunction::unassigned) << std::hex << base;
  }
  for (std::uint32_t id :
       {0x101u, 0x17Fu, 0x680u, 0x6FFu, 0x780u, 0x7E3u, 0x7E6u, 0x7FFu, 0x800u, 0x1FFFFFFFu}) {
    EXPECT_EQ(classify_cob_id(id).function, CobFunction::unassigned) << std::hex << id;
  }
}

TEST(CobIdClassify, EveryElevenBitIdRoundTrips) {
  // Given every 11-bit identifier
  // When classified and the class turned back into an identifier
  // Then the identifier is the same, or the class is unassigned
  int assigned = 0;
  for (std::uint32_t id = 0; id <= 0x7FF; ++id) {
    const CobIdClass cls = classify_cob_id(id);
    if (cls.function == CobFunction::unassigned) {
      EXPECT_FALSE(default_cob_id(cls.function, cls.node).has_value());
      continue;
    }
    ++assigned;
    const auto back = default_cob_id(cls.function, cls.node);
    ASSERT_TRUE(back.has_value()) << std::hex << id;
    EXPECT_EQ(*back, id);
  }
  // NMT, SYNC, TIME, 2 LSS + 14 node-specific objects x 127 nodes... 12 of them node-specific
  // in 80h..77Fh: EMCY, 8 PDOs, 2 SDOs, NMT EC.
  EXPECT_EQ(assigned, 5 + 12 * 127);
}

TEST(CobIdClassify, FramesOutsideThePredefinedSet) {
  // Given a 29-bit frame with a low identifier and an error frame
  // When classified
  // Then both are unassigned; a remote frame classifies by its id
  const std::uint8_t none[1] = {0};
  EXPECT_EQ(classify_cob_id(can::Frame::extended(0x181, none)).function, CobFunction::unassigned);
  can::Frame error;
  error.kind = can::FrameKind::error;
  error.id = 0x0;
  EXPECT_EQ(classify_cob_id(error).function, CobFunction::unassigned);
  EXPECT_EQ(classify_cob_id(can::Frame::remote(0x705)),
            (CobIdClass{CobFunction::nmt_error_control, 5}));
}

TEST(CobIdDefault, RejectsNodeOutOfRange) {
  // Given node-specific functions with node 0 and 128
  // When asked for their identifier
  // Then there is none; node-independent functions ignore the node
  EXPECT_FALSE(default_cob_id(CobFunction::tpdo1, 0));
  EXPECT_FALSE(default_cob_id(CobFunction::tpdo1, 128));
  EXPECT_EQ(default_cob_id(CobFunction::tpdo1, 127), 0x1FF);
  EXPECT_EQ(default_cob_id(CobFunction::sync, 99), 0x080);
  EXPECT_TRUE(is_node_specific(CobFunction::sdo_rx));
  EXPECT_FALSE(is_node_specific(CobFunction::time));
}

TEST(CobIdRestricted, TableOfCia301) {
  // Given the restricted CAN-IDs of CiA 301 §7.3.5
  // When single identifiers are checked
  // Then NMT, SDO, error control and the reserved ranges are restricted; SYNC, EMCY, TIME and
  //      PDO identifiers of nodes are not
  for (std::uint32_t id : {0x000u, 0x001u, 0x07Fu, 0x101u, 0x180u, 0x581u, 0x5FFu, 0x601u, 0x67Fu,
                           0x6E0u, 0x6FFu, 0x701u, 0x77Fu, 0x780u, 0x7E4u, 0x7FFu}) {
    EXPECT_TRUE(is_restricted_cob_id(id)) << std::hex << id;
  }
  for (std::uint32_t id : {0x080u, 0x081u, 0x0FFu, 0x100u, 0x181u, 0x1FFu, 0x200u, 0x57Fu, 0x580u,
                           0x600u, 0x680u, 0x6DFu, 0x700u}) {
    EXPECT_FALSE(is_restricted_cob_id(id)) << std::hex << id;
  }
  EXPECT_EQ(find_restricted_cob_id(0x605)->used_by, "default SDO (rx)");
}

TEST(CobIdRestricted, RangesAreOrderedAndDisjoint) {
  // Given the restricted-ranges table
  // When walked in order
  // Then ranges ascend without overlap
  const auto ranges = restricted_cob_ids();
  ASSERT_FALSE(ranges.empty());
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    EXPECT_LE(ranges[i].first, ranges[i].last);
    if (i > 0) {
      EXPECT_GT(ranges[i].first, ranges[i - 1].last);
    }
  }
}

TEST(CobIdNames, ShortNames) {
  EXPECT_EQ(to_string(CobFunction::sdo_rx), "SDO rx");
  EXPECT_EQ(to_string(CobFunction::nmt_error_control), "NMT EC");
  EXPECT_EQ(to_string(CobFunction::rpdo4), "RPDO4");
}

}  // namespace
}  // namespace drivecheck::cia301

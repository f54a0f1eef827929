#include "protocol/cia301/pdo.hpp"

#include <gtest/gtest.h>

namespace drivecheck::cia301 {
namespace {

TEST(PdoCobId, FestoDefaultIsDeactivated) {
  // Given the Festo TPDO1 default C0000181h (Tab. 3.5, 000_33c1d912b8b6010a.txt L878-911)
  const auto cob = decode_pdo_cob_id(0xC0000181);
  // When decoded
  // Then bit 31 = 1: not valid; bit 30 = 1: no RTR; CAN-ID 181h
  ASSERT_TRUE(cob) << cob.error().reason;
  EXPECT_FALSE(cob->valid);
  EXPECT_FALSE(cob->rtr_allowed);
  EXPECT_FALSE(cob->extended);
  EXPECT_EQ(cob->can_id, 0x181u);
  EXPECT_EQ(cob->encode(), 0xC0000181u);
}

TEST(PdoCobId, FestoActivationExample) {
  // Given the Festo remap example: C0000187h (deactivated) then 40000187h (active, L946-994)
  // When decoded
  // Then only bit 31 differs: valid after activation
  const auto before = decode_pdo_cob_id(0xC0000187);
  const auto after = decode_pdo_cob_id(0x40000187);
  ASSERT_TRUE(before && after);
  EXPECT_FALSE(before->valid);
  EXPECT_TRUE(after->valid);
  EXPECT_EQ(after->can_id, 0x187u);
}

TEST(PdoCobId, DunkerRtrAllowedDefault) {
  // Given Dunker defaults 00000180h + node (valid, RTR allowed) and 80000280h + node
  //   (004_956552dcd17e975a.txt §14.3.2 L1106-1250), node 1
  // When decoded
  // Then the first is valid with RTR allowed, the second not valid
  EXPECT_TRUE(decode_pdo_cob_id(0x00000181)->valid);
  EXPECT_TRUE(decode_pdo_cob_id(0x00000181)->rtr_allowed);
  EXPECT_FALSE(decode_pdo_cob_id(0x80000281)->valid);
}

TEST(PdoCobId, ElevenBitIdWithHighBitsIsInvalid) {
  // Given an 11-bit COB-ID with bit 11 set, and a 29-bit one
  // When decoded
  // Then the first is invalid, the second a 29-bit id
  const auto bad = decode_pdo_cob_id(0x00000981);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().reason.find("bits 28..11 must be 0"), std::string::npos);
  const auto extended = decode_pdo_cob_id(0x20000981);
  ASSERT_TRUE(extended);
  EXPECT_TRUE(extended->extended);
  EXPECT_EQ(extended->can_id, 0x981u);
  EXPECT_EQ(extended->encode(), 0x20000981u);
}

TEST(PdoTransmissionType, Classes) {
  // Given every transmission type value
  // When classified (CiA 301 §7.5.2.35)
  // Then 0 / 1..240 / 241..251 / 252 / 253 / 254 / 255 are the seven kinds
  EXPECT_EQ(transmission_kind(0), TransmissionKind::synchronous_acyclic);
  EXPECT_EQ(transmission_kind(1), TransmissionKind::synchronous_cyclic);
  EXPECT_EQ(transmission_kind(240), TransmissionKind::synchronous_cyclic);
  EXPECT_EQ(transmission_kind(241), TransmissionKind::reserved);
  EXPECT_EQ(transmission_kind(251), TransmissionKind::reserved);
  EXPECT_EQ(transmission_kind(252), TransmissionKind::rtr_synchronous);
  EXPECT_EQ(transmission_kind(253), TransmissionKind::rtr_event);
  EXPECT_EQ(transmission_kind(254), TransmissionKind::event_manufacturer);
  EXPECT_EQ(transmission_kind(255), TransmissionKind::event_profile);
  int rpdo = 0;
  int tpdo = 0;
  for (unsigned type = 0; type < 256; ++type) {
    rpdo += is_valid_transmission_type(static_cast<std::uint8_t>(type), PdoDirection::receive);
    tpdo += is_valid_transmission_type(static_cast<std::uint8_t>(type), PdoDirection::transmit);
  }
  EXPECT_EQ(rpdo, 241 + 2);
  EXPECT_EQ(tpdo, 241 + 4);
  EXPECT_EQ(describe_transmission_type(4), "synchronous cyclic (every 4th SYNC)");
  EXPECT_EQ(describe_transmission_type(245), "reserved (245)");
}

TEST(PdoTimes, Units) {
  // Given the Festo inhibit time 64h = 10 ms (L946-994: "100 x 100 µs") and an event timer
  // Then inhibit time counts 100 µs, event timer ms
  EXPECT_EQ(inhibit_time(0x64), std::chrono::milliseconds{10});
  EXPECT_EQ(event_timer(250), std::chrono::milliseconds{250});
  EXPECT_TRUE(is_valid_sync_start_value(0));
  EXPECT_TRUE(is_valid_sync_start_value(240));
  EXPECT_FALSE(is_valid_sync_start_value(241));
}

TEST(PdoIndices, CommunicationAndMapping) {
  EXPECT_EQ(pdo_communication_index(PdoDirection::receive, 1), 0x1400);
  EXPECT_EQ(pdo_mapping_index(PdoDirection::receive, 4), 0x1603);
  EXPECT_EQ(pdo_communication_index(PdoDirection::transmit, 1), 0x1800);
  EXPECT_EQ(pdo_mapping_index(PdoDirection::transmit, 512), 0x1BFF);
}

TEST(PdoMappingEntry, FestoStatuswordEntry) {
  // Given 60410010h (Festo Tab. 3.6 L913-918: 6041h:00, 16 bit)
  const auto entry = decode_pdo_mapping_entry(0x60410010);
  // When decoded
  // Then index 6041h, sub 0, 16 bits, not a dummy
  ASSERT_TRUE(entry) << entry.error().reason;
  EXPECT_EQ(entry->index, 0x6041);
  EXPECT_EQ(entry->sub_index, 0);
  EXPECT_EQ(entry->bits, 16);
  EXPECT_FALSE(entry->is_dummy());
  EXPECT_EQ(entry->encode(), 0x60410010u);
}

TEST(PdoMappingEntry, DummyEntries) {
  // Given dummy entries for every data type 0002h..0007h with their sizes
  // When decoded
  // Then each is a dummy; a wrong size, a sub-index or another data type is invalid
  const std::pair<std::uint32_t, unsigned> dummies[] = {{0x00020008, 8},  {0x00030010, 16},
                                                        {0x00040020, 32}, {0x00050008, 8},
                                                        {0x00060010, 16}, {0x00070020, 32}};
  for (const auto& [value, bits] : dummies) {
    const auto entry = decode_pdo_mapping_entry(value);
    ASSERT_TRUE(entry) << std::hex << value;
    EXPECT_TRUE(entry->is_dummy());
    EXPECT_EQ(entry->bits, bits);
  }
  EXPECT_FALSE(decode_pdo_mapping_entry(0x00050010));  // UNSIGNED8 dummy with 16 bits
  EXPECT_FALSE(decode_pdo_mapping_entry(0x00050108));  // sub-index 1
  EXPECT_FALSE(decode_pdo_mapping_entry(0x00010001));  // BOOLEAN is not a dummy here
  EXPECT_FALSE(decode_pdo_mapping_entry(0x00080020));  // REAL32
  EXPECT_FALSE(decode_pdo_mapping_entry(0x60410000));  // length 0
  EXPECT_FALSE(decode_pdo_mapping_entry(0x60410041));  // 65 bits
}

TEST(PdoPayload, FestoRemapExample) {
  // Given the Festo TPDO1 mapping 6041h (16) + 6061h (8) + 60FDh (32) = 56 bits (L946-994)
  const PdoMapping mapping{{{0x6041, 0, 16}, {0x6061, 0, 8}, {0x60FD, 0, 32}}};
  // statusword 0627h, mode 01h, digital inputs 00FF0004h
  const std::uint8_t payload[] = {0x27, 0x06, 0x01, 0x04, 0x00, 0xFF, 0x00};
  // When unpacked
  const auto values = unpack_pdo(mapping, payload);
  // Then each value sits at its bit offset, little-endian
  ASSERT_TRUE(values) << values.error().reason;
  ASSERT_EQ(values->size(), 3u);
  EXPECT_EQ((*values)[0].raw, 0x0627u);
  EXPECT_EQ((*values)[1].bit_offset, 16u);
  EXPECT_EQ((*values)[1].raw, 0x01u);
  EXPECT_EQ((*values)[2].bit_offset, 24u);
  EXPECT_EQ((*values)[2].raw, 0x00FF0004u);
  EXPECT_EQ(mapping.total_bits(), 56u);
  const std::uint64_t raw[] = {0x0627, 0x01, 0x00FF0004};
  EXPECT_EQ(pack_pdo(mapping, raw),
            std::vector<std::uint8_t>(std::begin(payload), std::end(payload)));
}

TEST(PdoPayload, BitMappingAndSignedValues) {
  // Given a mapping of 1 + 3 + 4 bits and an INTEGER16
  const PdoMapping mapping{{{0x2000, 1, 1}, {0x2000, 2, 3}, {0x2000, 3, 4}, {0x2001, 0, 16}}};
  // byte 0 = 1 | 101b << 1 | 1001b << 4 = 0x9B; INTEGER16 -2 = FFFEh
  const std::uint8_t payload[] = {0x9B, 0xFE, 0xFF};
  // When unpacked
  const auto values = unpack_pdo(mapping, payload);
  // Then the bit fields and the sign extension are right
  ASSERT_TRUE(values) << values.error().reason;
  EXPECT_EQ((*values)[0].raw, 1u);
  EXPECT_EQ((*values)[1].raw, 5u);
  EXPECT_EQ((*values)[2].raw, 9u);
  EXPECT_EQ((*values)[2].as_signed(), -7);
  EXPECT_EQ((*values)[3].as_signed(), -2);
}

TEST(PdoPayload, ShortPayloadAndOversizedMapping) {
  // Given a 32-bit mapping and a 3-byte PDO; a mapping of 72 bits; a 9-byte-free longer PDO
  const PdoMapping mapping{{{0x607A, 0, 32}}};
  const std::uint8_t three[] = {1, 2, 3};
  const std::uint8_t five[] = {1, 2, 3, 4, 5};
  // When unpacked / validated
  // Then the short PDO is invalid (EMCY 8210h), the long one uses its first bytes, 72 bits fail
  const auto short_pdo = unpack_pdo(mapping, three);
  ASSERT_FALSE(short_pdo);
  EXPECT_NE(short_pdo.error().reason.find("8210h"), std::string::npos);
  const auto long_pdo = unpack_pdo(mapping, five);
  ASSERT_TRUE(long_pdo);
  EXPECT_EQ((*long_pdo)[0].raw, 0x04030201u);
  const PdoMapping too_big{{{0x6064, 0, 32}, {0x606C, 0, 32}, {0x6041, 0, 8}}};
  const auto invalid = too_big.validate();
  ASSERT_FALSE(invalid);
  EXPECT_NE(invalid.error().reason.find("72 bits"), std::string::npos);
}

}  // namespace
}  // namespace drivecheck::cia301

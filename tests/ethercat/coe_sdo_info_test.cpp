#include "protocol/ethercat/coe_sdo_info.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "protocol/ethercat/coe_sdo_server.hpp"
#include "tests/ethercat/coe_test_dictionary.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;

// Asks and reassembles; fails the test on an assembler error.
SdoInfoMessage ask(cia301::ObjectDictionary& od, const Bytes& request, std::size_t read_size,
                   std::size_t* fragment_count = nullptr, const SdoInfoHidden& hidden = {}) {
  const auto answer = answer_sdo_information(od, request, read_size, hidden);
  if (fragment_count) *fragment_count = answer.size();
  SdoInfoAssembler assembler;
  for (std::size_t i = 0; i < answer.size(); ++i) {
    EXPECT_LE(answer[i].size() + kMailboxHeaderSize, read_size);
    auto r = assembler.add(answer[i]);
    EXPECT_TRUE(r) << (r ? "" : r.error());
    if (r && *r) {
      EXPECT_EQ(i + 1, answer.size());
      return **r;
    }
  }
  ADD_FAILURE() << "no complete message";
  return {};
}

TEST(SdoInformation, ListsAllObjectsInFragments) {
  // Given the test dictionary (7 objects) and a read mailbox of 18 octets (6 octets a fragment)
  auto od = test::make_test_dictionary();
  // When the master asks for the list of all objects
  std::size_t fragments = 0;
  const auto m = ask(od, sdo_info_od_list_request(OdListType::all_objects), 18, &fragments);
  // Then the reassembled list has every index in order, over 16 octets in 3 fragments
  const auto list = parse_od_list(m);
  ASSERT_TRUE(list);
  EXPECT_EQ(*list,
            (std::vector<std::uint16_t>{0x1008, 0x1018, 0x1C12, 0x2000, 0x2001, 0x2002, 0x6040}));
  EXPECT_EQ(fragments, 3u);
}

TEST(SdoInformation, ListLengthsAndMappableObjects) {
  // Given the test dictionary, where only 6040h is PDO mappable (rw: both directions)
  auto od = test::make_test_dictionary();
  // When the master asks for the list lengths and the RxPDO-mappable list
  const auto lengths = ask(od, sdo_info_od_list_request(OdListType::list_lengths), 128);
  const auto rx = parse_od_list(ask(od, sdo_info_od_list_request(OdListType::rxpdo_mappable), 128));
  // Then the lengths are 7 objects, 1 RxPDO-, 1 TxPDO-mappable; the RxPDO list is 6040h
  ASSERT_EQ(lengths.data.size(), 12u);
  EXPECT_EQ(lengths.data[2], 7);
  EXPECT_EQ(lengths.data[4], 1);
  EXPECT_EQ(lengths.data[6], 1);
  ASSERT_TRUE(rx);
  EXPECT_EQ(*rx, (std::vector<std::uint16_t>{0x6040}));
}

TEST(SdoInformation, DescribesObjectsAndEntries) {
  // Given the test dictionary
  auto od = test::make_test_dictionary();
  // When 1018h and 1018h:02 (with its default value) are described
  const auto object = parse_object_description(ask(od, sdo_info_object_request(0x1018), 128));
  const auto entry = parse_entry_description(ask(od, sdo_info_entry_request(0x1018, 2, 0x10), 128));
  // Then the object is a RECORD (9) up to sub-index 4 named "Identity"; the entry an UNSIGNED32
  // (0007h) of 32 bits, read-only in every state (07h), its default then its name
  ASSERT_TRUE(object);
  EXPECT_EQ(object->max_sub_index, 4);
  EXPECT_EQ(object->object_code, 9);
  EXPECT_EQ(object->name, "Identity");
  ASSERT_TRUE(entry);
  EXPECT_EQ(entry->data_type, 0x0007);
  EXPECT_EQ(entry->bit_length, 32);
  EXPECT_EQ(entry->object_access, 0x0007);
  EXPECT_EQ(entry->value_info, 0x10);
  EXPECT_EQ(entry->values_and_name,
            (Bytes{0x78, 0x56, 0x34, 0x12, 'P', 'r', 'o', 'd', 'u', 'c', 't'}));
}

TEST(SdoInformation, ErrorsForMissingAndMalformed) {
  // Given the test dictionary
  auto od = test::make_test_dictionary();
  // When a missing object, a missing sub-index, list type 9 and a truncated request are asked
  // Then SDO information errors 06020000h, 06090011h, 06010000h and 05040001h
  const auto code = [&](const Bytes& request) {
    const auto r = parse_sdo_info_error(ask(od, request, 128));
    return r ? *r : 0u;
  };
  EXPECT_EQ(code(sdo_info_object_request(0x7000)), 0x06020000u);
  EXPECT_EQ(code(sdo_info_entry_request(0x1018, 9)), 0x06090011u);
  EXPECT_EQ(code(sdo_info_od_list_request(static_cast<OdListType>(9))), 0x06010000u);
  EXPECT_EQ(code(Bytes{0x00, 0x80, 0x05, 0x00, 0x00, 0x00, 0x18}), 0x05040001u);
}

TEST(SdoInformation, HiddenObjectsAreNeitherListedNorDescribed) {
  // Given the test dictionary and 1008h hidden (a drive's CoE rules: Festo's 1008h-100Ah)
  auto od = test::make_test_dictionary();
  const SdoInfoHidden hidden = [](std::uint16_t index) { return index == 0x1008; };
  // When the master asks for the list of all objects, the list lengths, and 1008h's
  // object and entry descriptions
  const auto list = parse_od_list(
      ask(od, sdo_info_od_list_request(OdListType::all_objects), 128, nullptr, hidden));
  const auto lengths =
      ask(od, sdo_info_od_list_request(OdListType::list_lengths), 128, nullptr, hidden);
  const auto object =
      parse_sdo_info_error(ask(od, sdo_info_object_request(0x1008), 128, nullptr, hidden));
  const auto entry =
      parse_sdo_info_error(ask(od, sdo_info_entry_request(0x1008, 0), 128, nullptr, hidden));
  // Then the list has the six others, its length says 6, both descriptions answer 06020000h
  ASSERT_TRUE(list);
  EXPECT_EQ(*list, (std::vector<std::uint16_t>{0x1018, 0x1C12, 0x2000, 0x2001, 0x2002, 0x6040}));
  ASSERT_EQ(lengths.data.size(), 12u);
  EXPECT_EQ(lengths.data[2], 6);
  ASSERT_TRUE(object);
  EXPECT_EQ(*object, 0x06020000u);
  ASSERT_TRUE(entry);
  EXPECT_EQ(*entry, 0x06020000u);
  // And without the rule 1008h is described
  EXPECT_FALSE(parse_sdo_info_error(ask(od, sdo_info_object_request(0x1008), 128)));
}

TEST(SdoInformation, AssemblerRefusesBrokenFragmentChains) {
  // Given fragments of a list answer with 2 more to come
  auto od = test::make_test_dictionary();
  const auto answer =
      answer_sdo_information(od, sdo_info_od_list_request(OdListType::all_objects), 18);
  ASSERT_EQ(answer.size(), 3u);
  // When the first is followed by the last (the middle one lost)
  SdoInfoAssembler assembler;
  ASSERT_TRUE(assembler.add(answer[0]));
  const auto r = assembler.add(answer[2]);
  // Then the assembler reports the break; an SDO response is refused too
  EXPECT_FALSE(r);
  EXPECT_FALSE(assembler.add(Bytes{0x00, 0x30, 0x60, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(SdoInformation, SlaveAnswersThroughTheMailbox) {
  // Given a CoE slave with SDO information (read mailbox 128)
  auto od = test::make_test_dictionary();
  CoeSlave slave(od);
  MailboxHeader h;
  h.type = 3;
  h.counter = 1;
  // When the master asks for the description of 6040h
  slave.on_write_mailbox(build_mailbox(h, sdo_info_object_request(0x6040), 128));
  // Then one CoE message answers it, naming "Controlword"
  const auto reply = slave.take_reply();
  ASSERT_TRUE(reply);
  SdoInfoAssembler assembler;
  const auto m = assembler.add(parse_mailbox(*reply)->data);
  ASSERT_TRUE(m && *m);
  EXPECT_EQ(parse_object_description(**m)->name, "Controlword");
}

}  // namespace
}  // namespace drivecheck::ethercat

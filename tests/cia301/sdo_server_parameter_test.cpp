// Further SDO server channels: the parameter records 1201h..127Fh
// (protocol/cia301/sdo_server_parameter.hpp) and SdoServer::set_channel, which the device
// calls when a record changes. The state machine is fed frames directly (no bus).
#include "protocol/cia301/sdo_server_parameter.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/sdo_server.hpp"

namespace drivecheck::cia301 {
namespace {

can::Frame frame(std::string_view text) {
  auto parsed = can::parse_candump(text);
  EXPECT_TRUE(parsed) << text;
  return parsed ? *parsed : can::Frame{};
}

std::array<std::uint8_t, 4> le32(std::uint32_t v) {
  return {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8),
          static_cast<std::uint8_t>(v >> 16), static_cast<std::uint8_t>(v >> 24)};
}

ObjectDictionary dictionary(SdoNodeIdSub sub) {
  ObjectDictionary od(5);
  EXPECT_TRUE(od.add_var(0x1000, "Device type", DataType::unsigned32, AccessType::ro,
                         Value::of_unsigned(0x00020192)));
  EXPECT_TRUE(od.add_var(0x1008, "Device name", DataType::visible_string, AccessType::constant,
                         Value::of_string("drivecheck reference")));
  auto added = add_sdo_server_parameter(od, 0x1201, sub);
  EXPECT_TRUE(added) << (added ? "" : added.error());
  return od;
}

TEST(SdoServerParameter, FurtherRecordStartsNotValid) {
  // Given a dictionary with record 1201h (sub 03h: the client's node-ID)
  // When its entries are read
  // Then sub 0 = 3, both COB-IDs 80000000h, sub 3 = 0, and the channel is not valid
  auto od = dictionary(SdoNodeIdSub::client);
  EXPECT_EQ(od.find(0x1201, 0)->as_unsigned(), 3u);
  EXPECT_EQ(od.find(0x1201, 1)->as_unsigned(), 0x80000000u);
  EXPECT_EQ(od.find(0x1201, 2)->as_unsigned(), 0x80000000u);
  EXPECT_EQ(od.find(0x1201, 3)->as_unsigned(), 0u);
  EXPECT_EQ(read_sdo_server_channel(od, 0x1201), (SdoServerChannel{0, 0, false}));
  EXPECT_FALSE(read_sdo_server_channel(od, 0x1202));
}

TEST(SdoServerParameter, IndexOutsideTheFurtherRangeIsRefused) {
  // Given a dictionary
  // When records 1200h (the default channel) or 1280h are added as further channels
  // Then both are refused; 127Fh is taken; without sub 03h the record has sub 0 = 2
  ObjectDictionary od(5);
  EXPECT_FALSE(add_sdo_server_parameter(od, 0x1200, SdoNodeIdSub::client));
  EXPECT_FALSE(add_sdo_server_parameter(od, 0x1280, SdoNodeIdSub::client));
  ASSERT_TRUE(add_sdo_server_parameter(od, 0x127F, SdoNodeIdSub::none));
  EXPECT_EQ(od.find(0x127F, 0)->as_unsigned(), 2u);
  EXPECT_EQ(od.find(0x127F, 3), nullptr);
  EXPECT_FALSE(add_sdo_server_parameter(od, 0x127F, SdoNodeIdSub::none));  // taken
}

TEST(SdoServerParameter, CobIdRulesAsForAPdo) {
  // Given record 1201h with sub 01h valid on 67Fh
  // When a 29-bit COB-ID, reserved bits, or a new CAN-ID while valid is written
  // Then each aborts 06090030h; after bit 31 is set the new CAN-ID is taken
  auto od = dictionary(SdoNodeIdSub::client);
  ASSERT_TRUE(od.write(0x1201, 1, le32(0x67F)));
  EXPECT_EQ(od.write(0x1201, 1, le32(0x2000067F)).error(), SdoAbort::invalid_value);
  EXPECT_EQ(od.write(0x1201, 1, le32(0x0001067F)).error(), SdoAbort::invalid_value);
  EXPECT_EQ(od.write(0x1201, 1, le32(0x67E)).error(), SdoAbort::invalid_value);
  EXPECT_TRUE(od.write(0x1201, 1, le32(0x8000067F)));
  EXPECT_TRUE(od.write(0x1201, 1, le32(0x67E)));
  EXPECT_TRUE(od.write(0x1201, 2, le32(0x5FE)));
  EXPECT_EQ(read_sdo_server_channel(od, 0x1201), (SdoServerChannel{0x67E, 0x5FE, true}));
}

TEST(SdoServerParameter, ServerNodeIdMovesBothCobIds) {
  // Given record 1201h whose sub 03h is the server's own node-ID (ESR)
  // When sub 03h is written 7Fh, then 0, then 80h
  // Then the COB-IDs become 67Fh/5FFh valid, then 80000000h; 80h aborts 06090031h
  auto od = dictionary(SdoNodeIdSub::server);
  const std::array<std::uint8_t, 1> node{0x7F};
  ASSERT_TRUE(od.write(0x1201, 3, node));
  EXPECT_EQ(read_sdo_server_channel(od, 0x1201), (SdoServerChannel{0x67F, 0x5FF, true}));
  const std::array<std::uint8_t, 1> zero{0};
  ASSERT_TRUE(od.write(0x1201, 3, zero));
  EXPECT_EQ(od.find(0x1201, 1)->as_unsigned(), 0x80000000u);
  EXPECT_FALSE(read_sdo_server_channel(od, 0x1201)->valid);
  const std::array<std::uint8_t, 1> too_high{0x80};
  EXPECT_EQ(od.write(0x1201, 3, too_high).error(), SdoAbort::value_too_high);
}

TEST(SdoServerChannel, DisabledServerTakesNoRequest) {
  // Given a server moved to 67Fh/5FFh but not enabled
  // When an upload request arrives on 67Fh
  // Then it is no request of this server and nothing is answered
  auto od = dictionary(SdoNodeIdSub::client);
  SdoServer server(od, SdoServerConfig::for_node(5));
  server.set_channel(0x67F, 0x5FF, false);
  const auto request = frame("67F#4000100000000000");  // ccs=2 upload 1000h:00
  EXPECT_FALSE(server.enabled());
  EXPECT_FALSE(server.is_request(request));
  EXPECT_TRUE(server.on_frame(request, can::TimePoint{}).empty());
}

TEST(SdoServerChannel, MovingTheChannelDropsTheOpenTransferSilently) {
  // Given a segmented upload of 1008h open on 605h/585h
  // When the channel moves to 67Fh/5FFh (enabled)
  // Then the transfer is dropped without a frame, 605h is no longer served, and a request on
  //      67Fh is answered on 5FFh
  auto od = dictionary(SdoNodeIdSub::client);
  SdoServer server(od, SdoServerConfig::for_node(5));
  ASSERT_EQ(server.on_frame(frame("605#4008100000000000"), can::TimePoint{}).size(), 1u);
  ASSERT_TRUE(server.busy());
  server.set_channel(0x67F, 0x5FF, true);
  EXPECT_FALSE(server.busy());
  EXPECT_FALSE(server.is_request(frame("605#4000100000000000")));
  const auto answer = server.on_frame(frame("67F#4000100000000000"), can::TimePoint{});
  ASSERT_EQ(answer.size(), 1u);
  // scs=2 e=1 s=1 n=0, 1000h sub 0, 00020192h
  EXPECT_EQ(answer[0], frame("5FF#4300100092010200"));
}

TEST(SdoServerChannel, SameChannelKeepsTheOpenTransfer) {
  // Given a segmented upload open on 605h/585h
  // When set_channel is called with the same COB-IDs, enabled
  // Then the transfer stays open (nothing changed)
  auto od = dictionary(SdoNodeIdSub::client);
  SdoServer server(od, SdoServerConfig::for_node(5));
  ASSERT_EQ(server.on_frame(frame("605#4008100000000000"), can::TimePoint{}).size(), 1u);
  server.set_channel(0x605, 0x585, true);
  EXPECT_TRUE(server.busy());
}

}  // namespace
}  // namespace drivecheck::cia301

#include "protocol/ethercat/pcap.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "protocol/ethercat/esc_slave.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sim_segment.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

TEST(EthernetPcap, RoundTripsRecordsAndRejectsGarbage) {
  // Given two records with nanosecond timestamps
  // When they are written as a file image and parsed
  // Then the records come back; a truncated file and a CAN pcap give errors naming the offset
  std::vector<EthernetPcapRecord> records = {{1'700'000'000'000'000'123ns, Bytes(60, 0xAB)},
                                             {1'700'000'000'000'100'000ns, Bytes(62, 0x01)}};
  Bytes file = ethernet_pcap_file_header();
  for (const auto& r : records) {
    const auto bytes = encode_ethernet_pcap_record(r);
    ASSERT_TRUE(bytes);
    file.insert(file.end(), bytes->begin(), bytes->end());
  }
  const auto parsed = parse_ethernet_pcap(file);
  ASSERT_TRUE(parsed) << parsed.error();
  EXPECT_EQ(*parsed, records);
  const auto cut = parse_ethernet_pcap(std::span(file).first(file.size() - 1));
  ASSERT_FALSE(cut);
  EXPECT_NE(cut.error().find("byte 100"), std::string::npos) << cut.error();
  Bytes can = ethernet_pcap_file_header();
  can[20] = 227;
  EXPECT_FALSE(parse_ethernet_pcap(can));
  EXPECT_FALSE(parse_ethernet_pcap(Bytes(10)));
  EXPECT_FALSE(encode_ethernet_pcap_record({-1ns, {}}));
}

TEST(EthernetPcap, AFractionOfOneSecondOrMoreIsRefused) {
  // Given a record whose nanosecond field is 10^9 (one second) at the last second a record holds
  // When the file is read
  // Then it is an error naming the field's byte, not a record that cannot be written back
  //      (found by the ethercat_pcap fuzz target in a 170 s run)
  Bytes file = ethernet_pcap_file_header();
  const auto record = encode_ethernet_pcap_record({0xFFFFFFFFLL * 1'000'000'000ns, Bytes(60, 1)});
  ASSERT_TRUE(record);
  file.insert(file.end(), record->begin(), record->end());
  ASSERT_TRUE(parse_ethernet_pcap(file));
  const std::uint32_t second = 1'000'000'000;
  for (int i = 0; i < 4; ++i)
    file[24 + 4 + i] = static_cast<std::uint8_t>(second >> (8 * i));
  const auto read = read_ethernet_pcap(file);
  ASSERT_TRUE(read.error);
  EXPECT_NE(read.error->find("byte 28"), std::string::npos) << *read.error;
  EXPECT_TRUE(read.records.empty());
}

std::string run_tshark(const std::string& args) {
  std::string output;
  FILE* pipe = ::popen(("tshark " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return output;
  std::array<char, 4096> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr)
    output += buffer.data();
  ::pclose(pipe);
  return output;
}

TEST(EthernetPcap, TsharkDecodesDatagramsMailboxAndCoeSdo) {
  // Given a simulated segment with one slave, recorded to a pcap by a monitor, carrying an
  // APWR, an FPRD of AL status, an LRW and an FPWR of SM0 holding a CoE SDO upload request
  // When tshark reads the file
  // Then it decodes the EtherCAT datagrams (command names, working counters), the mailbox
  // header and the CoE SDO request for 1018h:01
  if (std::system("command -v tshark >/dev/null 2>&1") != 0) {
    GTEST_SKIP() << "tshark is not installed (apt-get install tshark)";
  }
  SiiImage image;
  image.header.standard_receive = {0x1000, 128};
  image.header.standard_send = {0x1080, 128};
  EscSlaveConfig config;
  config.esc.sii = *build_sii(image);
  EscSlave slave(config);
  SimSegment segment({.seed = 1, .unix_offset = 1'700'000'000s, .rx_queue_limit = 100});
  segment.attach(slave);
  const auto path = std::filesystem::temp_directory_path() /
                    ("drivecheck-ethercat-" + std::to_string(::getpid()) + ".pcap");
  {
    PcapWriter pcap(path, segment.unix_offset());
    ASSERT_TRUE(pcap.ok()) << pcap.error();
    segment.add_monitor([&](const TimedFrame& f, FrameDirection) { pcap.write(f); });
    auto exchange = [&](std::vector<Datagram> datagrams) {
      Frame frame;
      frame.source = {0x02, 0, 0, 0, 0, 1};
      frame.datagrams = std::move(datagrams);
      ASSERT_FALSE(segment.send(*encode_frame(frame)));
      ASSERT_TRUE(segment.receive(segment.now() + 1ms));
    };
    exchange({Datagram::physical(Command::apwr, 1, 0, reg::kStationAddress, {0x01, 0x10}),
              Datagram::physical(Command::fprd, 2, 0x1001, reg::kAlStatus, {0, 0})});
    // SM0 1000h/128 write mailbox, SM1 1080h/128 read mailbox, both enabled
    exchange({Datagram::physical(Command::fpwr, 3, 0x1001, reg::kSyncManager,
                                 {0x00, 0x10, 0x80, 0x00, 0x26, 0, 1, 0,  //
                                  0x80, 0x10, 0x80, 0x00, 0x22, 0, 1, 0})});
    exchange({Datagram::logical(Command::lrw, 4, 0x10000, Bytes(4, 0))});
    Bytes mailbox(128, 0);
    // mailbox header: length 10, address 0, channel/priority 0, type 3 (CoE) counter 1;
    // CoE header: number 0, service 2 (SDO request);
    // SDO: ccs=2 upload initiate (40h), index 1018h sub 01h, 4 bytes 0
    const Bytes request = {0x0A, 0x00, 0x00, 0x00, 0x00, 0x13, 0x00, 0x20,
                           0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00};
    std::copy(request.begin(), request.end(), mailbox.begin());
    exchange({Datagram::physical(Command::fpwr, 5, 0x1001, 0x1000, mailbox)});
    pcap.flush();
  }
  const std::string text = run_tshark("-r " + path.string() + " -V");
  if (std::getenv("DRIVECHECK_KEEP_PCAP") == nullptr) std::filesystem::remove(path);
  for (const char* expected : {"EtherCAT datagram", "APWR", "FPRD", "LRW", "FPWR", "Working Cnt: 1",
                               "Mailbox", "CoE", "SDO"}) {
    EXPECT_NE(text.find(expected), std::string::npos)
        << "tshark output lacks \"" << expected << "\":\n"
        << text.substr(0, 4000);
  }
}

}  // namespace
}  // namespace drivecheck::ethercat

// Fuzz target: pcap captures of EtherCAT frames (protocol/ethercat/pcap.hpp) and the EtherCAT
// dissector over them (protocol/ethercat/dissector.hpp), as `drivecheck decode FILE.pcap`
// reads them.
//
// Input: the bytes of a capture file. Oracles:
//  - read_ethernet_pcap keeps the records before a damaged one; without an error it agrees with
//    parse_ethernet_pcap, and the records written again (file header + records) read back the
//    same;
//  - every record is dissected by one FrameDissector (its state: SyncManager configuration,
//    the outgoing frame awaiting its return): never a crash; a frame decode_frame refuses gives
//    exactly one line "malformed: ..."; a frame it accepts one non-empty line per datagram;
//    shapes are empty (mailbox content) or one per line;
//  - the whole input as one Ethernet frame, to reach datagrams without a pcap header: the same.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz/support/fuzz_check.hpp"
#include "protocol/ethercat/dissector.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/pcap.hpp"

namespace {

using namespace drivecheck;

void check_dissection(ethercat::FrameDissector& dissector, std::span<const std::uint8_t> bytes) {
  const auto frame = dissector.dissect(bytes);
  const auto decoded = ethercat::decode_frame(bytes);
  DRIVECHECK_FUZZ_CHECK_EQ(frame.malformed, !decoded.has_value(),
                           "dissector and decode_frame disagree on malformed");
  if (frame.malformed) {
    DRIVECHECK_FUZZ_CHECK_EQ(frame.lines.size(), std::size_t{1}, "malformed: not one line");
    DRIVECHECK_FUZZ_CHECK(frame.lines[0].rfind("malformed: ", 0) == 0,
                          "malformed frame line lacks its label");
    return;
  }
  DRIVECHECK_FUZZ_CHECK_EQ(frame.lines.size(), decoded->datagrams.size(),
                           "not one line per datagram");
  for (const std::string& line : frame.lines)
    DRIVECHECK_FUZZ_CHECK(!line.empty(), "empty datagram line");
  DRIVECHECK_FUZZ_CHECK(frame.shapes.empty() || frame.shapes.size() == frame.lines.size(),
                        "shapes neither empty nor one per line");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> input(data, size);
  const auto read = ethercat::read_ethernet_pcap(input);
  const auto parsed = ethercat::parse_ethernet_pcap(input);
  DRIVECHECK_FUZZ_CHECK_EQ(parsed.has_value(), !read.error.has_value(),
                           "read_ethernet_pcap and parse_ethernet_pcap disagree");
  if (read.error) DRIVECHECK_FUZZ_CHECK(!read.error->empty(), "pcap error without a message");
  if (parsed) {
    DRIVECHECK_FUZZ_CHECK(*parsed == read.records, "the two readers read different records");
    std::vector<std::uint8_t> written = ethercat::ethernet_pcap_file_header();
    for (const auto& record : read.records) {
      const auto bytes = ethercat::encode_ethernet_pcap_record(record);
      DRIVECHECK_FUZZ_CHECK_DETAIL(bytes.has_value(), "a parsed record cannot be encoded",
                                   bytes.error());
      written.insert(written.end(), bytes->begin(), bytes->end());
    }
    const auto again = ethercat::parse_ethernet_pcap(written);
    DRIVECHECK_FUZZ_CHECK_DETAIL(again.has_value(), "written capture does not parse",
                                 again.error());
    DRIVECHECK_FUZZ_CHECK(*again == read.records, "records changed in a pcap round trip");
  }
  ethercat::FrameDissector dissector;
  for (const auto& record : read.records)
    check_dissection(dissector, record.bytes);
  ethercat::FrameDissector fresh;
  check_dissection(fresh, input);
  return 0;
}

// Fuzz target: pcap capture files of CAN frames (protocol/can/pcap.hpp).
//
// Input: the bytes of a capture file. Oracle: a capture that parses is written again (file
// header + encode_pcap_record for every record) and parses to the same records; a record that
// parsed can always be encoded (its timestamp came from a pcap, so pcap can hold it).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz/support/fuzz_check.hpp"
#include "protocol/can/pcap.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace drivecheck;
  const auto records = can::parse_pcap({data, size});
  if (!records) {
    DRIVECHECK_FUZZ_CHECK(!records.error().empty(), "pcap error without a message");
    return 0;
  }
  const auto header = can::pcap_file_header();
  std::vector<std::uint8_t> written(header.begin(), header.end());
  for (const can::PcapRecord& record : *records) {
    const auto bytes = can::encode_pcap_record(record);
    DRIVECHECK_FUZZ_CHECK_DETAIL(bytes.has_value(), "a parsed pcap record cannot be encoded",
                                 bytes.error());
    written.insert(written.end(), bytes->begin(), bytes->end());
  }
  const auto again = can::parse_pcap(written);
  DRIVECHECK_FUZZ_CHECK_DETAIL(again.has_value(), "written capture does not parse", again.error());
  DRIVECHECK_FUZZ_CHECK_EQ(again->size(), records->size(), "written capture lost records");
  for (std::size_t i = 0; i < records->size(); ++i) {
    DRIVECHECK_FUZZ_CHECK_EQ((*again)[i].frame, (*records)[i].frame,
                             "frame changed in a pcap round trip");
    DRIVECHECK_FUZZ_CHECK_EQ((*again)[i].timestamp.count(), (*records)[i].timestamp.count(),
                             "timestamp changed in a pcap round trip");
  }
  return 0;
}

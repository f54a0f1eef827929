// drivecheck decode FILE: a candump log or a pcap capture as a decoded transcript.
//
// FILE is told apart by its first bytes: a pcap file (magic A1B2C3D4h or A1B23C4Dh, either byte
// order) is read by its link type: Ethernet (1, EtherCAT: `drivecheck run --bus ethercat:sim
// --pcap`, Wireshark captures) or SocketCAN (227, `drivecheck run --pcap` on CAN); anything
// else is candump text. pcapng is refused with a hint (tshark/editcap -F pcap convert it).
//
// EtherCAT pcap, one line per datagram (protocol/ethercat/dissector.hpp):
//
//   0.000100160  #2  ret  FPRD station 1001h 0130h AL status len 2 wkc 1: PREOP
//   ^ time (s.ns)  ^ frame number in the file
//                       ^ out: the master's frame as sent; ret: as it came back (inferred by
//                         the dissector: same commands and Idx tags as the frame before)
//
// A frame that is not well-formed EtherCAT gives one "malformed: ..." line. At the end stderr
// says how many frames and datagrams were read and how many were malformed; a cut-off capture
// (a writer killed mid-record) is decoded up to the cut and the cut is reported (exit 0 when
// any frame was read, else 2).
//
// candump: a CANopen transcript, one line per record:
//
//   1700000000.002000  vcan0  T  605#4041600000000000  SDO rx  node 5  initiate upload 6041:00
//   (statusword) ^ Unix time        ^ if.  ^ direction (R/T, '-' when the log has none)
//                                 ^ frame                ^ the CANopen dissector's summary
//
// LOG is a `candump -L` log, plain `candump` output or `candump -ta` output, told apart line by
// line (protocol/can/candump_text.hpp); a line without time shows '-' for it.
// The last column is cia301::Dissector::dissect(frame).summary(): function, node and the
// decoded content (protocol/cia301/dissector.hpp). The dissector follows the log in order, so
// SDO block transfers and guarding responses are told apart by what came before.
// --node N (repeatable) names the nodes on the bus (others are flagged); --eds FILE takes the
// object names of an EDS/DCF for SDO and PDO lines.
// A line that cannot be read is skipped; after the transcript, stderr lists each as
// "file:line: message" and how many there were. The exit code is 2 only when no line could be
// read at all (or the file cannot be opened); "-" reads standard input.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "cli/commands.hpp"
#include "cli/options.hpp"
#include "protocol/can/candump_log.hpp"
#include "protocol/can/candump_text.hpp"
#include "protocol/can/pcap.hpp"
#include "protocol/cia301/dissector.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/ethercat/dissector.hpp"
#include "protocol/ethercat/pcap.hpp"

namespace drivecheck::cli {
namespace {

struct DecodeOptions {
  std::string log;
  std::vector<int> nodes;
  std::string eds;
};

// Object names of an EDS/DCF: "<ParameterName>" for an object's sub-index 0 without
// sub-objects, "<object>: <sub-object>" for sub-objects (CompactSubObj names included).
using NameTable = std::map<std::pair<std::uint16_t, std::uint8_t>, std::string>;

NameTable eds_names(const cia306::Eds& eds) {
  NameTable names;
  for (const cia306::EdsObject& object : eds.objects) {
    const std::string& name = object.keys.parameter_name;
    if (object.subs.empty() && object.names.empty()) {
      if (!name.empty()) names[{object.index, 0}] = name;
      continue;
    }
    for (const cia306::SubObject& sub : object.subs) {
      if (sub.keys.parameter_name.empty()) continue;
      names[{object.index, sub.sub_index}] =
          name.empty() ? sub.keys.parameter_name : name + ": " + sub.keys.parameter_name;
    }
    for (const cia306::CompactItem& item : object.names) {
      names[{object.index, item.sub_index}] = name.empty() ? item.text : name + ": " + item.text;
    }
  }
  return names;
}

std::string format_time(std::chrono::nanoseconds unix_time) {
  const std::int64_t ns = unix_time.count();  // never negative in a log we read
  return fmt::format("{}.{:06}", ns / 1'000'000'000, ns % 1'000'000'000 / 1000);
}

std::string format_time_ns(std::chrono::nanoseconds unix_time) {
  const std::int64_t ns = unix_time.count();
  return fmt::format("{}.{:09}", ns / 1'000'000'000, ns % 1'000'000'000);
}

enum class FileKind { candump, pcap, pcapng };

FileKind kind_of(std::string_view bytes) {
  if (bytes.size() < 4) return FileKind::candump;
  const auto b = [&](std::size_t i) { return static_cast<std::uint8_t>(bytes[i]); };
  const std::uint32_t le = b(0) | (b(1) << 8) | (b(2) << 16) | (std::uint32_t{b(3)} << 24);
  const std::uint32_t be = __builtin_bswap32(le);
  for (const std::uint32_t magic : {0xA1B2C3D4U, 0xA1B23C4DU})
    if (le == magic || be == magic) return FileKind::pcap;
  if (le == 0x0A0D0D0AU) return FileKind::pcapng;
  return FileKind::candump;
}

std::uint32_t pcap_link_type(std::string_view bytes) {
  if (bytes.size() < 24) return 0;
  const auto b = [&](std::size_t i) { return static_cast<std::uint8_t>(bytes[i]); };
  const std::uint32_t magic = b(0) | (b(1) << 8) | (b(2) << 16) | (std::uint32_t{b(3)} << 24);
  const std::uint32_t le = b(20) | (b(21) << 8) | (b(22) << 16) | (std::uint32_t{b(23)} << 24);
  const bool swap = magic != 0xA1B2C3D4U && magic != 0xA1B23C4DU;
  return swap ? __builtin_bswap32(le) : le;
}

int decode_ethercat_pcap(std::string_view text, const std::string& name) {
  const auto bytes = std::span<const std::uint8_t>(
      reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
  const auto read = ethercat::read_ethernet_pcap(bytes);
  ethercat::FrameDissector dissector;
  std::string out;
  std::size_t datagrams = 0;
  std::size_t malformed = 0;
  for (std::size_t i = 0; i < read.records.size(); ++i) {
    const auto& record = read.records[i];
    const auto frame = dissector.dissect(record.bytes);
    if (frame.malformed) ++malformed;
    const char* pass = frame.malformed                               ? "?  "
                       : frame.pass == ethercat::FramePass::returned ? "ret"
                                                                     : "out";
    for (const std::string& line : frame.lines) {
      fmt::format_to(std::back_inserter(out), "{}  #{}  {}  {}\n", format_time_ns(record.timestamp),
                     i + 1, pass, line);
    }
    if (!frame.malformed) datagrams += frame.lines.size();
    if (out.size() > (1U << 20)) {
      std::fwrite(out.data(), 1, out.size(), stdout);
      out.clear();
    }
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  std::fflush(stdout);
  fmt::print(stderr,
             "drivecheck decode: {}: {} EtherCAT frame(s), {} datagram(s), {} malformed{}\n", name,
             read.records.size(), datagrams, malformed,
             read.error ? fmt::format("; stopped: {}", *read.error) : std::string());
  return read.records.empty() && read.error ? kExitUsage : kExitPass;
}

int decode(const DecodeOptions& options) {
  const std::string& path = options.log;
  cia301::DissectorOptions dissector_options;
  for (int node : options.nodes)
    dissector_options.nodes.set(static_cast<std::size_t>(node));
  if (!options.eds.empty()) {
    auto eds = cia306::read_eds_file(options.eds);
    if (!eds) {
      fmt::print(stderr, "{}\n", eds.error().to_string());
      return kExitUsage;
    }
    auto names = std::make_shared<NameTable>(eds_names(eds->eds));
    dissector_options.object_name = [names](std::uint16_t index,
                                            std::uint8_t sub) -> std::optional<std::string> {
      const auto it = names->find({index, sub});
      if (it == names->end()) return std::nullopt;
      return it->second;
    };
  }
  cia301::Dissector dissector(std::move(dissector_options));
  std::string text;
  std::string name = path;
  if (path == "-") {
    name = "<stdin>";
    text.assign(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
  } else {
    std::ifstream file(path, std::ios::binary);
    if (!file) {
      fmt::print(stderr, "{}: cannot open: {}\n", path,
                 std::error_code(errno, std::generic_category()).message());
      return kExitUsage;
    }
    std::ostringstream content;
    content << file.rdbuf();
    if (file.bad()) {
      fmt::print(stderr, "{}: cannot read\n", path);
      return kExitUsage;
    }
    text = std::move(content).str();
  }
  const FileKind kind = kind_of(text);
  if (kind == FileKind::pcapng) {
    fmt::print(stderr,
               "{}: a pcapng file; drivecheck decode reads pcap (convert it: editcap -F pcap "
               "{} out.pcap)\n",
               name, name);
    return kExitUsage;
  }
  std::vector<can::LogRecord> pcap_records;
  if (kind == FileKind::pcap) {
    const std::uint32_t link = pcap_link_type(text);
    if (link == ethercat::kLinktypeEthernet) return decode_ethercat_pcap(text, name);
    const auto records = can::parse_pcap(std::span<const std::uint8_t>(
        reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
    if (!records) {
      fmt::print(stderr, "{}: {}\n", name, records.error());
      return kExitUsage;
    }
    for (const auto& record : *records) {
      can::LogRecord line;
      line.timestamp = record.timestamp;
      line.interface = "pcap";
      line.frame = record.frame;
      pcap_records.push_back(std::move(line));
    }
  }
  can::CandumpText read;
  if (kind == FileKind::pcap) {
    for (auto& record : pcap_records) {
      can::CandumpLine line;
      line.record = std::move(record);
      line.format = can::CandumpLineFormat::log;
      read.lines.push_back(std::move(line));
    }
  } else {
    read = can::read_candump_text(text, name);
  }
  std::size_t time_width = 0;
  std::size_t interface_width = 0;
  std::size_t frame_width = 0;
  std::vector<std::string> times;
  std::vector<std::string> frames;
  times.reserve(read.lines.size());
  frames.reserve(read.lines.size());
  for (const auto& line : read.lines) {
    times.push_back(line.has_timestamp() ? format_time(line.record.timestamp) : "-");
    frames.push_back(can::to_candump(line.record.frame));
    time_width = std::max(time_width, times.back().size());
    interface_width = std::max(interface_width, line.record.interface.size());
    frame_width = std::max(frame_width, frames.back().size());
  }
  std::string out;
  for (std::size_t i = 0; i < read.lines.size(); ++i) {
    const auto& record = read.lines[i].record;
    const char direction = !record.direction                                    ? '-'
                           : *record.direction == can::TraceDirection::transmit ? 'T'
                                                                                : 'R';
    fmt::format_to(std::back_inserter(out), "{:<{}}  {:<{}}  {}  {:<{}}  {}\n", times[i],
                   time_width, record.interface, interface_width, direction, frames[i], frame_width,
                   dissector.dissect(record.frame).summary());
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  std::fflush(stdout);
  for (const auto& bad : read.bad_lines)
    fmt::print(stderr, "{}\n", bad.to_string());
  if (!read.bad_lines.empty()) {
    fmt::print(stderr, "drivecheck decode: {}: {} line(s) not read, {} decoded\n", name,
               read.bad_lines.size(), read.lines.size());
  }
  return read.lines.empty() && !read.bad_lines.empty() ? kExitUsage : kExitPass;
}

}  // namespace

void add_decode_command(CLI::App& app) {
  auto options = std::make_shared<DecodeOptions>();
  CLI::App* cmd = app.add_subcommand(
      "decode",
      "Print candump output (-L log, plain or -ta) or a pcap capture (CAN, or EtherCAT "
      "Ethernet frames) as a decoded transcript");
  cmd->add_option("LOG", options->log,
                  "candump output (a -L log, plain candump or candump -ta) or a pcap file (CAN "
                  "or EtherCAT, told apart by its header); '-' reads standard input")
      ->required();
  cmd->add_option("--node", options->nodes,
                  "Node id on the bus (repeatable); frames of other nodes are flagged")
      ->check(CLI::Range(kMinNodeId, kMaxNodeId));
  cmd->add_option("--eds", options->eds, "EDS/DCF file whose object names the transcript uses");
  cmd->callback([options] { exit_with(decode(*options)); });
}

}  // namespace drivecheck::cli

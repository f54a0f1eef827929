// drivecheck decode LOG: a candump -L log as a CANopen transcript, one line per record:
//
//   1700000000.002000  vcan0  T  605#4041600000000000  SDO rx  node 5  initiate upload 6041:00
//   (statusword) ^ Unix time        ^ if.  ^ direction (R/T, '-' when the log has none)
//                                 ^ frame                ^ the CANopen dissector's summary
//
// The last column is cia301::Dissector::dissect(frame).summary(): function, node and the
// decoded content (protocol/cia301/dissector.hpp). The dissector follows the log in order, so
// SDO block transfers and guarding responses are told apart by what came before.
// --node N (repeatable) names the nodes on the bus (others are flagged); --eds FILE takes the
// object names of an EDS/DCF for SDO and PDO lines.
// A bad log prints "file:line: message" and exits 2; "-" reads standard input.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cli/commands.hpp"
#include "cli/options.hpp"
#include "protocol/can/candump_log.hpp"
#include "protocol/cia301/dissector.hpp"
#include "protocol/cia306/eds.hpp"

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
  Expected<std::vector<can::LogRecord>, TextError> records = std::vector<can::LogRecord>{};
  if (path == "-") {
    const std::string text{std::istreambuf_iterator<char>(std::cin),
                           std::istreambuf_iterator<char>()};
    records = can::read_candump_log(text, "<stdin>");
  } else {
    records = can::read_candump_log_file(path);
  }
  if (!records) {
    fmt::print(stderr, "{}\n", records.error().to_string());
    return kExitUsage;
  }
  std::size_t interface_width = 0;
  std::size_t frame_width = 0;
  std::vector<std::string> frames;
  frames.reserve(records->size());
  for (const auto& record : *records) {
    frames.push_back(can::to_candump(record.frame));
    interface_width = std::max(interface_width, record.interface.size());
    frame_width = std::max(frame_width, frames.back().size());
  }
  std::string out;
  for (std::size_t i = 0; i < records->size(); ++i) {
    const auto& record = (*records)[i];
    const char direction = !record.direction                                    ? '-'
                           : *record.direction == can::TraceDirection::transmit ? 'T'
                                                                                : 'R';
    fmt::format_to(std::back_inserter(out), "{}  {:<{}}  {}  {:<{}}  {}\n",
                   format_time(record.timestamp), record.interface, interface_width, direction,
                   frames[i], frame_width, dissector.dissect(record.frame).summary());
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  return kExitPass;
}

}  // namespace

void add_decode_command(CLI::App& app) {
  auto options = std::make_shared<DecodeOptions>();
  CLI::App* cmd =
      app.add_subcommand("decode", "Print a candump -L log as a decoded CANopen transcript");
  cmd->add_option("LOG", options->log, "candump -L log file ('-' reads standard input)")
      ->required();
  cmd->add_option("--node", options->nodes,
                  "Node id on the bus (repeatable); frames of other nodes are flagged")
      ->check(CLI::Range(kMinNodeId, kMaxNodeId));
  cmd->add_option("--eds", options->eds, "EDS/DCF file whose object names the transcript uses");
  cmd->callback([options] { exit_with(decode(*options)); });
}

}  // namespace drivecheck::cli

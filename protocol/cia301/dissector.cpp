#include "protocol/cia301/dissector.hpp"

#include <fmt/chrono.h>
#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <variant>

#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/error_control.hpp"
#include "protocol/cia301/heartbeat_consumer.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/cia301/sync.hpp"
#include "protocol/cia301/time.hpp"
#include "protocol/cia402/modes.hpp"
#include "protocol/cia402/object_ids.hpp"
#include "protocol/cia402/state_machine.hpp"

namespace drivecheck::cia301 {
namespace {

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

// "01 02 FF" (upper-case hex, one blank between bytes), or "(no data)". Built by hand: it
// runs for most frames of a transcript.
std::string hex_bytes(std::span<const std::uint8_t> bytes) {
  if (bytes.empty()) return "(no data)";
  static constexpr char kDigits[] = "0123456789ABCDEF";
  std::string text;
  text.reserve(bytes.size() * 3);
  for (std::uint8_t byte : bytes) {
    if (!text.empty()) text += ' ';
    text += kDigits[byte >> 4];
    text += kDigits[byte & 0xF];
  }
  return text;
}

std::uint64_t little_endian(std::span<const std::uint8_t> bytes) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < bytes.size() && i < 8; ++i) {
    value |= static_cast<std::uint64_t>(bytes[i]) << (8 * i);
  }
  return value;
}

std::string mux_text(std::uint16_t index, std::uint8_t sub_index) {
  return fmt::format(FMT_COMPILE("{:04X}:{:02X}"), index, sub_index);
}

std::string_view pdo_sub_name(std::uint8_t sub) {
  switch (sub) {
    case 0:
      return "highest sub-index supported";
    case 1:
      return "COB-ID";
    case 2:
      return "transmission type";
    case 3:
      return "inhibit time";
    case 4:
      return "reserved";
    case 5:
      return "event timer";
    case 6:
      return "SYNC start value";
    default:
      return "";
  }
}

std::optional<std::string> communication_object_name(std::uint16_t index, std::uint8_t sub) {
  auto with_sub = [sub](std::string_view name, std::string_view sub_name) {
    return sub_name.empty() ? fmt::format(FMT_COMPILE("{} sub {:02X}h"), name, sub)
                            : fmt::format(FMT_COMPILE("{}: {}"), name, sub_name);
  };
  switch (index) {
    case 0x1000:
      return std::string("device type");
    case 0x1001:
      return std::string("error register");
    case 0x1002:
      return std::string("manufacturer status register");
    case 0x1003:
      return sub == 0 ? std::string("pre-defined error field: number of errors")
                      : fmt::format(FMT_COMPILE("pre-defined error field: standard error field {}"),
                                    sub);
    case 0x1005:
      return std::string("COB-ID SYNC");
    case 0x1006:
      return std::string("communication cycle period");
    case 0x1007:
      return std::string("synchronous window length");
    case 0x1008:
      return std::string("manufacturer device name");
    case 0x1009:
      return std::string("manufacturer hardware version");
    case 0x100A:
      return std::string("manufacturer software version");
    case 0x100C:
      return std::string("guard time");
    case 0x100D:
      return std::string("life time factor");
    case 0x1010:
      return with_sub("store parameters", sub == 0   ? "highest sub-index supported"
                                          : sub == 1 ? "save all parameters"
                                                     : "");
    case 0x1011:
      return with_sub("restore default parameters", sub == 0   ? "highest sub-index supported"
                                                    : sub == 1 ? "restore all default parameters"
                                                               : "");
    case 0x1012:
      return std::string("COB-ID TIME");
    case 0x1013:
      return std::string("high resolution time stamp");
    case 0x1014:
      return std::string("COB-ID EMCY");
    case 0x1015:
      return std::string("inhibit time EMCY");
    case 0x1016:
      return sub == 0 ? std::string("consumer heartbeat time: highest sub-index supported")
                      : fmt::format(FMT_COMPILE("consumer heartbeat time {}"), sub);
    case 0x1017:
      return std::string("producer heartbeat time");
    case 0x1018: {
      constexpr std::string_view kSubs[] = {"highest sub-index supported", "vendor-ID",
                                            "product code", "revision number", "serial number"};
      return with_sub("identity object", sub < 5 ? kSubs[sub] : "");
    }
    case 0x1019:
      return std::string("synchronous counter overflow value");
    case 0x1020:
      return std::string("verify configuration");
    case 0x1029:
      return std::string("error behavior");
    case 0x1F80:
      return std::string("NMT startup");
    default:
      break;
  }
  if (index >= 0x1200 && index <= 0x127F) {
    constexpr std::string_view kSubs[] = {"highest sub-index supported", "COB-ID client→server",
                                          "COB-ID server→client", "node-ID of the client"};
    return with_sub(fmt::format(FMT_COMPILE("SDO server parameter {}"), index - 0x1200 + 1),
                    sub < 4 ? kSubs[sub] : "");
  }
  if (index >= 0x1280 && index <= 0x12FF) {
    constexpr std::string_view kSubs[] = {"highest sub-index supported", "COB-ID client→server",
                                          "COB-ID server→client", "node-ID of the server"};
    return with_sub(fmt::format(FMT_COMPILE("SDO client parameter {}"), index - 0x1280 + 1),
                    sub < 4 ? kSubs[sub] : "");
  }
  struct Range {
    std::uint16_t base;
    std::string_view name;
    bool mapping;
  };
  constexpr Range kPdoRanges[] = {{0x1400, "RPDO{} communication parameter", false},
                                  {0x1600, "RPDO{} mapping parameter", true},
                                  {0x1800, "TPDO{} communication parameter", false},
                                  {0x1A00, "TPDO{} mapping parameter", true}};
  for (const Range& range : kPdoRanges) {
    if (index < range.base || index > range.base + 0x1FF) continue;
    const std::string name = fmt::format(fmt::runtime(range.name), index - range.base + 1);
    if (range.mapping) {
      return sub == 0 ? name + ": number of mapped objects"
                      : fmt::format(FMT_COMPILE("{}: mapped object {}"), name, sub);
    }
    return with_sub(name, pdo_sub_name(sub));
  }
  return std::nullopt;
}

std::string emcy_text(const Emcy& emcy) {
  std::string text = emcy.is_error_reset()
                         ? fmt::format(FMT_COMPILE("error reset ({:04X}h)"), emcy.error_code)
                         : describe_emcy_code(emcy.error_code);
  fmt::format_to(std::back_inserter(text), FMT_COMPILE("; register {:02X}h {}"),
                 emcy.error_register, describe_error_register(emcy.error_register));
  const bool any = std::any_of(emcy.manufacturer.begin(), emcy.manufacturer.end(),
                               [](std::uint8_t b) { return b != 0; });
  if (any) text += "; manufacturer " + hex_bytes(emcy.manufacturer);
  return text;
}

std::string_view lss_command_name(std::uint8_t cs) {
  switch (cs) {
    case 0x04:
      return "switch state global";
    case 0x11:
      return "configure node-ID";
    case 0x13:
      return "configure bit timing";
    case 0x15:
      return "activate bit timing";
    case 0x17:
      return "store configuration";
    case 0x40:
      return "switch state selective: vendor-ID";
    case 0x41:
      return "switch state selective: product code";
    case 0x42:
      return "switch state selective: revision number";
    case 0x43:
      return "switch state selective: serial number";
    case 0x44:
      return "switch state selective: response";
    case 0x4C:
      return "identify non-configured remote slave";
    case 0x4F:
      return "identify slave: response";
    case 0x50:
      return "identify non-configured slave: response";
    case 0x51:
      return "fastscan";
    case 0x5A:
      return "inquire vendor-ID";
    case 0x5B:
      return "inquire product code";
    case 0x5C:
      return "inquire revision number";
    case 0x5D:
      return "inquire serial number";
    case 0x5E:
      return "inquire node-ID";
    default:
      return "";
  }
}

}  // namespace

std::string Dissection::summary() const {
  // "{:<6}  " by hand (the function left-aligned in 6 code points): this runs for every line.
  std::string line = function;
  const auto code_points = static_cast<std::size_t>(
      std::count_if(function.begin(), function.end(), [](char c) { return (c & 0xC0) != 0x80; }));
  line.append(code_points < 6 ? 6 - code_points : 0, ' ');
  line += "  ";
  if (node) fmt::format_to(std::back_inserter(line), FMT_COMPILE("node {}  "), *node);
  line += text;
  return line;
}

std::optional<std::string> builtin_object_name(std::uint16_t index, std::uint8_t sub_index) {
  if (auto name = communication_object_name(index, sub_index)) return name;
  if (const auto object = cia402::find_object(index, sub_index)) return std::string(object->name);
  return std::nullopt;
}

Dissector::Dissector(DissectorOptions options) : options_(std::move(options)) {}

void Dissector::reset() {
  nodes_ = {};
}

std::string Dissector::object_text(std::uint16_t index, std::uint8_t sub_index) const {
  std::optional<std::string> name;
  if (options_.object_name) name = options_.object_name(index, sub_index);
  if (!name) name = builtin_object_name(index, sub_index);
  const std::string mux = mux_text(index, sub_index);
  return name ? fmt::format(FMT_COMPILE("{} ({})"), mux, *name) : mux;
}

std::string Dissector::value_text(std::uint16_t index, std::uint8_t sub_index,
                                  std::span<const std::uint8_t> bytes, bool size_known) const {
  const std::uint64_t raw = little_endian(bytes);
  // "0x" and fmt's "{:0{width}X}" with two digits per byte, by hand (runs for most SDO frames).
  std::string text = "0x";
  {
    static constexpr char kDigits[] = "0123456789ABCDEF";
    char digits[16];
    std::size_t count = 0;
    std::uint64_t rest = raw;
    do {
      digits[count++] = kDigits[rest & 0xF];
      rest >>= 4;
    } while (rest != 0);
    if (count < bytes.size() * 2) text.append(bytes.size() * 2 - count, '0');
    while (count > 0)
      text += digits[--count];
  }
  std::string meaning;
  const auto object = cia402::find_object(index, sub_index);
  if (index == 0x6040 && sub_index == 0) {
    meaning = cia402::describe_controlword(static_cast<std::uint16_t>(raw));
  } else if (index == 0x6041 && sub_index == 0) {
    meaning = cia402::describe_statusword(static_cast<std::uint16_t>(raw));
  } else if ((index == 0x6060 || index == 0x6061) && sub_index == 0) {
    meaning = cia402::describe_mode(static_cast<std::int8_t>(static_cast<std::uint8_t>(raw)));
  } else if (index == 0x6502 && sub_index == 0) {
    meaning = cia402::describe_supported_modes(static_cast<std::uint32_t>(raw));
  } else if (index == 0x603F && sub_index == 0) {
    meaning = describe_emcy_code(static_cast<std::uint16_t>(raw));
  } else if (index == 0x1001 && sub_index == 0) {
    meaning = describe_error_register(static_cast<std::uint8_t>(raw));
  } else if (index == 0x1017 || index == 0x100C) {
    meaning = fmt::format(FMT_COMPILE("{} ms"), raw);
  } else if ((index == 0x1010 || index == 0x1011) && sub_index >= 1 && bytes.size() == 4) {
    const bool ascii = std::all_of(bytes.begin(), bytes.end(),
                                   [](std::uint8_t b) { return b >= 0x20 && b < 0x7F; });
    if (ascii)
      meaning = fmt::format(FMT_COMPILE("\"{}{}{}{}\""), char(bytes[0]), char(bytes[1]),
                            char(bytes[2]), char(bytes[3]));
  } else if (index == 0x1016 && sub_index >= 1) {
    if (auto entry = decode_consumer_heartbeat_entry(static_cast<std::uint32_t>(raw))) {
      meaning = entry->is_used()
                    ? fmt::format(FMT_COMPILE("node {}, {} ms"), entry->node, entry->time_ms)
                    : std::string("not used");
    } else {
      meaning = entry.error().reason;
    }
  } else if ((index >= 0x1400 && index <= 0x15FF) || (index >= 0x1800 && index <= 0x19FF)) {
    const auto direction = index < 0x1800 ? PdoDirection::receive : PdoDirection::transmit;
    if (sub_index == pdo_sub::kCobId && size_known && bytes.size() == 4) {
      if (auto cob = decode_pdo_cob_id(static_cast<std::uint32_t>(raw))) {
        meaning =
            fmt::format(FMT_COMPILE("{}, {}, CAN-ID {:03X}h"), cob->valid ? "valid" : "not valid",
                        cob->rtr_allowed ? "RTR allowed" : "no RTR", cob->can_id);
      } else {
        meaning = cob.error().reason;
      }
    } else if (sub_index == pdo_sub::kTransmissionType) {
      const auto type = static_cast<std::uint8_t>(raw);
      meaning = describe_transmission_type(type);
      if (!is_valid_transmission_type(type, direction)) meaning += ", not valid for this PDO";
    } else if (sub_index == pdo_sub::kInhibitTime) {
      meaning = fmt::format(FMT_COMPILE("{} µs"), raw * 100);
    } else if (sub_index == pdo_sub::kEventTimer) {
      meaning = fmt::format(FMT_COMPILE("{} ms"), raw);
    }
  } else if (((index >= 0x1600 && index <= 0x17FF) || (index >= 0x1A00 && index <= 0x1BFF)) &&
             sub_index >= 1 && bytes.size() == 4) {
    if (auto entry = decode_pdo_mapping_entry(static_cast<std::uint32_t>(raw))) {
      meaning = entry->is_dummy()
                    ? fmt::format(FMT_COMPILE("dummy {:04X}h, {} bit"), entry->index, entry->bits)
                    : fmt::format(FMT_COMPILE("{} {} bit"),
                                  object_text(entry->index, entry->sub_index), entry->bits);
    } else {
      meaning = entry.error().reason;
    }
  } else if (object && size_known && bytes.size() == cia402::size_of(object->type)) {
    if (cia402::is_signed(object->type)) {
      const unsigned bits = static_cast<unsigned>(bytes.size() * 8);
      const std::int64_t value = bits >= 64 ? static_cast<std::int64_t>(raw)
                                 : (raw & (std::uint64_t{1} << (bits - 1)))
                                     ? static_cast<std::int64_t>(raw) - (std::int64_t{1} << bits)
                                     : static_cast<std::int64_t>(raw);
      meaning = fmt::format(FMT_COMPILE("{}"), value);
    } else if (raw > 9) {
      meaning = fmt::format(FMT_COMPILE("{}"), raw);
    }
  }
  if (!meaning.empty()) text += " = " + meaning;
  if (!size_known) text += " (size not indicated)";
  return text;
}

Dissection Dissector::dissect_sdo(const can::Frame& frame, CobIdClass cob, bool from_client) {
  Dissection out{cob, std::string(to_string(cob.function)), cob.node, {}, true};
  NodeState& state = nodes_[cob.node];
  if (frame.length() < kSdoFrameLength && !frame.is_remote() && !frame.is_error()) {
    out.valid = false;
    out.text = fmt::format(FMT_COMPILE("{} with DLC {}: invalid (SDO frames carry 8 bytes)"),
                           out.function, frame.dlc);
    return out;
  }
  auto name = [this](const Multiplexer& mux) { return object_text(mux.index, mux.sub_index); };
  auto invalid = [&](const SdoInvalid& m) {
    out.valid = false;
    return fmt::format(FMT_COMPILE("invalid: {}"), describe(m.reason));
  };
  auto abort = [&](const AbortTransfer& m) {
    state.client_block_segments = false;
    state.server_block_segments = false;
    state.server_last_seqno = 0;
    return fmt::format(FMT_COMPILE("abort {} {}"), name(m.mux), describe_sdo_abort(m.code));
  };
  if (from_client) {
    const auto message = decode_client_message(
        frame, state.client_block_segments ? SdoFraming::block_segment : SdoFraming::command);
    out.text = std::visit(
        Overloaded{
            [&](const SdoInvalid& m) { return invalid(m); },
            [&](const InitiateDownloadRequest& m) {
              if (m.expedited) {
                return fmt::format(
                    FMT_COMPILE("initiate download expedited {} = {}"), name(m.mux),
                    value_text(m.mux.index, m.mux.sub_index, m.expedited_data(), m.size_indicated));
              }
              return fmt::format(FMT_COMPILE("initiate download segmented {}{}"), name(m.mux),
                                 m.size_indicated ? fmt::format(FMT_COMPILE(", {} bytes"), m.size)
                                                  : ", size not indicated");
            },
            [&](const InitiateUploadRequest& m) {
              return fmt::format(FMT_COMPILE("initiate upload {}"), name(m.mux));
            },
            [&](const BlockDownloadInitiateRequest& m) {
              return fmt::format(
                  FMT_COMPILE("block download initiate {}{}{}"), name(m.mux),
                  m.crc_supported ? ", CRC" : ", no CRC",
                  m.size_indicated ? fmt::format(FMT_COMPILE(", {} bytes"), m.size) : "");
            },
            [&](const BlockUploadInitiateRequest& m) {
              state.server_last_seqno = 0;
              return fmt::format(FMT_COMPILE("block upload initiate {}{}, blksize {}, pst {}"),
                                 name(m.mux), m.crc_supported ? ", CRC" : ", no CRC", m.block_size,
                                 m.protocol_switch_threshold);
            },
            [&](const BlockUploadStart&) {
              state.server_block_segments = true;
              state.server_last_seqno = 0;
              return std::string("block upload start");
            },
            [&](const BlockUploadAck& m) {
              // A further sub-block, unless the client acknowledged the server's last segment:
              // then the server's next frame is the end request (scs=6 ss=1, CiA 301 §7.2.4.3.15),
              // whose byte 0 (C1h..DDh) would otherwise read as a segment.
              const bool ended =
                  state.server_last_seqno != 0 && m.ackseq >= state.server_last_seqno;
              state.server_block_segments = !ended;
              state.server_last_seqno = 0;
              return fmt::format(FMT_COMPILE("block upload response ackseq {} blksize {}"),
                                 m.ackseq, m.block_size);
            },
            [&](const BlockSegment& m) {
              if (m.last) state.client_block_segments = false;
              return fmt::format(FMT_COMPILE("block download segment {}{} data {}"), m.seqno,
                                 m.last ? " (last)" : "", hex_bytes(m.data));
            },
            [&](const AbortTransfer& m) { return abort(m); },
            [&](const auto& m) { return to_string(SdoClientMessage{m}); },
        },
        message);
    return out;
  }
  const auto message = decode_server_message(
      frame, state.server_block_segments ? SdoFraming::block_segment : SdoFraming::command);
  out.text = std::visit(
      Overloaded{
          [&](const SdoInvalid& m) { return invalid(m); },
          [&](const InitiateUploadResponse& m) {
            if (m.expedited) {
              return fmt::format(
                  FMT_COMPILE("initiate upload response expedited {} = {}"), name(m.mux),
                  value_text(m.mux.index, m.mux.sub_index, m.expedited_data(), m.size_indicated));
            }
            return fmt::format(FMT_COMPILE("initiate upload response segmented {}{}"), name(m.mux),
                               m.size_indicated ? fmt::format(FMT_COMPILE(", {} bytes"), m.size)
                                                : ", size not indicated");
          },
          [&](const InitiateDownloadResponse& m) {
            return fmt::format(FMT_COMPILE("initiate download response {}"), name(m.mux));
          },
          [&](const BlockDownloadInitiateResponse& m) {
            state.client_block_segments = true;
            return fmt::format(FMT_COMPILE("block download initiate response {}{}, blksize {}"),
                               name(m.mux), m.crc_supported ? ", CRC" : ", no CRC", m.block_size);
          },
          [&](const BlockDownloadAck& m) {
            // More sub-blocks follow unless the client already sent its last segment; the
            // client's next frame tells: a segment (byte 0 = seqno) or the end request (C1h..).
            state.client_block_segments = false;
            return fmt::format(FMT_COMPILE("block download response ackseq {} blksize {}"),
                               m.ackseq, m.block_size);
          },
          [&](const BlockUploadInitiateResponse& m) {
            return fmt::format(
                FMT_COMPILE("block upload initiate response {}{}{}"), name(m.mux),
                m.crc_supported ? ", CRC" : ", no CRC",
                m.size_indicated ? fmt::format(FMT_COMPILE(", {} bytes"), m.size) : "");
          },
          [&](const BlockSegment& m) {
            if (m.last) {
              state.server_block_segments = false;
              state.server_last_seqno = m.seqno;
            }
            return fmt::format(FMT_COMPILE("block upload segment {}{} data {}"), m.seqno,
                               m.last ? " (last)" : "", hex_bytes(m.data));
          },
          [&](const AbortTransfer& m) { return abort(m); },
          [&](const auto& m) { return to_string(SdoServerMessage{m}); },
      },
      message);
  return out;
}

Dissection Dissector::dissect_error_control(const can::Frame& frame, CobIdClass cob) {
  Dissection out{cob, std::string(to_string(cob.function)), cob.node, {}, true};
  NodeState& state = nodes_[cob.node];
  const auto message = decode_error_control(frame);
  if (!message) {
    out.valid = false;
    out.text = message.error().reason;
    state.guard_request_pending = false;
    return out;
  }
  out.text = std::visit(
      Overloaded{
          [&](const BootUp&) {
            state.guard_request_pending = false;
            return std::string("boot-up");
          },
          [&](const GuardRequest& m) {
            state.guard_request_pending = true;
            return m.dlc == 0
                       ? std::string("node-guarding request")
                       : fmt::format(FMT_COMPILE("node-guarding request (RTR DLC {})"), m.dlc);
          },
          [&](const NodeStatus& m) {
            const bool response = state.guard_request_pending || m.toggle;
            state.guard_request_pending = false;
            if (response) {
              return fmt::format(FMT_COMPILE("node-guarding response toggle {} {}"),
                                 m.toggle ? 1 : 0, to_string(m.state));
            }
            return fmt::format(FMT_COMPILE("heartbeat {}"), to_string(m.state));
          },
      },
      *message);
  return out;
}

Dissection Dissector::dissect_pdo(const can::Frame& frame, CobIdClass cob) {
  Dissection out{cob, std::string(to_string(cob.function)), cob.node, {}, true};
  if (frame.is_remote()) {
    out.text = fmt::format(FMT_COMPILE("remote request (RTR DLC {})"), frame.dlc);
    return out;
  }
  out.text = hex_bytes(frame.payload());
  const auto mapping = options_.pdo_mappings.find(frame.id);
  if (mapping == options_.pdo_mappings.end() || frame.is_extended()) return out;
  const auto values = unpack_pdo(mapping->second, frame.payload());
  if (!values) {
    out.valid = false;
    out.text += ": " + values.error().reason;
    return out;
  }
  std::string mapped;
  for (const MappedValue& value : *values) {
    if (value.entry.is_dummy()) continue;
    if (!mapped.empty()) mapped += ", ";
    const std::size_t bytes = (value.entry.bits + 7) / 8;
    if (value.entry.bits % 8 == 0 && bytes <= 8) {
      std::array<std::uint8_t, 8> raw{};
      for (std::size_t i = 0; i < bytes; ++i)
        raw[i] = static_cast<std::uint8_t>(value.raw >> (8 * i));
      mapped +=
          fmt::format(FMT_COMPILE("{} = {}"), object_text(value.entry.index, value.entry.sub_index),
                      value_text(value.entry.index, value.entry.sub_index,
                                 std::span<const std::uint8_t>(raw.data(), bytes), true));
    } else {
      mapped += fmt::format(FMT_COMPILE("{} = {} ({} bit)"),
                            object_text(value.entry.index, value.entry.sub_index), value.raw,
                            value.entry.bits);
    }
  }
  out.text += " (" + mapped + ")";
  const std::size_t needed = (mapping->second.total_bits() + 7) / 8;
  if (frame.length() > needed) {
    out.text += fmt::format(FMT_COMPILE(" (+{} bytes beyond the mapping: CiA 301 EMCY 8220h)"),
                            frame.length() - needed);
  }
  return out;
}

Dissection Dissector::dissect(const can::Frame& frame) {
  if (frame.is_error()) {
    return Dissection{{},
                      "CAN",
                      std::nullopt,
                      fmt::format(FMT_COMPILE("error frame, error class {:08X}h"), frame.id),
                      true};
  }
  // Configured SYNC/TIME identifiers first (they may be moved off 080h/100h).
  const bool extended = frame.is_extended();
  if (frame.id == options_.sync_cob_id &&
      extended == (options_.sync_cob_id > can::kMaxStandardId)) {
    Dissection out{{CobFunction::sync, 0}, "SYNC", std::nullopt, {}, true};
    const auto sync = decode_sync(frame, options_.sync_cob_id);
    if (!sync) {
      out.valid = false;
      out.text = sync.error().reason;
    } else {
      out.text =
          sync->counter ? fmt::format(FMT_COMPILE("counter {}"), *sync->counter) : "no counter";
    }
    return out;
  }
  if (frame.id == options_.time_cob_id &&
      extended == (options_.time_cob_id > can::kMaxStandardId)) {
    Dissection out{{CobFunction::time, 0}, "TIME", std::nullopt, {}, true};
    const auto time = decode_time(frame, options_.time_cob_id);
    if (!time) {
      out.valid = false;
      out.text = time.error().reason;
    } else {
      const auto instant = time->to_sys_time();
      out.text = fmt::format("{:%Y-%m-%d %H:%M:%S}.{:03} (day {}, {} ms)",
                             std::chrono::floor<std::chrono::seconds>(instant), time->ms % 1000,
                             time->days, time->ms);
    }
    return out;
  }
  if (extended) {
    return Dissection{
        {},
        "29-bit",
        std::nullopt,
        fmt::format(FMT_COMPILE("{}: not in the CANopen pre-defined connection set"),
                    frame.is_remote() ? "remote request" : hex_bytes(frame.payload())),
        true};
  }

  const CobIdClass cob = classify_cob_id(frame);
  Dissection out;
  switch (cob.function) {
    case CobFunction::nmt: {
      out = Dissection{cob, "NMT", std::nullopt, {}, true};
      const auto nmt = decode_nmt_node_control(frame);
      if (!nmt) {
        out.valid = false;
        out.text = nmt.error().reason;
      } else {
        out.text = nmt->is_broadcast()
                       ? fmt::format(FMT_COMPILE("{} all nodes"), to_string(nmt->command))
                       : fmt::format(FMT_COMPILE("{} node {}"), to_string(nmt->command), nmt->node);
      }
      return out;
    }
    case CobFunction::sync:
    case CobFunction::time:
      // Default SYNC/TIME ids moved elsewhere by the options: plain bytes.
      return Dissection{cob, std::string(to_string(cob.function)), std::nullopt,
                        fmt::format(FMT_COMPILE("{} (not the configured {} CAN-ID)"),
                                    hex_bytes(frame.payload()), to_string(cob.function)),
                        true};
    case CobFunction::emcy: {
      out = Dissection{cob, "EMCY", cob.node, {}, true};
      const auto emcy = decode_emcy(frame);
      if (!emcy) {
        out.valid = false;
        out.text = emcy.error().reason;
      } else {
        out.text = emcy_text(*emcy);
      }
      break;
    }
    case CobFunction::sdo_rx:
      out = dissect_sdo(frame, cob, true);
      break;
    case CobFunction::sdo_tx:
      out = dissect_sdo(frame, cob, false);
      break;
    case CobFunction::nmt_error_control:
      out = dissect_error_control(frame, cob);
      break;
    case CobFunction::tpdo1:
    case CobFunction::tpdo2:
    case CobFunction::tpdo3:
    case CobFunction::tpdo4:
    case CobFunction::rpdo1:
    case CobFunction::rpdo2:
    case CobFunction::rpdo3:
    case CobFunction::rpdo4:
      out = dissect_pdo(frame, cob);
      break;
    case CobFunction::lss_slave_to_master:
    case CobFunction::lss_master_to_slave: {
      out = Dissection{cob, std::string(to_string(cob.function)), std::nullopt, {}, true};
      if (frame.is_remote() || frame.dlc != 8) {
        out.valid = false;
        out.text = fmt::format(
            FMT_COMPILE("LSS with {}: invalid (LSS frames carry 8 bytes)"),
            frame.is_remote() ? "a remote request" : fmt::format(FMT_COMPILE("DLC {}"), frame.dlc));
      } else {
        const std::string_view name = lss_command_name(frame.data[0]);
        out.text =
            fmt::format(FMT_COMPILE("cs {:02X}h{}{} data {}"), frame.data[0],
                        name.empty() ? "" : " ", name, hex_bytes(frame.payload().subspan(1)));
      }
      return out;
    }
    case CobFunction::unassigned: {
      out = Dissection{cob, "-", std::nullopt, {}, true};
      // A PDO moved to a free CAN-ID can still be shown with its mapping.
      if (options_.pdo_mappings.count(frame.id) != 0) {
        const Dissection pdo = dissect_pdo(frame, cob);
        out.function = "PDO";
        out.text = pdo.text;
        out.valid = pdo.valid;
        return out;
      }
      const auto restricted = find_restricted_cob_id(frame.id);
      out.text = fmt::format(
          FMT_COMPILE("{}{}"),
          frame.is_remote() ? fmt::format(FMT_COMPILE("remote request (RTR DLC {})"), frame.dlc)
                            : hex_bytes(frame.payload()),
          restricted ? fmt::format(FMT_COMPILE(" (CAN-ID {:03X}h unassigned, restricted: {})"),
                                   frame.id, restricted->used_by)
                     : fmt::format(FMT_COMPILE(" (CAN-ID {:03X}h unassigned)"), frame.id));
      return out;
    }
  }
  if (options_.nodes.any() && cob.node != 0 && !options_.nodes.test(cob.node)) {
    out.text += fmt::format(FMT_COMPILE(" (node {} not configured)"), cob.node);
  }
  return out;
}

std::string Dissector::line(const can::Frame& frame) {
  const Dissection d = dissect(frame);
  // The identifier as candump prints it: an error frame carries CAN_ERR_FLAG, so it cannot be
  // mistaken for a 29-bit data frame with the same number.
  const std::string id = frame.is_error()
                             ? fmt::format(FMT_COMPILE("{:08X}"), can::kErrorFlag | frame.id)
                         : frame.is_extended() ? fmt::format(FMT_COMPILE("{:08X}"), frame.id)
                                               : fmt::format(FMT_COMPILE("{:03X}"), frame.id);
  return id + " " + d.summary();
}

Dissection dissect_frame(const can::Frame& frame, const DissectorOptions& options) {
  Dissector dissector(options);
  return dissector.dissect(frame);
}

}  // namespace drivecheck::cia301

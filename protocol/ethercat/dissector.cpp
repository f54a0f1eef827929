// The EtherCAT dissector (dissector.hpp): datagrams, registers, mailboxes, CoE.
#include "protocol/ethercat/dissector.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <type_traits>
#include <variant>

#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/ethercat/al_state_machine.hpp"
#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/datagram.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {
namespace {

constexpr std::uint16_t kSmBlockEnd = reg::kSyncManager + 16 * 8;
constexpr std::uint16_t kFmmuBlockEnd = reg::kFmmu + 16 * 16;
// The bytes of one SyncManager's 8 (ESC Section II §8, as esc.hpp documents them); a 2-byte
// field's second byte is named "+1".
constexpr std::array<std::string_view, 8> kSmFields = {
    "start", "start +1", "length", "length +1", "control", "status", "activate", "PDI control"};

std::uint16_t le16_at(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint16_t>(bytes[at] | (bytes[at + 1] << 8));
}

std::string hex_bytes(std::span<const std::uint8_t> data, std::size_t max = 32) {
  std::string text;
  const std::size_t shown = std::min(data.size(), max);
  for (std::size_t i = 0; i < shown; ++i) {
    if (i != 0) text += ' ';
    fmt::format_to(std::back_inserter(text), "{:02X}", data[i]);
  }
  if (shown < data.size()) text += " ...";
  return text;
}

std::string sdo_text(const CoeSdoRequest& request) {
  if (const auto* abort = std::get_if<CoeAbort>(&request)) {
    return fmt::format("SDO abort by the client {:04X}h:{:02X} {}", abort->mux.index,
                       abort->mux.sub_index, cia301::describe_sdo_abort(abort->code));
  }
  std::string text = to_string(request);
  if (const auto* d = std::get_if<CoeDownloadInitiate>(&request); d && !d->data.empty())
    text += " data " + hex_bytes(d->data, 16);
  return text;
}

std::string sdo_text(const CoeSdoResponse& response) {
  if (const auto* abort = std::get_if<CoeAbort>(&response)) {
    return fmt::format("SDO abort by the server {:04X}h:{:02X} {}", abort->mux.index,
                       abort->mux.sub_index, cia301::describe_sdo_abort(abort->code));
  }
  std::string text = to_string(response);
  if (const auto* u = std::get_if<CoeUploadInitiateResponse>(&response); u && !u->data.empty())
    text += " data " + hex_bytes(u->data, 16);
  return text;
}

std::string coe_text(std::span<const std::uint8_t> data) {
  const auto service = peek_coe_service(data);
  if (!service)
    return fmt::format("malformed: CoE: {} octet(s), the CoE header needs 2", data.size());
  switch (*service) {
    case static_cast<std::uint8_t>(CoeService::sdo_request): {
      const auto r = decode_sdo_request(data);
      return r ? sdo_text(*r) : "malformed: SDO request: " + std::string(r.error().reason);
    }
    case static_cast<std::uint8_t>(CoeService::sdo_response): {
      const auto r = decode_sdo_response(data);
      return r ? sdo_text(*r) : "malformed: SDO response: " + std::string(r.error().reason);
    }
    case static_cast<std::uint8_t>(CoeService::emergency): {
      const auto e = decode_emergency(data);
      if (!e) return "malformed: CoE emergency: " + std::string(e.error().reason);
      return fmt::format("emergency {}, register {:02X}h, manufacturer {}",
                         cia301::describe_emcy_code(e->emcy.error_code), e->emcy.error_register,
                         hex_bytes(e->emcy.manufacturer));
    }
    case static_cast<std::uint8_t>(CoeService::sdo_information): {
      if (data.size() < kCoeHeaderSize + 4)
        return fmt::format("malformed: SDO information: {} octet(s), at least 6 needed",
                           data.size());
      return fmt::format("SDO information opcode {}, {} fragment(s) left",
                         data[kCoeHeaderSize] & 0x7F, le16_at(data, kCoeHeaderSize + 2));
    }
    default: {
      const auto name = coe_service_name(*service);
      return fmt::format("CoE {} ({} octets)",
                         name ? std::string(*name) : fmt::format("service {} (reserved)", *service),
                         data.size());
    }
  }
}

struct SmHit {
  unsigned n = 0;
  std::uint16_t offset = 0;  // of the access within the SM buffer
  bool ecat_writes = false;  // the write mailbox (master to slave)
};

std::optional<SmHit> find_mailbox_sm(const std::array<std::uint8_t, 128>& sms, std::uint16_t ado) {
  for (unsigned n = 0; n < 16; ++n) {
    const auto block = std::span<const std::uint8_t>(sms).subspan(8 * n, 8);
    const std::uint16_t start = le16_at(block, 0);
    const std::uint16_t length = le16_at(block, 2);
    const std::uint8_t control = block[4];
    if ((block[6] & sm::kActivateEnable) == 0 || (control & sm::kModeMask) != sm::kModeMailbox ||
        length == 0 || start < reg::kProcessRam)
      continue;
    if (ado < start || ado >= start + length) continue;
    return SmHit{n, static_cast<std::uint16_t>(ado - start),
                 (control & sm::kDirectionMask) == sm::kDirectionEcatWrites};
  }
  return std::nullopt;
}

// The value of a register access of at most 8 bytes, as the register means it.
std::string register_value(std::uint16_t ado, std::span<const std::uint8_t> data) {
  const std::size_t n = data.size();
  const auto covers = [&](std::uint16_t address, std::size_t size) {
    return ado <= address && ado + n >= address + size;
  };
  std::vector<std::string> parts;
  if (covers(reg::kAlControl, 1)) {
    const std::uint8_t b = data[reg::kAlControl - ado];
    parts.push_back(fmt::format("request {}{}", al_state_name(b & 0x0F),
                                (b & 0x10) != 0 ? " + acknowledge" : ""));
  }
  if (covers(reg::kAlStatus, 1)) {
    const std::uint8_t b = data[reg::kAlStatus - ado];
    parts.push_back(
        fmt::format("{}{}", al_state_name(b & 0x0F), (b & 0x10) != 0 ? " + error" : ""));
  }
  if (covers(reg::kAlStatusCode, 2)) {
    parts.push_back("code " + describe_al_status_code(le16_at(data, reg::kAlStatusCode - ado)));
  }
  if (!parts.empty()) return fmt::format("{}", fmt::join(parts, ", "));
  return "data=" + hex_bytes(data);
}

}  // namespace

std::string describe_registers(std::uint16_t ado, std::size_t length) {
  const std::size_t n = std::max<std::size_t>(length, 1);
  if (ado >= reg::kProcessRam) return "process RAM";
  if (ado >= reg::kSyncManager && ado < kSmBlockEnd) {
    const unsigned first = (ado - reg::kSyncManager) / 8;
    const unsigned offset = (ado - reg::kSyncManager) % 8;
    const std::size_t end = std::min<std::size_t>(ado + n, kSmBlockEnd);
    const unsigned last = static_cast<unsigned>((end - 1 - reg::kSyncManager) / 8);
    if (offset == 0 && n >= 8)
      return first == last ? fmt::format("SM{}", first) : fmt::format("SM{}..SM{}", first, last);
    std::string text = fmt::format("SM{} {}", first, kSmFields[offset]);
    if (last != first || offset + n > 8) text += fmt::format(" ..SM{}", last);
    return text;
  }
  if (ado >= reg::kFmmu && ado < kFmmuBlockEnd) {
    const unsigned first = (ado - reg::kFmmu) / 16;
    const unsigned offset = (ado - reg::kFmmu) % 16;
    const std::size_t end = std::min<std::size_t>(ado + n, kFmmuBlockEnd);
    const unsigned last = static_cast<unsigned>((end - 1 - reg::kFmmu) / 16);
    std::string text = fmt::format("FMMU{}", first);
    if (offset != 0) text += fmt::format(" +{}", offset);
    if (last != first) text += fmt::format("..FMMU{}", last);
    return text;
  }
  std::vector<std::string> names;
  std::size_t more = 0;
  for (const EscRegisterInfo& row : esc_register_table()) {
    if (row.address >= ado + n || row.address + row.size <= ado) continue;
    if (names.size() == 3) {
      ++more;
      continue;
    }
    std::string name(row.text);
    if (row.address < ado) name += fmt::format(" +{}", ado - row.address);
    names.push_back(std::move(name));
  }
  if (names.empty()) return fmt::format("reserved {:04X}h", ado);
  std::string text = fmt::format("{}", fmt::join(names, ", "));
  if (more != 0) text += fmt::format(" and {} more", more);
  return text;
}

std::string describe_mailbox(std::span<const std::uint8_t> buffer) {
  if (buffer.size() < kMailboxHeaderSize)
    return fmt::format("malformed: mailbox of {} octet(s), the header needs 6", buffer.size());
  const MailboxHeader h = decode_mailbox_header(buffer.first<kMailboxHeaderSize>());
  const std::size_t room = buffer.size() - kMailboxHeaderSize;
  std::string head =
      fmt::format("{} len {} addr {:04X}h", describe_mailbox_type(h.type), h.length, h.address);
  if (h.channel != 0) head += fmt::format(" channel {}", h.channel);
  if (h.priority != 0) head += fmt::format(" priority {}", h.priority);
  head += fmt::format(" cnt {}", h.counter);
  if (h.length > room)
    return fmt::format(
        "{}: malformed: mailbox Length {} runs past the {} octet(s) after the header", head,
        h.length, room);
  const auto data = buffer.subspan(kMailboxHeaderSize, h.length);
  if (h.type == static_cast<std::uint8_t>(MailboxType::err)) {
    const auto code = parse_mailbox_error_data(data);
    if (!code) return head + ": malformed: mailbox error reply";
    return fmt::format("{}: {}", head, describe_mailbox_error(*code));
  }
  if (h.type == static_cast<std::uint8_t>(MailboxType::coe))
    return fmt::format("{}: {}", head, coe_text(data));
  return fmt::format("{}: {} octet(s)", head, data.size());
}

// The mailbox with its counter (header octet 5, bits 4-6) cleared: the same message whatever
// counter it went with.
std::vector<std::uint8_t> without_counter(std::span<const std::uint8_t> buffer) {
  std::vector<std::uint8_t> out(buffer.begin(), buffer.end());
  if (out.size() > 5) out[5] = static_cast<std::uint8_t>(out[5] & 0x8F);
  return out;
}

void FrameDissector::reset() {
  sync_managers_.clear();
  outgoing_.reset();
}

DissectedFrame FrameDissector::dissect(std::span<const std::uint8_t> bytes, FramePass pass) {
  DissectedFrame out;
  out.pass = pass;
  const auto frame = decode_frame(bytes);
  if (!frame) {
    out.malformed = true;
    out.lines.push_back("malformed: " + frame.error().message());
    return out;
  }
  std::vector<std::pair<std::uint8_t, std::uint8_t>> signature;
  for (const Datagram& d : frame->datagrams)
    signature.emplace_back(static_cast<std::uint8_t>(d.command), d.index);
  if (pass == FramePass::unknown)
    pass = outgoing_ && *outgoing_ == signature ? FramePass::returned : FramePass::outgoing;
  if (pass == FramePass::returned) {
    outgoing_.reset();
  } else {
    outgoing_ = std::move(signature);
  }
  out.pass = pass;
  const bool returned = pass == FramePass::returned;
  bool mailbox_content = false;
  std::vector<std::string> shapes;
  for (const Datagram& d : frame->datagrams) {
    const auto info = find_command(static_cast<std::uint8_t>(d.command));
    if (!info) {  // decode_frame refuses unknown codes; kept total all the same
      out.lines.push_back(
          fmt::format("malformed: command {:02X}h", static_cast<unsigned>(d.command)));
      out.patterns.emplace_back();  // never part of a pattern
      continue;
    }
    const bool reads = info->access == Access::read || info->access == Access::read_write ||
                       info->access == Access::read_multiple_write;
    const bool writes = info->access != Access::none && info->access != Access::read;
    // The data says something: what was written, or what was read once it came back.
    const bool data_meaningful = writes || (reads && returned && d.working_counter > 0);
    std::string line(info->mnemonic);
    std::string value;
    // `line` but for the mailbox counter and the SII EEPROM interface's values (see patterns).
    std::string pattern_tail;
    std::size_t pattern_from = std::string::npos;
    if (info->addressing == Addressing::logical) {
      line += fmt::format(" logical {:08X}h len {} wkc {}", d.address, d.data.size(),
                          d.working_counter);
      if (data_meaningful && !d.data.empty()) value = " data=" + hex_bytes(d.data);
    } else if (info->addressing == Addressing::none) {
      line += fmt::format(" len {} wkc {}", d.data.size(), d.working_counter);
    } else {
      const std::uint16_t ado = d.ado();
      const bool station = info->addressing == Addressing::station;
      if (station) {
        line += fmt::format(" station {:04X}h", d.adp());
      } else if (info->addressing == Addressing::position) {
        line += fmt::format(" adp {:04X}h", d.adp());
      }
      // The SyncManager registers the master writes, to find the mailboxes later.
      if (station && writes && (!returned || d.working_counter > 0) && ado < kSmBlockEnd &&
          ado + d.data.size() > reg::kSyncManager) {
        auto& sms = sync_managers_[Key{true, d.adp()}];
        for (std::size_t i = 0; i < d.data.size(); ++i) {
          const std::size_t at = ado + i;
          if (at >= reg::kSyncManager && at < kSmBlockEnd) sms[at - reg::kSyncManager] = d.data[i];
        }
      }
      std::optional<SmHit> mailbox;
      if (station && ado >= reg::kProcessRam) {
        if (const auto it = sync_managers_.find(Key{true, d.adp()}); it != sync_managers_.end())
          mailbox = find_mailbox_sm(it->second, ado);
      }
      if (mailbox) {
        line += fmt::format(" {:04X}h SM{} {} mailbox", ado, mailbox->n,
                            mailbox->ecat_writes ? "write" : "read");
        if (mailbox->offset != 0) line += fmt::format(" +{}", mailbox->offset);
      } else {
        line += fmt::format(" {:04X}h {}", ado, describe_registers(ado, d.data.size()));
      }
      line += fmt::format(" len {} wkc {}", d.data.size(), d.working_counter);
      pattern_from = line.size();
      if (mailbox && mailbox->offset == 0) {
        if (mailbox->ecat_writes && writes) {
          line += ": " + describe_mailbox(d.data);
          pattern_tail += ": " + describe_mailbox(without_counter(d.data));
          if (returned && d.working_counter == 0) {
            line += " (not taken: wkc 0, the mailbox is full)";
            pattern_tail += " (not taken: wkc 0, the mailbox is full)";
          }
          mailbox_content = true;
        } else if (!mailbox->ecat_writes && reads && returned) {
          if (d.working_counter == 0) {
            line += ": empty";
            pattern_tail += ": empty";
          } else {
            line += ": " + describe_mailbox(d.data);
            pattern_tail += ": " + describe_mailbox(without_counter(d.data));
            mailbox_content = true;
          }
        }
      } else if (!mailbox && data_meaningful && !d.data.empty() && d.data.size() <= 8) {
        line += ": " + register_value(ado, d.data);
        // The SII EEPROM interface (0500h-050Fh): the address and data of each word read.
        constexpr std::size_t kSiiFirst = reg::kSiiConfiguration;
        constexpr std::size_t kSiiEnd = kSiiFirst + 0x10;
        if (ado + d.data.size() <= kSiiFirst || ado >= kSiiEnd)
          pattern_tail += ": " + register_value(ado, d.data);
      } else if (!mailbox && data_meaningful && ado >= reg::kProcessRam && !d.data.empty()) {
        value = " data=" + hex_bytes(d.data);
      }
    }
    std::string pattern =
        pattern_from == std::string::npos ? line : line.substr(0, pattern_from) + pattern_tail;
    if (d.circulating) {
      line += " (circulating)";
      pattern += " (circulating)";
    }
    shapes.push_back(line);
    out.patterns.push_back(std::move(pattern));
    out.lines.push_back(line + value);
  }
  if (!mailbox_content) out.shapes = std::move(shapes);
  return out;
}

}  // namespace drivecheck::ethercat

#include "protocol/ethercat/coe.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>

#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {
namespace {

struct ServiceRow {
  CoeService service;
  std::string_view text;
};
constexpr ServiceRow kServices[] = {
#define DRIVECHECK_COE_SERVICE(name, value, text) {CoeService::name, text},
#include "protocol/ethercat/coe_services.inc"
#undef DRIVECHECK_COE_SERVICE
};

constexpr std::size_t kSegmentData = 7;

std::uint32_t get32(std::span<const std::uint8_t> b) {
  return static_cast<std::uint32_t>(b[0]) | (static_cast<std::uint32_t>(b[1]) << 8) |
         (static_cast<std::uint32_t>(b[2]) << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
}
void put32(std::uint32_t v, std::vector<std::uint8_t>& out) {
  for (int i = 0; i < 4; ++i)
    out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
Multiplexer get_mux(std::span<const std::uint8_t> sdo) {
  return {static_cast<std::uint16_t>(sdo[1] | (sdo[2] << 8)), sdo[3]};
}

std::vector<std::uint8_t> start(CoeService service) {
  std::vector<std::uint8_t> out(kCoeHeaderSize);
  CoeHeader h;
  h.service = static_cast<std::uint8_t>(service);
  encode_coe_header(h, std::span<std::uint8_t, 2>(out.data(), 2));
  return out;
}
void put_mux(const Multiplexer& mux, std::vector<std::uint8_t>& out) {
  out.push_back(static_cast<std::uint8_t>(mux.index & 0xFF));
  out.push_back(static_cast<std::uint8_t>(mux.index >> 8));
  out.push_back(mux.sub_index);
}

// The initiate form shared by the download request and the upload response.
void put_initiate(std::uint8_t specifier, const Multiplexer& mux, bool complete_access,
                  bool expedited, bool size_indicated, std::uint32_t complete_size,
                  const std::vector<std::uint8_t>& data, std::vector<std::uint8_t>& out) {
  std::uint8_t cmd = static_cast<std::uint8_t>(specifier << 5);
  if (complete_access) cmd |= 0x10;
  if (expedited) {
    cmd |= 0x02;
    if (size_indicated) {
      cmd |= 0x01;
      const auto n = static_cast<std::uint8_t>((4 - std::min<std::size_t>(data.size(), 4)) & 3);
      cmd |= static_cast<std::uint8_t>(n << 2);
    }
    out.push_back(cmd);
    put_mux(mux, out);
    for (std::size_t i = 0; i < 4; ++i)
      out.push_back(i < data.size() ? data[i] : 0);
    return;
  }
  if (size_indicated) cmd |= 0x01;
  out.push_back(cmd);
  put_mux(mux, out);
  put32(complete_size, out);
  out.insert(out.end(), data.begin(), data.end());
}

void put_segment(std::uint8_t specifier, bool toggle, bool last,
                 const std::vector<std::uint8_t>& data, std::vector<std::uint8_t>& out) {
  std::uint8_t cmd = static_cast<std::uint8_t>(specifier << 5);
  if (toggle) cmd |= 0x10;
  if (last) cmd |= 0x01;
  if (data.size() < kSegmentData)
    cmd |= static_cast<std::uint8_t>((kSegmentData - data.size()) << 1);
  out.push_back(cmd);
  out.insert(out.end(), data.begin(), data.end());
  while (out.size() < kCoeSdoMessageSize)
    out.push_back(0);
}

void put_reserved(std::uint8_t cmd, std::size_t count, std::vector<std::uint8_t>& out) {
  out.push_back(cmd);
  out.insert(out.end(), count, 0);
}

struct Initiate {
  Multiplexer mux;
  bool complete_access;
  bool expedited;
  bool size_indicated;
  std::uint32_t complete_size;
  std::vector<std::uint8_t> data;
};
Initiate read_initiate(std::span<const std::uint8_t> sdo) {
  const std::uint8_t cmd = sdo[0];
  Initiate i{get_mux(sdo), (cmd & 0x10) != 0, (cmd & 0x02) != 0, (cmd & 0x01) != 0, 0, {}};
  if (i.expedited) {
    const std::size_t size = i.size_indicated ? 4 - ((cmd >> 2) & 3) : 4;
    i.complete_size = i.size_indicated ? static_cast<std::uint32_t>(size) : 0;
    i.data.assign(sdo.begin() + 4, sdo.begin() + 4 + static_cast<std::ptrdiff_t>(size));
  } else {
    i.complete_size = get32(sdo.subspan(4, 4));
    i.data.assign(sdo.begin() + kCoeSdoSize, sdo.end());
  }
  return i;
}

struct Segment {
  bool toggle;
  bool last;
  std::vector<std::uint8_t> data;
};
Expected<Segment, CoeDecodeError> read_segment(std::span<const std::uint8_t> sdo) {
  const std::uint8_t cmd = sdo[0];
  const std::size_t n = (cmd >> 1) & 7;
  const auto rest = sdo.subspan(1);
  Segment s{(cmd & 0x10) != 0, (cmd & 0x01) != 0, {}};
  if (rest.size() == kSegmentData) {
    s.data.assign(rest.begin(), rest.begin() + static_cast<std::ptrdiff_t>(kSegmentData - n));
  } else {
    if (n != 0) {
      return Unexpected(CoeDecodeError{"a segment longer than 7 octets with n != 0",
                                       cia301::SdoAbort::length_mismatch});
    }
    s.data.assign(rest.begin(), rest.end());
  }
  return s;
}

Expected<std::span<const std::uint8_t>, CoeDecodeError> sdo_part(
    std::span<const std::uint8_t> data) {
  if (data.size() < kCoeSdoMessageSize) {
    return Unexpected(CoeDecodeError{"shorter than a CoE SDO message (10 octets)", std::nullopt});
  }
  return data.subspan(kCoeHeaderSize);
}

}  // namespace

std::optional<std::string_view> coe_service_name(std::uint8_t value) {
  for (const auto& row : kServices) {
    if (static_cast<std::uint8_t>(row.service) == value) return row.text;
  }
  return std::nullopt;
}

void encode_coe_header(const CoeHeader& header, std::span<std::uint8_t, 2> out) {
  const auto word = static_cast<std::uint16_t>(
      (header.number & 0x1FF) | ((header.reserved & 0x7) << 9) | ((header.service & 0xF) << 12));
  out[0] = static_cast<std::uint8_t>(word & 0xFF);
  out[1] = static_cast<std::uint8_t>(word >> 8);
}

CoeHeader decode_coe_header(std::span<const std::uint8_t, 2> bytes) {
  const auto word = static_cast<std::uint16_t>(bytes[0] | (bytes[1] << 8));
  return {static_cast<std::uint16_t>(word & 0x1FF), static_cast<std::uint8_t>((word >> 9) & 0x7),
          static_cast<std::uint8_t>(word >> 12)};
}

std::optional<std::uint8_t> peek_coe_service(std::span<const std::uint8_t> data) {
  if (data.size() < kCoeHeaderSize) return std::nullopt;
  return decode_coe_header(data.first<kCoeHeaderSize>()).service;
}

Expected<CoeSdoRequest, CoeDecodeError> decode_sdo_request(std::span<const std::uint8_t> data) {
  auto sdo = sdo_part(data);
  if (!sdo) return Unexpected(sdo.error());
  const auto service = decode_coe_header(data.first<kCoeHeaderSize>()).service;
  const auto b = *sdo;
  if (service != static_cast<std::uint8_t>(CoeService::sdo_request)) {
    return Unexpected(CoeDecodeError{"not an SDO request (CoE service)", std::nullopt});
  }
  switch (b[0] >> 5) {
    case 0: {
      auto s = read_segment(b);
      if (!s) return Unexpected(s.error());
      return CoeSdoRequest{CoeDownloadSegment{s->toggle, s->last, std::move(s->data)}};
    }
    case 1: {
      auto i = read_initiate(b);
      return CoeSdoRequest{CoeDownloadInitiate{i.mux, i.complete_access, i.expedited,
                                               i.size_indicated, i.complete_size,
                                               std::move(i.data)}};
    }
    case 2:
      return CoeSdoRequest{CoeUploadInitiate{get_mux(b), (b[0] & 0x10) != 0}};
    case 3:
      return CoeSdoRequest{CoeUploadSegmentRequest{(b[0] & 0x10) != 0}};
    case 4:
      return CoeSdoRequest{CoeAbort{get_mux(b), get32(b.subspan(4, 4))}};
    default:
      return Unexpected(CoeDecodeError{"command specifier 5..7 (block transfer is not in CoE)",
                                       cia301::SdoAbort::invalid_command_specifier});
  }
}

Expected<CoeSdoResponse, CoeDecodeError> decode_sdo_response(std::span<const std::uint8_t> data) {
  auto sdo = sdo_part(data);
  if (!sdo) return Unexpected(sdo.error());
  const auto service = decode_coe_header(data.first<kCoeHeaderSize>()).service;
  const auto b = *sdo;
  // An abort may come with either SDO service; everything else is a response.
  if ((b[0] >> 5) == 4 && (service == static_cast<std::uint8_t>(CoeService::sdo_response) ||
                           service == static_cast<std::uint8_t>(CoeService::sdo_request))) {
    return CoeSdoResponse{CoeAbort{get_mux(b), get32(b.subspan(4, 4))}};
  }
  if (service != static_cast<std::uint8_t>(CoeService::sdo_response)) {
    return Unexpected(CoeDecodeError{"not an SDO response (CoE service)", std::nullopt});
  }
  switch (b[0] >> 5) {
    case 0: {
      auto s = read_segment(b);
      if (!s) return Unexpected(s.error());
      return CoeSdoResponse{CoeUploadSegment{s->toggle, s->last, std::move(s->data)}};
    }
    case 1:
      return CoeSdoResponse{CoeDownloadSegmentResponse{(b[0] & 0x10) != 0}};
    case 2: {
      auto i = read_initiate(b);
      return CoeSdoResponse{CoeUploadInitiateResponse{i.mux, i.complete_access, i.expedited,
                                                      i.size_indicated, i.complete_size,
                                                      std::move(i.data)}};
    }
    case 3:
      return CoeSdoResponse{CoeDownloadInitiateResponse{get_mux(b)}};
    default:
      return Unexpected(CoeDecodeError{"server command specifier 5..7 (not in CoE)",
                                       cia301::SdoAbort::invalid_command_specifier});
  }
}

std::vector<std::uint8_t> encode(const CoeSdoRequest& message) {
  auto out = start(CoeService::sdo_request);
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, CoeDownloadInitiate>) {
          put_initiate(1, m.mux, m.complete_access, m.expedited, m.size_indicated, m.complete_size,
                       m.data, out);
        } else if constexpr (std::is_same_v<T, CoeDownloadSegment>) {
          put_segment(0, m.toggle, m.last, m.data, out);
        } else if constexpr (std::is_same_v<T, CoeUploadInitiate>) {
          out.push_back(static_cast<std::uint8_t>(0x40 | (m.complete_access ? 0x10 : 0)));
          put_mux(m.mux, out);
          out.insert(out.end(), 4, 0);
        } else if constexpr (std::is_same_v<T, CoeUploadSegmentRequest>) {
          put_reserved(static_cast<std::uint8_t>(0x60 | (m.toggle ? 0x10 : 0)), 7, out);
        } else {
          out.push_back(0x80);
          put_mux(m.mux, out);
          put32(m.code, out);
        }
      },
      message);
  return out;
}

std::vector<std::uint8_t> encode(const CoeSdoResponse& message) {
  auto out = start(CoeService::sdo_response);
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, CoeUploadInitiateResponse>) {
          put_initiate(2, m.mux, m.complete_access, m.expedited, m.size_indicated, m.complete_size,
                       m.data, out);
        } else if constexpr (std::is_same_v<T, CoeUploadSegment>) {
          put_segment(0, m.toggle, m.last, m.data, out);
        } else if constexpr (std::is_same_v<T, CoeDownloadInitiateResponse>) {
          out.push_back(0x60);
          put_mux(m.mux, out);
          out.insert(out.end(), 4, 0);
        } else if constexpr (std::is_same_v<T, CoeDownloadSegmentResponse>) {
          put_reserved(static_cast<std::uint8_t>(0x20 | (m.toggle ? 0x10 : 0)), 7, out);
        } else {
          out.push_back(0x80);
          put_mux(m.mux, out);
          put32(m.code, out);
        }
      },
      message);
  return out;
}

namespace {
std::string mux_text(const Multiplexer& mux, bool complete_access) {
  return fmt::format("{:04X}h:{:02X}{}", mux.index, mux.sub_index,
                     complete_access ? " (complete access)" : "");
}
}  // namespace

std::string to_string(const CoeSdoRequest& message) {
  return std::visit(
      [](const auto& m) -> std::string {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, CoeDownloadInitiate>) {
          return fmt::format(
              "SDO download initiate {} {} {} octets", mux_text(m.mux, m.complete_access),
              m.expedited ? "expedited" : "normal", m.expedited ? m.data.size() : m.complete_size);
        } else if constexpr (std::is_same_v<T, CoeDownloadSegment>) {
          return fmt::format("SDO download segment t={} {} octets{}", m.toggle ? 1 : 0,
                             m.data.size(), m.last ? " last" : "");
        } else if constexpr (std::is_same_v<T, CoeUploadInitiate>) {
          return fmt::format("SDO upload initiate {}", mux_text(m.mux, m.complete_access));
        } else if constexpr (std::is_same_v<T, CoeUploadSegmentRequest>) {
          return fmt::format("SDO upload segment request t={}", m.toggle ? 1 : 0);
        } else {
          return fmt::format("SDO abort {} {:08X}h", mux_text(m.mux, false), m.code);
        }
      },
      message);
}

std::string to_string(const CoeSdoResponse& message) {
  return std::visit(
      [](const auto& m) -> std::string {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, CoeUploadInitiateResponse>) {
          return fmt::format(
              "SDO upload response {} {} {} octets", mux_text(m.mux, m.complete_access),
              m.expedited ? "expedited" : "normal", m.expedited ? m.data.size() : m.complete_size);
        } else if constexpr (std::is_same_v<T, CoeUploadSegment>) {
          return fmt::format("SDO upload segment t={} {} octets{}", m.toggle ? 1 : 0, m.data.size(),
                             m.last ? " last" : "");
        } else if constexpr (std::is_same_v<T, CoeDownloadInitiateResponse>) {
          return fmt::format("SDO download response {}", mux_text(m.mux, false));
        } else if constexpr (std::is_same_v<T, CoeDownloadSegmentResponse>) {
          return fmt::format("SDO download segment response t={}", m.toggle ? 1 : 0);
        } else {
          return fmt::format("SDO abort {} {:08X}h", mux_text(m.mux, false), m.code);
        }
      },
      message);
}

std::vector<std::uint8_t> encode(const CoeEmergency& message) {
  auto out = start(CoeService::emergency);
  out.push_back(static_cast<std::uint8_t>(message.emcy.error_code & 0xFF));
  out.push_back(static_cast<std::uint8_t>(message.emcy.error_code >> 8));
  out.push_back(message.emcy.error_register);
  out.insert(out.end(), message.emcy.manufacturer.begin(), message.emcy.manufacturer.end());
  out.insert(out.end(), message.extra.begin(), message.extra.end());
  return out;
}

Expected<CoeEmergency, CoeDecodeError> decode_emergency(std::span<const std::uint8_t> data) {
  if (data.size() < kCoeHeaderSize + kCoeEmergencySize) {
    return Unexpected(CoeDecodeError{"shorter than a CoE emergency (10 octets)", std::nullopt});
  }
  if (decode_coe_header(data.first<kCoeHeaderSize>()).service !=
      static_cast<std::uint8_t>(CoeService::emergency)) {
    return Unexpected(CoeDecodeError{"not an emergency (CoE service)", std::nullopt});
  }
  const auto b = data.subspan(kCoeHeaderSize);
  CoeEmergency e;
  e.emcy.error_code = static_cast<std::uint16_t>(b[0] | (b[1] << 8));
  e.emcy.error_register = b[2];
  std::copy(b.begin() + 3, b.begin() + 8, e.emcy.manufacturer.begin());
  e.extra.assign(b.begin() + 8, b.end());
  return e;
}

std::string describe_mailbox_message(std::span<const std::uint8_t> buffer) {
  const auto m = parse_mailbox(buffer);
  if (!m) return "no mailbox: " + describe_mailbox_error(static_cast<std::uint16_t>(m.error()));
  const MailboxHeader& h = m->header;
  const std::string head = fmt::format("{} cnt {}", describe_mailbox_type(h.type), h.counter);
  if (h.type == static_cast<std::uint8_t>(MailboxType::err)) {
    const auto code = parse_mailbox_error_data(m->data);
    if (!code) return head + ": malformed mailbox error reply";
    return fmt::format("{}: {}", head, describe_mailbox_error(*code));
  }
  if (h.type != static_cast<std::uint8_t>(MailboxType::coe)) {
    return fmt::format("{}: {} octets", head, m->data.size());
  }
  const auto service = peek_coe_service(m->data);
  if (!service) return head + ": shorter than a CoE header";
  switch (*service) {
    case static_cast<std::uint8_t>(CoeService::sdo_request): {
      const auto r = decode_sdo_request(m->data);
      return fmt::format(
          "{}: {}", head,
          r ? to_string(*r) : "malformed SDO request: " + std::string(r.error().reason));
    }
    case static_cast<std::uint8_t>(CoeService::sdo_response): {
      const auto r = decode_sdo_response(m->data);
      return fmt::format(
          "{}: {}", head,
          r ? to_string(*r) : "malformed SDO response: " + std::string(r.error().reason));
    }
    case static_cast<std::uint8_t>(CoeService::emergency): {
      const auto e = decode_emergency(m->data);
      if (!e) return head + ": malformed emergency";
      return fmt::format("{}: emergency {}, register {:02X}h", head,
                         cia301::describe_emcy_code(e->emcy.error_code), e->emcy.error_register);
    }
    case static_cast<std::uint8_t>(CoeService::sdo_information): {
      if (m->data.size() < kCoeHeaderSize + 4) return head + ": malformed SDO information";
      return fmt::format("{}: SDO information opcode {}, {} fragment(s) left", head,
                         m->data[kCoeHeaderSize] & 0x7F,
                         m->data[kCoeHeaderSize + 2] | (m->data[kCoeHeaderSize + 3] << 8));
    }
    default: {
      const auto name = coe_service_name(*service);
      return fmt::format("{}: {} ({} octets)", head,
                         name ? std::string(*name) : fmt::format("service {}", *service),
                         m->data.size());
    }
  }
}

}  // namespace drivecheck::ethercat

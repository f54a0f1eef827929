#include "protocol/ethercat/master_link.hpp"

#include <fmt/format.h>

#include <utility>

namespace drivecheck::ethercat {
namespace {

class MasterCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "ethercat-master"; }
  std::string message(int value) const override {
    switch (static_cast<MasterErrc>(value)) {
      case MasterErrc::link_error:
        return "link_error";
      case MasterErrc::no_response:
        return "no_response";
      case MasterErrc::working_counter:
        return "working_counter";
      case MasterErrc::slave_count:
        return "slave_count";
      case MasterErrc::station_address:
        return "station_address";
      case MasterErrc::sii_timeout:
        return "sii_timeout";
      case MasterErrc::sii_error:
        return "sii_error";
      case MasterErrc::sii_malformed:
        return "sii_malformed";
      case MasterErrc::sii_unsupported:
        return "sii_unsupported";
      case MasterErrc::al_timeout:
        return "al_timeout";
      case MasterErrc::al_refused:
        return "al_refused";
      case MasterErrc::al_state_lost:
        return "al_state_lost";
      case MasterErrc::mailbox_timeout:
        return "mailbox_timeout";
      case MasterErrc::mailbox_error:
        return "mailbox_error";
      case MasterErrc::sdo_abort:
        return "sdo_abort";
      case MasterErrc::process_data_wkc:
        return "process_data_wkc";
      case MasterErrc::not_configured:
        return "not_configured";
      case MasterErrc::frame_too_long:
        return "frame_too_long";
    }
    return fmt::format("unknown ethercat-master error {}", value);
  }
};

// Whether `back` answers `sent`: the same number of datagrams, commands and the tag.
bool answers(const std::vector<Datagram>& sent, const std::vector<Datagram>& back,
             std::uint8_t tag) {
  if (sent.size() != back.size()) return false;
  for (std::size_t i = 0; i < sent.size(); ++i) {
    if (back[i].command != sent[i].command || back[i].index != tag ||
        back[i].data.size() != sent[i].data.size()) {
      return false;
    }
  }
  return true;
}

}  // namespace

const std::error_category& master_category() {
  static const MasterCategory category;
  return category;
}

std::error_code make_error_code(MasterErrc error) {
  return {static_cast<int>(error), master_category()};
}

std::string MasterError::message() const {
  return fmt::format("{}: {}: {}", code.category().name(), code.message(), detail);
}

Unexpected<MasterError> master_error(MasterErrc code, std::string detail, std::uint16_t station) {
  MasterError error;
  error.code = code;
  error.detail = std::move(detail);
  error.station = station;
  return Unexpected(std::move(error));
}

std::string describe_access(Command command, std::uint16_t adp, std::uint16_t ado) {
  const auto info = find_command(static_cast<std::uint8_t>(command));
  if (info && info->addressing == Addressing::station) {
    return fmt::format("{} {:04X}h at station {:04X}h", command_name(command), ado, adp);
  }
  if (info && info->addressing == Addressing::position) {
    return fmt::format("{} {:04X}h at position {}", command_name(command), ado,
                       static_cast<std::uint16_t>(0 - adp));
  }
  return fmt::format("{} {:04X}h", command_name(command), ado);
}

std::vector<std::uint8_t> le16(std::uint16_t value) {
  return {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8)};
}
std::vector<std::uint8_t> le32(std::uint32_t value) {
  return {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
          static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)};
}
std::uint16_t get_le16(std::span<const std::uint8_t> bytes, std::size_t at) {
  if (bytes.size() < at + 2) return 0;
  return static_cast<std::uint16_t>(bytes[at] | (bytes[at + 1] << 8));
}
std::uint32_t get_le32(std::span<const std::uint8_t> bytes, std::size_t at) {
  return get_le16(bytes, at) | (static_cast<std::uint32_t>(get_le16(bytes, at + 2)) << 16);
}

MasterPort::MasterPort(Link& link, MasterPortConfig config) : link_(link), config_(config) {}

Expected<std::vector<Datagram>, MasterError> MasterPort::exchange(std::vector<Datagram> datagrams) {
  return exchange(std::move(datagrams), ExchangeOptions{config_.retries});
}

Expected<std::vector<Datagram>, MasterError> MasterPort::exchange(std::vector<Datagram> datagrams,
                                                                  ExchangeOptions options) {
  if (datagrams.empty()) return std::vector<Datagram>{};
  // Described only when something goes wrong (formatting costs more than the exchange).
  const auto first = [&datagrams] { return fmt::format("{}", datagrams.front()); };
  for (unsigned attempt = 0; attempt <= options.retries; ++attempt) {
    const std::uint8_t tag = ++tag_;
    for (Datagram& d : datagrams)
      d.index = tag;
    Frame frame;
    frame.source = config_.source;
    frame.datagrams = datagrams;
    auto bytes = encode_frame(frame);
    if (!bytes) {
      return master_error(MasterErrc::frame_too_long,
                          fmt::format("{} datagrams starting with {} do not fit one frame: {}",
                                      datagrams.size(), first(), bytes.error().message()));
    }
    if (const std::error_code error = link_.send(*bytes)) {
      MasterError e;
      e.code = MasterErrc::link_error;
      e.link = error;
      e.detail = fmt::format("sending {}: {}", first(), error.message());
      return Unexpected(std::move(e));
    }
    ++frames_sent_;
    const TimePoint deadline = link_.now() + config_.response_timeout;
    for (;;) {
      auto received = link_.receive(deadline);
      if (!received) break;
      auto decoded = decode_frame(received->bytes);
      if (decoded && answers(datagrams, decoded->datagrams, tag)) {
        return std::move(decoded->datagrams);
      }
      ++frames_dropped_;
    }
    ++frames_lost_;
  }
  return master_error(
      MasterErrc::no_response,
      fmt::format(
          "no answer to the frame with {} within {} µs, {} attempt(s)", first(),
          std::chrono::duration_cast<std::chrono::microseconds>(config_.response_timeout).count(),
          options.retries + 1));
}

Expected<Datagram, MasterError> MasterPort::exchange(Datagram datagram) {
  std::vector<Datagram> one;
  one.push_back(std::move(datagram));
  auto back = exchange(std::move(one));
  if (!back) return Unexpected(back.error());
  return std::move(back->front());
}

namespace {

Expected<std::vector<std::uint8_t>, MasterError> checked(Expected<Datagram, MasterError> back,
                                                         Command command, std::uint16_t adp,
                                                         std::uint16_t ado,
                                                         std::uint16_t expected_wkc) {
  if (!back) return Unexpected(back.error());
  if (back->working_counter != expected_wkc) {
    return master_error(
        MasterErrc::working_counter,
        fmt::format("{}: working counter {}, expected {}", describe_access(command, adp, ado),
                    back->working_counter, expected_wkc),
        adp);
  }
  return std::move(back->data);
}

}  // namespace

Expected<std::vector<std::uint8_t>, MasterError> MasterPort::read(Command command,
                                                                  std::uint16_t adp,
                                                                  std::uint16_t ado,
                                                                  std::size_t size,
                                                                  std::uint16_t expected_wkc) {
  return checked(
      exchange(Datagram::physical(command, 0, adp, ado, std::vector<std::uint8_t>(size, 0))),
      command, adp, ado, expected_wkc);
}

Expected<void, MasterError> MasterPort::write(Command command, std::uint16_t adp, std::uint16_t ado,
                                              std::vector<std::uint8_t> data,
                                              std::uint16_t expected_wkc) {
  auto done = checked(exchange(Datagram::physical(command, 0, adp, ado, std::move(data))), command,
                      adp, ado, expected_wkc);
  if (!done) return Unexpected(done.error());
  return {};
}

void MasterPort::wait(Duration duration) {
  link_.run_until(link_.now() + duration);
}

}  // namespace drivecheck::ethercat

#include "reference_drive/sdo_client_channel.hpp"

#include <chrono>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "reference_drive/dictionary.hpp"

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint32_t kNotValid = 0x80000000u;  // bit 31
constexpr std::uint32_t kFrame = 0x20000000u;     // bit 29: 29-bit CAN-ID
constexpr std::uint32_t kReserved = 0x1FFFF800u;  // bits 28..11 with an 11-bit CAN-ID
constexpr std::uint32_t kCanId = 0x7FFu;
constexpr std::size_t kMaxData = 64;  // 2F00h sub 02h

namespace sub {
constexpr std::uint8_t kRequestCobId = 1;  // 1280h
constexpr std::uint8_t kResponseCobId = 2;
constexpr std::uint8_t kServerNodeId = 3;
constexpr std::uint8_t kMultiplexer = 1;  // 2F00h
constexpr std::uint8_t kData = 2;
constexpr std::uint8_t kCommand = 3;
constexpr std::uint8_t kStatus = 4;
constexpr std::uint8_t kAbortCode = 5;
constexpr std::uint8_t kTimeout = 6;
}  // namespace sub

bool valid(std::uint32_t cob_id) {
  return (cob_id & kNotValid) == 0;
}

// The default SDO channel of the pre-defined connection set in this direction: 601h-67Fh
// (client -> server), 581h-5FFh (server -> client).
bool default_sdo_channel(std::uint8_t sub_index, std::uint32_t can_id) {
  const std::uint32_t base =
      sub_index == sub::kRequestCobId ? cia301::kSdoRequestBase : cia301::kSdoResponseBase;
  return can_id > base && can_id <= base + cia301::kMaxNodeId;
}

}  // namespace

SdoClientChannel::SdoClientChannel(cia301::ObjectDictionary& od, SdoClientChannelOptions options)
    : od_(od),
      options_(options),
      parameter_(od.find(kSdoClientParameterIndex)),
      request_(od.find(kSdoClientRequestIndex)) {
  if (!present()) return;
  for (const std::uint8_t s : {sub::kRequestCobId, sub::kResponseCobId}) {
    cia301::Entry* entry = od.find(kSdoClientParameterIndex, s);
    if (entry == nullptr) continue;
    entry->set_write_validator(
        [options, s](const cia301::ObjectDictionary&, const cia301::Entry& self,
                     std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          const auto before = static_cast<std::uint32_t>(self.as_unsigned());
          const auto after = static_cast<std::uint32_t>(cia301::load_unsigned(data));
          if ((after & (kFrame | kReserved)) != 0) {
            return Unexpected(cia301::SdoAbort::invalid_value);
          }
          if (valid(before) && valid(after) && ((before ^ after) & kCanId) != 0) {
            return Unexpected(cia301::SdoAbort::invalid_value);
          }
          const std::uint32_t can_id = after & kCanId;
          if (options.refuse_restricted && valid(after) && cia301::is_restricted_cob_id(can_id) &&
              !default_sdo_channel(s, can_id)) {
            return Unexpected(cia301::SdoAbort::invalid_value);  // CiA 301 §7.3.5
          }
          return {};
        });
  }
  if (cia301::Entry* node = od.find(kSdoClientParameterIndex, sub::kServerNodeId)) {
    node->set_write_validator(
        [](const cia301::ObjectDictionary&, const cia301::Entry&,
           std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          if (cia301::load_unsigned(data) > cia301::kMaxNodeId) {
            return Unexpected(cia301::SdoAbort::value_too_high);
          }
          return {};
        });
  }
  if (cia301::Entry* command = od.find(kSdoClientRequestIndex, sub::kCommand)) {
    command->set_write_observer([this](cia301::ObjectDictionary&, cia301::Entry& self) {
      if (self.as_unsigned() != 0) pending_ = true;
    });
  }
}

std::vector<can::Frame> SdoClientChannel::start(can::TimePoint now) {
  pending_ = false;
  if (!present()) return {};
  std::vector<can::Frame> out;
  if (transfer_ && transfer_->running()) {
    const auto aborted = transfer_->abort(cia301::SdoAbort::general_error);
    out.assign(aborted.begin(), aborted.end());
  }
  const auto request = static_cast<std::uint32_t>(
      od_.find(kSdoClientParameterIndex, sub::kRequestCobId)->as_unsigned());
  const auto response = static_cast<std::uint32_t>(
      od_.find(kSdoClientParameterIndex, sub::kResponseCobId)->as_unsigned());
  const auto server = static_cast<std::uint8_t>(
      od_.find(kSdoClientParameterIndex, sub::kServerNodeId)->as_unsigned());
  if (!valid(request) || !valid(response)) {
    transfer_.reset();
    set_status(SdoClientStatus::no_client, 0);
    return out;
  }
  cia301::SdoClientOptions client;
  client.cob_ids = cia301::SdoCobIds{request & kCanId, response & kCanId, can::IdFormat::standard};
  // Deviation sdo-client-wrong-cob-id: the requests go to the server's default channel.
  if (options_.wrong_cob_id && cia301::is_valid_node_id(server)) {
    client.cob_ids->request = cia301::kSdoRequestBase + server;
  }
  client.timeout =
      std::chrono::milliseconds(od_.find(kSdoClientRequestIndex, sub::kTimeout)->as_unsigned());
  if (options_.no_timeout) client.timeout = std::chrono::hours(24 * 365);  // deviation
  client.max_upload_size = kMaxData;

  const auto mux_value = static_cast<std::uint32_t>(
      od_.find(kSdoClientRequestIndex, sub::kMultiplexer)->as_unsigned());
  const cia301::Multiplexer mux{static_cast<std::uint16_t>(mux_value >> 16),
                                static_cast<std::uint8_t>(mux_value >> 8)};
  const auto command = od_.find(kSdoClientRequestIndex, sub::kCommand)->as_unsigned();
  const auto data = od_.find(kSdoClientRequestIndex, sub::kData)->bytes();
  const std::vector<std::uint8_t> bytes(data.begin(), data.end());

  transfer_.emplace(server == 0 ? std::uint8_t{1} : server, client);
  upload_ = command == 1;
  std::span<const can::Frame> frames;
  if (upload_) {
    frames = transfer_->start_upload(mux, now);
  } else {
    frames = transfer_->start_download(
        mux, bytes, now,
        command == 3 ? cia301::SdoTransferMode::segmented : cia301::SdoTransferMode::automatic);
  }
  set_status(SdoClientStatus::running, 0);
  auto rest = finish(frames);
  out.insert(out.end(), rest.begin(), rest.end());
  return out;
}

bool SdoClientChannel::takes(const can::Frame& frame) const {
  return transfer_ && transfer_->running() && !frame.is_error() &&
         frame.format == transfer_->cob_ids().format && frame.id == transfer_->cob_ids().response;
}

std::vector<can::Frame> SdoClientChannel::on_frame(const can::Frame& frame, can::TimePoint now) {
  if (!takes(frame)) return {};
  return finish(transfer_->on_frame(frame, now));
}

std::vector<can::Frame> SdoClientChannel::on_time(can::TimePoint now) {
  if (!transfer_ || !transfer_->running() || now < transfer_->next_deadline()) return {};
  return finish(transfer_->on_time(now));
}

can::TimePoint SdoClientChannel::next_deadline() const {
  return transfer_ && transfer_->running() ? transfer_->next_deadline() : can::kForever;
}

void SdoClientChannel::stop() {
  pending_ = false;
  if (!transfer_ || !transfer_->running()) return;
  transfer_->cancel();
  set_status(SdoClientStatus::failed, 0);
}

void SdoClientChannel::reset() {
  pending_ = false;
  if (transfer_ && transfer_->running()) transfer_->cancel();
  transfer_.reset();
  if (!present()) return;
  // The request object is no parameter (stored in no group): every entry back to its default.
  for (cia301::Entry& entry : request_->entries()) {
    if (entry.sub_index() != 0) (void)entry.assign_bytes(entry.default_bytes(od_.node_id()));
  }
}

std::vector<can::Frame> SdoClientChannel::finish(std::span<const can::Frame> frames) {
  std::vector<can::Frame> out(frames.begin(), frames.end());
  if (!transfer_ || transfer_->running()) return out;
  if (transfer_->succeeded()) {
    if (upload_) {
      (void)od_.find(kSdoClientRequestIndex, sub::kData)->assign_bytes(transfer_->data());
    }
    set_status(SdoClientStatus::succeeded, 0);
    return out;
  }
  std::uint32_t code = 0;
  if (auto server = cia301::server_abort_code(transfer_->error())) {
    code = *server;
  } else if (auto sent = transfer_->sent_abort()) {
    code = *sent;
  }
  set_status(SdoClientStatus::failed, code);
  return out;
}

void SdoClientChannel::set_status(SdoClientStatus status, std::uint32_t abort_code) {
  od_.find(kSdoClientRequestIndex, sub::kStatus)
      ->assign_unsigned(static_cast<std::uint8_t>(status));
  od_.find(kSdoClientRequestIndex, sub::kAbortCode)->assign_unsigned(abort_code);
}

}  // namespace drivecheck::reference_drive

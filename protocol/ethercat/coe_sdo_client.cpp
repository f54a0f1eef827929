#include "protocol/ethercat/coe_sdo_client.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {

using cia301::SdoAbort;

CoeSdoClient::CoeSdoClient(CoeSdoClientOptions options) : options_(options) {}

std::vector<std::uint8_t> CoeSdoClient::start_upload(Multiplexer mux, bool complete_access) {
  state_ = State::upload_initiate;
  mux_ = mux;
  value_.clear();
  offset_ = 0;
  size_ = 0;
  toggle_ = false;
  error_.reset();
  return encode(CoeSdoRequest{CoeUploadInitiate{mux, complete_access}});
}

std::vector<std::uint8_t> CoeSdoClient::start_download(Multiplexer mux,
                                                       std::span<const std::uint8_t> data,
                                                       bool complete_access) {
  state_ = State::download_initiate;
  mux_ = mux;
  value_.assign(data.begin(), data.end());
  size_ = static_cast<std::uint32_t>(data.size());
  toggle_ = true;  // so that the first segment gets 0
  last_sent_ = false;
  error_.reset();
  CoeDownloadInitiate m;
  m.mux = mux;
  m.complete_access = complete_access;
  m.size_indicated = true;
  m.complete_size = size_;
  if (options_.expedited && !data.empty() && data.size() <= 4) {
    m.expedited = true;
    m.data = value_;
    offset_ = value_.size();
    return encode(CoeSdoRequest{std::move(m)});
  }
  const std::size_t overhead = kMailboxHeaderSize + kCoeSdoMessageSize;
  const std::size_t room = options_.write_size > overhead ? options_.write_size - overhead : 0;
  offset_ = std::min(value_.size(), room);
  m.data.assign(value_.begin(), value_.begin() + static_cast<std::ptrdiff_t>(offset_));
  return encode(CoeSdoRequest{std::move(m)});
}

CoeClientStep CoeSdoClient::fail(CoeClientError::Kind kind, SdoAbort code, std::string detail) {
  CoeClientStep step;
  step.done = true;
  step.error = CoeClientError{kind, static_cast<std::uint32_t>(code), std::move(detail)};
  step.request = encode(CoeSdoRequest{CoeAbort{mux_, static_cast<std::uint32_t>(code)}});
  error_ = step.error;
  state_ = State::idle;
  return step;
}

std::vector<std::uint8_t> CoeSdoClient::timeout() {
  return *fail(CoeClientError::Kind::timeout, SdoAbort::protocol_timed_out,
               "no SDO response in time")
              .request;
}

CoeClientStep CoeSdoClient::on_response(std::span<const std::uint8_t> data) {
  CoeClientStep step;
  if (state_ == State::idle) {
    step.ignored = true;
    return step;
  }
  auto response = decode_sdo_response(data);
  if (!response) {
    if (!response.error().abort) {
      step.ignored = true;
      return step;
    }
    return fail(CoeClientError::Kind::protocol, *response.error().abort,
                std::string(response.error().reason));
  }
  if (const auto* a = std::get_if<CoeAbort>(&*response)) {
    step.done = true;
    step.error = CoeClientError{CoeClientError::Kind::server_abort, a->code,
                                cia301::describe_sdo_abort(a->code)};
    error_ = step.error;
    state_ = State::idle;
    return step;
  }
  if (state_ == State::upload_initiate || state_ == State::upload_segment) {
    return on_upload(*response);
  }
  return on_download(*response);
}

CoeClientStep CoeSdoClient::on_upload(const CoeSdoResponse& response) {
  using Kind = CoeClientError::Kind;
  if (state_ == State::upload_initiate) {
    const auto* r = std::get_if<CoeUploadInitiateResponse>(&response);
    if (r == nullptr) {
      return fail(Kind::protocol, SdoAbort::invalid_command_specifier,
                  "expected an upload initiate response, got: " + to_string(response));
    }
    if (r->mux != mux_) {
      return fail(Kind::protocol, SdoAbort::general_error,
                  fmt::format("response for {:04X}h:{:02X}, requested {:04X}h:{:02X}", r->mux.index,
                              r->mux.sub_index, mux_.index, mux_.sub_index));
    }
    value_ = r->data;
    CoeClientStep step;
    if (r->expedited) {
      step.done = true;
      state_ = State::idle;
      return step;
    }
    size_ = r->complete_size;
    if (value_.size() > size_) {
      return fail(Kind::protocol, SdoAbort::length_too_high,
                  fmt::format("{} octets for a complete size of {}", value_.size(), size_));
    }
    if (value_.size() == size_) {
      step.done = true;
      state_ = State::idle;
      return step;
    }
    state_ = State::upload_segment;
    toggle_ = false;
    step.request = encode(CoeSdoRequest{CoeUploadSegmentRequest{toggle_}});
    return step;
  }
  const auto* s = std::get_if<CoeUploadSegment>(&response);
  if (s == nullptr) {
    return fail(Kind::protocol, SdoAbort::invalid_command_specifier,
                "expected an upload segment, got: " + to_string(response));
  }
  if (s->toggle != toggle_) {
    return fail(Kind::protocol, SdoAbort::toggle_bit_not_alternated,
                fmt::format("segment toggle {} where {} was requested", s->toggle ? 1 : 0,
                            toggle_ ? 1 : 0));
  }
  if (value_.size() + s->data.size() > size_) {
    return fail(Kind::protocol, SdoAbort::length_too_high,
                fmt::format("more than the complete size of {} octets", size_));
  }
  value_.insert(value_.end(), s->data.begin(), s->data.end());
  CoeClientStep step;
  if (s->last) {
    if (value_.size() < size_) {
      return fail(
          Kind::protocol, SdoAbort::length_too_low,
          fmt::format("{} octets at the last segment, complete size {}", value_.size(), size_));
    }
    step.done = true;
    state_ = State::idle;
    return step;
  }
  toggle_ = !toggle_;
  step.request = encode(CoeSdoRequest{CoeUploadSegmentRequest{toggle_}});
  return step;
}

CoeClientStep CoeSdoClient::next_download_segment() {
  const std::size_t overhead = kMailboxHeaderSize + kCoeHeaderSize + 1;
  const std::size_t room = options_.write_size > overhead + 7 ? options_.write_size - overhead : 7;
  const std::size_t chunk = std::min(value_.size() - offset_, room);
  CoeDownloadSegment segment;
  toggle_ = !toggle_;
  segment.toggle = toggle_;
  segment.data.assign(value_.begin() + static_cast<std::ptrdiff_t>(offset_),
                      value_.begin() + static_cast<std::ptrdiff_t>(offset_ + chunk));
  offset_ += chunk;
  segment.last = offset_ == value_.size();
  last_sent_ = segment.last;
  state_ = State::download_segment;
  CoeClientStep step;
  step.request = encode(CoeSdoRequest{std::move(segment)});
  return step;
}

CoeClientStep CoeSdoClient::on_download(const CoeSdoResponse& response) {
  using Kind = CoeClientError::Kind;
  if (state_ == State::download_initiate) {
    const auto* r = std::get_if<CoeDownloadInitiateResponse>(&response);
    if (r == nullptr) {
      return fail(Kind::protocol, SdoAbort::invalid_command_specifier,
                  "expected a download initiate response, got: " + to_string(response));
    }
    if (r->mux != mux_) {
      return fail(Kind::protocol, SdoAbort::general_error,
                  fmt::format("response for {:04X}h:{:02X}, requested {:04X}h:{:02X}", r->mux.index,
                              r->mux.sub_index, mux_.index, mux_.sub_index));
    }
    if (offset_ == value_.size()) {
      CoeClientStep step;
      step.done = true;
      state_ = State::idle;
      return step;
    }
    return next_download_segment();
  }
  const auto* s = std::get_if<CoeDownloadSegmentResponse>(&response);
  if (s == nullptr) {
    return fail(Kind::protocol, SdoAbort::invalid_command_specifier,
                "expected a download segment response, got: " + to_string(response));
  }
  if (s->toggle != toggle_) {
    return fail(Kind::protocol, SdoAbort::toggle_bit_not_alternated,
                fmt::format("segment response toggle {} for a segment with {}", s->toggle ? 1 : 0,
                            toggle_ ? 1 : 0));
  }
  if (last_sent_) {
    CoeClientStep step;
    step.done = true;
    state_ = State::idle;
    return step;
  }
  return next_download_segment();
}

}  // namespace drivecheck::ethercat

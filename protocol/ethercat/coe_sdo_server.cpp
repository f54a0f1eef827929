#include "protocol/ethercat/coe_sdo_server.hpp"

#include <algorithm>
#include <utility>

#include "protocol/ethercat/coe_sdo_info.hpp"

namespace drivecheck::ethercat {

using cia301::SdoAbort;

namespace {

// Bits appended LSB first; octet-sized entries start at an octet boundary.
class BitWriter {
 public:
  void put(std::span<const std::uint8_t> bytes, std::size_t bits) {
    if (bits % 8 == 0) {
      align();
      out_.insert(out_.end(), bytes.begin(),
                  bytes.begin() + static_cast<std::ptrdiff_t>(std::min(bytes.size(), bits / 8)));
      bits_ += bits;
      return;
    }
    for (std::size_t i = 0; i < bits; ++i, ++bits_) {
      if (bits_ / 8 >= out_.size()) out_.push_back(0);
      const bool bit = i / 8 < bytes.size() && ((bytes[i / 8] >> (i % 8)) & 1) != 0;
      if (bit) out_[bits_ / 8] = static_cast<std::uint8_t>(out_[bits_ / 8] | (1u << (bits_ % 8)));
    }
  }
  void align() {
    bits_ = (bits_ + 7) / 8 * 8;
    out_.resize(bits_ / 8, 0);
  }
  std::vector<std::uint8_t> take() {
    align();
    return std::move(out_);
  }

 private:
  std::vector<std::uint8_t> out_;
  std::size_t bits_ = 0;
};

struct Slot {
  cia301::Entry* entry;
  std::size_t bit_offset;
  std::size_t bits;
};

// The layout of entries 1..highest of an object, after `start_bits` (16 with SI0, else 0).
Expected<std::vector<Slot>, SdoAbort> layout(cia301::Object& object, std::uint8_t highest,
                                             std::size_t start_bits, std::size_t& total_bits) {
  std::vector<Slot> slots;
  std::size_t bits = start_bits;
  for (unsigned sub = 1; sub <= highest; ++sub) {
    cia301::Entry* entry = object.find(static_cast<std::uint8_t>(sub));
    if (entry == nullptr) continue;
    const auto& ti = cia301::info(entry->type());
    if (ti.size == 0) return Unexpected(SdoAbort::coe_complete_access_unsupported);
    if (ti.bit_size % 8 == 0) bits = (bits + 7) / 8 * 8;
    slots.push_back({entry, bits, ti.bit_size});
    bits += ti.bit_size;
  }
  total_bits = bits;
  return slots;
}

Expected<cia301::Object*, SdoAbort> complete_object(cia301::ObjectDictionary& od,
                                                    std::uint16_t index, std::uint8_t first) {
  cia301::Object* object = od.find(index);
  if (object == nullptr) return Unexpected(SdoAbort::object_does_not_exist);
  if (first > 1 || !cia301::has_sub_entries(object->code()) || object->find(0) == nullptr) {
    return Unexpected(SdoAbort::unsupported_access);
  }
  return object;
}

// The bits of a slot from the data, as the entry's octets (bit entries: one octet, low bits).
std::vector<std::uint8_t> extract(std::span<const std::uint8_t> data, const Slot& slot) {
  if (slot.bits % 8 == 0) {
    const auto first = data.begin() + static_cast<std::ptrdiff_t>(slot.bit_offset / 8);
    return {first, first + static_cast<std::ptrdiff_t>(slot.bits / 8)};
  }
  std::vector<std::uint8_t> out((slot.bits + 7) / 8, 0);
  for (std::size_t i = 0; i < slot.bits; ++i) {
    const std::size_t at = slot.bit_offset + i;
    if ((data[at / 8] >> (at % 8)) & 1) {
      out[i / 8] = static_cast<std::uint8_t>(out[i / 8] | (1u << (i % 8)));
    }
  }
  return out;
}

bool same_bits(std::span<const std::uint8_t> current, const std::vector<std::uint8_t>& value,
               std::size_t bits) {
  for (std::size_t i = 0; i < bits; ++i) {
    const bool a = i / 8 < current.size() && ((current[i / 8] >> (i % 8)) & 1) != 0;
    const bool b = i / 8 < value.size() && ((value[i / 8] >> (i % 8)) & 1) != 0;
    if (a != b) return false;
  }
  return true;
}

}  // namespace

Expected<std::vector<std::uint8_t>, SdoAbort> read_complete_access(cia301::ObjectDictionary& od,
                                                                   std::uint16_t index,
                                                                   std::uint8_t first) {
  auto object = complete_object(od, index, first);
  if (!object) return Unexpected(object.error());
  auto si0 = od.read(index, 0);
  if (!si0) return Unexpected(si0.error());
  if (si0->empty()) return Unexpected(SdoAbort::general_error);
  const std::uint8_t highest = (*si0)[0];
  BitWriter writer;
  if (first == 0) {
    const std::uint8_t padded[2] = {highest, 0};
    writer.put(padded, 16);
  }
  std::size_t total_bits = 0;
  auto slots = layout(**object, highest, first == 0 ? 16 : 0, total_bits);
  if (!slots) return Unexpected(slots.error());
  for (const Slot& slot : *slots) {
    auto bytes = od.read(index, slot.entry->sub_index());
    if (!bytes) return Unexpected(bytes.error());
    writer.put(*bytes, slot.bits);
  }
  return writer.take();
}

Expected<void, SdoAbort> write_complete_access(cia301::ObjectDictionary& od, std::uint16_t index,
                                               std::uint8_t first,
                                               std::span<const std::uint8_t> data) {
  auto found = complete_object(od, index, first);
  if (!found) return Unexpected(found.error());
  cia301::Object& object = **found;
  cia301::Entry& si0 = *object.find(0);
  if (first == 0 && data.size() < 2) return Unexpected(SdoAbort::length_too_low);
  const std::uint8_t highest = first == 0 ? data[0] : static_cast<std::uint8_t>(si0.as_unsigned());
  std::size_t total_bits = 0;
  auto slots = layout(object, highest, first == 0 ? 16 : 0, total_bits);
  if (!slots) return Unexpected(slots.error());
  const std::size_t octets = (total_bits + 7) / 8;
  if (data.size() > octets) return Unexpected(SdoAbort::length_too_high);
  if (data.size() < octets) return Unexpected(SdoAbort::length_too_low);

  // Snapshot for all-or-nothing.
  std::vector<std::pair<cia301::Entry*, std::vector<std::uint8_t>>> before;
  for (cia301::Entry& entry : object.entries()) {
    before.emplace_back(&entry,
                        std::vector<std::uint8_t>(entry.bytes().begin(), entry.bytes().end()));
  }
  auto fail = [&](SdoAbort code) -> Expected<void, SdoAbort> {
    for (auto& [entry, bytes] : before)
      (void)entry->assign_bytes(bytes);
    return Unexpected(code);
  };

  const bool si0_writable = first == 0 && cia301::is_writable(si0.access());
  if (first == 0 && !si0_writable && si0.as_unsigned() != highest) {
    return fail(SdoAbort::write_read_only);
  }
  if (si0_writable && si0.as_unsigned() != 0) {
    const std::uint8_t zero[1] = {0};
    if (auto ok = od.write(index, 0, zero); !ok) return fail(ok.error());
  }
  for (const Slot& slot : *slots) {
    const auto value = extract(data, slot);
    if (!cia301::is_writable(slot.entry->access())) {
      if (same_bits(slot.entry->bytes(), value, slot.bits)) continue;
      return fail(SdoAbort::write_read_only);
    }
    if (auto ok = od.write(index, slot.entry->sub_index(), value); !ok) return fail(ok.error());
  }
  if (si0_writable) {
    const std::uint8_t n[1] = {highest};
    if (auto ok = od.write(index, 0, n); !ok) return fail(ok.error());
  }
  return {};
}

// ---- CoeSdoServer -----------------------------------------------------------------------------

CoeSdoServer::CoeSdoServer(cia301::ObjectDictionary& od, CoeSdoServerOptions options)
    : od_(od), options_(options) {}

void CoeSdoServer::reset() {
  state_ = State::idle;
  buffer_.clear();
  offset_ = 0;
  expected_size_.reset();
  toggle_ = false;
  complete_access_ = false;
}

std::size_t CoeSdoServer::initiate_capacity() const {
  const std::size_t overhead = kMailboxHeaderSize + kCoeSdoMessageSize;
  return options_.read_size > overhead ? options_.read_size - overhead : 0;
}

std::size_t CoeSdoServer::segment_capacity() const {
  const std::size_t overhead = kMailboxHeaderSize + kCoeHeaderSize + 1;
  return options_.read_size > overhead + 7 ? options_.read_size - overhead : 7;
}

std::vector<std::uint8_t> CoeSdoServer::abort(const Multiplexer& mux, SdoAbort code) {
  reset();
  return encode(CoeSdoResponse{CoeAbort{mux, static_cast<std::uint32_t>(code)}});
}

CoeServerReply CoeSdoServer::reply(const CoeSdoRequest* request, std::vector<std::uint8_t> bytes) {
  if (hook_ == nullptr) return {std::move(bytes), std::nullopt};
  auto response = decode_sdo_response(bytes);
  if (!response) return {std::move(bytes), std::nullopt};
  auto sent = hook_->after(request, std::move(*response));
  if (!sent) return {};
  return {encode(*sent), std::nullopt};
}

CoeServerReply CoeSdoServer::handle(std::span<const std::uint8_t> data) {
  auto request = decode_sdo_request(data);
  if (!request) {
    if (request.error().abort) {
      if (hook_ != nullptr) {
        if (auto instead = hook_->before(nullptr)) return reply(nullptr, encode(*instead));
      }
      const Multiplexer mux = busy() ? mux_ : Multiplexer{};
      return reply(nullptr, abort(mux, *request.error().abort));
    }
    const bool too_short = data.size() < kCoeSdoMessageSize;
    return {std::nullopt,
            too_short ? MailboxError::size_too_short : MailboxError::service_not_supported};
  }
  if (hook_ != nullptr) {
    if (auto instead = hook_->before(&*request)) return reply(&*request, encode(*instead));
  }
  return std::visit(
      [&](const auto& m) -> CoeServerReply {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, CoeDownloadInitiate>) {
          return reply(&*request, on_download(m));
        } else if constexpr (std::is_same_v<T, CoeDownloadSegment>) {
          return reply(&*request, on_segment(m));
        } else if constexpr (std::is_same_v<T, CoeUploadInitiate>) {
          return reply(&*request, on_upload(m));
        } else if constexpr (std::is_same_v<T, CoeUploadSegmentRequest>) {
          return reply(&*request, on_upload_segment(m));
        } else {
          reset();  // the client aborted: no reply
          return {};
        }
      },
      *request);
}

std::vector<std::uint8_t> CoeSdoServer::on_upload(const CoeUploadInitiate& m) {
  reset();
  std::vector<std::uint8_t> value;
  if (m.complete_access) {
    if (!options_.complete_access) return abort(m.mux, SdoAbort::unsupported_access);
    auto bytes = read_complete_access(od_, m.mux.index, m.mux.sub_index);
    if (!bytes) return abort(m.mux, bytes.error());
    value = std::move(*bytes);
  } else {
    auto bytes = od_.read(m.mux.index, m.mux.sub_index);
    if (!bytes) return abort(m.mux, bytes.error());
    value.assign(bytes->begin(), bytes->end());
  }
  CoeUploadInitiateResponse response;
  response.mux = m.mux;
  response.complete_access = m.complete_access;
  response.size_indicated = true;
  response.complete_size = static_cast<std::uint32_t>(value.size());
  if (!value.empty() && value.size() <= 4) {
    response.expedited = true;
    response.data = std::move(value);
    return encode(CoeSdoResponse{std::move(response)});
  }
  const std::size_t first = std::min(value.size(), initiate_capacity());
  response.data.assign(value.begin(), value.begin() + static_cast<std::ptrdiff_t>(first));
  if (first < value.size()) {
    state_ = State::uploading;
    mux_ = m.mux;
    complete_access_ = m.complete_access;
    buffer_ = std::move(value);
    offset_ = first;
    toggle_ = false;
  }
  return encode(CoeSdoResponse{std::move(response)});
}

std::vector<std::uint8_t> CoeSdoServer::on_upload_segment(const CoeUploadSegmentRequest& m) {
  if (state_ != State::uploading) {
    return abort(busy() ? mux_ : Multiplexer{}, SdoAbort::invalid_command_specifier);
  }
  if (m.toggle != toggle_) return abort(mux_, SdoAbort::toggle_bit_not_alternated);
  const std::size_t chunk = std::min(buffer_.size() - offset_, segment_capacity());
  CoeUploadSegment segment;
  segment.toggle = toggle_;
  segment.data.assign(buffer_.begin() + static_cast<std::ptrdiff_t>(offset_),
                      buffer_.begin() + static_cast<std::ptrdiff_t>(offset_ + chunk));
  offset_ += chunk;
  segment.last = offset_ == buffer_.size();
  toggle_ = !toggle_;
  if (segment.last) reset();
  return encode(CoeSdoResponse{std::move(segment)});
}

std::vector<std::uint8_t> CoeSdoServer::on_download(const CoeDownloadInitiate& m) {
  reset();
  if (m.complete_access && !options_.complete_access) {
    return abort(m.mux, SdoAbort::unsupported_access);
  }
  if (!m.complete_access) {
    auto entry = od_.locate(m.mux.index, m.mux.sub_index);
    if (!entry) return abort(m.mux, entry.error());
    if (!cia301::is_writable((*entry)->access())) return abort(m.mux, SdoAbort::write_read_only);
  } else if (auto object = complete_object(od_, m.mux.index, m.mux.sub_index); !object) {
    return abort(m.mux, object.error());
  }
  mux_ = m.mux;
  complete_access_ = m.complete_access;
  if (m.expedited) {
    buffer_ = m.data;
    if (!m.size_indicated && !m.complete_access) {
      // s = 0: 4 octets of unindicated size; a fixed-size entry of 1..4 octets takes its own.
      const auto size = cia301::info(od_.find(m.mux.index, m.mux.sub_index)->type()).size;
      if (size >= 1 && size <= 4) buffer_.resize(size);
    }
    return finish_download();
  }
  if (m.data.size() > options_.max_download) return abort(m.mux, SdoAbort::out_of_memory);
  buffer_ = m.data;
  if (m.size_indicated) expected_size_ = m.complete_size;
  if (expected_size_ && buffer_.size() > *expected_size_) {
    return abort(m.mux, SdoAbort::length_too_high);
  }
  if (expected_size_ && buffer_.size() == *expected_size_) return finish_download();
  state_ = State::downloading;
  toggle_ = false;
  return encode(CoeSdoResponse{CoeDownloadInitiateResponse{m.mux}});
}

std::vector<std::uint8_t> CoeSdoServer::on_segment(const CoeDownloadSegment& m) {
  if (state_ != State::downloading) {
    return abort(busy() ? mux_ : Multiplexer{}, SdoAbort::invalid_command_specifier);
  }
  if (m.toggle != toggle_) return abort(mux_, SdoAbort::toggle_bit_not_alternated);
  if (buffer_.size() + m.data.size() > options_.max_download) {
    return abort(mux_, SdoAbort::out_of_memory);
  }
  buffer_.insert(buffer_.end(), m.data.begin(), m.data.end());
  if (expected_size_ && buffer_.size() > *expected_size_) {
    return abort(mux_, SdoAbort::length_too_high);
  }
  const bool toggle = toggle_;
  toggle_ = !toggle_;
  if (!m.last) return encode(CoeSdoResponse{CoeDownloadSegmentResponse{toggle}});
  if (expected_size_ && buffer_.size() < *expected_size_) {
    return abort(mux_, SdoAbort::length_too_low);
  }
  const Multiplexer mux = mux_;
  if (auto ok = write_buffer(); !ok) return abort(mux, ok.error());
  return encode(CoeSdoResponse{CoeDownloadSegmentResponse{toggle}});
}

Expected<void, SdoAbort> CoeSdoServer::write_buffer() {
  const Multiplexer mux = mux_;
  Expected<void, SdoAbort> written =
      complete_access_ ? write_complete_access(od_, mux.index, mux.sub_index, buffer_)
                       : od_.write(mux.index, mux.sub_index, buffer_);
  reset();
  return written;
}

std::vector<std::uint8_t> CoeSdoServer::finish_download() {
  const Multiplexer mux = mux_;
  if (auto ok = write_buffer(); !ok) return abort(mux, ok.error());
  return encode(CoeSdoResponse{CoeDownloadInitiateResponse{mux}});
}

// ---- CoeSlave ---------------------------------------------------------------------------------

CoeSlave::CoeSlave(cia301::ObjectDictionary& od, MailboxSlaveConfig mailbox,
                   CoeSdoServerOptions sdo)
    : mailbox_(std::move(mailbox)), sdo_(od, sdo), od_(od), options_(sdo) {}

void CoeSlave::on_write_mailbox(std::span<const std::uint8_t> buffer) {
  const MailboxReceived received = mailbox_.receive(buffer);
  if (received.receipt != MailboxReceipt::deliver) return;
  const MailboxHeader& h = received.message.header;
  const auto data = received.message.data;
  const auto service = peek_coe_service(data);
  if (!service) {
    mailbox_.post_error(MailboxError::size_too_short, h.address);
    return;
  }
  if (*service == static_cast<std::uint8_t>(CoeService::sdo_information) &&
      options_.sdo_information) {
    for (const auto& fragment : answer_sdo_information(od_, data, mailbox_.config().read_size,
                                                       options_.sdo_information_hidden)) {
      if (auto ok = mailbox_.post(MailboxType::coe, fragment, h.address); !ok) {
        mailbox_.post_error(ok.error(), h.address);
        return;
      }
    }
    return;
  }
  if (*service != static_cast<std::uint8_t>(CoeService::sdo_request)) {
    // Emergencies, PDOs over the mailbox and SDO information are not served by this slave.
    mailbox_.post_error(MailboxError::service_not_supported, h.address);
    return;
  }
  const CoeServerReply reply = sdo_.handle(data);
  if (reply.coe) {
    if (auto ok = mailbox_.post(MailboxType::coe, *reply.coe, h.address); !ok) {
      mailbox_.post_error(ok.error(), h.address);
    }
  } else if (reply.mailbox_error) {
    mailbox_.post_error(*reply.mailbox_error, h.address);
  }
}

Expected<void, MailboxError> CoeSlave::post_emergency(const cia301::Emcy& emcy) {
  return mailbox_.post(MailboxType::coe, encode(CoeEmergency{emcy, {}}));
}

void CoeSlave::reset() {
  mailbox_.reset();
  sdo_.reset();
}

}  // namespace drivecheck::ethercat

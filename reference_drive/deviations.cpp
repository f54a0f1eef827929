#include "reference_drive/deviations.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <memory>
#include <utility>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/emcy_producer.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/pdo.hpp"
#include "reference_drive/sdo_deviations.hpp"

namespace drivecheck::reference_drive {
namespace {

// ---------------------------------------------------------------------------------------------
// Names

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + cost});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::vector<std::string_view> words_of(std::string_view name) {
  std::vector<std::string_view> words;
  while (!name.empty()) {
    const auto dash = name.find_first_of("-_ ");
    if (dash != 0) words.push_back(name.substr(0, dash));
    if (dash == std::string_view::npos) break;
    name.remove_prefix(dash + 1);
  }
  return words;
}

// Lower is closer; SIZE_MAX: not close at all.
std::size_t closeness(std::string_view query, std::string_view name) {
  constexpr std::size_t kFar = static_cast<std::size_t>(-1);
  if (query.empty()) return kFar;
  if (name.starts_with(query)) return 0;
  const std::size_t distance = edit_distance(query, name);
  if (distance <= std::max<std::size_t>(2, query.size() / 4)) return 1 + distance;
  // Shared words: "toggle" finds every "...-toggle-..." name.
  std::size_t shared = 0;
  const auto name_words = words_of(name);
  for (std::string_view word : words_of(query)) {
    if (word.size() < 3) continue;
    if (std::find(name_words.begin(), name_words.end(), word) != name_words.end()) ++shared;
  }
  if (shared > 0) return 100 - std::min<std::size_t>(shared, 50);
  if (name.find(query) != std::string_view::npos) return 60;
  return kFar;
}

// ---------------------------------------------------------------------------------------------
// Frames

constexpr std::uint32_t kNmtId = 0x000;
constexpr std::uint32_t kSdoRequestBase = 0x600;
constexpr std::uint32_t kSdoResponseBase = 0x580;
constexpr std::uint32_t kErrorControlBase = 0x700;
constexpr std::uint32_t kEmcyBase = 0x080;

// SDO byte 0.
constexpr std::uint8_t kAbort = 0x80;
constexpr std::uint8_t kDownloadResponse = 0x60;
constexpr std::uint8_t kBlockDownloadAck = 0xA2;          // scs 5, ss 2
constexpr std::uint8_t kBlockUploadAck = 0xA2;            // ccs 5, cs 2
constexpr std::uint8_t kEndBlockDownloadResponse = 0xA1;  // scs 5, ss 1
constexpr std::uint8_t kEndBlockUpload = 0xC1;            // scs 6, ss 1 (n in bits 4..2)
constexpr std::uint8_t kMaxBlockSize = 127;               // seqno 1..127
constexpr unsigned ccs_of(std::uint8_t byte0) {
  return byte0 >> 5;
}
constexpr unsigned kCcsDownloadSegment = 0;
constexpr unsigned kCcsDownloadInitiate = 1;
constexpr unsigned kCcsUploadInitiate = 2;
constexpr unsigned kCcsUploadSegment = 3;
constexpr unsigned kCcsAbort = 4;
constexpr unsigned kCcsInvalid = 7;

// Abort codes (CiA 301 §7.2.4.3.17) the CAN-only mutators look at (the SDO service ones are
// in sdo_deviations.cpp).
constexpr std::uint32_t kAbortUnsupportedAccess = 0x06010000;
constexpr std::uint32_t kAbortNoSubIndex = 0x06090011;
constexpr std::uint32_t kAbortInvalidValue = 0x06090030;

// Heartbeat / NMT state bytes.
constexpr std::uint8_t kStateStopped = 0x04;
constexpr std::uint8_t kStateOperational = 0x05;
constexpr std::uint8_t kStatePreOperational = 0x7F;

std::uint32_t load_u32(const can::Frame& frame, std::size_t at) {
  return static_cast<std::uint32_t>(frame.data[at]) |
         (static_cast<std::uint32_t>(frame.data[at + 1]) << 8) |
         (static_cast<std::uint32_t>(frame.data[at + 2]) << 16) |
         (static_cast<std::uint32_t>(frame.data[at + 3]) << 24);
}
void store_u32(can::Frame& frame, std::size_t at, std::uint32_t value) {
  for (std::size_t i = 0; i < 4; ++i)
    frame.data[at + i] = static_cast<std::uint8_t>(value >> (8 * i));
}
std::uint16_t index_of(const can::Frame& frame) {
  return static_cast<std::uint16_t>(frame.data[1] | (frame.data[2] << 8));
}
bool is_standard_data(const can::Frame& frame, std::uint32_t id, std::size_t length) {
  return !frame.is_extended() && !frame.is_remote() && !frame.is_error() && frame.id == id &&
         frame.length() == length;
}
// An initiate download response for the multiplexer of `frame` (an SDO frame).
can::Frame download_response(std::uint32_t id, const can::Frame& frame) {
  return can::Frame::standard(
      id, {kDownloadResponse, frame.data[1], frame.data[2], frame.data[3], 0, 0, 0, 0});
}
// An SDO request (the 8 data octets of 600h+N) as the SDO deviations see it.
SdoRequestView request_view(std::span<const std::uint8_t, 8> data) {
  SdoRequestView r;
  r.index = static_cast<std::uint16_t>(data[1] | (data[2] << 8));
  r.sub = data[3];
  switch (ccs_of(data[0])) {
    case kCcsDownloadInitiate: {
      r.kind = SdoRequestView::Kind::download;
      r.expedited = (data[0] & 0x02) != 0;
      if (r.expedited) {
        const std::size_t size = (data[0] & 0x01) != 0 ? 4 - ((data[0] >> 2) & 0x03) : 4;
        r.data.assign(data.begin() + 4, data.begin() + 4 + static_cast<std::ptrdiff_t>(size));
      }
      break;
    }
    case kCcsUploadInitiate:
      r.kind = SdoRequestView::Kind::upload;
      break;
    case kCcsDownloadSegment:
      r.kind = SdoRequestView::Kind::download_segment;
      break;
    case kCcsUploadSegment:
      r.kind = SdoRequestView::Kind::upload_segment;
      break;
    case kCcsAbort:
      r.kind = SdoRequestView::Kind::abort;
      break;
    case kCcsInvalid:
      r.kind = SdoRequestView::Kind::invalid;
      break;
    default:
      r.kind = SdoRequestView::Kind::other;
      break;  // block transfers
  }
  return r;
}
// An SDO response (580h+N, 8 octets) as the SDO deviations see it.
SdoAnswerView answer_view(const can::Frame& frame) {
  const std::uint8_t command = frame.data[0];
  const std::uint16_t index = index_of(frame);
  const std::uint8_t sub = frame.data[3];
  if (command == kAbort) return SdoAnswerView::abort_of(index, sub, load_u32(frame, 4));
  if (command == kDownloadResponse) return SdoAnswerView::confirmed(index, sub);
  if ((command & 0xE3) == 0x43) {  // scs 2, e = 1, s = 1: n in bits 2-3
    const std::size_t size = 4 - ((command >> 2) & 0x03);
    return SdoAnswerView::upload(
        index, sub,
        {frame.data.begin() + 4, frame.data.begin() + 4 + static_cast<std::ptrdiff_t>(size)});
  }
  SdoAnswerView a;
  if ((command & 0xE0) == 0x00) {  // scs 0: upload segment, toggle in bit 4
    a.kind = SdoAnswerView::Kind::upload_segment;
    a.toggle = (command & 0x10) != 0;
  }
  return a;
}
// The frame of `answer` on `id`; an upload segment keeps `original` but for its toggle bit.
can::Frame answer_frame(std::uint32_t id, const SdoAnswerView& answer, const can::Frame& original) {
  const auto lo = static_cast<std::uint8_t>(answer.index);
  const auto hi = static_cast<std::uint8_t>(answer.index >> 8);
  switch (answer.kind) {
    case SdoAnswerView::Kind::abort: {
      can::Frame frame = can::Frame::standard(id, {kAbort, lo, hi, answer.sub, 0, 0, 0, 0});
      store_u32(frame, 4, answer.code);
      return frame;
    }
    case SdoAnswerView::Kind::download_confirmed:
      return can::Frame::standard(id, {kDownloadResponse, lo, hi, answer.sub, 0, 0, 0, 0});
    case SdoAnswerView::Kind::expedited_upload: {
      const std::size_t size = std::min<std::size_t>(answer.data.size(), 4);
      can::Frame frame = can::Frame::standard(
          id,
          {static_cast<std::uint8_t>(0x43 | ((4 - size) << 2)), lo, hi, answer.sub, 0, 0, 0, 0});
      std::copy_n(answer.data.begin(), size, frame.data.begin() + 4);
      return frame;
    }
    case SdoAnswerView::Kind::upload_segment: {
      can::Frame frame = original;
      frame.id = id;
      frame.data[0] =
          static_cast<std::uint8_t>(answer.toggle ? frame.data[0] | 0x10 : frame.data[0] & ~0x10);
      return frame;
    }
    case SdoAnswerView::Kind::other:
      break;
  }
  can::Frame frame = original;
  frame.id = id;
  return frame;
}
// The objects that hold a configurable COB-ID (CiA 301 §7.3.5 restricts their CAN-IDs): SYNC
// 1005h, TIME 1012h, EMCY 1014h (sub 0); RPDO 1400h-15FFh and TPDO 1800h-19FFh (sub 1).
bool is_cob_id_object(std::uint16_t index, std::uint8_t sub) {
  if (index == 0x1005 || index == 0x1012 || index == 0x1014) return sub == 0;
  const bool pdo = (index >= 0x1400 && index <= 0x15FF) || (index >= 0x1800 && index <= 0x19FF);
  return pdo && sub == 1;
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// Names and sets

std::optional<Deviation> find_deviation(std::string_view name) {
  for (const DeviationInfo& info : kDeviations) {
    if (info.name == name) return info.deviation;
  }
  return std::nullopt;
}

std::vector<std::string_view> close_deviation_names(std::string_view name, std::size_t limit) {
  std::vector<std::pair<std::size_t, std::string_view>> ranked;
  for (const DeviationInfo& info : kDeviations) {
    const std::size_t score = closeness(name, info.name);
    if (score != static_cast<std::size_t>(-1)) ranked.emplace_back(score, info.name);
  }
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string_view> names;
  for (std::size_t i = 0; i < ranked.size() && i < limit; ++i)
    names.push_back(ranked[i].second);
  return names;
}

std::string deviation_table() {
  std::size_t name_width = 0;
  std::size_t family_width = 0;
  for (const DeviationInfo& info : kDeviations) {
    name_width = std::max(name_width, info.name.size());
    family_width = std::max(family_width, info.family.size());
  }
  std::string table;
  for (const DeviationInfo& info : kDeviations) {
    table += fmt::format("{:<{}}  {:<{}}  {:<8}  {}\n", info.name, name_width, info.family,
                         family_width, to_string(info.kind), info.description);
  }
  return table;
}

Expected<void, std::string> DeviationSet::add(std::string_view name) {
  if (const auto deviation = find_deviation(name)) {
    add(*deviation);
    return {};
  }
  std::string message = fmt::format("unknown deviation '{}'", name);
  const auto close = close_deviation_names(name);
  if (!close.empty()) message += fmt::format(" (did you mean: {}?)", fmt::join(close, ", "));
  message += fmt::format("; {} deviations exist (reference_drive/deviations.inc)", kDeviationCount);
  return Unexpected(std::move(message));
}

Expected<DeviationSet, std::string> DeviationSet::parse(std::span<const std::string> names) {
  DeviationSet set;
  for (const std::string& item : names) {
    std::string_view rest = item;
    while (true) {
      const auto comma = rest.find(',');
      std::string_view name = rest.substr(0, comma);
      while (!name.empty() && name.front() == ' ')
        name.remove_prefix(1);
      while (!name.empty() && name.back() == ' ')
        name.remove_suffix(1);
      if (!name.empty()) {
        if (auto ok = set.add(name); !ok) return Unexpected(std::move(ok).error());
      }
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
  }
  return set;
}

bool DeviationSet::any_fatal() const {
  for (Deviation deviation : list()) {
    if (info_of(deviation).kind == DeviationKind::fatal) return true;
  }
  return false;
}

std::vector<Deviation> DeviationSet::list() const {
  std::vector<Deviation> members;
  for (const DeviationInfo& info : kDeviations) {
    if (has(info.deviation)) members.push_back(info.deviation);
  }
  return members;
}

std::string DeviationSet::names() const {
  if (empty()) return "none";
  std::vector<std::string_view> members;
  for (Deviation deviation : list())
    members.push_back(to_string(deviation));
  return fmt::format("{}", fmt::join(members, ", "));
}

// ---------------------------------------------------------------------------------------------
// DeviationPort

DeviationPort::DeviationPort(can::Bus& port, DeviationSet deviations)
    : port_(port), deviations_(deviations), sdo_(std::make_unique<SdoDeviations>(deviations)) {}

DeviationPort::~DeviationPort() {
  if (held_timer_ != can::kNoTimer) port_.cancel_timer(held_timer_);
  for (can::TimerId id : timers_)
    port_.cancel_timer(id);
  if (handler_) port_.set_frame_handler({});
}

std::uint8_t DeviationPort::node() const {
  return od_ != nullptr ? od_->node_id() : 0;
}

std::optional<std::uint32_t> DeviationPort::emcy_cob_id() const {
  if (od_ == nullptr) return std::nullopt;
  const auto entry = cia301::configured_emcy_cob_id(*od_);
  if (!entry || !entry->valid || entry->extended) return std::nullopt;
  return entry->can_id;
}

std::optional<std::uint16_t> DeviationPort::pdo_number_of(cia301::PdoDirection direction,
                                                          std::uint32_t id) const {
  if (od_ == nullptr) return std::nullopt;
  for (std::uint16_t number = 1; number <= 512; ++number) {
    const std::uint16_t index = cia301::pdo_communication_index(direction, number);
    const cia301::Entry* cob = od_->find(index, cia301::pdo_sub::kCobId);
    if (cob == nullptr) break;
    const auto decoded = cia301::decode_pdo_cob_id(static_cast<std::uint32_t>(cob->as_unsigned()));
    if (decoded && decoded->valid && !decoded->extended && decoded->can_id == id) return number;
  }
  return std::nullopt;
}

bool DeviationPort::is_tpdo(std::uint32_t id, bool synchronous_only) const {
  const auto number = pdo_number_of(cia301::PdoDirection::transmit, id);
  if (!number) return false;
  if (!synchronous_only) return true;
  const cia301::Entry* type =
      od_->find(cia301::pdo_communication_index(cia301::PdoDirection::transmit, *number),
                cia301::pdo_sub::kTransmissionType);
  return type != nullptr && type->as_unsigned() <= 240;
}

std::optional<can::Frame> DeviationPort::without_dummy_bits(const can::Frame& frame) const {
  const auto number = pdo_number_of(cia301::PdoDirection::receive, frame.id);
  if (!number) return std::nullopt;
  const std::uint16_t mapping = cia301::pdo_mapping_index(cia301::PdoDirection::receive, *number);
  const cia301::Entry* count = od_->find(mapping, 0);
  if (count == nullptr) return std::nullopt;
  std::uint64_t payload = 0;
  for (std::size_t i = 0; i < frame.length() && i < 8; ++i)
    payload |= static_cast<std::uint64_t>(frame.data[i]) << (8 * i);
  std::uint64_t packed = 0;
  unsigned from = 0;
  unsigned to = 0;
  bool dummy = false;
  for (unsigned sub = 1; sub <= count->as_unsigned(); ++sub) {
    const cia301::Entry* entry = od_->find(mapping, static_cast<std::uint8_t>(sub));
    if (entry == nullptr) return std::nullopt;
    const auto value = static_cast<std::uint32_t>(entry->as_unsigned());
    const unsigned bits = value & 0xFF;
    const unsigned object = value >> 16;
    if (bits == 0 || from + bits > 64) return std::nullopt;
    if (object >= 0x0001 && object <= 0x0007) {
      dummy = true;  // takes no room: the next entry is read from here
    } else {
      const std::uint64_t mask = bits == 64 ? ~0ULL : ((1ULL << bits) - 1);
      packed |= ((payload >> from) & mask) << to;
      to += bits;
    }
    from += bits;
  }
  if (!dummy) return std::nullopt;
  can::Frame out = frame;
  for (std::size_t i = 0; i < 8; ++i)
    out.data[i] = i < frame.length() ? static_cast<std::uint8_t>(packed >> (8 * i)) : 0;
  return out;
}

bool DeviationPort::restricted_cob_id_written(const can::Frame& abort) const {
  const auto& request = last_request_data_;
  const bool expedited = ccs_of(request[0]) == kCcsDownloadInitiate && (request[0] & 0x02) != 0;
  if (!expedited || request[1] != abort.data[1] || request[2] != abort.data[2] ||
      request[3] != abort.data[3]) {
    return false;
  }
  const auto index = static_cast<std::uint16_t>(request[1] | (request[2] << 8));
  if (!is_cob_id_object(index, request[3])) return false;
  const std::uint32_t value = static_cast<std::uint32_t>(request[4]) |
                              (static_cast<std::uint32_t>(request[5]) << 8) |
                              (static_cast<std::uint32_t>(request[6]) << 16) |
                              (static_cast<std::uint32_t>(request[7]) << 24);
  const bool extended = (value & 0x20000000) != 0;
  return !extended && cia301::is_restricted_cob_id(value & 0x7FF);
}

bool DeviationPort::refuses_non_expedited_download(const can::Frame& request) {
  // Inside a block download the frames are segments (seqno | c), not initiate requests.
  if (block_download_running_) return false;
  const std::uint8_t command = request.data[0];
  const bool segmented = ccs_of(command) == kCcsDownloadInitiate && (command & 0x02) == 0;
  const bool block = (command & 0xE1) == 0xC0;  // ccs 6, cs 0: initiate block download
  if (!segmented && !block) return false;
  const std::uint16_t index = index_of(request);
  const cia301::Entry* entry = od_->find(index, request.data[3]);
  const bool refused = index != 0x1017 && entry != nullptr &&
                       !cia301::is_variable_length(entry->type()) &&
                       cia301::info(entry->type()).size <= 4;
  if (block && !refused) block_download_running_ = true;
  return refused;
}

std::error_code DeviationPort::send(const can::Frame& frame) {
  if (crashed_) return {};  // a crashed node transmits nothing (and nobody tells its software)
  const auto changed = outgoing(frame);
  if (!changed) return {};
  return port_.send(*changed);
}

std::error_code DeviationPort::transmit(const can::Frame& frame) {
  return port_.send(frame);
}

std::optional<can::Frame> DeviationPort::outgoing(const can::Frame& frame) {
  const DeviationSet& d = deviations_;
  if (od_ == nullptr || frame.is_extended() || frame.is_error()) return frame;
  const std::uint8_t node_id = node();
  can::Frame out = frame;

  // SDO responses.
  if (is_standard_data(frame, kSdoResponseBase + node_id, 8)) {
    if (sdo_hung_) return std::nullopt;
    const std::uint8_t command = frame.data[0];
    if (d.has(Deviation::sdo_block_sequence_ignored)) {
      // An abort ends the block download; a block acknowledge (scs 5, ss 2) opens the next
      // sub-block while the last segment has not come.
      if (command == kAbort) {
        block_download_seqno_ = 0;
        block_download_open_ = false;
      } else if (command == kBlockDownloadAck && block_download_open_) {
        block_download_seqno_ = 1;
      }
    }
    if (command == kAbort || command == kEndBlockDownloadResponse) block_download_running_ = false;
    if (command == kAbort) {
      const std::uint32_t code = load_u32(frame, 4);
      if (code == kAbortNoSubIndex && d.has(Deviation::fatal_sdo_hang_on_missing_sub)) {
        sdo_hung_ = true;
        return std::nullopt;
      }
      if (code == kAbortInvalidValue && d.has(Deviation::restricted_cob_id_accepted) &&
          restricted_cob_id_written(frame)) {
        return download_response(frame.id, frame);
      }
    }
    // End block upload (scs 6, ss 1) with n = 0 after the client's block acknowledge (ccs 5,
    // cs 2): n = 7 instead, the off-by-one of n = 7 - size mod 7. (A sub-block segment with c = 1
    // and seqno 65 has the same byte 0; no vector uploads that many segments.)
    if ((command & 0xE3) == kEndBlockUpload && ((command >> 2) & 0x07) == 0 &&
        last_request_ == kBlockUploadAck && d.has(Deviation::sdo_block_upload_n_seven)) {
      out.data[0] = static_cast<std::uint8_t>(command | (7U << 2));
      return out;
    }
    // The SDO service deviations, shared with CoE (sdo_deviations.hpp).
    const SdoAnswerView answer = answer_view(frame);
    if (answer.kind == SdoAnswerView::Kind::other) return out;
    const auto changed = sdo_->after(request_view(last_request_data_), answer, *od_);
    if (!changed) return std::nullopt;
    if (*changed == answer) return out;
    return answer_frame(frame.id, *changed, frame);
  }

  // Boot-up, heartbeat, guarding responses.
  if (is_standard_data(frame, kErrorControlBase + node_id, 1)) {
    const std::uint8_t state = frame.data[0];
    if (in_guarding_request_) {
      if (d.has(Deviation::guarding_toggle_not_alternated)) {
        out.data[0] = static_cast<std::uint8_t>(state & 0x7F);
      }
      return out;
    }
    const can::TimePoint now = port_.now();
    last_nmt_state_ =
        state == 0x00 ? kStatePreOperational : static_cast<std::uint8_t>(state & 0x7F);
    if (state == 0x00) {  // boot-up
      guarding_took_over_ = false;
      guarding_toggle_ = false;
      last_heartbeat_ = now;
      held_heartbeat_.reset();
      if (held_timer_ != can::kNoTimer) port_.cancel_timer(held_timer_);
      held_timer_ = can::kNoTimer;
      if (d.has(Deviation::bootup_missing)) return std::nullopt;
      if (d.has(Deviation::nmt_starts_operational)) {
        // Deviation: the drive starts itself, as if it had received NMT start (01h) right
        // after its boot-up.
        start_owned_timer(now, [this, node_id] {
          if (handler_ && !crashed_) {
            const std::array<std::uint8_t, 2> start{0x01, node_id};
            handler_(can::TimedFrame{can::Frame::standard(0x000, start), port_.now(), false});
          }
        });
      }
      return out;
    }
    if (guarding_took_over_) return std::nullopt;  // guarding-request-stops-heartbeat
    if (state == kStateStopped && d.has(Deviation::heartbeat_missing_in_stopped)) {
      return std::nullopt;
    }
    if (d.has(Deviation::heartbeat_wrong_state)) {
      if (state == kStateOperational) out.data[0] = kStatePreOperational;
      if (state == kStatePreOperational) out.data[0] = kStateOperational;
    }
    if (d.has(Deviation::heartbeat_period_long)) {
      const cia301::Entry* entry = od_->find(0x1017, 0);
      const auto period = std::chrono::milliseconds(entry != nullptr ? entry->as_unsigned() : 0);
      const can::Duration long_period = period * 11 / 10;
      if (period.count() == 0 || last_heartbeat_ == can::TimePoint::min() ||
          now >= last_heartbeat_ + long_period) {
        last_heartbeat_ = now;
        return out;
      }
      // Held back until 1.1 periods after the last one; a newer heartbeat replaces it.
      held_heartbeat_ = out;
      if (held_timer_ == can::kNoTimer) {
        held_timer_ =
            port_.start_timer(last_heartbeat_ + long_period, [this] { send_held_heartbeat(); });
      }
      return std::nullopt;
    }
    return out;
  }

  // EMCY (on 1014h's COB-ID).
  if (const auto emcy = emcy_cob_id(); emcy && is_standard_data(frame, *emcy, 8)) {
    const auto code = static_cast<std::uint16_t>(frame.data[0] | (frame.data[1] << 8));
    if (code == 0 && d.has(Deviation::emcy_error_reset_missing)) return std::nullopt;
    if ((code == 0x8210 || code == 0x8220) && d.has(Deviation::rpdo_length_error_not_reported)) {
      return std::nullopt;
    }
    if (d.has(Deviation::emcy_register_zero)) out.data[2] = 0;
    if (d.has(Deviation::emcy_cob_id_ignored)) out.id = kEmcyBase + node_id;
    return out;
  }

  // TPDOs.
  if (!frame.is_remote() &&
      (d.has(Deviation::sync_tpdo_missing) || d.has(Deviation::tpdo_wrong_length))) {
    if (d.has(Deviation::sync_tpdo_missing) && is_tpdo(frame.id, true)) {
      fake_echo(frame);  // as if lost on the wire: the PDO pacing goes on
      return std::nullopt;
    }
    if (d.has(Deviation::tpdo_wrong_length) && is_tpdo(frame.id, false)) out.dlc = 8;
  }
  return out;
}

std::optional<can::Frame> DeviationPort::incoming(const can::Frame& frame) {
  const DeviationSet& d = deviations_;
  if (od_ == nullptr || frame.is_extended() || frame.is_error()) return frame;
  const std::uint8_t node_id = node();
  can::Frame in = frame;

  // NMT node control: byte 0 command specifier, byte 1 node-ID (0: all).
  if (is_standard_data(frame, kNmtId, 2)) {
    const std::uint8_t command = frame.data[0];
    const std::uint8_t target = frame.data[1];
    const bool for_us = target == 0 || target == node_id;
    const bool known =
        command == 0x01 || command == 0x02 || command == 0x80 || command == 0x81 || command == 0x82;
    if (for_us && !known && d.has(Deviation::fatal_babble_on_unknown_nmt)) {
      if (!babbling_) {
        babbling_ = true;
        babble();
      }
      return std::nullopt;
    }
    if (target == 0 && d.has(Deviation::nmt_broadcast_ignored)) return std::nullopt;
    if (for_us && command == 0x02 && d.has(Deviation::nmt_stop_ignored)) return std::nullopt;
    if (!for_us && d.has(Deviation::nmt_other_node_obeyed)) in.data[1] = node_id;
    return in;
  }

  // SDO requests.
  if (is_standard_data(frame, kSdoRequestBase + node_id, 8)) {
    if (sdo_hung_) return std::nullopt;
    // Block download segments numbered in the order they come: a segment with a valid seqno
    // (1..127) gets the one the server expects next, so a lost segment goes unnoticed.
    if (d.has(Deviation::sdo_block_sequence_ignored)) {
      const std::uint8_t seqno = frame.data[0] & 0x7F;
      const bool last = (frame.data[0] & 0x80) != 0;
      if (block_download_seqno_ != 0 && seqno != 0) {
        in.data[0] = static_cast<std::uint8_t>((frame.data[0] & 0x80) | block_download_seqno_);
        block_download_seqno_ = last || block_download_seqno_ == kMaxBlockSize
                                    ? 0
                                    : static_cast<std::uint8_t>(block_download_seqno_ + 1);
        if (last) block_download_open_ = false;
        return in;
      }
      if (block_download_seqno_ == 0 && (frame.data[0] & 0xE1) == 0xC0) {  // ccs 6, cs 0
        block_download_seqno_ = 1;
        block_download_open_ = true;
      }
    }
    if (ccs_of(frame.data[0]) == kCcsInvalid && d.has(Deviation::fatal_crash_on_invalid_command)) {
      crashed_ = true;
      babbling_ = false;
      return std::nullopt;
    }
    last_request_ = frame.data[0];
    std::copy(frame.data.begin(), frame.data.begin() + 8, last_request_data_.begin());
    if (d.has(Deviation::sdo_non_expedited_download_heartbeat_only) &&
        refuses_non_expedited_download(frame)) {
      (void)send(answer_frame(
          kSdoResponseBase + node_id,
          SdoAnswerView::abort_of(index_of(frame), frame.data[3], kAbortUnsupportedAccess), frame));
      return std::nullopt;
    }
    // The SDO service deviations, shared with CoE (sdo_deviations.hpp): answered here, or the
    // data of an expedited download replaced (as 4 octets, e = 1, s = 1, n = 0).
    const SdoBefore before = sdo_->before(request_view(last_request_data_), *od_);
    if (before.answer) {
      (void)send(answer_frame(kSdoResponseBase + node_id, *before.answer, frame));
      return std::nullopt;
    }
    if (before.replaced && before.replaced->size() == 4) {
      in.data[0] = 0x23;
      std::copy(before.replaced->begin(), before.replaced->end(), in.data.begin() + 4);
    }
    return in;
  }

  if (frame.is_remote()) {
    if (frame.id == kErrorControlBase + node_id && d.has(Deviation::guarding_no_response)) {
      return std::nullopt;
    }
    if (frame.id == kErrorControlBase + node_id) {
      const auto value_of = [this](std::uint16_t index) {
        const cia301::Entry* entry = od_->find(index, 0);
        return entry != nullptr ? entry->as_unsigned() : 0;
      };
      // The firmware takes a guarding request as the master's choice of guarding, when guarding
      // is configured: the heartbeat stops.
      if (d.has(Deviation::guarding_request_stops_heartbeat) && value_of(0x100C) != 0 &&
          value_of(0x100D) != 0) {
        guarding_took_over_ = true;
      }
      // The firmware leaves guarding requests to the heartbeat only while guarding is
      // configured: with the guard time 0 it answers them, heartbeat or not.
      if (d.has(Deviation::guarding_answered_with_guard_time_zero) && value_of(0x1017) != 0 &&
          value_of(0x100C) == 0) {
        const auto answer =
            static_cast<std::uint8_t>((guarding_toggle_ ? 0x80 : 0x00) | last_nmt_state_);
        guarding_toggle_ = !guarding_toggle_;
        (void)transmit(can::Frame::standard(kErrorControlBase + node_id, {answer}));
        return std::nullopt;
      }
    }
    // A guarding request of any node (700h + 1..127) taken as one for this drive.
    if (d.has(Deviation::guarding_any_node_id) && frame.id > kErrorControlBase &&
        frame.id <= kErrorControlBase + 0x7F) {
      in.id = kErrorControlBase + node_id;
      return in;
    }
    if (d.has(Deviation::pdo_rtr_ignored) && is_tpdo(frame.id, false)) return std::nullopt;
  } else if (d.has(Deviation::pdo_dummy_entry_takes_no_room)) {
    if (auto read = without_dummy_bits(frame)) return read;
  }
  return in;
}

void DeviationPort::on_frame(const can::TimedFrame& timed) {
  if (crashed_ || !handler_) return;
  if (timed.own) {
    if (babbling_ && timed.frame.id == kEmcyBase + node()) {
      babble();
      return;
    }
    handler_(timed);
    return;
  }
  const auto frame = incoming(timed.frame);
  if (!frame) return;
  in_guarding_request_ = frame->is_remote() && frame->id == kErrorControlBase + node();
  const FrameHandler handler = handler_;  // the handler may replace itself
  handler(can::TimedFrame{*frame, timed.timestamp, false});
  in_guarding_request_ = false;
}

std::optional<can::TimedFrame> DeviationPort::receive(can::TimePoint deadline) {
  while (true) {
    auto timed = port_.receive(deadline);
    if (!timed) return std::nullopt;
    if (crashed_) continue;
    if (timed->own) return timed;
    if (auto frame = incoming(timed->frame)) {
      return can::TimedFrame{*frame, timed->timestamp, false};
    }
  }
}

void DeviationPort::set_frame_handler(FrameHandler handler) {
  handler_ = std::move(handler);
  if (handler_) {
    port_.set_frame_handler([this](const can::TimedFrame& frame) { on_frame(frame); });
  } else {
    port_.set_frame_handler({});
  }
}

void DeviationPort::set_loopback(bool enabled) {
  loopback_ = enabled;
  port_.set_loopback(enabled);
}

void DeviationPort::start_owned_timer(can::TimePoint at, std::function<void()> callback) {
  auto id = std::make_shared<can::TimerId>(can::kNoTimer);
  *id = port_.start_timer(at, [this, id, callback = std::move(callback)] {
    std::erase(timers_, *id);
    callback();
  });
  timers_.push_back(*id);
}

void DeviationPort::fake_echo(const can::Frame& frame) {
  if (!loopback_) return;
  start_owned_timer(port_.now(), [this, frame] {
    if (handler_ && !crashed_) handler_(can::TimedFrame{frame, port_.now(), true});
  });
}

void DeviationPort::send_held_heartbeat() {
  held_timer_ = can::kNoTimer;
  if (!held_heartbeat_ || crashed_) return;
  last_heartbeat_ = port_.now();
  (void)transmit(*held_heartbeat_);
  held_heartbeat_.reset();
}

void DeviationPort::babble() {
  if (!babbling_ || crashed_) return;
  // Garbage on the node's EMCY identifier, back to back: the next one is queued when the
  // previous one comes back (loopback), else every 100 µs.
  const can::Frame frame =
      can::Frame::standard(kEmcyBase + node(), {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF});
  if (transmit(frame)) {
    babbling_ = false;  // bus-off or queue full: the controller gave up
    return;
  }
  if (!loopback_) {
    start_owned_timer(port_.now() + std::chrono::microseconds(100), [this] { babble(); });
  }
}

}  // namespace drivecheck::reference_drive

#include "protocol/ethercat/mailbox.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>

namespace drivecheck::ethercat {
namespace {

constexpr MailboxTypeInfo kTypes[] = {
#define DRIVECHECK_MAILBOX_TYPE(name, value, abbreviation, text) \
  {MailboxType::name, #name, abbreviation, text},
#include "protocol/ethercat/mailbox_types.inc"
#undef DRIVECHECK_MAILBOX_TYPE
};

constexpr MailboxErrorInfo kErrors[] = {
#define DRIVECHECK_MAILBOX_ERROR(name, value, text, source) \
  {MailboxError::name, #name, text, source},
#include "protocol/ethercat/mailbox_error_codes.inc"
#undef DRIVECHECK_MAILBOX_ERROR
};

constexpr bool errors_ascending() {
  for (std::size_t i = 1; i < std::size(kErrors); ++i) {
    if (static_cast<std::uint16_t>(kErrors[i - 1].code) >=
        static_cast<std::uint16_t>(kErrors[i].code)) {
      return false;
    }
  }
  return true;
}
static_assert(errors_ascending(), "mailbox_error_codes.inc: ascending codes, once each");

constexpr bool types_ascending() {
  for (std::size_t i = 1; i < std::size(kTypes); ++i) {
    if (static_cast<std::uint8_t>(kTypes[i - 1].type) >=
        static_cast<std::uint8_t>(kTypes[i].type)) {
      return false;
    }
  }
  return true;
}
static_assert(types_ascending(), "mailbox_types.inc: ascending values, once each");

class MailboxErrorCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "ethercat-mailbox"; }
  std::string message(int value) const override {
    return describe_mailbox_error(static_cast<std::uint16_t>(value));
  }
};

void put16(std::uint16_t value, std::uint8_t* out) {
  out[0] = static_cast<std::uint8_t>(value & 0xFF);
  out[1] = static_cast<std::uint8_t>(value >> 8);
}
std::uint16_t get16(const std::uint8_t* in) {
  return static_cast<std::uint16_t>(in[0] | (in[1] << 8));
}

}  // namespace

std::span<const MailboxTypeInfo> mailbox_type_table() {
  return kTypes;
}

std::optional<MailboxTypeInfo> find_mailbox_type(std::uint8_t value) {
  for (const auto& row : kTypes) {
    if (static_cast<std::uint8_t>(row.type) == value) return row;
  }
  return std::nullopt;
}

std::string describe_mailbox_type(std::uint8_t value) {
  if (const auto row = find_mailbox_type(value)) return std::string(row->abbreviation);
  return fmt::format("type {} (reserved)", value);
}

std::span<const MailboxErrorInfo> mailbox_error_table() {
  return kErrors;
}

std::optional<MailboxErrorInfo> find_mailbox_error(std::uint16_t value) {
  for (const auto& row : kErrors) {
    if (static_cast<std::uint16_t>(row.code) == value) return row;
  }
  return std::nullopt;
}

std::string describe_mailbox_error(std::uint16_t value) {
  if (const auto row = find_mailbox_error(value)) {
    return fmt::format("{:04X}h {}: {}", value, row->name, row->text);
  }
  return fmt::format("{:04X}h (unknown mailbox error code)", value);
}

const std::error_category& mailbox_error_category() {
  static const MailboxErrorCategory category;
  return category;
}

std::error_code make_error_code(MailboxError error) {
  return {static_cast<int>(error), mailbox_error_category()};
}

void encode_mailbox_header(const MailboxHeader& header, std::span<std::uint8_t, 6> out) {
  put16(header.length, &out[0]);
  put16(header.address, &out[2]);
  out[4] = static_cast<std::uint8_t>((header.channel & 0x3F) | ((header.priority & 0x03) << 6));
  out[5] = static_cast<std::uint8_t>((header.type & 0x0F) | ((header.counter & 0x07) << 4) |
                                     (header.reserved ? 0x80 : 0x00));
}

MailboxHeader decode_mailbox_header(std::span<const std::uint8_t, 6> bytes) {
  MailboxHeader h;
  h.length = get16(&bytes[0]);
  h.address = get16(&bytes[2]);
  h.channel = bytes[4] & 0x3F;
  h.priority = static_cast<std::uint8_t>(bytes[4] >> 6);
  h.type = bytes[5] & 0x0F;
  h.counter = static_cast<std::uint8_t>((bytes[5] >> 4) & 0x07);
  h.reserved = (bytes[5] & 0x80) != 0;
  return h;
}

Expected<MailboxMessage, MailboxError> parse_mailbox(std::span<const std::uint8_t> buffer) {
  if (buffer.size() < kMailboxHeaderSize) return Unexpected(MailboxError::size_too_short);
  MailboxMessage message;
  message.header = decode_mailbox_header(buffer.first<kMailboxHeaderSize>());
  const auto rest = buffer.subspan(kMailboxHeaderSize);
  if (message.header.length > rest.size()) return Unexpected(MailboxError::invalid_size);
  message.data = rest.first(message.header.length);
  return message;
}

std::vector<std::uint8_t> build_mailbox(MailboxHeader header, std::span<const std::uint8_t> data,
                                        std::size_t buffer_size) {
  header.length = static_cast<std::uint16_t>(data.size());
  std::vector<std::uint8_t> out(std::max(kMailboxHeaderSize + data.size(), buffer_size), 0);
  encode_mailbox_header(header, std::span<std::uint8_t, 6>(out.data(), 6));
  std::copy(data.begin(), data.end(), out.begin() + kMailboxHeaderSize);
  return out;
}

std::vector<std::uint8_t> mailbox_error_data(MailboxError error) {
  std::vector<std::uint8_t> out(kMailboxErrorDataSize);
  put16(kMailboxErrorService, &out[0]);
  put16(static_cast<std::uint16_t>(error), &out[2]);
  return out;
}

Expected<std::uint16_t, MailboxError> parse_mailbox_error_data(std::span<const std::uint8_t> data) {
  if (data.size() < kMailboxErrorDataSize) return Unexpected(MailboxError::size_too_short);
  if (get16(&data[0]) != kMailboxErrorService) {
    return Unexpected(MailboxError::service_not_supported);
  }
  return get16(&data[2]);
}

// ---- MailboxSlave ---------------------------------------------------------------------------

MailboxSlave::MailboxSlave(MailboxSlaveConfig config) : config_(std::move(config)) {}

bool MailboxSlave::serves(std::uint8_t type) const {
  return std::any_of(config_.protocols.begin(), config_.protocols.end(),
                     [&](MailboxType t) { return static_cast<std::uint8_t>(t) == type; });
}

void MailboxSlave::queue_error(MailboxError error, std::uint16_t address) {
  const auto data = mailbox_error_data(error);
  // An ERR reply always fits (10 octets); the queue limit still holds: a flood of bad requests
  // must not grow the queue without bound.
  (void)post(MailboxType::err, data, address);
}

MailboxReceived MailboxSlave::receive(std::span<const std::uint8_t> buffer) {
  MailboxReceived result;
  auto parsed = parse_mailbox(buffer);
  if (!parsed) {
    // No header to echo: the Address of a reply to garbage is 0 (the master).
    std::uint16_t address = 0;
    if (buffer.size() >= kMailboxHeaderSize) {
      address = decode_mailbox_header(buffer.first<kMailboxHeaderSize>()).address;
    }
    result.error = parsed.error();
    queue_error(parsed.error(), address);
    return result;
  }
  result.message = *parsed;
  const MailboxHeader& h = result.message.header;
  if (kMailboxHeaderSize + h.length > config_.write_size) {
    result.error = MailboxError::invalid_size;
  } else if (h.type == static_cast<std::uint8_t>(MailboxType::err) || !serves(h.type)) {
    // A master has no business sending an ERR message: it is no protocol the slave serves.
    result.error = MailboxError::unsupported_protocol;
  } else if (config_.check_channel && h.channel != 0) {
    result.error = MailboxError::invalid_channel;
  }
  if (result.error) {
    queue_error(*result.error, h.address);
    return result;
  }
  if (config_.honour_counter && h.counter != 0 && h.counter == last_request_counter_) {
    result.receipt = MailboxReceipt::repeated;
    if (config_.repeat == RepeatPolicy::reply_again && queue_.empty() && last_taken_) {
      queue_.push_back(*last_taken_);
    }
    return result;
  }
  last_request_counter_ = h.counter;
  result.receipt = MailboxReceipt::deliver;
  return result;
}

Expected<void, MailboxError> MailboxSlave::post(MailboxType type,
                                                std::span<const std::uint8_t> data,
                                                std::uint16_t address, std::uint8_t priority) {
  if (kMailboxHeaderSize + data.size() > config_.read_size) {
    return Unexpected(MailboxError::invalid_size);
  }
  if (queue_.size() >= config_.queue_limit) return Unexpected(MailboxError::no_more_memory);
  reply_counter_ = next_mailbox_counter(reply_counter_);
  MailboxHeader h;
  h.address = address;
  h.priority = priority;
  h.type = static_cast<std::uint8_t>(type);
  h.counter = reply_counter_;
  queue_.push_back(build_mailbox(h, data, config_.read_size));
  return {};
}

std::optional<std::vector<std::uint8_t>> MailboxSlave::take_reply() {
  if (queue_.empty()) return std::nullopt;
  last_taken_ = std::move(queue_.front());
  queue_.pop_front();
  return last_taken_;
}

std::optional<std::vector<std::uint8_t>> MailboxSlave::repeat_last() const {
  return last_taken_;
}

void MailboxSlave::reset() {
  last_request_counter_ = 0;
  reply_counter_ = 0;
  queue_.clear();
  last_taken_.reset();
}

// ---- MailboxMaster --------------------------------------------------------------------------

MailboxMaster::MailboxMaster(MailboxMasterConfig config) : config_(config) {}

std::vector<std::uint8_t> MailboxMaster::request(MailboxType type,
                                                 std::span<const std::uint8_t> data,
                                                 std::chrono::nanoseconds now,
                                                 std::uint8_t priority) {
  request_counter_ = next_mailbox_counter(request_counter_);
  MailboxHeader h;
  h.address = config_.address;
  h.priority = priority;
  h.type = static_cast<std::uint8_t>(type);
  h.counter = request_counter_;
  last_request_ = build_mailbox(h, data, config_.write_size);
  waiting_since_ = now;
  return last_request_;
}

std::optional<std::vector<std::uint8_t>> MailboxMaster::repeat_request(
    std::chrono::nanoseconds now) {
  if (last_request_.empty()) return std::nullopt;
  waiting_since_ = now;
  return last_request_;
}

Expected<MailboxReply, MailboxError> MailboxMaster::accept(std::span<const std::uint8_t> buffer) {
  auto parsed = parse_mailbox(buffer);
  if (!parsed) return Unexpected(parsed.error());
  MailboxReply reply;
  reply.message = *parsed;
  const std::uint8_t counter = reply.message.header.counter;
  if (counter == 0) {
    reply.order = ReplyOrder::uncounted;
  } else if (!last_reply_counter_ || *last_reply_counter_ == 0) {
    reply.order = ReplyOrder::next;
  } else if (counter == *last_reply_counter_) {
    reply.order = ReplyOrder::duplicate;
  } else if (counter != next_mailbox_counter(*last_reply_counter_)) {
    reply.order = ReplyOrder::gap;
    // Steps from the expected counter to the one received, in the 1..7 cycle.
    const int expected = next_mailbox_counter(*last_reply_counter_);
    reply.lost =
        static_cast<std::uint8_t>((counter - expected + kMailboxCounterMax) % kMailboxCounterMax);
  }
  last_reply_counter_ = counter;
  if (reply.message.header.type == static_cast<std::uint8_t>(MailboxType::err)) {
    auto detail = parse_mailbox_error_data(reply.message.data);
    if (!detail) return Unexpected(detail.error());
    reply.error = *detail;
  }
  return reply;
}

bool MailboxMaster::reply_overdue(std::chrono::nanoseconds now) const {
  return waiting_since_ && now - *waiting_since_ > config_.reply_timeout;
}

void MailboxMaster::reset() {
  request_counter_ = 0;
  last_reply_counter_.reset();
  waiting_since_.reset();
  last_request_.clear();
  repeat_bit_ = false;
}

}  // namespace drivecheck::ethercat

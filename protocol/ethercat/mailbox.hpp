// The EtherCAT mailbox (ETG.1000.4 data link layer mailbox, ETG.1000.6 mailbox protocols):
// the 6-octet header, the counter rules, mailbox error replies, and two pure state machines, the
// slave's (fed the bytes the master wrote into the write mailbox SyncManager, SM0, handing out
// the bytes for the read mailbox, SM1) and the master's (building requests, matching replies).
// No I/O, no ESC registers: the slave front end and the master's link layer move the bytes.
//
// Mailbox header, little-endian (public layout: Wireshark's packet-ecatmb.h, contributed by
// Beckhoff; the Beckhoff SSC mailbox.h TMBXHEADER):
//   byte 0-1  Length    octets of mailbox data after the header (the SM buffer may be longer:
//                       the rest is padding up to the SM length)
//   byte 2-3  Address   master → slave: station address of the source (0 = the master);
//                       slave → master: station address of the destination
//   byte 4    bits 0..5 Channel (0; a slave may ignore it), bits 6..7 Priority (0 lowest .. 3)
//   byte 5    bits 0..3 Type (mailbox_types.inc), bits 4..6 Cnt, bit 7 reserved (0)
//
// Counter (Cnt): 1..7, incremented by the sender for every new message and wrapping 7 → 1;
// 0 means the sender does not use the counter. Each direction counts on its own.
//  - The slave treats a request whose counter equals the previous request's (non-zero) counter
//    as a repeat of it: the service is not executed again. It answers again with its last reply
//    when that reply was already taken from the read mailbox (the master lost it), else it
//    drops the repeat (the reply is still queued). RepeatPolicy::discard drops it always.
//  - The master matches replies: a reply whose counter follows the previous one is new; the same
//    counter again is a duplicate (a repeated reply); a jump means replies were lost.
//  - Repeat request (the master toggles the SM1 repeat bit, the slave acknowledges by toggling
//    its repeat-ack bit): MailboxSlave::repeat_last() gives the last reply again, unchanged, same
//    counter; the front end puts it back into SM1 and toggles the ack.
//
// Mailbox error reply (Type 0 ERR), 4 octets of data:
//   byte 0-1  Type   0001h: mailbox command (the only service)
//   byte 2-3  Detail the error code (mailbox_error_codes.inc)
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "protocol/common/expected.hpp"

namespace drivecheck::ethercat {

inline constexpr std::size_t kMailboxHeaderSize = 6;
inline constexpr std::uint16_t kMailboxErrorService = 0x0001;  // the ERR reply's Type field
inline constexpr std::size_t kMailboxErrorDataSize = 4;
inline constexpr std::uint8_t kMailboxCounterMax = 7;

enum class MailboxType : std::uint8_t {
#define DRIVECHECK_MAILBOX_TYPE(name, value, abbreviation, text) name = value,
#include "protocol/ethercat/mailbox_types.inc"
#undef DRIVECHECK_MAILBOX_TYPE
};

struct MailboxTypeInfo {
  MailboxType type;
  std::string_view name;          // enumerator: "coe"
  std::string_view abbreviation;  // "CoE"
  std::string_view text;
};
std::span<const MailboxTypeInfo> mailbox_type_table();
// The row of a Type field value; nullopt for the reserved values 6..14.
std::optional<MailboxTypeInfo> find_mailbox_type(std::uint8_t value);
// "CoE", or "type 9 (reserved)".
std::string describe_mailbox_type(std::uint8_t value);

enum class MailboxError : std::uint16_t {
#define DRIVECHECK_MAILBOX_ERROR(name, value, text, source) name = value,
#include "protocol/ethercat/mailbox_error_codes.inc"
#undef DRIVECHECK_MAILBOX_ERROR
};

struct MailboxErrorInfo {
  MailboxError code;
  std::string_view name;
  std::string_view text;
  std::string_view source;
};
std::span<const MailboxErrorInfo> mailbox_error_table();
std::optional<MailboxErrorInfo> find_mailbox_error(std::uint16_t value);
// "0006h size_too_short: Length of the received mailbox data is too short", or
// "0042h (unknown mailbox error code)".
std::string describe_mailbox_error(std::uint16_t value);
const std::error_category& mailbox_error_category();
std::error_code make_error_code(MailboxError error);

struct MailboxHeader {
  std::uint16_t length = 0;
  std::uint16_t address = 0;
  std::uint8_t channel = 0;   // 0..63
  std::uint8_t priority = 0;  // 0..3
  std::uint8_t type = 0;      // raw 4-bit Type (MailboxType for the known values)
  std::uint8_t counter = 0;   // 0..7
  bool reserved = false;      // byte 5 bit 7 as received (encoders write it as given)

  friend bool operator==(const MailboxHeader&, const MailboxHeader&) = default;
};

// Writes the header into 6 octets. Fields wider than their bits are masked.
void encode_mailbox_header(const MailboxHeader& header, std::span<std::uint8_t, 6> out);
// Reads 6 octets (total: every bit pattern is a header).
MailboxHeader decode_mailbox_header(std::span<const std::uint8_t, 6> bytes);

// A header plus its data; `data` views the buffer it was parsed from.
struct MailboxMessage {
  MailboxHeader header;
  std::span<const std::uint8_t> data;
};

// Parses a mailbox buffer (the SM content: header, Length octets of data, padding).
// Errors: fewer than 6 octets → size_too_short; Length past the buffer → invalid_size.
Expected<MailboxMessage, MailboxError> parse_mailbox(std::span<const std::uint8_t> buffer);

// Header + data, padded with zeros to `buffer_size` when that is larger (a whole SM buffer);
// the header's Length is set to data.size().
std::vector<std::uint8_t> build_mailbox(MailboxHeader header, std::span<const std::uint8_t> data,
                                        std::size_t buffer_size = 0);

// The 4 data octets of an ERR reply.
std::vector<std::uint8_t> mailbox_error_data(MailboxError error);
// Reads an ERR reply's data: the Detail code (any value, known or not). Errors: fewer than 4
// octets → size_too_short; a Type other than 0001h → service_not_supported.
Expected<std::uint16_t, MailboxError> parse_mailbox_error_data(std::span<const std::uint8_t> data);

// The counter after `counter`: 1..7 wrapping 7 → 1 (0 → 1).
constexpr std::uint8_t next_mailbox_counter(std::uint8_t counter) {
  return counter >= kMailboxCounterMax ? 1 : static_cast<std::uint8_t>(counter + 1);
}

// ---------------------------------------------------------------------------------------------
// Slave side
// ---------------------------------------------------------------------------------------------

enum class RepeatPolicy : std::uint8_t {
  reply_again,  // a repeated request gets the last reply again when it was already taken
  discard,      // a repeated request is dropped
};

struct MailboxSlaveConfig {
  std::size_t write_size = 128;  // SM0 length: the largest request (header included)
  std::size_t read_size = 128;   // SM1 length: the largest reply (header included)
  std::vector<MailboxType> protocols{MailboxType::coe};  // what the slave serves
  bool check_channel = true;                             // refuse Channel != 0 with invalid_channel
  RepeatPolicy repeat = RepeatPolicy::reply_again;
  // false is a fault for named deviations ("mailbox counter ignored"): every request is
  // delivered, a repeated one is executed again.
  bool honour_counter = true;
  std::size_t queue_limit = 16;  // replies waiting for SM1; more → no_more_memory
};

// What a write into the write mailbox came to.
enum class MailboxReceipt : std::uint8_t {
  deliver,   // a new request for the protocol named in the message's header
  repeated,  // the same counter as the previous request: not to be executed again
  refused,   // malformed or unsupported: an ERR reply is queued (error says which)
};

struct MailboxReceived {
  MailboxReceipt receipt = MailboxReceipt::refused;
  MailboxMessage message;             // deliver/repeated: the request
  std::optional<MailboxError> error;  // refused: the code of the queued ERR reply
};

class MailboxSlave {
 public:
  explicit MailboxSlave(MailboxSlaveConfig config = {});

  const MailboxSlaveConfig& config() const { return config_; }

  // The master wrote `buffer` into SM0. A refused message queues its ERR reply (Address
  // echoed, counter of the slave's sequence).
  MailboxReceived receive(std::span<const std::uint8_t> buffer);

  // Queues a message for the read mailbox (data after the header). Errors: the message does not
  // fit SM1 → invalid_size; the queue is full → no_more_memory.
  Expected<void, MailboxError> post(MailboxType type, std::span<const std::uint8_t> data,
                                    std::uint16_t address = 0, std::uint8_t priority = 0);

  // The next message for SM1 (read_size octets, padded), or nullopt when none waits. The
  // front end calls it when SM1 is free (the master read the previous one).
  std::optional<std::vector<std::uint8_t>> take_reply();
  // Repeat request: the last message taken, again, unchanged (nullopt when none was taken).
  std::optional<std::vector<std::uint8_t>> repeat_last() const;

  // Queues an ERR reply (e.g. a protocol handler's service_not_supported).
  void post_error(MailboxError error, std::uint16_t address = 0) { queue_error(error, address); }

  std::size_t pending() const { return queue_.size(); }
  // Back to the power-on state (INIT): no counters seen, queue and last reply forgotten.
  void reset();

 private:
  void queue_error(MailboxError error, std::uint16_t address);
  bool serves(std::uint8_t type) const;

  MailboxSlaveConfig config_;
  std::uint8_t last_request_counter_ = 0;  // 0: none yet (or the master does not count)
  std::uint8_t reply_counter_ = 0;
  std::deque<std::vector<std::uint8_t>> queue_;
  std::optional<std::vector<std::uint8_t>> last_taken_;
};

// ---------------------------------------------------------------------------------------------
// Master side
// ---------------------------------------------------------------------------------------------

enum class ReplyOrder : std::uint8_t {
  next,       // the counter follows the previous reply's (or the first reply seen)
  duplicate,  // the same counter as the previous reply: a reply seen before
  gap,        // the counter skips: `lost` replies were never read
  uncounted,  // counter 0: the slave does not count
};

struct MailboxReply {
  MailboxMessage message;
  ReplyOrder order = ReplyOrder::next;
  std::uint8_t lost = 0;               // gap: replies skipped (1..5)
  std::optional<std::uint16_t> error;  // an ERR reply: its Detail code
};

struct MailboxMasterConfig {
  std::size_t write_size = 128;  // the slave's SM0 length (requests are padded to it)
  std::uint16_t address = 0;     // the master's own address in the Address field
  std::chrono::nanoseconds reply_timeout = std::chrono::milliseconds(100);
};

class MailboxMaster {
 public:
  explicit MailboxMaster(MailboxMasterConfig config = {});

  // A new request: the next counter, padded to write_size. Precondition: it fits
  // (6 + data.size() <= write_size); see fits().
  std::vector<std::uint8_t> request(MailboxType type, std::span<const std::uint8_t> data,
                                    std::chrono::nanoseconds now, std::uint8_t priority = 0);
  bool fits(std::size_t data_size) const {
    return kMailboxHeaderSize + data_size <= config_.write_size;
  }
  // The last request again, same counter (a resend after the write was lost).
  std::optional<std::vector<std::uint8_t>> repeat_request(std::chrono::nanoseconds now);
  std::uint8_t last_request_counter() const { return request_counter_; }

  // A read of SM1. Errors: the buffer is no mailbox (size_too_short / invalid_size).
  Expected<MailboxReply, MailboxError> accept(std::span<const std::uint8_t> buffer);

  // Repeat request (ETG.1000.4 mailbox repeat: the master toggles the repeat request bit of
  // SM1, the slave puts its last reply back into SM1 and toggles its repeat acknowledge bit to
  // the same value). toggle_repeat_request() gives the bit to write; repeat_acknowledged(ack)
  // says whether the slave's ack bit shows it done (then read SM1 again).
  bool toggle_repeat_request() {
    repeat_bit_ = !repeat_bit_;
    return repeat_bit_;
  }
  bool repeat_acknowledged(bool ack_bit) const { return ack_bit == repeat_bit_; }

  // The caller's transaction got its answer (a reply it matched): the wait ends. Unsolicited
  // messages (a CoE emergency) arrive through accept() too, so accept() cannot end it.
  void reply_matched() { waiting_since_.reset(); }
  // True while a request waits for its reply longer than reply_timeout: the reply is lost.
  bool reply_overdue(std::chrono::nanoseconds now) const;
  bool awaiting_reply() const { return waiting_since_.has_value(); }
  void reset();

 private:
  MailboxMasterConfig config_;
  std::uint8_t request_counter_ = 0;
  std::optional<std::uint8_t> last_reply_counter_;
  std::optional<std::chrono::nanoseconds> waiting_since_;
  std::vector<std::uint8_t> last_request_;
  bool repeat_bit_ = false;
};

}  // namespace drivecheck::ethercat

template <>
struct std::is_error_code_enum<drivecheck::ethercat::MailboxError> : std::true_type {};

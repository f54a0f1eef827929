// The master's mailbox over the link: polling the slave's read mailbox (SM1), writing its write
// mailbox (SM0), the repeat request on a lost reply, and CoE SDO transfers on top (the
// protocol state machines are mailbox.hpp MailboxMaster and coe_sdo_client.hpp CoeSdoClient;
// this file moves their bytes). Sources: ESC datasheet Section I §8.2 (mailbox SyncManager:
// written only while empty, read only while full, the last byte flips the state; repeat
// request: the master toggles SM activate bit 1, the slave writes the last reply again and
// toggles PDI control bit 1 to match), ETG.1000.4/.6 (mailbox, CoE).
//
// Sending: FPWR of the whole SM0 buffer; working counter 1 = taken. 0 = SM0 still full (the
// slave has not read the previous request): polled again until MailboxPollOptions::timeout
// (mailbox_timeout). A lost frame is sent again (same counter: the slave does not execute a
// repeated request twice).
//
// Receiving: one frame with FPRD of SM1's status byte (080Dh, bit 3 full) and FPRD of the
// whole SM1 buffer; the buffer's working counter 1 means a message was read (the ESC answers an
// empty mailbox with working counter 0). That frame is never resent blindly (reading empties
// SM1): when it is lost, the master toggles the repeat request and waits for the slave's
// acknowledge, then reads again. Duplicate replies (the same counter, ReplyOrder::duplicate)
// are dropped. A CoE emergency read while waiting for something else is queued
// (emergencies()).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <vector>

#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/coe_sdo_client.hpp"
#include "protocol/ethercat/mailbox.hpp"
#include "protocol/ethercat/master_config.hpp"
#include "protocol/ethercat/master_link.hpp"

namespace drivecheck::ethercat {

struct MailboxPollOptions {
  Duration timeout = std::chrono::seconds(1);  // for a reply, and for SM0 to become free
  Duration poll_interval = std::chrono::microseconds(20);
  unsigned repeat_attempts = 3;  // repeat requests for one lost reply
};

// One message read from SM1 (owned bytes).
struct MailboxIn {
  MailboxHeader header;
  std::vector<std::uint8_t> data;      // Length octets after the header
  std::optional<std::uint16_t> error;  // an ERR reply: its Detail
  ReplyOrder order = ReplyOrder::next;
};

class MasterMailbox {
 public:
  // `layout` must have mailbox_out and mailbox_in (else not_configured on every call).
  MasterMailbox(MasterPort& port, const SlaveLayout& layout, MailboxPollOptions options = {});

  Expected<void, MasterError> send(MailboxType type, std::span<const std::uint8_t> data);
  // Writes `buffer` into SM0 exactly as given (header, counter and all; padded with zeros to
  // the SM0 length, at most that long): the raw access a conformance tool or a fuzzer needs to
  // send malformed mailboxes. The same FPWR and full-mailbox polling as send(). The counter in
  // the buffer is the caller's business: take it from protocol().request() (then mutate the
  // bytes) to keep the master's sequence and the slave's apart from collisions.
  Expected<void, MasterError> send_raw(std::span<const std::uint8_t> buffer);
  // The next message from SM1 until `deadline` (nullopt then). Duplicates are skipped.
  Expected<std::optional<MailboxIn>, MasterError> receive(TimePoint deadline);
  // One poll of SM1: a message, or nullopt when it is empty.
  Expected<std::optional<MailboxIn>, MasterError> poll();

  // CoE SDO upload / download (expedited, normal, segmented as the size needs). Errors:
  // sdo_abort (abort_code: the server's, or the client's when the server broke the protocol),
  // mailbox_timeout (the client's abort 05040000h is sent), mailbox_error (ERR reply).
  Expected<std::vector<std::uint8_t>, MasterError> sdo_upload(Multiplexer mux,
                                                              bool complete_access = false);
  Expected<void, MasterError> sdo_download(
      Multiplexer mux, std::span<const std::uint8_t> data, bool complete_access = false,
      CoeDownloadTransfer transfer = CoeDownloadTransfer::expedited_if_it_fits);

  std::deque<CoeEmergency>& emergencies() { return emergencies_; }
  MailboxMaster& protocol() { return master_; }
  std::uint64_t repeat_requests() const { return repeat_requests_; }

 private:
  Expected<void, MasterError> repeat_request();
  // FPWR of a whole SM0 buffer, polled while SM0 is full: the one place that writes SM0.
  Expected<void, MasterError> write_sm0(const std::vector<std::uint8_t>& buffer);
  Expected<void, MasterError> configured() const;
  Expected<void, MasterError> run_sdo(CoeSdoClient& client, std::vector<std::uint8_t> request,
                                      Multiplexer mux);

  MasterPort& port_;
  std::uint16_t station_;
  std::optional<SyncManagerSetup> out_;
  std::optional<SyncManagerSetup> in_;
  MailboxPollOptions options_;
  MailboxMaster master_;
  std::deque<CoeEmergency> emergencies_;
  std::uint64_t repeat_requests_ = 0;
};

}  // namespace drivecheck::ethercat

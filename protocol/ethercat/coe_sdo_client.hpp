// The CoE SDO client (the master's side, drivecheck's): one transfer at a time, a pure state
// machine fed the CoE SDO responses the master reads from the slave's read mailbox, giving the
// requests to write into its write mailbox (wrapped by MailboxMaster::request). Time is the
// master's: when MailboxMaster::reply_overdue says the reply is lost, timeout() gives the abort.
//
// Transfers (coe.hpp has the octets):
//   upload    initiate; an expedited response ends it; a normal one carries the complete size
//             and the first octets, then upload segment requests (t = 0, 1, 0, ...) until the
//             segment with c = 1
//   download  1..4 octets expedited (s = 1); longer or empty values normal: complete size and as
//             many octets as fit the slave's write mailbox (write_size - 16), the rest in
//             download segments of up to write_size - 9 octets
// What the client checks in every response, and the abort it sends when one is wrong (the
// server is then told, and the transfer ends with a protocol error):
//   a response of the wrong kind for the step                    → 05040001h
//   index/sub-index other than requested                         → 08000000h (general error)
//   a segment whose toggle is not the one requested              → 05030000h
//   more octets than the complete size, or fewer at the last one → 06070012h / 06070013h
// An abort from the server ends the transfer with that code and sends nothing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/ethercat/coe.hpp"

namespace drivecheck::ethercat {

// How a download of at most 4 bytes travels: expedited (the data in the initiate), or as a normal
// transfer (size indicated, the data after it) as CiA 301's "segmented" download does on CAN.
enum class CoeDownloadTransfer : std::uint8_t { expedited_if_it_fits, normal };

struct CoeSdoClientOptions {
  std::size_t write_size = 128;  // the slave's write mailbox (SM0) length, header included
  bool expedited = true;         // false: every download is a normal transfer
};

struct CoeClientError {
  enum class Kind : std::uint8_t {
    server_abort,  // the slave aborted with `code`
    protocol,      // the slave broke the protocol; the client aborted with `code`
    timeout,       // no reply in time; the client aborted with 05040000h
  };
  Kind kind = Kind::server_abort;
  std::uint32_t code = 0;
  std::string detail;
};

// The outcome of one response.
struct CoeClientStep {
  std::optional<std::vector<std::uint8_t>> request;  // to send next (a segment, or an abort)
  bool done = false;                                 // the transfer ended (success or error)
  std::optional<CoeClientError> error;
  bool ignored = false;  // the message was no SDO response (e.g. an emergency): route it elsewhere
};

class CoeSdoClient {
 public:
  explicit CoeSdoClient(CoeSdoClientOptions options = {});

  // Starts a transfer (any transfer in progress is forgotten) and returns the first request
  // (mailbox data, CoE header included).
  std::vector<std::uint8_t> start_upload(Multiplexer mux, bool complete_access = false);
  std::vector<std::uint8_t> start_download(Multiplexer mux, std::span<const std::uint8_t> data,
                                           bool complete_access = false);

  // A message the master read from the slave's read mailbox (mailbox data).
  CoeClientStep on_response(std::span<const std::uint8_t> data);
  // The reply is overdue: the abort to send (05040000h, SDO protocol timed out); the transfer
  // ends with a timeout error (last_error()).
  std::vector<std::uint8_t> timeout();

  bool busy() const { return state_ != State::idle; }
  // The uploaded value once an upload is done.
  const std::vector<std::uint8_t>& value() const { return value_; }
  const std::optional<CoeClientError>& last_error() const { return error_; }

 private:
  enum class State : std::uint8_t {
    idle,
    upload_initiate,
    upload_segment,
    download_initiate,
    download_segment
  };
  CoeClientStep fail(CoeClientError::Kind kind, cia301::SdoAbort code, std::string detail);
  CoeClientStep next_download_segment();
  CoeClientStep on_upload(const CoeSdoResponse& response);
  CoeClientStep on_download(const CoeSdoResponse& response);

  CoeSdoClientOptions options_;
  State state_ = State::idle;
  Multiplexer mux_;
  bool toggle_ = false;  // the toggle of the segment requested / sent last
  bool last_sent_ = false;
  std::uint32_t size_ = 0;
  std::vector<std::uint8_t> value_;  // upload: received; download: to send
  std::size_t offset_ = 0;
  std::optional<CoeClientError> error_;
};

}  // namespace drivecheck::ethercat

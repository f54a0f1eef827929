// The master's transceiver: the one place where the master touches its Link (link.hpp). It
// sends a frame of datagrams and waits for that frame to come back, on the link's clock (the
// simulated segment's time, or real time on a RawLink), and says what went wrong as a
// MasterError. Every master service (master_scan, master_sii, master_al, master_mailbox,
// master_process_data) builds datagrams and checks working counters through it.
//
// Matching: every frame the port sends carries one tag in the Idx byte of all its datagrams
// (incremented per frame, wrapping). A received frame is the answer when it is a well-formed
// EtherCAT frame with the same number of datagrams, the same commands and the tag; anything
// else (a late answer to an earlier attempt, a stranger's frame) is counted and dropped.
//
// Loss: when no answer arrives within `response_timeout` the frame is sent again, at most
// `retries` times (each with a new tag); then the exchange fails with no_response. A caller
// whose frame has side effects that must not happen twice (the read of a read mailbox empties
// it) asks for 0 retries and recovers at its own level (the mailbox repeat request).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "protocol/common/expected.hpp"
#include "protocol/ethercat/datagram.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/link.hpp"

namespace drivecheck::ethercat {

// What a master service reports (category "ethercat-master"). Tests compare these codes.
enum class MasterErrc {
  link_error = 1,    // the link refused the frame (down, too long): MasterError::link
  no_response,       // no answer to a frame after every retry
  working_counter,   // a datagram's working counter is not the expected one
  slave_count,       // the scan found more or fewer slaves than configured
  station_address,   // a configured station address did not read back
  sii_timeout,       // the SII EEPROM interface stayed busy past the timeout
  sii_error,         // the SII EEPROM interface reported an error (0502h bits 11..14)
  sii_malformed,     // the SII image does not parse (SiiParseError in the detail)
  sii_unsupported,   // the SII lacks what the configuration needs (mailbox, process data)
  al_timeout,        // a slave did not reach the requested AL state in time
  al_refused,        // a slave set the error indication: MasterError::al_status_code
  al_state_lost,     // a slave left the state the master holds it in (e.g. SM watchdog)
  mailbox_timeout,   // no mailbox reply in time (after the repeat request)
  mailbox_error,     // a mailbox ERR reply, or a malformed mailbox
  sdo_abort,         // the CoE SDO transfer ended with an abort: MasterError::abort_code
  process_data_wkc,  // the cyclic LRW's working counter is not the expected one
  not_configured,    // the call needs a step of the bring-up that has not happened
  frame_too_long,    // the datagrams do not fit one frame
};
const std::error_category& master_category();
std::error_code make_error_code(MasterErrc error);

struct MasterError {
  std::error_code code;
  std::string detail;                // what, where, expected and actual
  std::uint16_t station = 0;         // the slave concerned (0: none or the whole segment)
  std::uint16_t al_status_code = 0;  // al_refused / al_state_lost: register 0134h
  std::uint32_t abort_code = 0;      // sdo_abort: the SDO abort code
  std::uint16_t mailbox_error = 0;   // mailbox_error: the ERR reply's Detail
  std::error_code link;              // link_error: the link's code
  // "ethercat-master: al_refused: slave 1001h refused SAFEOP: 001Dh invalid_output_configuration"
  std::string message() const;
};

// A MasterError from a code and a detail.
Unexpected<MasterError> master_error(MasterErrc code, std::string detail,
                                     std::uint16_t station = 0);

struct MasterPortConfig {
  Duration response_timeout = std::chrono::milliseconds(2);
  unsigned retries = 3;
  MacAddress source = {0x02, 0x00, 0x00, 0x00, 0x00, 0x01};  // locally administered
};

struct ExchangeOptions {
  unsigned retries = 3;
};

class MasterPort {
 public:
  explicit MasterPort(Link& link, MasterPortConfig config = {});

  // Sends the datagrams in one frame (Idx set by the port) and returns them as they came back.
  // Errors: link_error, frame_too_long, no_response.
  Expected<std::vector<Datagram>, MasterError> exchange(std::vector<Datagram> datagrams);
  Expected<std::vector<Datagram>, MasterError> exchange(std::vector<Datagram> datagrams,
                                                        ExchangeOptions options);
  Expected<Datagram, MasterError> exchange(Datagram datagram);

  // One register access with its working counter checked (working_counter otherwise).
  // `station` is the configured address (FPxx) or, for APxx, the position as ADP (0 - k).
  Expected<std::vector<std::uint8_t>, MasterError> read(Command command, std::uint16_t adp,
                                                        std::uint16_t ado, std::size_t size,
                                                        std::uint16_t expected_wkc = 1);
  Expected<void, MasterError> write(Command command, std::uint16_t adp, std::uint16_t ado,
                                    std::vector<std::uint8_t> data, std::uint16_t expected_wkc = 1);

  // Lets `duration` pass on the link's clock (handlers and timers run; a simulated segment
  // advances its time). Used between polls.
  void wait(Duration duration);

  Link& link() { return link_; }
  TimePoint now() const { return link_.now(); }
  const MasterPortConfig& config() const { return config_; }
  std::uint64_t frames_sent() const { return frames_sent_; }
  std::uint64_t frames_lost() const { return frames_lost_; }
  std::uint64_t frames_dropped() const { return frames_dropped_; }

 private:
  Link& link_;
  MasterPortConfig config_;
  std::uint8_t tag_ = 0;
  std::uint64_t frames_sent_ = 0;
  std::uint64_t frames_lost_ = 0;     // sent frames that never came back in time
  std::uint64_t frames_dropped_ = 0;  // received frames that answered nothing we wait for
};

// "FPRD 0130h at station 1001h"
std::string describe_access(Command command, std::uint16_t adp, std::uint16_t ado);

// Little-endian helpers for register values.
std::vector<std::uint8_t> le16(std::uint16_t value);
std::vector<std::uint8_t> le32(std::uint32_t value);
std::uint16_t get_le16(std::span<const std::uint8_t> bytes, std::size_t at = 0);
std::uint32_t get_le32(std::span<const std::uint8_t> bytes, std::size_t at = 0);

}  // namespace drivecheck::ethercat

template <>
struct std::is_error_code_enum<drivecheck::ethercat::MasterErrc> : std::true_type {};

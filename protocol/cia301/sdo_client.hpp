// The SDO client (CiA 301 §7.2.4): a pure state machine for one transfer at a time
// (SdoClientTransfer), and a blocking convenience class over a can::Bus (SdoClient) for masters
// and tests.
//
// Transfers: expedited and segmented upload/download, block upload and download (CRC on or off,
// blksize, protocol switch threshold), falling back to segmented transfer when the server
// aborts a block initiate with 05040001h (command specifier not valid). Every answer is
// checked strictly; a protocol error ends the transfer with a SdoClientError code and the client
// sends the abort code below to the server, so that the server does not wait for its own
// timeout (CiA 301 names the code for toggle, timeout, command specifier, block size, sequence
// number, CRC and memory errors; for the others the choice is ours and is marked "ours"):
//
//   SdoClientError        abort sent
//   timeout               05040000h SDO protocol timed out
//   toggle_mismatch       05030000h toggle bit not alternated
//   unexpected_response   05040001h command specifier not valid or unknown
//   invalid_response      05040001h (a frame that is no SDO frame: DLC < 8, reserved scs)
//   invalid_block_size    05040002h invalid block size
//   sequence_error        05040003h invalid sequence number
//   crc_mismatch          05040004h CRC error
//   data_too_large        05040005h out of memory
//   size_mismatch         06070010h length of service parameter does not match (ours)
//   wrong_multiplexer     08000000h general error (ours)
//   interrupted           08000000h general error (ours; blocking client only)
//   aborted_locally       the code given to abort()
//
// A server's abort ends the transfer with std::error_code{code, sdo_abort_category()}: compare
// with `error == SdoAbort::write_read_only`; codes no table lists keep their value. The client
// does not answer an abort.
//
// Frames on other identifiers than the response COB-ID are ignored by the state machine; the
// blocking client hands them to SdoClientOptions::other_frames.
#pragma once

#include <chrono>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <system_error>
#include <type_traits>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

// Protocol errors the client detects (std::error_code category "sdo-client").
enum class SdoClientError {
  timeout = 1,          // no answer within SdoClientOptions::timeout
  wrong_multiplexer,    // the answer names another index/sub-index than the request
  toggle_mismatch,      // segment answer with the wrong toggle bit
  unexpected_response,  // an SDO frame that does not belong to this phase of the transfer
  invalid_response,     // a frame on the response COB-ID that is no valid SDO frame
  size_mismatch,        // the data differ in length from the size the server indicated, or
                        // (upload_value/download_value) from the size of the value type
  data_too_large,       // the upload exceeds SdoClientOptions::max_upload_size
  crc_mismatch,         // block transfer: the CRC does not match the data
  sequence_error,       // block transfer: seqno 0 or above blksize, or ackseq above the
                        // number of segments sent
  invalid_block_size,   // block transfer: the server's blksize is 0 or above 127
  aborted_locally,      // the client's user aborted the transfer
  busy,                 // a transfer is already running on this state machine
  invalid_argument,     // option or argument out of range (blksize 0 or > 127, data > 4 GiB)
  interrupted,          // the bus's stop() ended the wait (blocking client)
};
const std::error_category& sdo_client_category();
std::error_code make_error_code(SdoClientError error);

// The abort code the client sends for a protocol error (table above); nullopt for errors that
// send none (busy, invalid_argument, aborted_locally: the caller's code).
std::optional<SdoAbort> abort_code_for(SdoClientError error);

// Whether `error` is a server's abort (category sdo-abort), and its 32-bit code.
std::optional<std::uint32_t> server_abort_code(const std::error_code& error);

// The COB-IDs of one SDO channel (client's view).
struct SdoCobIds {
  std::uint32_t request = kSdoRequestBase;    // client → server (server's RSDO)
  std::uint32_t response = kSdoResponseBase;  // server → client (server's TSDO)
  can::IdFormat format = can::IdFormat::standard;

  // The default SDO channel of a node: 600h + node / 580h + node.
  static SdoCobIds for_node(std::uint8_t node_id) {
    return {kSdoRequestBase + node_id, kSdoResponseBase + node_id, can::IdFormat::standard};
  }
  friend bool operator==(const SdoCobIds&, const SdoCobIds&) = default;
};

enum class SdoTransferMode : std::uint8_t {
  automatic,  // download: expedited for 1..4 bytes, else segmented; upload: the server chooses
              // expedited or segmented
  segmented,  // download: segmented even for 1..4 bytes; upload: as automatic
  block,      // block transfer (see SdoClientOptions::block_fallback)
};

// What a transfer turned out to be (after a protocol switch or fallback).
enum class SdoTransferKind : std::uint8_t { none, expedited, segmented, block };

struct SdoClientOptions {
  std::optional<SdoCobIds> cob_ids;  // default: SdoCobIds::for_node(node_id)
  // Per request: how long the client waits for each answer (in a block upload: for each
  // segment). The clock starts when the state machine emits the request.
  can::Duration timeout = std::chrono::milliseconds(1000);
  SdoTransferMode upload_mode = SdoTransferMode::automatic;
  SdoTransferMode download_mode = SdoTransferMode::automatic;
  std::uint8_t block_size = kSdoMaxBlockSize;  // blksize offered in block upload, 1..127
  std::uint8_t protocol_switch_threshold = 0;  // pst of block upload; 0: no switch
  bool block_crc = true;                       // offer CRC in block transfers
  bool block_fallback = true;  // block initiate aborted with 05040001h: retry segmented
  std::size_t max_upload_size = std::size_t{16} << 20;  // more: abort 05040005h
  // Blocking client only: frames on other identifiers that arrive while it waits (the
  // pull-mode port would otherwise drop them). Own loopback frames are never passed on.
  std::function<void(const can::TimedFrame&)> other_frames;
};

// One SDO transfer as a state machine fed frames and time. No I/O, no clock of its own:
// every call returns the frames to send now, in order (a span into the transfer, valid until
// the next call). The transfer is reusable: start another one when the last is finished; a
// start_* call while one is running() returns no frames and changes nothing. A start with an
// out-of-range option (block_size 0 or > 127 for a block upload) fails at once with
// SdoClientError::invalid_argument and no frame.
//
//   SdoClientTransfer t(5);                               // node 5: 605h / 585h
//   send(t.start_upload({0x6041, 0}, now));
//   while (t.running()) {
//     auto frame = receive_until(t.next_deadline());
//     send(frame ? t.on_frame(*frame, frame_time) : t.on_time(now));
//   }
//   if (t.succeeded()) use(t.data());  else report(t.error());
class SdoClientTransfer {
 public:
  enum class State : std::uint8_t { idle, running, succeeded, failed };

  explicit SdoClientTransfer(std::uint8_t node_id, SdoClientOptions options = {});

  // Starts reading `mux`. `mode` defaults to options().upload_mode.
  std::span<const can::Frame> start_upload(Multiplexer mux, can::TimePoint now);
  std::span<const can::Frame> start_upload(Multiplexer mux, can::TimePoint now,
                                           SdoTransferMode mode);
  // Starts writing `data` (copied) to `mux`. `mode` defaults to options().download_mode.
  std::span<const can::Frame> start_download(Multiplexer mux, std::span<const std::uint8_t> data,
                                             can::TimePoint now);
  std::span<const can::Frame> start_download(Multiplexer mux, std::span<const std::uint8_t> data,
                                             can::TimePoint now, SdoTransferMode mode);

  // A frame from the bus (frames on other identifiers are ignored).
  std::span<const can::Frame> on_frame(const can::Frame& frame, can::TimePoint now);
  // Time has passed: at or after next_deadline() the transfer times out (abort 05040000h).
  std::span<const can::Frame> on_time(can::TimePoint now);
  // Client-initiated abort of a running transfer: the abort frame with `code`; the transfer
  // fails with SdoClientError::aborted_locally. Nothing when no transfer is running.
  std::span<const can::Frame> abort(std::uint32_t code);
  std::span<const can::Frame> abort(SdoAbort code) {
    return abort(static_cast<std::uint32_t>(code));
  }
  // Ends a running transfer without a frame (e.g. its request could not be sent); it fails
  // with SdoClientError::aborted_locally.
  void cancel();

  // When on_time() must be called next: the answer's deadline while running, else kForever.
  can::TimePoint next_deadline() const;

  State state() const { return state_; }
  bool running() const { return state_ == State::running; }
  bool succeeded() const { return state_ == State::succeeded; }
  bool failed() const { return state_ == State::failed; }
  // Why the transfer failed (empty unless failed()).
  std::error_code error() const { return error_; }
  // The data read by a succeeded upload.
  std::span<const std::uint8_t> data() const { return data_; }
  // The abort code the client sent, if it sent one.
  std::optional<std::uint32_t> sent_abort() const { return sent_abort_; }
  // How the transfer ran: expedited, segmented or block (none before the first answer).
  SdoTransferKind kind() const { return kind_; }
  // Whether a block initiate was aborted with 05040001h and the transfer went on segmented.
  bool fell_back() const { return fell_back_; }
  Multiplexer multiplexer() const { return mux_; }
  const SdoCobIds& cob_ids() const { return cob_ids_; }
  const SdoClientOptions& options() const { return options_; }

 private:
  enum class Phase : std::uint8_t {
    idle,
    upload_initiate,
    upload_segment,
    download_initiate,
    download_segment,
    block_download_initiate,
    block_download_sub_block,
    block_download_end,
    block_upload_initiate,
    block_upload_sub_block,
    block_upload_end,
  };

  std::span<const can::Frame> begin(can::TimePoint now);
  bool prepare_start();
  void reject_start(SdoClientError error);
  void emit(const SdoPayload& payload);
  void expect_answer(can::TimePoint now);
  void succeed();
  void fail(SdoClientError error);
  void fail_with_server_abort(std::uint32_t code);

  void start_initiate_upload(can::TimePoint now);
  void start_initiate_download(can::TimePoint now);
  void send_download_segment(can::TimePoint now);
  void send_block_sub_block(can::TimePoint now);

  void on_upload_initiate(const SdoServerMessage& message, can::TimePoint now);
  void on_upload_segment(const SdoServerMessage& message, can::TimePoint now);
  void on_download_initiate(const SdoServerMessage& message, can::TimePoint now);
  void on_download_segment(const SdoServerMessage& message, can::TimePoint now);
  void on_block_download_initiate(const SdoServerMessage& message, can::TimePoint now);
  void on_block_download_ack(const SdoServerMessage& message, can::TimePoint now);
  void on_block_download_end(const SdoServerMessage& message);
  void on_block_upload_initiate(const SdoServerMessage& message, can::TimePoint now);
  void on_block_upload_segment(const SdoServerMessage& message, can::TimePoint now);
  void on_block_upload_end(const SdoServerMessage& message);
  // Shared by every phase: abort and invalid frames. True when the message was handled.
  bool handle_common(const SdoServerMessage& message);
  bool check_mux(Multiplexer answered);

  SdoClientOptions options_;
  SdoCobIds cob_ids_;
  State state_ = State::idle;
  Phase phase_ = Phase::idle;
  SdoTransferMode mode_ = SdoTransferMode::automatic;
  SdoTransferKind kind_ = SdoTransferKind::none;
  bool upload_ = false;
  bool fell_back_ = false;
  Multiplexer mux_;
  can::TimePoint deadline_ = can::kForever;
  std::error_code error_;
  std::optional<std::uint32_t> sent_abort_;

  std::vector<std::uint8_t> data_;  // upload: received; download: to send
  std::vector<can::Frame> out_;     // frames of the current call

  bool toggle_ = false;
  bool size_indicated_ = false;
  std::uint32_t size_ = 0;
  std::size_t offset_ = 0;  // download: bytes acknowledged (segmented: sent)
  bool last_sent_ = false;  // segmented download: the last segment is out

  // Block transfer.
  bool crc_ = false;                 // both sides support CRC
  std::uint8_t block_size_ = 0;      // segments in the current sub-block
  std::uint8_t segments_sent_ = 0;   // download: segments in the sub-block just sent
  bool sub_block_has_last_ = false;  // download: it carries the last segment
  std::uint8_t expected_seqno_ = 1;  // upload: next seqno in sequence
  bool last_received_ = false;       // upload: the c=1 segment arrived in sequence
};

// A blocking SDO client over one Bus port in pull mode (the port must have no frame handler).
// Each call runs one transfer to its end: it sends, waits with receive() (on the simulated bus
// that advances simulated time and runs the other nodes), and returns the result.
//  - Before a transfer starts, frames already waiting on the port are taken off it: a late
//    answer to an earlier, timed-out request is dropped, other frames go to other_frames.
//  - While it waits, a timer at the answer's deadline is pending on the port, so a simulated
//    bus with nothing else to do runs until the deadline (the transfer then times out).
//  - bus.stop() during a wait ends the transfer: the client sends abort 08000000h and returns
//    SdoClientError::interrupted.
//  - A send() error ends the transfer with that error (BusError); nothing more is sent.
class SdoClient {
 public:
  SdoClient(can::Bus& bus, std::uint8_t node_id, SdoClientOptions options = {});

  Expected<std::vector<std::uint8_t>, std::error_code> upload(Multiplexer mux);
  Expected<std::vector<std::uint8_t>, std::error_code> upload(Multiplexer mux,
                                                              SdoTransferMode mode);
  Expected<void, std::error_code> download(Multiplexer mux, std::span<const std::uint8_t> data);
  Expected<void, std::error_code> download(Multiplexer mux, std::span<const std::uint8_t> data,
                                           SdoTransferMode mode);

  // An integer object, little-endian; the server must return exactly sizeof(T) bytes
  // (else SdoClientError::size_mismatch).
  template <std::integral T>
  Expected<T, std::error_code> upload_value(Multiplexer mux);
  template <std::integral T>
  Expected<void, std::error_code> download_value(Multiplexer mux, T value);

  // The state machine of the last transfer: kind(), sent_abort(), fell_back().
  const SdoClientTransfer& last_transfer() const { return transfer_; }
  const SdoCobIds& cob_ids() const { return transfer_.cob_ids(); }

 private:
  std::error_code run(std::span<const can::Frame> first);
  std::error_code send_all(std::span<const can::Frame> frames);
  void drain();
  void pass_on(const can::TimedFrame& frame);

  can::Bus& bus_;
  SdoClientTransfer transfer_;
};

template <std::integral T>
Expected<T, std::error_code> SdoClient::upload_value(Multiplexer mux) {
  auto bytes = upload(mux);
  if (!bytes) return Unexpected(bytes.error());
  if (bytes->size() != sizeof(T)) return Unexpected(make_error_code(SdoClientError::size_mismatch));
  std::make_unsigned_t<T> value = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    value = static_cast<std::make_unsigned_t<T>>(
        value | static_cast<std::make_unsigned_t<T>>((*bytes)[i]) << (8 * i));
  }
  return static_cast<T>(value);
}

template <std::integral T>
Expected<void, std::error_code> SdoClient::download_value(Multiplexer mux, T value) {
  std::array<std::uint8_t, sizeof(T)> bytes{};
  const auto raw = static_cast<std::make_unsigned_t<T>>(value);
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    bytes[i] = static_cast<std::uint8_t>(raw >> (8 * i));
  }
  return download(mux, bytes);
}

}  // namespace drivecheck::cia301

template <>
struct std::is_error_code_enum<drivecheck::cia301::SdoClientError> : std::true_type {};

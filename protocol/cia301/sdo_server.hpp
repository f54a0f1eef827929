// The SDO server (CiA 301 §7.2.4): one server channel of a device as a pure state machine fed
// the frames a client sends on the channel's request COB-ID and the time, returning the
// frames to send; plus SdoServerRunner, a thin adapter that runs it on a can::Bus port.
// It reads and writes an ObjectDictionary (object_dictionary.hpp), whose checks give most of
// the abort codes; the frame layouts of every message are in sdo_codec.hpp.
//
// The exchanges, request (client → server, 600h + node) then answer (server → client,
// 580h + node); byte 0 shown in hex/bits, "m" = index LE + sub-index (bytes 1..3):
//
//   Expedited download (§7.2.4.3.3)    2x m d d d d    -> 60 m 00 00 00 00
//     byte 0 = 001x nnes, e=1; s=1: 4-n data bytes; s=0: size not indicated (see below)
//   Segmented download (§7.2.4.3.3-4)  21 m ssssssss   -> 60 m
//     (e=0; s=1 with the size in bytes 4..7, or 20 m for no size)
//                                      000t nnnc data  -> 001t 0000  (t = the request's t)
//                                      ... until c=1; the OD is written when c=1 arrives, and
//                                      the last segment response is sent only if that worked
//   Expedited upload (§7.2.4.3.6)      40 m            -> 010x nn11 m d d d d  (1..4 bytes)
//   Segmented upload (§7.2.4.3.6-7)    40 m            -> 41 m ssssssss        (0 or > 4 bytes)
//                                      011t 0000       -> 000t nnnc data, until c=1
//   Block download (§7.2.4.3.9-11)     110x xcs0 m [size]           -> 101x xc00 m blksize
//                                      cSSSSSSS data  x seqno 1..blksize (no answer between)
//                                          -> A2 ackseq blksize     after seqno = blksize or c=1
//                                      110n nn01 crc16              -> A1
//   Block upload (§7.2.4.3.13-15)      101x xc00 m blksize pst      -> 110x xc10 m size
//                                      A3 (start)                   -> sub-block cSSSSSSS data
//                                      A2 ackseq blksize            -> next sub-block, or
//                                                                      110n nn01 crc16 (end)
//                                      A1                           (transfer complete)
//   Abort (§7.2.4.3.17)                80 m code (LE)  either side, at any time
//
// Decisions where CiA 301 leaves a choice (each one documented here and tested):
//  - Frames with DLC < 8. CiA 301 §7.2.4.3 defines every SDO frame with 8 data bytes; a
//    shorter frame is no SDO request (sdo_codec.hpp: SdoInvalid short_frame). By default
//    (ShortFramePolicy::ignore) the server ignores it: it sends nothing and an open transfer
//    goes on (its timeout still runs). The Festo manual (000 §3.2.1 L744-756) prints only the
//    significant bytes and leaves the DLC unspecified; ShortFramePolicy::pad models a drive
//    that reads the missing bytes as 00h. Remote and error frames are always ignored.
//  - One request at a time. In an open transfer, each protocol of §7.2.4.3 admits exactly one
//    kind of next request; any other command specifier - a new initiate included - is a
//    protocol error: the server answers abort 05040001h (command specifier not valid,
//    §7.2.4.3.17 Table 22) with the multiplexer of the OPEN transfer, drops that transfer and
//    does not execute the new request (the client sees the abort and starts again). CiA 301
//    has no clause that lets a second initiate silently replace a running transfer; this is
//    also what the Festo manual asks of a master (000 §3.2.1 L760-762: wait for the answer).
//    Inside a block-download sub-block every frame but 80h is a segment (byte 0 = c|seqno),
//    so there a new initiate is read as a segment, as CiA 301's framing implies.
//  - Requests that belong to no transfer (a segment or block sub-command while idle, or ccs 7)
//    are answered with 05040001h; the abort carries 0000h:00 (the request names no object),
//    except for ccs 7, where bytes 1..3 are echoed. An abort received while idle is ignored.
//  - A client's abort ends the open transfer silently, whatever multiplexer it names.
//  - Expedited download without size (s=0): bytes 4..7 hold data of unspecified length. The
//    server writes the entry's size when its type is 1..4 bytes, else all 4 bytes (the OD
//    then answers length_too_low for longer fixed-size types).
//  - Sizes. With a size indicated, the initiate is checked against the entry before any data
//    flows: read-only entries abort 06010002h, a size above/below a fixed-size type's
//    06070012h/06070013h, above a string/domain's max_size 06070012h, above
//    SdoServerConfig::max_download_size 05040005h (out of memory). Data that turns out longer
//    or shorter than the size the client indicated aborts 06070010h (length of service
//    parameter does not match), as soon as it is certain: a segment that overruns the size,
//    the last segment or the end block download request that leaves it short. Without a size,
//    more than max_download_size buffered bytes abort 05040005h.
//  - Block download: CRC is used when both sides announce it (c bit); a mismatch aborts
//    05040004h, checked before the size. Segments out of sequence (a lost or repeated seqno)
//    are not stored; the sub-block ends with seqno = blksize or a c=1 segment, in sequence or
//    not, and the ack carries ackseq = the last seqno received in sequence (0: none), so the
//    client retransmits from there (§7.2.4.3.10). If the frame that would end a sub-block is
//    itself lost, the server waits and times out. Seqno 0 or above the sub-block's blksize
//    cannot be fixed by retransmission and aborts 05040003h (invalid sequence number).
//  - Block upload: blksize 0 or > 127 in the initiate or an ack aborts 05040002h; an ackseq
//    above the number of segments sent aborts 05040003h; ackseq below it makes the server
//    resend from segment ackseq + 1, renumbered from 1, in sub-blocks of the new blksize.
//    With pst > 0 and size <= pst the server switches protocol (§7.2.4.3.13): it answers with
//    an initiate upload response (expedited for 1..4 bytes, else segmented) and goes on as a
//    segmented upload. An object of 0 bytes is one segment, c=1, and n=7 in the end request.
//  - Timeout (05040000h): the deadline is SdoServerConfig::timeout after the last frame of
//    the open transfer the server received (or sent, which happens at the same instant). At
//    the deadline on_time() aborts the transfer and drops it; a frame that arrives after the
//    deadline first times the transfer out, then is handled as a request to an idle server.
//  - The upload's data is read (read hook included) once, at the initiate, and kept: later
//    changes of the entry do not mix into a running transfer.
//  - Writes reach the OD only at the end of a complete, valid download (ObjectDictionary::
//    write: limits, validator, observer run then); segmented and block data is buffered.
//  - NMT: in Stopped, SDO is not allowed (CiA 301 NMT state table): the node should stop
//    feeding frames and call reset(), which drops an open transfer without any frame.
//
// Hot path: an expedited request does not allocate (decoding, OD access and the answer use
// fixed storage). Segmented and block transfers reuse one buffer that grows, never shrinks.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <system_error>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/deadline_timer.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::cia301 {

// What the server does with a frame on its request COB-ID whose DLC is below 8.
enum class ShortFramePolicy : std::uint8_t {
  ignore,  // CiA 301: not an SDO frame; no answer (default)
  pad,     // read missing bytes as 00h (a tolerant drive, as some manuals imply)
};

struct SdoServerConfig {
  std::uint32_t rx_cob_id = kSdoRequestBase + 1;   // client → server (RSDO), 1200h:01
  std::uint32_t tx_cob_id = kSdoResponseBase + 1;  // server → client (TSDO), 1200h:02
  can::IdFormat format = can::IdFormat::standard;
  // A client that stays silent this long in an open transfer gets abort 05040000h.
  can::Duration timeout = std::chrono::milliseconds(1000);
  // Block transfers supported; false: block initiates abort 05040001h (clients fall back).
  bool block_transfer = true;
  bool block_crc = true;  // the server supports CRC in block transfers (c bit)
  // blksize the server asks for in block download (1..127; clamped into that range).
  std::uint8_t block_size = kSdoMaxBlockSize;
  // Block upload: segments per sub-block. 0 = as many as the client's blksize allows (CiA 301
  // §7.2.4.3.13/14); another value ignores the client's blksize, which only a deviation of the
  // reference drive does (sdo-block-upload-blksize-ignored).
  std::uint8_t upload_block_size = 0;
  // The largest download the server buffers; more: abort 05040005h (out of memory).
  std::size_t max_download_size = std::size_t{1} << 20;
  ShortFramePolicy short_frames = ShortFramePolicy::ignore;

  // The default SDO server channel of a node: 600h + node / 580h + node.
  static SdoServerConfig for_node(std::uint8_t node_id) {
    SdoServerConfig config;
    config.rx_cob_id = kSdoRequestBase + node_id;
    config.tx_cob_id = kSdoResponseBase + node_id;
    return config;
  }
};

// Counters for reports and benchmarks.
struct SdoServerStatistics {
  std::uint64_t requests = 0;         // frames on the request COB-ID
  std::uint64_t completed = 0;        // transfers that ended successfully
  std::uint64_t aborts_sent = 0;      // timeouts included
  std::uint64_t aborts_received = 0;  // client aborts that ended an open transfer
  std::uint64_t timeouts = 0;
  std::uint64_t ignored = 0;  // remote/error/short frames, client aborts while idle
};

class SdoServer {
 public:
  enum class State : std::uint8_t {
    idle,
    download_segment,          // segmented download: waiting for a download segment request
    upload_segment,            // segmented upload: waiting for an upload segment request
    block_download_sub_block,  // waiting for the segments of a sub-block
    block_download_end,        // waiting for the end block download request
    block_upload_start,        // initiate answered: waiting for the client's start (A3)
    block_upload_ack,          // sub-block sent: waiting for the client's ack (A2)
    block_upload_end,          // end request sent: waiting for the end response (A1)
  };

  // The dictionary must outlive the server.
  SdoServer(ObjectDictionary& dictionary, SdoServerConfig config);

  // Whether a frame is addressed to this server (request COB-ID and format, not an error
  // frame). on_frame ignores every other frame.
  bool is_request(const can::Frame& frame) const;

  // A frame from the bus at time `now`: the frames to send now, in order (a span into the
  // server, valid until the next call; at most 128 frames, a block upload sub-block).
  std::span<const can::Frame> on_frame(const can::Frame& frame, can::TimePoint now);
  // Time has passed: at or after next_deadline() the open transfer times out (05040000h).
  std::span<const can::Frame> on_time(can::TimePoint now);
  // When on_time() must be called next: the open transfer's deadline, else kForever.
  can::TimePoint next_deadline() const { return deadline_; }

  // Application-side abort of the open transfer (e.g. the device changes state): the abort
  // frame with `code` and the transfer's multiplexer. Nothing when idle.
  std::span<const can::Frame> abort(std::uint32_t code);
  std::span<const can::Frame> abort(SdoAbort code) {
    return abort(static_cast<std::uint32_t>(code));
  }
  // Drops an open transfer without a frame (NMT reset communication, Stopped).
  void reset();
  // Moves the channel to other COB-IDs (its SDO server parameter record was written, 1200h..
  // 127Fh): an open transfer is dropped without a frame when anything changes. enabled false
  // (a COB-ID with bit 31 set): the server takes no request at all (is_request is false)
  // until enabled again. A SdoServerRunner that attach()ed keeps its old filter: attach again.
  void set_channel(std::uint32_t rx_cob_id, std::uint32_t tx_cob_id, bool enabled);
  bool enabled() const { return enabled_; }

  // Changes the blksize asked for in the next block download initiate or sub-block ack.
  void set_block_size(std::uint8_t block_size);

  State state() const { return state_; }
  bool busy() const { return state_ != State::idle; }
  // The multiplexer of the open (or last) transfer.
  Multiplexer multiplexer() const { return mux_; }
  const SdoServerConfig& config() const { return config_; }
  const SdoServerStatistics& statistics() const { return stats_; }

 private:
  void emit(const SdoPayload& payload);
  void send_abort(Multiplexer mux, std::uint32_t code);
  void fail(SdoAbort code);  // abort the open transfer with the server's code, then close
  void close();
  void complete();
  void arm(can::TimePoint now);
  void expire(can::TimePoint now);
  std::span<const can::Frame> output() const { return {out_.data(), out_count_}; }

  void handle(const SdoClientMessage& message, const can::Frame& frame, can::TimePoint now);
  void on_idle(const SdoClientMessage& message, can::TimePoint now);
  void on_initiate_download(const InitiateDownloadRequest& request, can::TimePoint now);
  void on_download_segment(const DownloadSegmentRequest& request, can::TimePoint now);
  void on_initiate_upload(Multiplexer mux, std::span<const std::uint8_t> data, can::TimePoint now);
  void on_upload_segment(const UploadSegmentRequest& request, can::TimePoint now);
  void on_block_download_initiate(const BlockDownloadInitiateRequest& request, can::TimePoint now);
  void on_block_download_segment(const BlockSegment& segment, can::TimePoint now);
  void on_block_download_end(const BlockDownloadEndRequest& request);
  void on_block_upload_initiate(const BlockUploadInitiateRequest& request, can::TimePoint now);
  void on_block_upload_ack(const BlockUploadAck& ack, can::TimePoint now);
  std::uint8_t upload_block_size(std::uint8_t asked) const;  // segments per upload sub-block
  void send_sub_block();
  // The checks of a download initiate that names a size: access, type length, memory.
  Expected<void, SdoAbort> check_download(Multiplexer mux, bool size_indicated, std::uint32_t size);

  ObjectDictionary& od_;
  SdoServerConfig config_;
  SdoServerStatistics stats_;
  bool enabled_ = true;
  State state_ = State::idle;
  Multiplexer mux_;
  can::TimePoint deadline_ = can::kForever;

  std::array<can::Frame, kSdoMaxBlockSize + 1> out_{};
  std::size_t out_count_ = 0;

  std::vector<std::uint8_t> buffer_;  // download: received data; upload: the data to send
  bool size_indicated_ = false;
  std::uint32_t size_ = 0;
  bool toggle_ = false;     // segmented: the toggle the next request must carry
  std::size_t offset_ = 0;  // upload: bytes sent (segmented) or acknowledged (block)

  // Block transfer.
  bool crc_ = false;                 // both sides support CRC
  std::uint8_t block_size_ = 0;      // segments in the current sub-block
  std::uint8_t expected_seqno_ = 1;  // download: next seqno in sequence
  bool last_received_ = false;       // download: the c=1 segment arrived in sequence
  std::uint8_t segments_sent_ = 0;   // upload: segments in the sub-block just sent
  bool sub_block_has_last_ = false;  // upload: it carries the last segment
};

// Runs an SdoServer on a Bus port in push mode: frames go through the server and its answers
// are sent at once; a bus timer at next_deadline() drives the timeout. A device that shares
// one port between several services does not attach() the runner but calls handle() from its
// own frame handler.
class SdoServerRunner {
 public:
  // The bus and the server must outlive the runner.
  SdoServerRunner(can::Bus& bus, SdoServer& server);
  ~SdoServerRunner();
  SdoServerRunner(const SdoServerRunner&) = delete;
  SdoServerRunner& operator=(const SdoServerRunner&) = delete;

  // Becomes the port's frame handler, with a filter for the server's request COB-ID.
  void attach();
  // Gives the port back (no handler, no filters) and cancels the timer.
  void detach();

  // A frame the port received: own (loopback) frames and frames for others are ignored.
  void handle(const can::TimedFrame& frame);
  // Sends frames the application got from the server (abort()) and re-arms the timer; call
  // after reset() too.
  void transmit(std::span<const can::Frame> frames);

  // Sends that failed (bus-off, queue full); the server does not know, its transfer then
  // times out as if the frame had been lost on the wire.
  std::uint64_t send_errors() const { return send_errors_; }
  std::error_code last_send_error() const { return last_send_error_; }

 private:
  void rearm();

  can::Bus& bus_;
  SdoServer& server_;
  bool attached_ = false;
  can::DeadlineTimer timer_{bus_, [this] { transmit(server_.on_time(bus_.now())); }};
  std::uint64_t send_errors_ = 0;
  std::error_code last_send_error_;
};

}  // namespace drivecheck::cia301

// A correct SDO server for one object, as the fuzz targets' reference peer (CiA 301 §7.2.4.3):
// expedited, segmented and block transfers in both directions, written from the standard and
// kept deliberately simple (no object dictionary, no timing). It answers the frames a client
// sends and queues its answers; the fuzz target decides when (and whether) they are delivered.
//
// The sdo_client fuzz target uses it in two ways: its frames drive the client deep into every
// protocol (mutations of them are the hostile frames), and in a run where nothing was lost,
// injected or mutated, "the model completed the transfer" and "the client succeeded" must
// agree, with the same data on both sides.
//
// Behaviour choices a server has (CiA 301 leaves them to the server) are options:
// expedited or segmented upload, size indicated or not, CRC support, refusing block transfer
// (abort 05040001h), protocol switch, the block size it asks for (an invalid one, 0 or above
// 127, makes the model nonconforming on purpose).
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::fuzz {

struct SdoServerModelOptions {
  bool crc = true;                       // supports CRC in block transfers
  bool upload_size_indicated = true;     // segmented/block upload: s=1
  bool expedited_upload = true;          // objects of 1..4 bytes go expedited
  bool expedited_size_indicated = true;  // ... with s=1 (else s=0: four bytes, zero-padded)
  bool refuse_block = false;             // answer block initiates with abort 05040001h
  bool protocol_switch = true;           // switch a block upload to normal when size <= pst
  std::uint8_t block_size = 127;         // blksize asked for in block download (raw)
};

class SdoServerModel {
 public:
  // `object`: what an upload returns. `cob_ids`: the client's view (request = what we receive).
  SdoServerModel(cia301::SdoCobIds cob_ids, cia301::Multiplexer mux,
                 std::vector<std::uint8_t> object, SdoServerModelOptions options);

  // A frame the client sent (frames on other identifiers are ignored).
  void on_client_frame(const can::Frame& frame);

  // Answers not yet delivered, oldest first.
  std::deque<can::Frame>& outbox() { return outbox_; }

  // The transfer ended well from the server's side (upload: the last data went out and, for
  // a block upload, the end was confirmed; download: the last part was received and
  // confirmed).
  bool complete() const { return complete_; }
  // The model refused a block transfer (abort 05040001h).
  bool refused_block() const { return refused_block_; }
  // The model asked for an invalid block size (it breaks CiA 301 on purpose).
  bool nonconforming() const { return options_.block_size == 0 || options_.block_size > 127; }
  // Why the model aborted because of something the client did wrong ("" when it did not).
  const std::string& client_violation() const { return client_violation_; }
  // Download: the bytes received. Upload: what a client must end up with (the object, or for
  // an expedited upload without size four bytes, zero-padded).
  const std::vector<std::uint8_t>& received() const { return received_; }
  const std::vector<std::uint8_t>& expected_upload() const { return expected_upload_; }

 private:
  enum class Phase : std::uint8_t {
    idle,
    upload_segment,
    download_segment,
    block_upload_start,
    block_upload_ack,
    block_upload_end,
    block_download_segments,
    block_download_end,
  };

  void send(const cia301::SdoPayload& payload);
  void abort(std::uint32_t code, std::string violation);
  void answer_upload_initiate();
  void send_block_upload_sub_block();
  void on_idle(const cia301::SdoClientMessage& message);

  cia301::SdoCobIds cob_ids_;
  cia301::Multiplexer mux_;
  std::vector<std::uint8_t> object_;
  SdoServerModelOptions options_;
  std::deque<can::Frame> outbox_;

  Phase phase_ = Phase::idle;
  bool complete_ = false;
  bool refused_block_ = false;
  std::string client_violation_;
  std::vector<std::uint8_t> received_;
  std::vector<std::uint8_t> expected_upload_;

  bool toggle_ = false;
  std::size_t offset_ = 0;  // upload: bytes sent (block: acknowledged)
  bool size_known_ = false;
  std::uint32_t size_ = 0;  // download: indicated size
  bool crc_ = false;        // block: both sides use CRC
  std::uint8_t client_block_size_ = 0;
  std::uint8_t segments_sent_ = 0;  // block upload: in the current sub-block
  bool sub_block_has_last_ = false;
  std::uint8_t expected_seqno_ = 1;  // block download
  bool last_received_ = false;
  std::vector<std::uint8_t> pending_;  // block download: in-sequence data of this sub-block
};

}  // namespace drivecheck::fuzz

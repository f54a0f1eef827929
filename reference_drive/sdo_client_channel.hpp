// The reference drive's SDO client (CiA 301 §7.2.4, parameter 1280h §7.5.2.34): the
// application's remote read/write request object 2F00h (dictionary.hpp) carried out by the
// harness's own SDO client state machine (protocol/cia301/sdo_client.hpp, SdoClientTransfer:
// one implementation of the client protocol in drivecheck). Pure: fed frames and time, it
// returns the frames to send.
//
// A write of 2F00h sub 03h (command 1..3) asks for a transfer; the drive starts it once the
// SDO write that asked is answered (start()). With 1280h sub 01h or 02h not valid (bit 31 = 1)
// there is no client: 2F00h sub 04h = 4, no frame. Otherwise the transfer runs on 1280h's
// COB-IDs (requests on sub 01h, answers taken on sub 02h), with 2F00h sub 06h as the answer
// timeout; a command written while one runs ends the running one (abort 08000000h, "general
// error", CiA 301's code for the cases it names no other for) and starts the new one. At its
// end 2F00h sub 04h is 2 (succeeded; an upload's data in sub 02h) or 3 (failed; sub 05h the
// server's abort code, or the code the client sent: 05040000h at the timeout, 05030000h for a
// toggle error, ...; 0 when the transfer was ended without a frame).
//
// 1280h sub 01h/02h writes are checked here too: 11-bit CAN-IDs only (bit 29 and bits 28..11
// refused 06090030h), the CAN-ID of a valid COB-ID not changed in one write (06090030h, as for
// a PDO), and a valid COB-ID on a restricted CAN-ID (CiA 301 §7.3.5) refused (06090030h), but
// for the default SDO channels of the pre-defined connection set, 601h-67Fh in sub 01h and
// 581h-5FFh in sub 02h, which are restricted for that use: a client talking to another node's
// default server uses them.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_client.hpp"

namespace drivecheck::reference_drive {

struct SdoClientChannelOptions {
  // Named deviations (deviations.inc).
  bool refuse_restricted = true;  // sdo-client-restricted-cob-id-accepted: false
  bool wrong_cob_id = false;      // sdo-client-wrong-cob-id: requests on 600h + 1280h sub 03h
  bool no_timeout = false;        // sdo-client-no-timeout: waits for an answer for ever
};

// 2F00h sub 04h.
enum class SdoClientStatus : std::uint8_t {
  idle = 0,
  running = 1,
  succeeded = 2,
  failed = 3,
  no_client = 4,
};

class SdoClientChannel {
 public:
  // Binds 1280h's validators and 2F00h sub 03h's observer; the dictionary must outlive the
  // channel. Without 1280h or 2F00h the channel does nothing (present() false).
  SdoClientChannel(cia301::ObjectDictionary& od, SdoClientChannelOptions options);

  bool present() const { return parameter_ != nullptr && request_ != nullptr; }
  // A command was written and waits for start().
  bool pending() const { return pending_; }
  // Starts the commanded transfer: the frames to send.
  std::vector<can::Frame> start(can::TimePoint now);
  // Whether `frame` is an answer the running transfer takes (1280h sub 02h's CAN-ID).
  bool takes(const can::Frame& frame) const;
  std::vector<can::Frame> on_frame(const can::Frame& frame, can::TimePoint now);
  std::vector<can::Frame> on_time(can::TimePoint now);
  can::TimePoint next_deadline() const;
  // NMT Stopped: a running transfer ends without a frame (status failed, abort code 0).
  void stop();
  // Reset communication: a running transfer ends without a frame; 2F00h back to its defaults.
  void reset();

 private:
  std::vector<can::Frame> finish(std::span<const can::Frame> frames);
  void set_status(SdoClientStatus status, std::uint32_t abort_code);

  cia301::ObjectDictionary& od_;
  SdoClientChannelOptions options_;
  cia301::Object* parameter_ = nullptr;  // 1280h
  cia301::Object* request_ = nullptr;    // 2F00h
  bool pending_ = false;
  bool upload_ = false;
  std::optional<cia301::SdoClientTransfer> transfer_;
};

}  // namespace drivecheck::reference_drive

// The CoE SDO server (ETG.1000.6 CoE SDO; CiA 301 §7.2.4 SDO semantics) over the object
// dictionary of protocol/cia301/object_dictionary.hpp, and the slave's CoE front: the mailbox
// (mailbox.hpp) and the SDO server together, fed the write mailbox and giving the read mailbox.
// Pure state machines: no I/O, no time (CoE SDO has no server timeout; the master's mailbox
// timeout covers a lost reply).
//
// Transfers (see coe.hpp for the octets):
//   upload    value of 1..4 octets     → expedited response (s=1, n = 4 - size)
//             longer (or empty) values → normal response: complete size, then as many octets
//                                        as fit the read mailbox (read_size - 16); the rest in
//                                        upload segments of up to read_size - 9 octets
//   download  expedited (s=1: 4 - n octets; s=0: the entry's size when it is a fixed size of
//             1..4, else all 4) → written at once
//             normal: complete size + first octets; further octets in download segments; the
//             value is written (and checked) when the announced size is complete
//   toggle    the first segment has t = 0, then alternating; a wrong toggle aborts 05030000h
//   abort     any error aborts the transfer with the dictionary's code (object_dictionary.hpp
//             lists them); an abort from the client ends it without a reply; a new initiate
//             replaces a transfer in progress (the old one is forgotten, as after an abort)
//
// Complete access (C = 1; ETG.1000.6; sub-index 0 includes SI0, 1 starts at sub-index 1):
//   the entries of an ARRAY/RECORD in sub-index order, 1..SI0 (the current SI0 for an upload
//   and for a download from 1; the SI0 being written for a download from 0); a sub-index the
//   object lacks is skipped. Octet layout (SOEM's maintainer on ETG.1000.5, SOEM issue #629:
//   "bit objects with lengths < 8 are concatenated and cross octet boundaries. When an object of
//   8 bits or a multiple are encountered they are padded to the next octet boundary"):
//     SI0           16 bits: the UINT8 value, then 8 bits of padding (public evidence: SOEM's
//                   complete-access structures {UINT8 n; UINT8 pad; UINT16/UINT32 entries[]})
//     entries       each its type's bit length (BOOLEAN 1 bit, LSB first); an entry of 8 bits
//                   or a multiple starts at the next octet boundary
//   Our choices where ETG leaves room (each a permitted reading, written down):
//     - sub-index other than 0/1, or C = 1 on a VAR/DOMAIN object → 06010000h unsupported access
//     - an entry of variable length (strings, DOMAIN) → 06010004h (CoE code)
//     - download: a read-only entry whose new bits equal its value is skipped, else 06010002h;
//       a writable SI0 is written 0 first, then the entries, then its new value (the PDO
//       assignment order of ETG.1000.6); a read-only SI0 must be sent unchanged
//     - download: the data must be exactly the layout's length (06070012h / 06070013h)
//     - download failing half way: every entry gets its bytes back (no hooks run for that)
//   CoeSdoServerOptions::complete_access = false answers every C = 1 with 06010000h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/coe_sdo_info.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {

// ---- Complete access layout -----------------------------------------------------------------

// The octets of a complete access upload of object `index` from sub-index `first` (0 or 1).
// Errors: see the file comment; a read hook's abort; read_write_only for a wo entry.
Expected<std::vector<std::uint8_t>, cia301::SdoAbort> read_complete_access(
    cia301::ObjectDictionary& od, std::uint16_t index, std::uint8_t first);
// Writes a complete access download (all or nothing, see the file comment).
Expected<void, cia301::SdoAbort> write_complete_access(cia301::ObjectDictionary& od,
                                                       std::uint16_t index, std::uint8_t first,
                                                       std::span<const std::uint8_t> data);

// ---- SDO server -------------------------------------------------------------------------------

struct CoeSdoServerOptions {
  std::size_t read_size = 128;  // the read mailbox (SM1) length, header included
  bool complete_access = true;
  bool sdo_information = true;  // CoeSlave answers SDO information requests (coe_sdo_info.hpp)
  // Objects SDO information leaves out (answer_sdo_information's `hidden`); empty: none.
  SdoInfoHidden sdo_information_hidden{};
  // The longest download the server buffers; more aborts 05040005h (out of memory). A hostile
  // master may announce any complete size: the buffer grows only with octets received.
  std::size_t max_download = 1 << 20;
};

// What the server answers one CoE message with: CoE reply octets (mailbox data), or a mailbox
// error when the message is not an SDO request it can answer at all, or nothing.
struct CoeServerReply {
  std::optional<std::vector<std::uint8_t>> coe;
  std::optional<MailboxError> mailbox_error;
};

// A filter around the server, for a slave that must misbehave on purpose (the reference drive's
// named deviations, reference_drive/ethercat/coe_deviations.hpp). It sees each request before
// the server and each response the server gives before it is sent.
class CoeSdoHook {
 public:
  virtual ~CoeSdoHook() = default;
  // `request` (nullptr: it could not be decoded) before the server: a response given instead
  // (the server does not see the request), or nullopt: the server handles it as the hook left
  // it.
  virtual std::optional<CoeSdoResponse> before(CoeSdoRequest* request) = 0;
  // The response to `request` (the server's or before()'s) as it is sent; nullopt: none is.
  virtual std::optional<CoeSdoResponse> after(const CoeSdoRequest* request,
                                              CoeSdoResponse response) = 0;
};

class CoeSdoServer {
 public:
  explicit CoeSdoServer(cia301::ObjectDictionary& od, CoeSdoServerOptions options = {});

  // One CoE message of the SDO request service (mailbox data, CoE header included).
  CoeServerReply handle(std::span<const std::uint8_t> data);

  bool busy() const { return state_ != State::idle; }
  // The hook (must outlive the server, or be reset to nullptr first); nullptr: none.
  void set_hook(CoeSdoHook* hook) { hook_ = hook; }
  // Forgets a transfer in progress (the slave left PREOP/SAFEOP/OP, or its mailbox was reset).
  void reset();

 private:
  enum class State : std::uint8_t { idle, downloading, uploading };
  std::vector<std::uint8_t> abort(const Multiplexer& mux, cia301::SdoAbort code);
  CoeServerReply reply(const CoeSdoRequest* request, std::vector<std::uint8_t> bytes);
  std::vector<std::uint8_t> on_download(const CoeDownloadInitiate& m);
  std::vector<std::uint8_t> on_segment(const CoeDownloadSegment& m);
  std::vector<std::uint8_t> on_upload(const CoeUploadInitiate& m);
  std::vector<std::uint8_t> on_upload_segment(const CoeUploadSegmentRequest& m);
  std::vector<std::uint8_t> finish_download();
  Expected<void, cia301::SdoAbort> write_buffer();  // writes buffer_, then back to idle
  std::size_t initiate_capacity() const;  // data octets in a normal initiate upload response
  std::size_t segment_capacity() const;   // data octets in an upload segment

  cia301::ObjectDictionary& od_;
  CoeSdoServerOptions options_;
  CoeSdoHook* hook_ = nullptr;
  State state_ = State::idle;
  Multiplexer mux_;
  bool complete_access_ = false;
  bool toggle_ = false;  // the toggle the next segment must carry
  std::optional<std::uint32_t> expected_size_;
  std::vector<std::uint8_t> buffer_;
  std::size_t offset_ = 0;
};

// ---- The slave's CoE front ------------------------------------------------------------------

// Mailbox + SDO server + emergencies: what the slave front end wires to SM0/SM1.
//   SM0 written by the master        → on_write_mailbox(bytes of SM0)
//   SM1 free (read by the master)    → take_reply(): the next SM1 content, if any
//   SM1 repeat request toggled       → repeat_last(): SM1 content again, then toggle the ack
//   an EMCY of the drive              → post_emergency(emcy)
// CoE services other than SDO request (and SDO information, unless switched off) get the
// mailbox error service_not_supported.
//   AL state INIT (mailbox off)       → reset()
class CoeSlave {
 public:
  CoeSlave(cia301::ObjectDictionary& od, MailboxSlaveConfig mailbox = {},
           CoeSdoServerOptions sdo = {});

  void on_write_mailbox(std::span<const std::uint8_t> buffer);
  std::optional<std::vector<std::uint8_t>> take_reply() { return mailbox_.take_reply(); }
  std::optional<std::vector<std::uint8_t>> repeat_last() const { return mailbox_.repeat_last(); }
  Expected<void, MailboxError> post_emergency(const cia301::Emcy& emcy);
  void reset();

  MailboxSlave& mailbox() { return mailbox_; }
  CoeSdoServer& sdo() { return sdo_; }

 private:
  MailboxSlave mailbox_;
  CoeSdoServer sdo_;
  cia301::ObjectDictionary& od_;
  CoeSdoServerOptions options_;
};

}  // namespace drivecheck::ethercat

// The CANopen dissector: any CAN frame → one readable line, for transcripts (drivecheck
// decode), reports and test failures.
//
//   605 SDO rx  node 5  initiate download expedited 6040:00 (controlword) = 0x000F = enable ...
//   701 NMT EC  node 1  heartbeat pre-operational
//   081 EMCY    node 1  8611h Following error; register 01h generic
//   000 NMT     start node 5
//   080 SYNC    counter 12
//   605 SDO rx  node 5  SDO rx with DLC 5: invalid (SDO frames carry 8 bytes)
//
// Every frame gives a line: frames that break their protocol's rules are explained, not
// dropped, and nothing a frame contains can crash or hang the dissector. The layouts are in the
// codecs' headers (nmt.hpp, error_control.hpp, sync.hpp, time.hpp, emcy.hpp, pdo.hpp,
// sdo_codec.hpp).
//
// Knowledge it can be given (DissectorOptions): the node-IDs on the bus (frames of other nodes
// are flagged), object names (an EDS or object dictionary supplies them; built in are the CiA
// 301 communication objects and the CiA 402 table), PDO mappings per CAN-ID (then PDOs show
// mapped values), and the SYNC/TIME CAN-IDs.
//
// Dissector is stateful: it follows SDO block transfers (whose segments carry no command
// specifier) and node guarding (a 1-byte answer after a remote request is a guarding response,
// otherwise a heartbeat). dissect_frame() is the stateless form.
#pragma once

#include <array>
#include <bitset>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/pdo.hpp"

namespace drivecheck::cia301 {

// Names an object dictionary entry ("controlword"); nullopt when it does not know it (the
// dissector then falls back to its built-in names).
using ObjectNameLookup =
    std::function<std::optional<std::string>(std::uint16_t index, std::uint8_t sub_index)>;

struct DissectorOptions {
  // Node-IDs known to be on the bus. None set: every node is accepted silently; otherwise frames
  // of other nodes get "(node N not configured)".
  std::bitset<128> nodes;
  ObjectNameLookup object_name;
  // PDO mappings by 11-bit CAN-ID (e.g. 181h → 6041h:00 16 bit + 6061h:00 8 bit).
  std::map<std::uint32_t, PdoMapping> pdo_mappings;
  std::uint32_t sync_cob_id = 0x080;
  std::uint32_t time_cob_id = 0x100;
};

struct Dissection {
  CobIdClass cob;
  std::string function;  // "SDO rx", "NMT", "EMCY", "-", "CAN error", "29-bit"
  std::optional<std::uint8_t> node;
  std::string text;   // the decoded content, or why the frame is invalid
  bool valid = true;  // false: the frame breaks its protocol's rules

  // "SDO rx  node 5  initiate ..." (function padded to 6, then node, then text).
  std::string summary() const;
};

class Dissector {
 public:
  explicit Dissector(DissectorOptions options = {});

  Dissection dissect(const can::Frame& frame);
  // "605 SDO rx  node 5  initiate ..." — the identifier as candump prints it, then summary().
  std::string line(const can::Frame& frame);
  // Forgets transfer and guarding state (e.g. between logs).
  void reset();

  const DissectorOptions& options() const { return options_; }

 private:
  Dissection dissect_sdo(const can::Frame& frame, CobIdClass cob, bool from_client);
  Dissection dissect_error_control(const can::Frame& frame, CobIdClass cob);
  Dissection dissect_pdo(const can::Frame& frame, CobIdClass cob);
  std::string object_text(std::uint16_t index, std::uint8_t sub_index) const;
  std::string value_text(std::uint16_t index, std::uint8_t sub_index,
                         std::span<const std::uint8_t> bytes, bool size_known) const;

  struct NodeState {
    bool client_block_segments = false;  // the client sends block download segments
    bool server_block_segments = false;  // the server sends block upload segments
    // The seqno of the server's last block upload segment (c=1) in the current sub-block,
    // 0 before it: once the client acknowledges it, the server's next frame is the end request.
    std::uint8_t server_last_seqno = 0;
    bool guard_request_pending = false;
  };
  DissectorOptions options_;
  std::array<NodeState, 128> nodes_{};
};

// Stateless: a fresh Dissector for one frame.
Dissection dissect_frame(const can::Frame& frame, const DissectorOptions& options = {});

// The built-in names: CiA 301 communication objects (1000h..1FFFh) and the CiA 402 table,
// e.g. "TPDO1 communication parameter: COB-ID", "statusword".
std::optional<std::string> builtin_object_name(std::uint16_t index, std::uint8_t sub_index);

}  // namespace drivecheck::cia301

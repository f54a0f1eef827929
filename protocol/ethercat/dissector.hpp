// The EtherCAT dissector: one line per datagram of an Ethernet frame, for traces
// (`drivecheck decode FILE.pcap`), the evidence of a run (conformance/datagram_evidence.hpp)
// and failure messages. Everything it names comes from the tables: commands
// (datagram_commands.inc), registers (esc_registers.inc), AL states and AL status codes
// (al_status_codes.inc), mailbox types (mailbox_types.inc), mailbox error codes, CoE services
// (coe_services.inc), SDO abort codes (cia301/sdo_abort_codes.inc), emergency codes (cia301).
//
//   FPRD station 1001h 0130h AL status len 2 wkc 1: PREOP
//   FPWR station 1001h 1000h SM0 write mailbox len 128 wkc 1: CoE len 10 addr 0000h cnt 1:
//        SDO request: upload initiate 6041h:00
//   FPRD station 1001h 1080h SM1 read mailbox len 128 wkc 1: CoE len 10 addr 0000h cnt 1:
//        SDO response: abort 6040h:00 06010002h write_read_only: Attempt to write a read only
//        object
//   LRW logical 00010000h len 14 wkc 3 data=0F 00 ...
//
// State: the dissector follows the SyncManager registers the master writes (0800h + 8n, per
// configured station address or position) to know where each slave's mailboxes are; a
// physical access to the start of an enabled mailbox SyncManager is decoded as a mailbox. A
// trace that begins after the configuration (no SM write seen) gets its mailbox accesses shown
// as plain process RAM.
//
// Pass: a frame goes out from the master and comes back processed (working counters, data
// read). The caller says which when it knows (a segment monitor does); otherwise
// (FramePass::unknown, a pcap) the dissector infers it: a frame with the same datagram
// commands and Idx tags as the previous outgoing frame, and not already answered, is its
// return. The data of a read is only decoded in the returned pass (outgoing it is what the
// master put there, usually zeros).
//
// Malformed input never throws and never reads out of bounds: a frame that is not well formed
// EtherCAT gives one line "malformed: <what, at which byte>"; a mailbox that does not parse
// gives "... malformed: <why>" in its datagram's line (fuzz target ethercat_pcap holds it to
// that).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace drivecheck::ethercat {

enum class FramePass : std::uint8_t { outgoing, returned, unknown };

struct DissectedFrame {
  FramePass pass = FramePass::unknown;  // as given, or as inferred
  bool malformed = false;               // not a well-formed EtherCAT frame (lines holds why)
  // One line per datagram (or one "malformed: ..." line).
  std::vector<std::string> lines;
  // For summarising runs of identical frames (the cyclic process data): each line without its
  // process data (LRD/LWR/LRW data, process RAM). Two frames with equal shapes differ at most
  // in their process data. Empty for a malformed frame and for a frame that carries mailbox
  // content (always shown, never summarised).
  std::vector<std::string> shapes;
  // For summarising repeated patterns (conformance/repeats.hpp): each line without its process
  // data, its mailbox counter and the SII EEPROM interface's values (0500h-050Fh: the address
  // and data of each word of an SII read). Two datagrams with equal patterns do the same thing
  // to the same place; one per line (empty for a malformed frame).
  std::vector<std::string> patterns;
};

class FrameDissector {
 public:
  // Dissects one Ethernet frame (without FCS). Never fails: malformed input is a line.
  DissectedFrame dissect(std::span<const std::uint8_t> frame, FramePass pass = FramePass::unknown);
  // Forgets the SyncManager configuration and the pending outgoing frame.
  void reset();

 private:
  struct Key {
    bool station = false;  // configured station address (FPxx) or position (APxx)
    std::uint16_t adp = 0;
    auto operator<=>(const Key&) const = default;
  };
  // The SyncManager registers 0800h..087Fh as the master wrote them, per slave.
  std::map<Key, std::array<std::uint8_t, 128>> sync_managers_;
  // The commands and tags of the last outgoing frame not answered yet.
  std::optional<std::vector<std::pair<std::uint8_t, std::uint8_t>>> outgoing_;
};

// The register(s) an access of `length` bytes at `ado` touches: "AL status",
// "AL status, AL status code", "SM1 status", "FMMU0", "SII EEPROM data +4", "process RAM",
// "reserved 0F00h".
std::string describe_registers(std::uint16_t ado, std::size_t length);

// One line for the content of a mailbox buffer (header, then CoE SDO / emergency / SDO
// information, ERR replies, or the size for other protocols); "malformed: ..." when it does
// not parse.
std::string describe_mailbox(std::span<const std::uint8_t> buffer);

}  // namespace drivecheck::ethercat

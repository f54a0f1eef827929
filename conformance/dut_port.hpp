// The engine's seam to the device under test: the services a vector step uses (SDO upload and
// download, so also controlword, statusword polls and the CiA 402 state walk) go through a
// DutPort, whatever link carries them. CanPort (can_port.hpp) is CiA 301 SDO over the engine's
// CAN port, every frame evidence; EthercatPort (ethercat_port.hpp) is CoE SDO through an
// EtherCAT master. Frame-level steps (send, expect_frame, nmt, ...) stay CAN-only: a vector
// that has one is not applicable on another link (verdict.hpp).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::conformance {

class VectorRun;

// The link a DUT port speaks (vectors/FORMAT.md `transports:`).
enum class LinkKind : std::uint8_t { can, ethercat };
std::string_view to_string(LinkKind link);

struct SdoOutcome {
  bool ok = false;
  std::vector<std::uint8_t> data;      // upload
  std::optional<std::uint32_t> abort;  // the server's abort code
  std::error_code error;               // any failure (abort included)
  // The vector's time limit ended the transfer (before its request or its answer): no
  // verdict on the server, which may not have had its SDO timeout yet.
  bool vector_timed_out = false;
  std::string describe() const;  // "ok", "abort 06010002h (...)", "no answer ..."
  // A failed transfer as an observation: its abort code, or nothing (no answer).
  Observation observed() const;
};

struct SdoRequest {
  cia301::Multiplexer mux;
  Transfer transfer = Transfer::automatic;
  can::Duration timeout{};  // the response time allowed
  // Block upload: the blksize the client offers (1..127); 0 = the client's default (127).
  std::uint8_t block_size = 0;
};

class DutPort {
 public:
  virtual ~DutPort() = default;
  virtual LinkKind link() const = 0;
  // One transfer for `run` (the vector running: its deadline, its evidence). A failure is in
  // the outcome (abort code, no answer, the vector's time limit), never an exception.
  virtual SdoOutcome upload(VectorRun& run, const SdoRequest& request) = 0;
  virtual SdoOutcome download(VectorRun& run, const SdoRequest& request,
                              std::span<const std::uint8_t> data) = 0;
  // Links without NMT frames (setup.cpp calls these instead of sending NMT; on CAN never):
  // a reset (`node`: of the whole device, else of its communication), and entering the link's
  // counterpart of an NMT state. "" when done, else why not.
  virtual std::string reset(bool node) {
    (void)node;
    return "no reset on this link";
  }
  virtual std::string enter_state(cia301::NmtState state) {
    (void)state;
    return "no communication states on this link";
  }
  // Links whose traffic is not the engine's CAN frames (EtherCAT): where the port records the
  // vector's evidence (VectorResult::datagrams) from now on; nullptr: nowhere. VectorRun sets
  // it for its lifetime and puts the previous one back after. Returns the previous sink. CAN
  // records its frames itself (VectorRun::pump).
  virtual VectorResult* set_evidence_sink(VectorResult* sink) {
    (void)sink;
    return nullptr;
  }
};

}  // namespace drivecheck::conformance

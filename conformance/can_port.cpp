// CiA 301 SDO over the engine's CAN port (moved unchanged from sdo_steps.cpp).
#include "conformance/can_port.hpp"

#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_client.hpp"

namespace drivecheck::conformance {
namespace {

cia301::SdoTransferMode mode_of(Transfer transfer) {
  switch (transfer) {
    case Transfer::segmented:
      return cia301::SdoTransferMode::segmented;
    case Transfer::block:
      return cia301::SdoTransferMode::block;
    case Transfer::automatic:
    case Transfer::expedited:
    case Transfer::complete_access:  // EtherCAT only: such a vector is not applicable on CAN
      return cia301::SdoTransferMode::automatic;
  }
  return cia301::SdoTransferMode::automatic;
}

SdoOutcome run_transfer(VectorRun& run, cia301::SdoClientTransfer& transfer,
                        std::span<const can::Frame> first) {
  SdoOutcome outcome;
  auto send_all = [&](std::span<const can::Frame> frames) {
    for (const auto& frame : frames) {
      if (auto ec = run.send(frame)) return ec;
    }
    return std::error_code{};
  };
  if (auto ec = send_all(first)) {
    transfer.cancel();
    outcome.error = ec;
    return outcome;
  }
  while (transfer.running()) {
    if (run.vector_timed_out()) {
      // The vector's limit, not the server's SDO timeout: say so (a device that answered every
      // request within 1 ms was reported as "did not answer in time" when a poll ran into it).
      (void)send_all(transfer.abort(std::uint32_t{0x05040000}));
      outcome.error = cia301::make_error_code(cia301::SdoClientError::aborted_locally);
      outcome.vector_timed_out = true;
      return outcome;
    }
    auto frame = run.pump(transfer.next_deadline());
    const auto out =
        frame ? transfer.on_frame(frame->frame, frame->timestamp) : transfer.on_time(run.now());
    if (auto ec = send_all(out)) {
      transfer.cancel();
      outcome.error = ec;
      return outcome;
    }
  }
  outcome.ok = transfer.succeeded();
  outcome.error = transfer.error();
  outcome.abort = cia301::server_abort_code(transfer.error());
  if (outcome.ok) outcome.data.assign(transfer.data().begin(), transfer.data().end());
  return outcome;
}

cia301::SdoClientOptions client_options(const SdoRequest& request) {
  cia301::SdoClientOptions options;
  options.timeout = request.timeout;
  options.block_fallback = request.transfer != Transfer::block;
  if (request.block_size != 0) options.block_size = request.block_size;
  return options;
}

}  // namespace

SdoOutcome CanPort::upload(VectorRun& run, const SdoRequest& request) {
  cia301::SdoClientTransfer sdo(run.node(), client_options(request));
  const auto first = sdo.start_upload(request.mux, run.now(), mode_of(request.transfer));
  return run_transfer(run, sdo, first);
}

SdoOutcome CanPort::download(VectorRun& run, const SdoRequest& request,
                             std::span<const std::uint8_t> data) {
  cia301::SdoClientTransfer sdo(run.node(), client_options(request));
  const auto first = sdo.start_download(request.mux, data, run.now(), mode_of(request.transfer));
  return run_transfer(run, sdo, first);
}

}  // namespace drivecheck::conformance

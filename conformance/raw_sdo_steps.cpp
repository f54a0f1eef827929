// The transport-neutral raw SDO steps on EtherCAT (FORMAT.md "Raw SDO steps"): `sdo_request`
// as a CoE SDO request, `expect_sdo_response` against the CoE SDO responses the slave puts into
// its read mailbox. The SDO part of a CoE SDO message is CiA 301's (ETG.1000.6 CoE: the CoE
// header, then command, index, sub-index and 4 data octets as CiA 301 §7.2.4.3 lays them out),
// so a response is judged as the CAN frame 580h+N with its first 8 octets would be: by the
// same FrameSpec matcher and the same abort set judgement as expect_frame (expectations.cpp).
// On CAN both steps are the `send` / `expect_frame` they stand for (sdo_steps.cpp,
// expectations.cpp).
#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "conformance/ethercat_port.hpp"
#include "conformance/isolation.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/mailbox.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

// The CAN frame 580h+N that carries the same SDO octets as a CoE SDO response: its first 8
// octets after the CoE header. nullopt for anything else: an ERR reply, another mailbox type,
// another CoE service, fewer than 8 SDO octets. Octets after the 8 (the data of a normal
// transfer, ETG.1000.6) are no part of the CAN form; the description shows them.
std::optional<can::Frame> sdo_frame_of(const EthercatPort::RawReply& reply, std::uint8_t node) {
  if (reply.error || reply.type != static_cast<std::uint8_t>(ethercat::MailboxType::coe) ||
      ethercat::peek_coe_service(reply.data) !=
          static_cast<std::uint8_t>(ethercat::CoeService::sdo_response) ||
      reply.data.size() < ethercat::kCoeSdoMessageSize)
    return std::nullopt;
  return can::Frame::standard(
      cia301::kSdoResponseBase + node,
      std::span<const std::uint8_t>(reply.data.data() + ethercat::kCoeHeaderSize,
                                    ethercat::kCoeSdoSize));
}

// "CoE SDO response 4F 18 10 00 04 00 00 00 (SDO upload initiate response ...)", "mailbox
// error 0002h (...)", ...
std::string describe_reply(const EthercatPort::RawReply& reply) {
  if (reply.error)
    return fmt::format("mailbox error {}", ethercat::describe_mailbox_error(*reply.error));
  if (reply.type != static_cast<std::uint8_t>(ethercat::MailboxType::coe))
    return fmt::format("mailbox type {} ({} octets)", reply.type, reply.data.size());
  const auto service = ethercat::peek_coe_service(reply.data);
  if (service != static_cast<std::uint8_t>(ethercat::CoeService::sdo_response)) {
    const auto name = service ? ethercat::coe_service_name(*service) : std::nullopt;
    return fmt::format("CoE service {} ({} octets)",
                       name ? std::string(*name) : fmt::format("{}", service.value_or(0)),
                       reply.data.size());
  }
  const std::span<const std::uint8_t> sdo(reply.data.data() + ethercat::kCoeHeaderSize,
                                          reply.data.size() - ethercat::kCoeHeaderSize);
  auto decoded = ethercat::decode_sdo_response(reply.data);
  return fmt::format("CoE SDO response {:02X} ({})", fmt::join(sdo, " "),
                     decoded ? ethercat::to_string(*decoded)
                             : fmt::format("not decodable: {}", decoded.error().reason));
}

std::string ms(can::Duration duration) {
  return fmt::format("{:.3f} ms", std::chrono::duration<double, std::milli>(duration).count());
}

// The octets of a pattern as the vector writes them ("4F181000........").
std::string octets(const FrameSpec& pattern) {
  const auto hash = pattern.text.find('#');
  return hash == std::string::npos ? pattern.text : pattern.text.substr(hash + 1);
}

}  // namespace

StepStatus VectorRun::send_coe_sdo_request(const SendStep& request, const std::string& name) {
  auto* port = dynamic_cast<EthercatPort*>(&context_.port);
  if (port == nullptr) return harness_error(name, "sdo_request: no EtherCAT port on this link");
  const can::Frame frame = request.frame.to_frame(node());
  // Isolation learns what the request may write, as pump() does from the CAN frame.
  if (const auto download = sdo_download_request(frame, node())) {
    note_download_request(download->mux, download->expedited_data
                                             ? std::optional(download->expedited_data->size())
                                             : std::nullopt);
  }
  const auto payload = frame.payload();
  if (auto why = port->send_raw_sdo(payload); !why.empty()) {
    return harness_error(name, fmt::format("cannot write the CoE SDO request {:02X}: {}",
                                           fmt::join(payload, " "), why));
  }
  check(name, "CoE SDO request written into the write mailbox",
        fmt::format("CoE SDO request {:02X}", fmt::join(payload, " ")), true);
  return StepStatus::ok;
}

StepStatus VectorRun::expect_coe_sdo_response(const ExpectFrameStep& e, const std::string& name) {
  auto* port = dynamic_cast<EthercatPort*>(&context_.port);
  if (port == nullptr)
    return harness_error(name, "expect_sdo_response: no EtherCAT port on this link");
  const auto within = resolve(e.within);
  // From the end of the previous step: the request was in the write mailbox then.
  const auto base = step_started_;
  const auto deadline = base + within;
  std::vector<std::string> patterns{octets(e.pattern)};
  for (const auto& alternative : e.alternatives)
    patterns.push_back(octets(alternative));
  auto expected = fmt::format("a CoE SDO response matching {} within {}",
                              fmt::join(patterns, " or "), profile::format_duration(within));
  if (e.abort) expected += fmt::format(", {}", e.abort->describe());
  // As expect_frame: nothing matched, with the last abort the server sent meanwhile.
  Observation observed;
  observed.nothing = true;
  std::vector<std::string> seen;
  for (;;) {
    std::string error;
    auto reply = port->receive_raw(deadline, error);
    if (!error.empty()) {
      // The read mailbox held no valid mailbox: the slave's fault, not the harness's.
      return fail(name, expected, fmt::format("the read mailbox: {}", error), observed);
    }
    if (!reply) break;
    note_dut_answer();
    const auto text = fmt::format("{} after {}", describe_reply(*reply), ms(reply->at - base));
    const auto frame = sdo_frame_of(*reply, node());
    if (frame) {
      // Isolation: a confirmed download, as pump() learns it from the CAN frame.
      if (const auto ref = confirmed_download(*frame, node()))
        note_confirmed_download({ref->index, ref->sub});
      const bool hit =
          e.pattern.matches(*frame, node()) ||
          std::any_of(e.alternatives.begin(), e.alternatives.end(),
                      [&](const FrameSpec& alt) { return alt.matches(*frame, node()); });
      if (hit) {
        if (const auto code = refused_abort(e, *frame, node())) {
          Observation refused;
          refused.abort = *code;
          return fail(
              name, expected,
              fmt::format("{}: abort {}", text,
                          cia301::make_error_code(static_cast<cia301::SdoAbort>(*code)).message()),
              refused);
        }
        if (!e.mark.empty()) set_mark(e.mark, reply->at, received_.size());
        check(name, expected, text, true);
        return StepStatus::ok;
      }
      const auto sdo = frame->payload();
      if (sdo[0] == 0x80) {
        observed.abort = static_cast<std::uint32_t>(sdo[4] | sdo[5] << 8 | sdo[6] << 16 |
                                                    static_cast<std::uint32_t>(sdo[7]) << 24);
      }
    }
    seen.push_back(text);
  }
  return fail_timed(
      name, expected,
      seen.empty() ? fmt::format("no CoE SDO response within {}", profile::format_duration(within))
                   : fmt::format("nothing matching within {}; read: {}",
                                 profile::format_duration(within), fmt::join(seen, "; ")),
      observed);
}

}  // namespace drivecheck::conformance

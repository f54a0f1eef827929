#include "protocol/ethercat/master_mailbox.hpp"

#include <fmt/format.h>

#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/ethercat/esc.hpp"

namespace drivecheck::ethercat {
namespace {

std::chrono::nanoseconds since_epoch(TimePoint t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch());
}

long long in_ms(Duration d) {
  return std::chrono::duration_cast<std::chrono::milliseconds>(d).count();
}

}  // namespace

MasterMailbox::MasterMailbox(MasterPort& port, const SlaveLayout& layout,
                             MailboxPollOptions options)
    : port_(port),
      station_(layout.station),
      out_(layout.mailbox_out),
      in_(layout.mailbox_in),
      options_(options),
      master_({.write_size = out_ ? out_->length : 0u,
               .address = 0,
               .reply_timeout =
                   std::chrono::duration_cast<std::chrono::nanoseconds>(options.timeout)}) {}

Expected<void, MasterError> MasterMailbox::configured() const {
  if (out_ && in_) return {};
  return master_error(MasterErrc::not_configured,
                      fmt::format("station {:04X}h has no mailbox (SII mailbox size 0)", station_),
                      station_);
}

Expected<void, MasterError> MasterMailbox::send(MailboxType type,
                                                std::span<const std::uint8_t> data) {
  if (auto ok = configured(); !ok) return ok;
  if (!master_.fits(data.size())) {
    return master_error(MasterErrc::mailbox_error,
                        fmt::format("station {:04X}h: a message of {} octets does not fit the "
                                    "write mailbox of {} octets",
                                    station_, data.size() + kMailboxHeaderSize, out_->length),
                        station_);
  }
  const std::vector<std::uint8_t> buffer = master_.request(type, data, since_epoch(port_.now()));
  return write_sm0(buffer);
}

Expected<void, MasterError> MasterMailbox::send_raw(std::span<const std::uint8_t> buffer) {
  if (auto ok = configured(); !ok) return ok;
  if (buffer.size() > out_->length) {
    return master_error(MasterErrc::mailbox_error,
                        fmt::format("station {:04X}h: a buffer of {} octets does not fit the "
                                    "write mailbox of {} octets",
                                    station_, buffer.size(), out_->length),
                        station_);
  }
  std::vector<std::uint8_t> padded(buffer.begin(), buffer.end());
  padded.resize(out_->length, 0);
  return write_sm0(padded);
}

Expected<void, MasterError> MasterMailbox::write_sm0(const std::vector<std::uint8_t>& buffer) {
  const TimePoint deadline = port_.now() + options_.timeout;
  for (;;) {
    auto back = port_.exchange(Datagram::physical(Command::fpwr, 0, station_, out_->start, buffer));
    if (!back) return Unexpected(back.error());
    if (back->working_counter == 1) return {};
    if (back->working_counter != 0) {
      return master_error(MasterErrc::working_counter,
                          fmt::format("station {:04X}h: write mailbox FPWR {:04X}h: working "
                                      "counter {}, expected 1",
                                      station_, out_->start, back->working_counter),
                          station_);
    }
    if (port_.now() >= deadline) {
      return master_error(MasterErrc::mailbox_timeout,
                          fmt::format("station {:04X}h: write mailbox (SM0 at {:04X}h) still full "
                                      "after {} ms",
                                      station_, out_->start, in_ms(options_.timeout)),
                          station_);
    }
    port_.wait(options_.poll_interval);
  }
}

Expected<void, MasterError> MasterMailbox::repeat_request() {
  ++repeat_requests_;
  const bool bit = master_.toggle_repeat_request();
  const std::uint16_t sm = reg::sync_manager(in_->index);
  const auto activate =
      static_cast<std::uint8_t>(sm::kActivateEnable | (bit ? sm::kActivateRepeat : 0));
  if (auto written =
          port_.write(Command::fpwr, station_, static_cast<std::uint16_t>(sm + 6), {activate});
      !written) {
    return written;
  }
  const TimePoint deadline = port_.now() + options_.timeout;
  for (;;) {
    auto pdi = port_.read(Command::fprd, station_, static_cast<std::uint16_t>(sm + 7), 1);
    if (!pdi) return Unexpected(pdi.error());
    if (master_.repeat_acknowledged(((*pdi)[0] & sm::kPdiRepeatAck) != 0)) return {};
    if (port_.now() >= deadline) {
      return master_error(MasterErrc::mailbox_timeout,
                          fmt::format("station {:04X}h: no acknowledge of the SM{} repeat "
                                      "request within {} ms",
                                      station_, in_->index, in_ms(options_.timeout)),
                          station_);
    }
    port_.wait(options_.poll_interval);
  }
}

Expected<std::optional<MailboxIn>, MasterError> MasterMailbox::poll() {
  if (auto ok = configured(); !ok) return Unexpected(ok.error());
  const std::uint16_t sm = reg::sync_manager(in_->index);
  std::vector<Datagram> frame;
  frame.push_back(
      Datagram::physical(Command::fprd, 0, station_, static_cast<std::uint16_t>(sm + 5), {0}));
  frame.push_back(Datagram::physical(Command::fprd, 0, station_, in_->start,
                                     std::vector<std::uint8_t>(in_->length, 0)));
  for (unsigned attempt = 0;; ++attempt) {
    auto back = port_.exchange(frame, ExchangeOptions{0});
    if (back) {
      const Datagram& buffer = (*back)[1];
      if (buffer.working_counter != 1) return std::optional<MailboxIn>{};
      auto reply = master_.accept(buffer.data);
      if (!reply) {
        MasterError e =
            master_error(
                MasterErrc::mailbox_error,
                fmt::format("station {:04X}h: read mailbox holds no valid "
                            "mailbox: {}",
                            station_,
                            describe_mailbox_error(static_cast<std::uint16_t>(reply.error()))),
                station_)
                .error();
        e.mailbox_error = static_cast<std::uint16_t>(reply.error());
        return Unexpected(std::move(e));
      }
      if (reply->order == ReplyOrder::duplicate) return std::optional<MailboxIn>{};
      MailboxIn in;
      in.header = reply->message.header;
      in.data.assign(reply->message.data.begin(), reply->message.data.end());
      in.error = reply->error;
      in.order = reply->order;
      return std::optional<MailboxIn>(std::move(in));
    }
    if (back.error().code != MasterErrc::no_response) return Unexpected(back.error());
    // The read may have emptied SM1 and its answer is lost: ask for the reply again.
    if (attempt >= options_.repeat_attempts) {
      return master_error(MasterErrc::mailbox_timeout,
                          fmt::format("station {:04X}h: read mailbox lost {} times, repeat "
                                      "requests exhausted ({})",
                                      station_, attempt + 1, back.error().detail),
                          station_);
    }
    if (auto repeated = repeat_request(); !repeated) return Unexpected(repeated.error());
  }
}

Expected<std::optional<MailboxIn>, MasterError> MasterMailbox::receive(TimePoint deadline) {
  for (;;) {
    auto message = poll();
    if (!message || *message) return message;
    if (port_.now() >= deadline) return std::optional<MailboxIn>{};
    port_.wait(options_.poll_interval);
  }
}

Expected<void, MasterError> MasterMailbox::run_sdo(CoeSdoClient& client,
                                                   std::vector<std::uint8_t> request,
                                                   Multiplexer mux) {
  if (auto sent = send(MailboxType::coe, request); !sent) return sent;
  TimePoint deadline = port_.now() + options_.timeout;
  for (;;) {
    auto message = receive(deadline);
    if (!message) return Unexpected(message.error());
    if (!*message) {
      const std::vector<std::uint8_t> abort = client.timeout();
      (void)send(MailboxType::coe, abort);  // best effort: the slave may be gone
      master_.reply_matched();
      MasterError e =
          master_error(MasterErrc::mailbox_timeout,
                       fmt::format("station {:04X}h: no SDO response for "
                                   "{:04X}h:{:02X}h within {} ms (aborted "
                                   "05040000h)",
                                   station_, mux.index, mux.sub_index, in_ms(options_.timeout)),
                       station_)
              .error();
      e.abort_code = 0x05040000;
      return Unexpected(std::move(e));
    }
    MailboxIn& in = **message;
    if (in.error) {
      master_.reply_matched();
      client = CoeSdoClient({.write_size = out_->length});
      MasterError e = master_error(MasterErrc::mailbox_error,
                                   fmt::format("station {:04X}h: SDO {:04X}h:{:02X}h answered "
                                               "with mailbox error {}",
                                               station_, mux.index, mux.sub_index,
                                               describe_mailbox_error(*in.error)),
                                   station_)
                          .error();
      e.mailbox_error = *in.error;
      return Unexpected(std::move(e));
    }
    if (in.header.type != static_cast<std::uint8_t>(MailboxType::coe)) continue;
    if (peek_coe_service(in.data) == static_cast<std::uint8_t>(CoeService::emergency)) {
      if (auto emergency = decode_emergency(in.data)) emergencies_.push_back(std::move(*emergency));
      continue;
    }
    const CoeClientStep step = client.on_response(in.data);
    if (step.ignored) continue;
    master_.reply_matched();
    if (step.request) {
      if (auto sent = send(MailboxType::coe, *step.request); !sent) return sent;
      deadline = port_.now() + options_.timeout;
    }
    if (!step.done) continue;
    if (!step.error) return {};
    const CoeClientError& error = *step.error;
    const char* who = error.kind == CoeClientError::Kind::server_abort
                          ? "the slave aborted"
                          : "the slave broke the SDO protocol; the master aborted";
    MasterError e = master_error(MasterErrc::sdo_abort,
                                 fmt::format("station {:04X}h: SDO {:04X}h:{:02X}h: {} with {}{}",
                                             station_, mux.index, mux.sub_index, who,
                                             cia301::describe_sdo_abort(error.code),
                                             error.detail.empty() ? "" : " (" + error.detail + ")"),
                                 station_)
                        .error();
    e.abort_code = error.code;
    return Unexpected(std::move(e));
  }
}

Expected<std::vector<std::uint8_t>, MasterError> MasterMailbox::sdo_upload(Multiplexer mux,
                                                                           bool complete_access) {
  if (auto ok = configured(); !ok) return Unexpected(ok.error());
  CoeSdoClient client({.write_size = out_->length});
  auto request = client.start_upload(mux, complete_access);
  if (auto done = run_sdo(client, std::move(request), mux); !done) {
    return Unexpected(done.error());
  }
  return client.value();
}

Expected<void, MasterError> MasterMailbox::sdo_download(Multiplexer mux,
                                                        std::span<const std::uint8_t> data,
                                                        bool complete_access,
                                                        CoeDownloadTransfer transfer) {
  if (auto ok = configured(); !ok) return ok;
  CoeSdoClient client({.write_size = out_->length,
                       .expedited = transfer == CoeDownloadTransfer::expedited_if_it_fits});
  auto request = client.start_download(mux, data, complete_access);
  return run_sdo(client, std::move(request), mux);
}

}  // namespace drivecheck::ethercat

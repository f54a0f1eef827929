// Fuzz target: one SDO client transfer (SdoClientTransfer, CiA 301 §7.2.4) against a server
// that is partly correct and partly hostile.
//
// Input: the header and operations of fuzz/support/sdo_client_input.hpp: who uploads or
// downloads what, in which mode, with which options; how the server model behaves; then what
// happens on the bus (the model's answers delivered, lost, duplicated or mutated, frames
// injected, the client's frames lost, time steps up to and past the deadline).
//
// Oracles: SdoConversationChecker on every call (fuzz/support/sdo_conversation_checker.hpp);
// after the input, the model's remaining answers are delivered, and then
//   - a run without loss, injection, mutation or missed deadline ends with the client and the
//     model agreeing (success with the same data, or the failure the setup calls for), and
//     without the model having caught the client breaking the protocol;
//   - every transfer ends at the latest at its deadline.
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz/support/frame_record.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "fuzz/support/sdo_client_input.hpp"
#include "fuzz/support/sdo_conversation_checker.hpp"
#include "fuzz/support/sdo_server_model.hpp"
#include "protocol/cia301/sdo_client.hpp"

namespace {

using namespace drivecheck;
using namespace drivecheck::cia301;
using drivecheck::fuzz::FuzzInput;

constexpr std::uint8_t kNode = 5;
constexpr std::size_t kSmallMaxUpload = 100;
constexpr int kMaxDrainSteps = 100000;

class Harness {
 public:
  Harness(SdoClientOptions options, fuzz::SdoTransferSpec spec, fuzz::SdoServerModel model)
      : client_(kNode, std::move(options)), model_(std::move(model)), checker_(std::move(spec)) {}

  SdoClientTransfer& client() { return client_; }
  fuzz::SdoServerModel& model() { return model_; }
  bool clean() const { return clean_; }
  can::TimePoint now() const { return now_; }

  void start(const fuzz::SdoTransferSpec& spec) {
    const auto sent = spec.upload
                          ? client_.start_upload(spec.mux, now_, spec.mode)
                          : client_.start_download(spec.mux, spec.download_data, now_, spec.mode);
    checker_.on_start(sent, client_, now_);
    route(sent);
  }

  void deliver(const can::Frame& frame) {
    const auto sent = client_.on_frame(frame, now_);
    checker_.on_server_frame(frame, sent, client_, now_);
    route(sent);
  }

  void advance_to(can::TimePoint to) {
    if (to < now_) return;
    if (client_.running() && to >= client_.next_deadline()) clean_ = false;
    now_ = to;
    const auto sent = client_.on_time(now_);
    checker_.on_time(now_, sent, client_);
    route(sent);
  }

  void lose_client_frames(int count) {
    drop_client_frames_ += count;
    clean_ = false;
  }
  void make_unclean() { clean_ = false; }

  // Delivers the model's answers until it has none; false if that did not settle.
  bool drain() {
    for (int step = 0; step < kMaxDrainSteps; ++step) {
      if (model_.outbox().empty()) return true;
      const can::Frame frame = model_.outbox().front();
      model_.outbox().pop_front();
      deliver(frame);
    }
    return false;
  }

 private:
  void route(std::span<const can::Frame> sent) {
    for (const can::Frame& frame : sent) {
      if (drop_client_frames_ > 0) {
        --drop_client_frames_;
        continue;
      }
      model_.on_client_frame(frame);
    }
  }

  SdoClientTransfer client_;
  fuzz::SdoServerModel model_;
  fuzz::SdoConversationChecker checker_;
  can::TimePoint now_ = can::TimePoint(std::chrono::seconds(1));
  bool clean_ = true;
  int drop_client_frames_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzInput in(data, size);
  const fuzz::SdoClientSetup setup = fuzz::SdoClientSetup::read(in);

  static constexpr std::chrono::milliseconds kTimeouts[] = {
      std::chrono::milliseconds(1), std::chrono::milliseconds(100), std::chrono::milliseconds(1000),
      std::chrono::milliseconds(30000)};
  const bool upload = setup.upload;
  const SdoTransferMode mode = setup.mode == 0   ? SdoTransferMode::automatic
                               : setup.mode == 1 ? SdoTransferMode::segmented
                                                 : SdoTransferMode::block;

  SdoClientOptions options;
  options.timeout = kTimeouts[setup.timeout & 0x3];
  options.block_size = setup.block_size;
  options.protocol_switch_threshold = setup.pst;
  options.block_crc = setup.crc;
  options.block_fallback = setup.fallback;
  if (setup.small_max_upload) options.max_upload_size = kSmallMaxUpload;

  fuzz::SdoTransferSpec spec;
  spec.cob_ids = SdoCobIds::for_node(kNode);
  spec.mux = Multiplexer{setup.index, setup.sub_index};
  spec.upload = upload;
  spec.mode = mode;
  spec.timeout = options.timeout;
  spec.block_size = options.block_size;
  spec.protocol_switch_threshold = options.protocol_switch_threshold;
  spec.block_crc = options.block_crc;
  spec.block_fallback = options.block_fallback;
  spec.max_upload_size = options.max_upload_size;

  const std::vector<std::uint8_t> object = fuzz::sdo_client_object(setup.size, setup.seed);
  if (!upload) spec.download_data = object;

  fuzz::SdoServerModelOptions model_options;
  model_options.crc = setup.server_crc;
  model_options.upload_size_indicated = setup.upload_size_indicated;
  model_options.expedited_upload = setup.expedited_upload;
  model_options.expedited_size_indicated = setup.expedited_size_indicated;
  model_options.refuse_block = setup.refuse_block;
  model_options.protocol_switch = setup.protocol_switch;
  model_options.block_size = setup.server_block_size;

  Harness harness(
      options, spec,
      fuzz::SdoServerModel(spec.cob_ids, spec.mux, upload ? object : std::vector<std::uint8_t>{},
                           model_options));
  harness.start(spec);

  auto& outbox = harness.model().outbox();
  while (!in.empty()) {
    const std::uint8_t op = in.u8();
    const unsigned p = op >> 3;
    using Op = fuzz::SdoClientOp;
    switch (static_cast<Op>(op & 0x7)) {
      case Op::deliver:
        if (!outbox.empty()) {
          const can::Frame frame = outbox.front();
          outbox.pop_front();
          harness.deliver(frame);
        }
        break;
      case Op::drain:
        DRIVECHECK_FUZZ_CHECK(harness.drain(), "SDO client and server model did not settle");
        break;
      case Op::time_step: {
        const can::TimePoint deadline = harness.client().next_deadline();
        switch (p % 4) {
          case 0:
            harness.advance_to(harness.now() + std::chrono::milliseconds(p / 4 + 1));
            break;
          case 1:
            if (deadline != can::kForever) harness.advance_to(deadline - can::Duration(1));
            break;
          case 2:
            if (deadline != can::kForever) harness.advance_to(deadline);
            break;
          default:
            harness.advance_to(harness.now() + std::chrono::milliseconds(in.u16()));
            break;
        }
        break;
      }
      case Op::inject: {
        can::Frame frame = fuzz::decode_frame_record(in);
        const SdoCobIds& ids = spec.cob_ids;
        switch (p % 4) {
          case 0:
            frame.id = ids.response;
            frame.format = frame.is_error() ? can::IdFormat::extended : can::IdFormat::standard;
            break;
          case 1:
            break;
          case 2:
            frame.id = ids.request;
            frame.format = frame.is_error() ? can::IdFormat::extended : can::IdFormat::standard;
            break;
          default:
            frame = can::Frame::standard(ids.response, frame.data);
            break;
        }
        harness.make_unclean();
        harness.deliver(frame);
        break;
      }
      case Op::mutate: {
        const std::uint8_t mask = in.u8();
        if (!outbox.empty()) {
          can::Frame frame = outbox.front();
          outbox.pop_front();
          frame.data[p % 8] ^= mask;
          harness.make_unclean();
          harness.deliver(frame);
        }
        break;
      }
      case Op::lose_answer:
        if (!outbox.empty()) {
          outbox.pop_front();
          harness.make_unclean();
        }
        break;
      case Op::duplicate:
        if (!outbox.empty()) {
          harness.make_unclean();
          harness.deliver(outbox.front());
        }
        break;
      case Op::lose_request:
        harness.lose_client_frames(static_cast<int>(p % 4) + 1);
        break;
    }
  }

  DRIVECHECK_FUZZ_CHECK(harness.drain(), "SDO client and server model did not settle");
  const SdoClientTransfer& client = harness.client();
  const fuzz::SdoServerModel& model = harness.model();

  if (harness.clean()) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(model.client_violation().empty(),
                                 "the server model caught the client breaking CiA 301",
                                 model.client_violation());
    DRIVECHECK_FUZZ_CHECK(!client.running(),
                          "a run without loss or hostility left the client waiting");
    // What a correct client must conclude with this setup and a correct server.
    std::error_code expected;
    if (upload && mode == SdoTransferMode::block && setup.block_size == 0) {
      expected = make_error_code(SdoClientError::invalid_argument);
    } else if (mode == SdoTransferMode::block && model.refused_block() && !options.block_fallback) {
      expected = std::error_code(0x05040001, sdo_abort_category());
    } else if (!upload && mode == SdoTransferMode::block && !model.refused_block() &&
               model.nonconforming()) {
      expected = make_error_code(SdoClientError::invalid_block_size);
    } else if (upload && model.expected_upload().size() > options.max_upload_size) {
      expected = make_error_code(SdoClientError::data_too_large);
    }
    const auto outcome = [&] {
      return fmt::format("client {} ({}), expected {}; server model {}",
                         client.succeeded() ? "succeeded" : "failed", client.error().message(),
                         expected ? expected.message() : "success",
                         model.complete() ? "complete" : "not complete");
    };
    if (expected) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(client.failed() && client.error() == expected,
                                   "a clean run ended otherwise than the setup calls for",
                                   outcome());
    } else {
      DRIVECHECK_FUZZ_CHECK_DETAIL(client.succeeded() && model.complete(),
                                   "a clean run against a correct server did not succeed",
                                   outcome());
      if (upload) {
        DRIVECHECK_FUZZ_CHECK(
            std::equal(client.data().begin(), client.data().end(), model.expected_upload().begin(),
                       model.expected_upload().end()),
            "upload data differ from the server's object");
      } else {
        DRIVECHECK_FUZZ_CHECK(model.received() == object,
                              "the server model received other data than the client downloaded");
      }
    }
  }

  // Termination: whatever happened, the transfer ends at its deadline.
  if (client.running()) harness.advance_to(client.next_deadline());
  DRIVECHECK_FUZZ_CHECK(!client.running(), "the transfer did not end at its deadline");
  return 0;
}

#include "tests/reference_drive/drive_rig.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <utility>

namespace drivecheck::reference_drive::testing {
namespace {

using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;
using cia301::Value;

EntryDefinition var(std::string name, DataType type, AccessType access, bool mappable,
                    std::uint8_t sub = 0) {
  EntryDefinition e;
  e.sub_index = sub;
  e.name = std::move(name);
  e.type = type;
  e.access = access;
  e.pdo_mappable = mappable;
  return e;
}

}  // namespace

Expected<void, std::string> TestApplication::add_objects(cia301::ObjectDictionary& od) {
  struct Row {
    std::uint16_t index;
    const char* name;
    DataType type;
    AccessType access;
    bool mappable;
  };
  const Row rows[] = {
      {0x2000, "Output word", DataType::unsigned16, AccessType::rw, true},
      {0x2001, "Output long", DataType::unsigned32, AccessType::rw, true},
      {0x2002, "Output byte", DataType::unsigned8, AccessType::rw, true},
      {0x2003, "Input word", DataType::unsigned16, AccessType::ro, true},
      {0x2004, "Command word", DataType::unsigned16, AccessType::wo, true},
      {0x2005, "Not mappable", DataType::unsigned16, AccessType::rw, false},
      {0x2006, "Text", DataType::visible_string, AccessType::rw, true},
      {0x2007, "Flag", DataType::boolean, AccessType::rw, true},
      {0x2008, "Limited byte", DataType::unsigned8, AccessType::rw, true},
      {0x2009, "Output quad", DataType::unsigned64, AccessType::rw, true},
  };
  for (const Row& row : rows) {
    EntryDefinition e = var(row.name, row.type, row.access, row.mappable);
    if (row.index == 0x2008) e.high_limit = Value::of_unsigned(100);
    if (row.index == 0x2006) e.max_size = 32;
    auto added = od.add_object({row.index, row.name, ObjectCode::var, {std::move(e)}});
    if (!added) return Unexpected(added.error());
  }
  EntryDefinition count =
      var("Highest sub-index supported", DataType::unsigned8, AccessType::ro, false);
  count.default_value = Value::of_unsigned(2);
  auto added = od.add_object(
      {0x200A,
       "Output pair",
       ObjectCode::array,
       {std::move(count), var("Output pair 1", DataType::integer16, AccessType::rw, true, 1),
        var("Output pair 2", DataType::integer16, AccessType::rw, true, 2)}});
  if (!added) return Unexpected(added.error());
  return {};
}

void TestApplication::on_reset(ReferenceDrive&, cia301::ResetKind kind) {
  resets.push_back(kind);
}

void TestApplication::on_cycle(ReferenceDrive&, can::TimePoint) {
  ++cycles;
}

DriveRig::DriveRig(std::uint8_t node, DriveConfig config, std::uint32_t bitrate)
    : node_(node), bus_(can::SimBusConfig{.bitrate = bitrate}) {
  tester_ = bus_.attach("tester");
  drive_port_ = bus_.attach(fmt::format("drive{}", node));
  tester_->set_frame_handler([this](const can::TimedFrame& frame) { seen_.push_back(frame); });
  master_ = bus_.attach("master");
  const can::Filter answers[] = {can::Filter::standard(0x580u + node)};
  master_->set_filters(answers);
  config.dictionary.node_id = node;
  if (config.application == nullptr) config.application = &application_;
  if (config.storage == nullptr) config.storage = &storage_;
  auto created = ReferenceDrive::create(*drive_port_, std::move(config));
  if (!created) {
    ADD_FAILURE() << "ReferenceDrive::create: " << created.error();
    return;
  }
  drive_ = std::move(*created);
  drive_->power_on();
  const auto boot = run(5ms);
  EXPECT_EQ(boot, std::vector<std::string>{id(0x700) + "#00"}) << "no boot-up message";
}

void DriveRig::send(std::string_view candump) {
  const auto frame = can::parse_candump(candump);
  ASSERT_TRUE(frame) << candump << ": " << frame.error();
  ASSERT_FALSE(tester_->send(*frame));
}

std::vector<can::TimedFrame> DriveRig::take() {
  return std::exchange(seen_, {});
}

std::vector<std::string> DriveRig::run(can::Duration window) {
  bus_.run_for(window);
  std::vector<std::string> out;
  for (const auto& timed : take())
    out.push_back(can::to_candump(timed.frame));
  return out;
}

std::vector<std::string> DriveRig::exchange(std::string_view candump, can::Duration window) {
  send(candump);
  return run(window);
}

std::string DriveRig::id(std::uint32_t base) const {
  return fmt::format("{:03X}", base + node_);
}

std::uint32_t DriveRig::write(std::uint16_t index, std::uint8_t sub_index, std::uint64_t value,
                              unsigned size) {
  // ccs=1, n=4-size, e=1, s=1
  const unsigned command = 0x23 | ((4 - size) << 2);
  std::string request = fmt::format("{}#{:02X}{:02X}{:02X}{:02X}", id(0x600), command, index & 0xFF,
                                    index >> 8, sub_index);
  for (unsigned i = 0; i < 4; ++i) {
    request += fmt::format("{:02X}", i < size ? (value >> (8 * i)) & 0xFF : 0);
  }
  take();  // frames from before belong to someone else
  for (const auto& answer : exchange(request, 5ms)) {
    if (answer.rfind(id(0x580) + "#", 0) != 0) continue;
    const auto frame = can::parse_candump(answer);
    if (frame->data[0] == 0x60) return 0;
    if (frame->data[0] == 0x80) {
      return static_cast<std::uint32_t>(frame->data[4] | frame->data[5] << 8 |
                                        frame->data[6] << 16 | frame->data[7] << 24);
    }
  }
  return kNoAnswer;
}

SdoResult DriveRig::read(std::uint16_t index, std::uint8_t sub_index) {
  // ccs=2 upload request
  const std::string request = fmt::format("{}#40{:02X}{:02X}{:02X}00000000", id(0x600),
                                          index & 0xFF, index >> 8, sub_index);
  SdoResult result;
  take();  // frames from before belong to someone else
  for (const auto& answer : exchange(request, 5ms)) {
    if (answer.rfind(id(0x580) + "#", 0) != 0) continue;
    const auto frame = can::parse_candump(answer);
    result.answered = true;
    const std::uint8_t command = frame->data[0];
    const std::uint64_t data = std::uint64_t{frame->data[4]} | std::uint64_t{frame->data[5]} << 8 |
                               std::uint64_t{frame->data[6]} << 16 |
                               std::uint64_t{frame->data[7]} << 24;
    if (command == 0x80) {
      result.abort = static_cast<std::uint32_t>(data);
    } else if ((command & 0xE3) == 0x43) {  // scs=2, e=1, s=1
      const unsigned size = 4 - ((command >> 2) & 3);
      result.value = size == 4 ? data : data & ((std::uint64_t{1} << (8 * size)) - 1);
    } else {
      ADD_FAILURE() << "not an expedited upload answer: " << answer;
    }
  }
  return result;
}

std::vector<std::string> DriveRig::nmt(std::uint8_t command) {
  return exchange(fmt::format("000#{:02X}{:02X}", command, node_), 10ms);
}

std::vector<std::string> DriveRig::sync(std::optional<std::uint8_t> counter) {
  return exchange(counter ? fmt::format("080#{:02X}", *counter) : std::string("080#"), 2ms);
}

std::string sdo_abort_frame(std::uint8_t node, std::uint16_t index, std::uint8_t sub_index,
                            std::uint32_t code) {
  return fmt::format("{:03X}#80{:02X}{:02X}{:02X}{:02X}{:02X}{:02X}{:02X}", 0x580 + node,
                     index & 0xFF, index >> 8, sub_index, code & 0xFF, (code >> 8) & 0xFF,
                     (code >> 16) & 0xFF, code >> 24);
}

std::string emcy_frame(std::uint8_t node, std::uint16_t code, std::uint8_t error_register) {
  return fmt::format("{:03X}#{:02X}{:02X}{:02X}0000000000", 0x80 + node, code & 0xFF, code >> 8,
                     error_register);
}

}  // namespace drivecheck::reference_drive::testing

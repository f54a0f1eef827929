#include "fuzz/live/ethercat_cases.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::fuzz_live {
namespace {

using Bytes = std::vector<std::uint8_t>;
using ethercat::AlState;

constexpr std::array<std::string_view, 7> kKinds = {
    "coe-upload",  "coe-download",   "coe-segmented-download", "coe-raw",
    "coe-service", "mailbox-header", "mailbox-counter",
};

constexpr std::uint8_t kCoeType = static_cast<std::uint8_t>(ethercat::MailboxType::coe);
constexpr std::uint8_t kSdoRequestService = 2;

std::uint64_t mix(std::uint64_t seed, std::uint64_t number) {
  Prng prng(seed ^ (number * 0xD1B54A32D192ED03ULL));
  return prng.next();
}

// The mailbox data of an SDO request with the CoE header of service `service`: command, index,
// sub-index, 4 octets, then `extra`.
Bytes sdo(std::uint8_t command, std::uint16_t index, std::uint8_t sub, std::uint32_t value,
          std::span<const std::uint8_t> extra = {}, std::uint8_t service = kSdoRequestService) {
  Bytes b = {0x00,
             static_cast<std::uint8_t>(service << 4),
             command,
             static_cast<std::uint8_t>(index & 0xFF),
             static_cast<std::uint8_t>(index >> 8),
             sub,
             static_cast<std::uint8_t>(value),
             static_cast<std::uint8_t>(value >> 8),
             static_cast<std::uint8_t>(value >> 16),
             static_cast<std::uint8_t>(value >> 24)};
  b.reserve(b.size() + extra.size());
  for (const std::uint8_t octet : extra)
    b.push_back(octet);
  return b;
}

class Builder {
 public:
  Builder(const EthercatGeneratorOptions& options, const std::vector<FuzzObject>& objects,
          Prng& rng)
      : options_(options), objects_(objects), rng_(rng) {
    for (const auto& object : objects_)
      if (object.writable && is_allowed_coe_write(object.index, options_.allow_motion))
        writable_.push_back(&object);
  }

  std::size_t max_data() const {
    return options_.write_size > ethercat::kMailboxHeaderSize
               ? options_.write_size - ethercat::kMailboxHeaderSize
               : 0;
  }

  const FuzzObject& any_object() { return objects_[rng_.below(objects_.size())]; }

  // An object's address, sometimes a neighbour that may not exist.
  std::pair<std::uint16_t, std::uint8_t> address(const FuzzObject& object) {
    std::uint16_t index = object.index;
    std::uint8_t sub = object.sub;
    switch (rng_.below(10)) {
      case 0:
        sub = static_cast<std::uint8_t>(sub + 1);
        break;
      case 1:
        index = static_cast<std::uint16_t>(index + 1);
        break;
      case 2:
        sub = 0xFF;
        break;
      default:
        break;
    }
    return {index, sub};
  }

  void step(Bytes data, CounterMode counter = CounterMode::next) {
    MailboxStep s;
    s.data = std::move(data);
    s.counter = counter;
    steps_.push_back(std::move(s));
  }

  std::vector<MailboxStep> take() {
    std::vector<MailboxStep> steps;
    for (auto& s : steps_) {
      if (s.data.size() > max_data()) s.data.resize(max_data());
      if (is_allowed_mailbox(s, options_.allow_motion)) steps.push_back(std::move(s));
    }
    return steps;
  }

  void upload() {
    const auto [index, sub] = address(any_object());
    const bool complete = rng_.chance(10);
    step(
        sdo(complete ? 0x50 : 0x40, index, complete ? static_cast<std::uint8_t>(sub & 1) : sub, 0));
    const auto segments = rng_.below(4);
    bool toggle = false;
    for (std::uint64_t i = 0; i < segments; ++i) {
      const bool t = rng_.chance(80) ? toggle : !toggle;
      step(sdo(t ? 0x70 : 0x60, 0, 0, 0));
      toggle = !toggle;
    }
  }

  std::uint32_t value_for(const FuzzObject& object) {
    switch (rng_.below(6)) {
      case 0:
        return static_cast<std::uint32_t>(object.min.value_or(0));
      case 1:
        return static_cast<std::uint32_t>(object.max.value_or(0xFFFFFFFF));
      case 2:
        return static_cast<std::uint32_t>(object.min.value_or(0) - 1);
      case 3:
        return static_cast<std::uint32_t>(object.max.value_or(0) + 1);
      case 4:
        return 0;
      default:
        return static_cast<std::uint32_t>(rng_.next());
    }
  }

  void download() {
    if (writable_.empty()) return upload();
    const FuzzObject& object = *writable_[rng_.below(writable_.size())];
    const auto [index, sub] = address(object);
    if (!is_allowed_coe_write(index, options_.allow_motion)) return upload();
    const std::uint32_t value = value_for(object);
    std::size_t size = object.size >= 1 && object.size <= 4 ? object.size : 1 + rng_.below(4);
    if (rng_.chance(15)) size = 1 + rng_.below(4);  // a wrong size
    switch (rng_.below(4)) {
      case 0:  // expedited, size not indicated
        step(sdo(0x22, index, sub, value));
        break;
      case 1: {  // normal: complete size then the octets
        Bytes data;
        for (std::size_t i = 0; i < size; ++i)
          data.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
        step(sdo(0x21, index, sub, static_cast<std::uint32_t>(size), data));
        break;
      }
      default:  // expedited, size indicated
        step(sdo(static_cast<std::uint8_t>(0x23 | ((4 - size) << 2)), index, sub, value));
        break;
    }
  }

  void segmented_download() {
    const FuzzObject* object =
        writable_.empty() ? nullptr : writable_[rng_.below(writable_.size())];
    const std::uint16_t index = object ? object->index : 0x1008;
    const std::uint8_t sub = object ? object->sub : 0;
    if (!is_allowed_coe_write(index, options_.allow_motion)) return upload();
    const auto announced = static_cast<std::uint32_t>(8 + rng_.below(293));
    const std::size_t first = std::min<std::size_t>(rng_.below(announced + 1), 16);
    Bytes data(first);
    for (auto& b : data)
      b = rng_.byte();
    step(sdo(0x21, index, sub, announced, data));
    const unsigned mode = static_cast<unsigned>(rng_.below(3));  // 0 cut short, 1 toggle, 2 more
    std::size_t sent = first;
    bool toggle = false;
    const std::size_t segments = mode == 0 ? rng_.below(3) : 1 + rng_.below(4);
    for (std::size_t i = 0; i < segments; ++i) {
      const std::size_t length = std::min<std::size_t>(7 + rng_.below(24), max_data() - 3);
      const bool last = mode == 2 ? i + 1 == segments : false;
      const bool t = mode == 1 && i == segments - 1 ? !toggle : toggle;
      Bytes seg = {0x00, static_cast<std::uint8_t>(kSdoRequestService << 4),
                   static_cast<std::uint8_t>((t ? 0x10 : 0) | (last ? 1 : 0))};
      for (std::size_t k = 0; k < length; ++k)
        seg.push_back(rng_.byte());
      step(std::move(seg));
      sent += length;
      toggle = !toggle;
    }
  }

  Bytes valid_request() {
    const FuzzObject& object = any_object();
    return sdo(0x40, object.index, object.sub, 0);
  }

  void raw() {
    Bytes b = rng_.chance(50) ? valid_request()
                              : sdo(0x23, any_object().index, any_object().sub, rng_.byte());
    switch (rng_.below(3)) {
      case 0:
        b[2] = rng_.byte();
        break;
      case 1:
        b[rng_.below(b.size())] = rng_.byte();
        break;
      default:
        b.resize(2 + rng_.below(8));
        break;
    }
    step(std::move(b));
  }

  void service() {
    static constexpr std::array<std::uint8_t, 13> kServices = {0,  9, 10, 11, 12, 13, 14,
                                                               15, 1, 3,  4,  5,  6};
    const std::uint8_t service = kServices[rng_.below(kServices.size())];
    const FuzzObject& object = any_object();
    Bytes b = sdo(0x40, object.index, object.sub, 0, {}, service);
    b[0] = rng_.chance(30) ? rng_.byte() : 0;  // the PDO number
    b.resize(2 + rng_.below(b.size() - 1));
    step(std::move(b));
  }

  void header() {
    MailboxStep s;
    s.data = valid_request();
    const auto n = static_cast<std::uint16_t>(s.data.size());
    switch (rng_.below(9)) {
      case 0:
        s.length = 0;
        break;
      case 1:
        s.length = static_cast<std::uint16_t>(1 + rng_.below(n - 1));
        break;
      case 2:
        s.length = static_cast<std::uint16_t>(n + 1 + rng_.below(4));
        break;
      case 3:
        s.length = static_cast<std::uint16_t>(max_data());
        break;
      case 4:
        s.length = static_cast<std::uint16_t>(max_data() + 1 + rng_.below(8));
        break;
      case 5:
        s.length = 0xFFFF;
        break;
      case 6:
        s.channel = static_cast<std::uint8_t>(1 + rng_.below(63));
        break;
      case 7:
        s.priority = static_cast<std::uint8_t>(1 + rng_.below(3));
        break;
      default: {
        static constexpr std::array<std::uint8_t, 10> kReserved = {0,  6,  7,  8,  9,
                                                                   10, 11, 12, 13, 14};
        s.type = kReserved[rng_.below(kReserved.size())];
        break;
      }
    }
    steps_.push_back(std::move(s));
  }

  void counter() {
    const Bytes request = valid_request();
    switch (rng_.below(4)) {
      case 0:
      case 1: {
        step(request);
        const auto repeats = 1 + rng_.below(3);
        for (std::uint64_t i = 0; i < repeats; ++i)
          step(request, CounterMode::repeat);
        break;
      }
      case 2:
        step(request, CounterMode::zero);
        step(request, CounterMode::zero);
        break;
      default:
        step(request, CounterMode::skip);
        step(request);
        break;
    }
  }

 private:
  const EthercatGeneratorOptions& options_;
  const std::vector<FuzzObject>& objects_;
  Prng& rng_;
  std::vector<const FuzzObject*> writable_;
  std::vector<MailboxStep> steps_;
};

}  // namespace

std::string_view to_string(CounterMode mode) {
  switch (mode) {
    case CounterMode::next:
      return "next";
    case CounterMode::repeat:
      return "repeat";
    case CounterMode::zero:
      return "zero";
    case CounterMode::skip:
      return "skip";
  }
  return "next";
}

bool is_allowed_coe_write(std::uint16_t index, bool allow_motion) {
  if (!is_allowed_write(index, allow_motion)) return false;
  if (index >= 0x1600 && index <= 0x17FF) return false;  // RxPDO mapping
  if (index >= 0x1A00 && index <= 0x1BFF) return false;  // TxPDO mapping
  if (index >= 0x1C00 && index <= 0x1CFF) return false;  // SM types, PDO assignment, 1C32h/1C33h
  return true;
}

bool is_allowed_mailbox(const MailboxStep& step, bool allow_motion) {
  const std::uint8_t type = step.type & 0x0F;
  const bool reserved = type == 0 || (type >= 6 && type <= 14);
  if (type != kCoeType && !reserved) return false;  // EoE, AoE, FoE, SoE, VoE
  const auto& d = step.data;
  // A download initiate (ccs 1, any other bits) names its object in octets 3-4; every CoE
  // service number is checked (a slave might take any of them for an SDO request).
  if (d.size() >= 3 && (d[2] >> 5) == 1) {
    const auto index = static_cast<std::uint16_t>(d.size() >= 5   ? d[3] | (d[4] << 8)
                                                  : d.size() == 4 ? d[3]
                                                                  : 0);
    if (!is_allowed_coe_write(index, allow_motion)) return false;
  }
  return true;
}

EthercatCaseGenerator::EthercatCaseGenerator(EthercatGeneratorOptions options,
                                             std::vector<FuzzObject> objects)
    : options_(std::move(options)), objects_(std::move(objects)) {
  if (objects_.empty()) objects_ = builtin_objects();
  if (options_.states.empty()) options_.states = {AlState::preop};
}

std::span<const std::string_view> EthercatCaseGenerator::kinds() {
  return kKinds;
}

EthercatCase EthercatCaseGenerator::generate(std::uint64_t number) const {
  Prng rng(mix(options_.seed, number));
  EthercatCase c;
  c.number = number;
  c.state = options_.states[rng.below(options_.states.size())];
  Builder builder(options_, objects_, rng);
  const auto kind = rng.below(kKinds.size());
  c.kind = std::string(kKinds[kind]);
  switch (kind) {
    case 0:
      builder.upload();
      break;
    case 1:
      builder.download();
      break;
    case 2:
      builder.segmented_download();
      break;
    case 3:
      builder.raw();
      break;
    case 4:
      builder.service();
      break;
    case 5:
      builder.header();
      break;
    default:
      builder.counter();
      break;
  }
  c.steps = builder.take();
  return c;
}

std::string describe_step(const MailboxStep& step) {
  ethercat::MailboxHeader header;
  header.length = step.length.value_or(static_cast<std::uint16_t>(step.data.size()));
  header.type = step.type;
  header.channel = step.channel;
  header.priority = step.priority;
  std::string octets;
  for (std::size_t i = 0; i < step.data.size(); ++i)
    octets += fmt::format("{}{:02X}", i == 0 ? "" : " ", step.data[i]);
  std::string what;
  if ((step.type & 0x0F) == kCoeType) {
    Bytes buffer = ethercat::build_mailbox(header, step.data);
    buffer[0] = static_cast<std::uint8_t>(header.length);
    buffer[1] = static_cast<std::uint8_t>(header.length >> 8);
    what = ethercat::describe_mailbox_message(buffer);
  } else {
    what = ethercat::describe_mailbox_type(step.type);
  }
  return fmt::format("Cnt {} Type {} Length {} Channel {} Priority {}: {} | {}",
                     to_string(step.counter), step.type, header.length, step.channel, step.priority,
                     what, octets);
}

}  // namespace drivecheck::fuzz_live

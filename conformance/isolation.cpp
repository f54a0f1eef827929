// What a vector may change, and the order in which it is put back (isolation.hpp).
#include "conformance/isolation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <variant>

#include "protocol/cia301/data_type.hpp"

namespace drivecheck::conformance {
namespace {

// Objects that are commands, not parameters (isolation.hpp).
constexpr std::array<std::uint16_t, 5> kCommandObjects{
    0x1003,  // pre-defined error field: writing 0 to sub 0 clears the history (CiA 301 §7.5.2.4)
    0x1010,  // store parameters (§7.5.2.13)
    0x1011,  // restore default parameters (§7.5.2.14)
    0x1F51,  // program control (CiA 302-3)
    0x6040,  // controlword (CiA 402-2): the teardown owns the drive's state
};

// COB-ID objects whose identifier bits may change only while the object does not exist.
struct CobIdObject {
  std::uint16_t index;
  std::uint32_t exists_set;    // bits that make it exist when set (SYNC/TIME: produce/consume)
  std::uint32_t exists_clear;  // bit that makes it exist when clear (EMCY/PDO: bit 31 invalid)
  const char* clause;
};
constexpr std::array<CobIdObject, 3> kCobIdObjects{{
    {0x1005, 0x40000000, 0, "CiA 301 §7.5.2.5"},   // SYNC: bit 30 generate
    {0x1012, 0xC0000000, 0, "CiA 301 §7.5.2.15"},  // TIME: bit 31 consume, 30 produce
    {0x1014, 0, 0x80000000, "CiA 301 §7.5.2.17"},  // EMCY: bit 31 invalid
}};
constexpr std::uint32_t kCobIdBits = 0x1FFFFFFF;  // identifier (29 bits) of a COB-ID entry
constexpr std::uint32_t kPdoInvalid = 0x80000000;

// Error control objects, restored last in this order (isolation.hpp).
constexpr std::array<std::uint16_t, 4> kErrorControl{0x1016, 0x100C, 0x100D, 0x1017};

bool is_pdo_communication(std::uint16_t index) {
  return (index >= 0x1400 && index <= 0x15FF) || (index >= 0x1800 && index <= 0x19FF);
}
bool is_pdo_mapping(std::uint16_t index) {
  return (index >= 0x1600 && index <= 0x17FF) || (index >= 0x1A00 && index <= 0x1BFF);
}
// The PDO's communication parameter index for either of its parameter objects.
std::uint16_t pdo_communication_of(std::uint16_t index) {
  return is_pdo_mapping(index) ? static_cast<std::uint16_t>(index - 0x200) : index;
}
bool is_error_control(std::uint16_t index) {
  return std::find(kErrorControl.begin(), kErrorControl.end(), index) != kErrorControl.end();
}
const CobIdObject* cob_id_object(ObjectRef ref) {
  if (ref.sub != 0) return nullptr;
  for (const auto& object : kCobIdObjects) {
    if (object.index == ref.index) return &object;
  }
  return nullptr;
}

std::uint32_t u32(const Bytes& bytes) {
  return static_cast<std::uint32_t>(
      cia301::load_unsigned(std::span(bytes.data(), std::min<std::size_t>(bytes.size(), 4))));
}
Bytes with_u32(const Bytes& shape, std::uint32_t value) {
  Bytes out(shape.size());
  for (std::size_t i = 0; i < out.size() && i < 4; ++i)
    out[i] = static_cast<std::uint8_t>(value >> (8 * i));
  return out;
}
bool all_zero(const Bytes& bytes) {
  return std::all_of(bytes.begin(), bytes.end(), [](std::uint8_t b) { return b == 0; });
}

// The frames a step sends to the DUT's SDO server, for the objects it downloads to.
template <typename Visit>
void for_each_written(const Vector& vector, std::uint8_t node, Visit&& visit) {
  for (const auto* list : {&vector.steps, &vector.finally_steps}) {
    for (const Step& step : *list) {
      if (const auto* write = std::get_if<SdoWriteStep>(&step.action)) {
        visit(ObjectRef{write->index, write->sub},
              write->value ? std::optional<Bytes>{} : std::optional<Bytes>{write->data});
      } else if (const auto* cyclic = std::get_if<CyclicStep>(&step.action)) {
        for (const CyclicSetPoint& point : cyclic->set)
          visit(ObjectRef{point.index, point.sub}, std::optional<Bytes>{});
      } else if (const auto* repeat = std::get_if<MailboxRepeatStep>(&step.action)) {
        visit(ObjectRef{repeat->index, repeat->sub}, std::optional<Bytes>{});
      } else if (const auto* send = frame_sent(step)) {  // send, sdo_request
        if (const auto request = sdo_download_request(send->frame.to_frame(node), node))
          visit(ObjectRef{request->mux.index, request->mux.sub_index}, request->expedited_data);
      }
    }
  }
}

}  // namespace

std::string to_string(const ObjectRef& ref) {
  return fmt::format("{:04X}h sub {}", ref.index, ref.sub);
}

bool is_command_object(ObjectRef ref) {
  return std::find(kCommandObjects.begin(), kCommandObjects.end(), ref.index) !=
         kCommandObjects.end();
}

std::optional<SdoDownloadRequest> sdo_download_request(const can::Frame& frame, std::uint8_t node) {
  if (frame.is_extended() || frame.is_remote() || frame.is_error() ||
      frame.id != cia301::kSdoRequestBase + node)
    return std::nullopt;
  const auto message = cia301::decode_client_message(frame);
  if (const auto* initiate = std::get_if<cia301::InitiateDownloadRequest>(&message)) {
    SdoDownloadRequest request{initiate->mux, std::nullopt};
    if (initiate->expedited) {
      const auto data = initiate->expedited_data();
      request.expedited_data = Bytes(data.begin(), data.end());
    }
    return request;
  }
  if (const auto* block = std::get_if<cia301::BlockDownloadInitiateRequest>(&message))
    return SdoDownloadRequest{block->mux, std::nullopt};
  return std::nullopt;
}

std::optional<ObjectRef> confirmed_download(const can::Frame& frame, std::uint8_t node) {
  if (frame.is_extended() || frame.is_remote() || frame.is_error() ||
      frame.id != cia301::kSdoResponseBase + node)
    return std::nullopt;
  const auto message = cia301::decode_server_message(frame);
  if (const auto* initiate = std::get_if<cia301::InitiateDownloadResponse>(&message))
    return ObjectRef{initiate->mux.index, initiate->mux.sub_index};
  if (const auto* block = std::get_if<cia301::BlockDownloadInitiateResponse>(&message))
    return ObjectRef{block->mux.index, block->mux.sub_index};
  return std::nullopt;
}

std::vector<ObjectRef> snapshot_objects(const Vector& vector, std::uint8_t node) {
  std::set<ObjectRef> objects;
  for_each_written(vector, node, [&](ObjectRef ref, const std::optional<Bytes>&) {
    if (is_command_object(ref)) return;
    objects.insert(ref);
    if (is_pdo_communication(ref.index) || is_pdo_mapping(ref.index))
      objects.insert(ObjectRef{pdo_communication_of(ref.index), 1});
    if (is_pdo_mapping(ref.index)) objects.insert(ObjectRef{ref.index, 0});
  });
  return {objects.begin(), objects.end()};
}

bool writes_restore_defaults(const Vector& vector, std::uint8_t node) {
  bool restores = false;
  for_each_written(vector, node, [&](ObjectRef ref, const std::optional<Bytes>&) {
    restores |= ref.index == 0x1011;
  });
  return restores;
}

RestorePlan plan_restore(const RestoreInput& input) {
  RestorePlan plan;
  // What must go back: written, readable before, not a command, not read-only, and different
  // now (or unreadable now).
  std::set<ObjectRef> changed;
  for (const ObjectRef& ref : input.written) {
    const auto before = input.before.find(ref);
    if (is_command_object(ref)) continue;
    if (before == input.before.end()) {
      plan.skipped.push_back(fmt::format("{}: unreadable before the vector", to_string(ref)));
      continue;
    }
    if (input.read_only.count(ref) != 0) {
      plan.skipped.push_back(fmt::format("{}: read-only", to_string(ref)));
      continue;
    }
    const auto after = input.after.find(ref);
    if (after != input.after.end() && after->second == before->second) continue;
    changed.insert(ref);
  }
  // Values as copies (absent: unknown), so that nothing dereferences a missing entry.
  const auto value_before = [&](ObjectRef ref) -> std::optional<Bytes> {
    const auto it = input.before.find(ref);
    if (it == input.before.end()) return std::nullopt;
    return it->second;
  };
  const auto value_after = [&](ObjectRef ref) -> std::optional<Bytes> {
    const auto it = input.after.find(ref);
    if (it == input.after.end()) return std::nullopt;
    return it->second;
  };
  // Only for objects in `changed` (all of them have a value before).
  const auto put_back = [&](ObjectRef ref) {
    plan.writes.push_back(RestoreWrite{ref, input.before.at(ref), "value before the vector"});
  };

  // PDOs, one at a time in index order.
  std::set<std::uint16_t> pdos;
  for (const ObjectRef& ref : changed) {
    if (is_pdo_communication(ref.index) || is_pdo_mapping(ref.index))
      pdos.insert(pdo_communication_of(ref.index));
  }
  for (const std::uint16_t communication : pdos) {
    const auto mapping = static_cast<std::uint16_t>(communication + 0x200);
    const ObjectRef cob{communication, 1};
    const ObjectRef count{mapping, 0};
    std::optional<Bytes> cob_now = value_after(cob);
    if (!cob_now) cob_now = value_before(cob);
    bool invalidated = false;
    if (cob_now && cob_now->size() == 4 && (u32(*cob_now) & kPdoInvalid) == 0) {
      plan.writes.push_back(
          RestoreWrite{cob, with_u32(*cob_now, u32(*cob_now) | kPdoInvalid),
                       fmt::format("PDO {:04X}h invalid while its parameters are restored "
                                   "(CiA 301 §7.5.2.35-38)",
                                   communication)});
      invalidated = true;
    }
    for (const ObjectRef& ref : changed) {
      if (ref.index == communication && ref.sub > 1) put_back(ref);
    }
    bool remapped = false;
    for (const ObjectRef& ref : changed)
      remapped |= ref.index == mapping;
    const std::optional<Bytes> count_before = value_before(count);
    if (remapped && count_before) {
      const std::optional<Bytes> count_now = value_after(count);
      if (!count_now || !all_zero(*count_now)) {
        plan.writes.push_back(RestoreWrite{
            count, Bytes(count_before->size(), 0),
            fmt::format("mapping {:04X}h disabled (count 0) before its entries (CiA 301 "
                        "§7.5.2.36/38)",
                        mapping)});
      }
      for (const ObjectRef& ref : changed) {
        if (ref.index == mapping && ref.sub > 0) put_back(ref);
      }
      plan.writes.push_back(RestoreWrite{count, *count_before, "value before the vector"});
    }
    if (const auto cob_before = value_before(cob);
        cob_before && (invalidated || changed.count(cob) != 0)) {
      plan.writes.push_back(RestoreWrite{cob, *cob_before, "value before the vector"});
    }
  }

  // Other objects (not error control), index order, sub 0 after the others of its index.
  std::vector<ObjectRef> ordinary;
  for (const ObjectRef& ref : changed) {
    if (is_pdo_communication(ref.index) || is_pdo_mapping(ref.index) || is_error_control(ref.index))
      continue;
    ordinary.push_back(ref);
  }
  std::stable_sort(ordinary.begin(), ordinary.end(), [](ObjectRef a, ObjectRef b) {
    if (a.index != b.index) return a.index < b.index;
    if ((a.sub == 0) != (b.sub == 0)) return b.sub == 0;
    return a.sub < b.sub;
  });
  for (const ObjectRef& ref : ordinary) {
    if (const CobIdObject* object = cob_id_object(ref)) {
      const std::optional<Bytes> now = value_after(ref);
      const Bytes& target = input.before.at(ref);
      if (now && now->size() == 4 && target.size() == 4) {
        const std::uint32_t current = u32(*now);
        const bool exists = (current & object->exists_set) != 0 ||
                            (object->exists_clear != 0 && (current & object->exists_clear) == 0);
        if (exists && (current & kCobIdBits) != (u32(target) & kCobIdBits)) {
          const std::uint32_t disabled = (current & ~object->exists_set) | object->exists_clear;
          plan.writes.push_back(
              RestoreWrite{ref, with_u32(*now, disabled),
                           fmt::format("{:04X}h disabled before its identifier changes ({})",
                                       ref.index, object->clause)});
        }
      }
    }
    put_back(ref);
  }

  // Error control last: what switches monitoring off, then what switches it on.
  std::vector<ObjectRef> monitoring;
  for (const std::uint16_t index : kErrorControl) {
    for (const ObjectRef& ref : changed) {
      if (ref.index == index) monitoring.push_back(ref);
    }
  }
  for (const bool off : {true, false}) {
    for (const ObjectRef& ref : monitoring) {
      if (all_zero(input.before.at(ref)) == off) put_back(ref);
    }
  }
  // A 1016h entry that changes from one node to another goes through 0 first (§7.5.2.19: two
  // entries must never name the same node with a non-zero time).
  std::vector<RestoreWrite> through_zero;
  for (const ObjectRef& ref : monitoring) {
    const std::optional<Bytes> now = value_after(ref);
    const Bytes& before = input.before.at(ref);
    if (ref.index == 0x1016 && ref.sub > 0 && !all_zero(before) && (!now || !all_zero(*now))) {
      through_zero.push_back(
          RestoreWrite{ref, Bytes(before.size(), 0),
                       "consumer entry off before the entries are put back (CiA 301 §7.5.2.19)"});
    }
  }
  if (!through_zero.empty()) {
    const auto first = std::find_if(plan.writes.begin(), plan.writes.end(),
                                    [](const RestoreWrite& w) { return w.ref.index == 0x1016; });
    plan.writes.insert(first, through_zero.begin(), through_zero.end());
  }
  return plan;
}

}  // namespace drivecheck::conformance

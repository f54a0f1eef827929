#include "protocol/cia301/pdo_service.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/sync_consumer.hpp"

namespace drivecheck::cia301 {
namespace {

constexpr std::uint32_t kInvalidBit = 0x80000000u;
constexpr std::uint32_t kNoRtrBit = 0x40000000;    // COB-ID bit 30: no RTR allowed
constexpr std::uint32_t kCobIdBits = 0x3FFFFFFFu;  // bits 0..29: CAN-ID and frame format
constexpr std::uint16_t kLengthError = static_cast<std::uint16_t>(EmcyCode::pdo_length_error);
constexpr std::uint16_t kLengthExceeded = static_cast<std::uint16_t>(EmcyCode::pdo_length_exceeded);
constexpr std::uint16_t kRpdoTimeout = static_cast<std::uint16_t>(EmcyCode::rpdo_timeout);

// Pre-defined connection set (CiA 301 §7.3.5): CAN-ID base of PDO 1..4 (node-ID added).
std::uint32_t predefined_base(PdoDirection direction, std::uint16_t number) {
  const std::uint32_t first = direction == PdoDirection::receive ? 0x200 : 0x180;
  return first + 0x100u * (number - 1u);
}

EntryDefinition entry(std::uint8_t sub, std::string name, DataType type, std::uint64_t value,
                      AccessType access = AccessType::rw) {
  return EntryDefinition::unsigned_entry(sub, std::move(name), type, access, value);
}

bool pdo_valid(const ObjectDictionary& od, PdoDirection direction, std::uint16_t number) {
  const Entry* cob = od.find(pdo_communication_index(direction, number), pdo_sub::kCobId);
  return cob != nullptr && (cob->as_unsigned() & kInvalidBit) == 0;
}

std::uint64_t raw_value(std::span<const std::uint8_t> data) {
  return load_unsigned(data);
}

WriteValidator cob_id_validator(bool enable_only) {
  return [enable_only](const ObjectDictionary&, const Entry& self,
                       std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    const auto before = static_cast<std::uint32_t>(self.as_unsigned());
    const auto after = static_cast<std::uint32_t>(raw_value(data));
    const auto decoded = decode_pdo_cob_id(after);
    if (!decoded) return Unexpected(SdoAbort::invalid_value);
    if (enable_only && ((before ^ after) & ~kInvalidBit) != 0) {
      return Unexpected(SdoAbort::invalid_value);
    }
    const bool valid_before = (before & kInvalidBit) == 0;
    if (valid_before && decoded->valid && ((before ^ after) & kCobIdBits) != 0) {
      return Unexpected(SdoAbort::invalid_value);
    }
    if (decoded->valid && !decoded->extended && is_restricted_cob_id(decoded->can_id)) {
      return Unexpected(SdoAbort::invalid_value);
    }
    return {};
  };
}

WriteValidator transmission_type_validator(PdoDirection direction) {
  return [direction](const ObjectDictionary&, const Entry&,
                     std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    if (!is_valid_transmission_type(data[0], direction)) {
      return Unexpected(SdoAbort::invalid_value);
    }
    return {};
  };
}

// Inhibit time and SYNC start value: not to be changed while the TPDO exists.
WriteValidator fixed_while_valid_validator(std::uint16_t number, std::uint64_t max) {
  return [number, max](const ObjectDictionary& od, const Entry& self,
                       std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    const std::uint64_t value = raw_value(data);
    if (value > max) return Unexpected(SdoAbort::invalid_value);
    if (value != self.as_unsigned() && pdo_valid(od, PdoDirection::transmit, number)) {
      return Unexpected(SdoAbort::invalid_value);
    }
    return {};
  };
}

WriteValidator mapping_count_validator(PdoDirection direction, std::uint16_t number,
                                       bool dummy_mapping, bool while_valid) {
  return [=](const ObjectDictionary& od, const Entry&,
             std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    if (!while_valid && pdo_valid(od, direction, number)) {
      return Unexpected(SdoAbort::unsupported_access);
    }
    const Object* mapping = od.find(pdo_mapping_index(direction, number));
    const unsigned count = data[0];
    if (count + 1u > mapping->entries().size()) return Unexpected(SdoAbort::pdo_length_exceeded);
    unsigned bits = 0;
    for (unsigned sub = 1; sub <= count; ++sub) {
      const Entry* slot = mapping->find(static_cast<std::uint8_t>(sub));
      if (slot == nullptr) return Unexpected(SdoAbort::pdo_length_exceeded);
      auto checked = check_pdo_mapping_entry(
          od, direction, static_cast<std::uint32_t>(slot->as_unsigned()), dummy_mapping);
      if (!checked) return Unexpected(checked.error());
      bits += *checked;
    }
    if (bits > kMaxPdoBits) return Unexpected(SdoAbort::pdo_length_exceeded);
    return {};
  };
}

WriteValidator mapping_entry_validator(PdoDirection direction, std::uint16_t number,
                                       bool dummy_mapping, bool while_valid) {
  return [=](const ObjectDictionary& od, const Entry&,
             std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    if (!while_valid && pdo_valid(od, direction, number)) {
      return Unexpected(SdoAbort::unsupported_access);
    }
    const Entry* count = od.find(pdo_mapping_index(direction, number), 0);
    if (count != nullptr && count->as_unsigned() != 0) {
      return Unexpected(SdoAbort::unsupported_access);
    }
    const auto value = static_cast<std::uint32_t>(raw_value(data));
    if (value == 0) return {};
    auto checked = check_pdo_mapping_entry(od, direction, value, dummy_mapping);
    if (!checked) return Unexpected(checked.error());
    return {};
  };
}

Expected<void, std::string> add_pdo(ObjectDictionary& od, PdoDirection direction,
                                    std::uint16_t number, const PdoDefaults& defaults,
                                    const PdoObjectOptions& options) {
  const bool receive = direction == PdoDirection::receive;
  const char* kind = receive ? "RPDO" : "TPDO";
  if (!is_valid_transmission_type(defaults.transmission_type, direction)) {
    return Unexpected(fmt::format("{}{}: default transmission type {} is not valid", kind, number,
                                  defaults.transmission_type));
  }
  if (defaults.mapping.size() > options.mapping_entries) {
    return Unexpected(fmt::format("{}{}: {} default mapping entries, {} supported", kind, number,
                                  defaults.mapping.size(), options.mapping_entries));
  }

  ObjectDefinition comm;
  comm.index = pdo_communication_index(direction, number);
  comm.name = fmt::format("{} communication parameter {}", kind, number);
  comm.code = ObjectCode::record;
  comm.entries.push_back(entry(0, "Highest sub-index supported", DataType::unsigned8,
                               receive ? pdo_sub::kEventTimer : pdo_sub::kSyncStartValue,
                               AccessType::ro));
  EntryDefinition cob =
      entry(pdo_sub::kCobId, fmt::format("COB-ID used by {}", kind), DataType::unsigned32, 0);
  if (number <= 4) {
    cob.default_value =
        Value::of_unsigned(predefined_base(direction, number) | (defaults.valid ? 0 : kInvalidBit) |
                           (defaults.rtr_allowed ? 0 : kNoRtrBit));
    cob.default_adds_node_id = true;
  } else if (defaults.valid) {
    return Unexpected(
        fmt::format("{}{}: no pre-defined CAN-ID, cannot default to valid", kind, number));
  } else {
    cob.default_value = Value::of_unsigned(kInvalidBit);
  }
  comm.entries.push_back(std::move(cob));
  comm.entries.push_back(entry(pdo_sub::kTransmissionType, "Transmission type", DataType::unsigned8,
                               defaults.transmission_type));
  if (!receive) {
    comm.entries.push_back(
        entry(pdo_sub::kInhibitTime, "Inhibit time", DataType::unsigned16, defaults.inhibit_time));
  }
  comm.entries.push_back(
      entry(pdo_sub::kEventTimer, "Event timer", DataType::unsigned16, defaults.event_timer));
  if (!receive) {
    comm.entries.push_back(
        entry(pdo_sub::kSyncStartValue, "SYNC start value", DataType::unsigned8, 0));
  }
  auto added_comm = od.add_object(std::move(comm));
  if (!added_comm) return Unexpected(added_comm.error());
  Object& comm_object = **added_comm;
  comm_object.find(pdo_sub::kCobId)
      ->set_write_validator(cob_id_validator(options.cob_id_enable_only));
  comm_object.find(pdo_sub::kTransmissionType)
      ->set_write_validator(transmission_type_validator(direction));
  if (!receive) {
    comm_object.find(pdo_sub::kInhibitTime)
        ->set_write_validator(fixed_while_valid_validator(number, 0xFFFF));
    comm_object.find(pdo_sub::kSyncStartValue)
        ->set_write_validator(fixed_while_valid_validator(number, 240));
  }

  ObjectDefinition mapping;
  mapping.index = pdo_mapping_index(direction, number);
  mapping.name = fmt::format("{} mapping parameter {}", kind, number);
  mapping.code = ObjectCode::record;
  mapping.entries.push_back(
      entry(0, "Number of mapped objects", DataType::unsigned8, defaults.mapping.size()));
  for (unsigned sub = 1; sub <= options.mapping_entries; ++sub) {
    const std::uint32_t value =
        sub <= defaults.mapping.size() ? defaults.mapping[sub - 1].encode() : 0;
    mapping.entries.push_back(entry(static_cast<std::uint8_t>(sub),
                                    fmt::format("Mapped object {}", sub), DataType::unsigned32,
                                    value));
  }
  auto added_mapping = od.add_object(std::move(mapping));
  if (!added_mapping) return Unexpected(added_mapping.error());
  for (Entry& e : (*added_mapping)->entries()) {
    e.set_write_validator(e.sub_index() == 0
                              ? mapping_count_validator(direction, number, options.dummy_mapping,
                                                        options.mapping_while_valid)
                              : mapping_entry_validator(direction, number, options.dummy_mapping,
                                                        options.mapping_while_valid));
  }
  return {};
}

std::array<std::uint8_t, 8> to_bytes(std::uint64_t value) {
  std::array<std::uint8_t, 8> out{};
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = static_cast<std::uint8_t>(value >> (8 * i));
  return out;
}

std::uint64_t from_bytes(const std::array<std::uint8_t, 8>& bytes) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i)
    value |= std::uint64_t{bytes[i]} << (8 * i);
  return value;
}

constexpr std::uint64_t mask_of(unsigned bits) {
  return bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
}

std::size_t error_slot(std::uint16_t code) {
  return code == kLengthError ? 0 : code == kLengthExceeded ? 1 : 2;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Objects

Expected<void, std::string> add_pdo_objects(ObjectDictionary& od, const PdoObjectOptions& options) {
  if (options.rpdo_count > kMaxPdoNumber || options.tpdo_count > kMaxPdoNumber) {
    return Unexpected(fmt::format("{} RPDOs / {} TPDOs: at most {} each", options.rpdo_count,
                                  options.tpdo_count, kMaxPdoNumber));
  }
  if (options.mapping_entries < 1 || options.mapping_entries > kMaxMappedObjects) {
    return Unexpected(fmt::format("{} mapping entries per PDO: 1..{} supported",
                                  options.mapping_entries, kMaxMappedObjects));
  }
  for (std::uint16_t n = 1; n <= options.rpdo_count; ++n) {
    const PdoDefaults defaults =
        n <= options.rpdo_defaults.size() ? options.rpdo_defaults[n - 1u] : PdoDefaults{};
    if (auto ok = add_pdo(od, PdoDirection::receive, n, defaults, options); !ok) return ok;
  }
  for (std::uint16_t n = 1; n <= options.tpdo_count; ++n) {
    const PdoDefaults defaults =
        n <= options.tpdo_defaults.size() ? options.tpdo_defaults[n - 1u] : PdoDefaults{};
    if (auto ok = add_pdo(od, PdoDirection::transmit, n, defaults, options); !ok) return ok;
  }
  for (std::uint16_t n = 1; options.change_mask_index != 0 && n <= options.tpdo_count; ++n) {
    ObjectDefinition mask;
    mask.index = static_cast<std::uint16_t>(options.change_mask_index + n - 1u);
    mask.name = fmt::format("TPDO transmit mask {}", n);
    mask.code = ObjectCode::record;
    mask.entries.push_back(EntryDefinition::highest_sub_index(2));
    mask.entries.push_back(EntryDefinition::unsigned_entry(
        1, "Transmit mask low", DataType::unsigned32, AccessType::rw, 0xFFFFFFFFu));
    mask.entries.push_back(EntryDefinition::unsigned_entry(
        2, "Transmit mask high", DataType::unsigned32, AccessType::rw, 0xFFFFFFFFu));
    if (auto added = od.add_object(std::move(mask)); !added) return Unexpected(added.error());
  }
  return {};
}

Expected<unsigned, SdoAbort> check_pdo_mapping_entry(const ObjectDictionary& od,
                                                     PdoDirection direction, std::uint32_t value,
                                                     bool dummy_mapping) {
  const auto index = static_cast<std::uint16_t>(value >> 16);
  const auto sub_index = static_cast<std::uint8_t>(value >> 8);
  const auto bits = static_cast<std::uint8_t>(value);
  if (const auto dummy = dummy_bits(index)) {
    if (direction == PdoDirection::transmit || !dummy_mapping || sub_index != 0 || bits != *dummy) {
      return Unexpected(SdoAbort::object_not_mappable);
    }
    return unsigned{bits};
  }
  const Object* object = od.find(index);
  if (object == nullptr) return Unexpected(SdoAbort::object_does_not_exist);
  const Entry* target = object->find(sub_index);
  if (target == nullptr) return Unexpected(SdoAbort::sub_index_does_not_exist);
  if (!target->pdo_mappable() || is_variable_length(target->type())) {
    return Unexpected(SdoAbort::object_not_mappable);
  }
  const bool direction_ok = direction == PdoDirection::receive ? is_writable(target->access())
                                                               : is_readable(target->access());
  if (!direction_ok) return Unexpected(SdoAbort::object_not_mappable);
  if (bits != info(target->type()).bit_size) return Unexpected(SdoAbort::object_not_mappable);
  return unsigned{bits};
}

// ---------------------------------------------------------------------------------------------
// Service: configuration

PdoService::PdoService(ObjectDictionary& od, const can::Clock& clock, bool dummy_mapping,
                       std::uint16_t change_mask_index)
    : od_(od), clock_(clock), dummy_mapping_(dummy_mapping), change_mask_index_(change_mask_index) {
  for (const Object& object : od_.objects()) {
    const std::uint16_t index = object.index();
    if (index >= kRpdoCommunicationBase && index < kRpdoMappingBase) {
      Rpdo pdo;
      pdo.number = static_cast<std::uint16_t>(index - kRpdoCommunicationBase + 1);
      rpdos_.push_back(std::move(pdo));
    } else if (index >= kTpdoCommunicationBase && index < kTpdoMappingBase) {
      Tpdo pdo;
      pdo.number = static_cast<std::uint16_t>(index - kTpdoCommunicationBase + 1);
      tpdos_.push_back(std::move(pdo));
    }
  }
  for (Rpdo& pdo : rpdos_)
    pdo.slots.reserve(kMaxMappedObjects);
  for (Tpdo& pdo : tpdos_)
    pdo.slots.reserve(kMaxMappedObjects);
  // Every TPDO per call at most (RTR answers, SYNC), twice when synchronous TPDOs held back
  // by the window (1007h) go with the event-driven ones; each RPDO's error changes.
  frames_.reserve(2 * tpdos_.size() + 1);
  held_.reserve(tpdos_.size());
  window_entry_ = od_.find(kSyncWindowLengthIndex, 0);
  errors_.reserve(6 * (rpdos_.size() + 1));
  for (Rpdo& pdo : rpdos_)
    configure(pdo);
  for (Tpdo& pdo : tpdos_)
    configure(pdo);
  errors_.clear();
  bind();
}

PdoService::~PdoService() {
  unbind();
}

bool PdoService::configure_common(Common& pdo, PdoDirection direction) {
  pdo.valid = false;
  pdo.active = false;
  pdo.problem.reset();
  pdo.slots.clear();
  pdo.length = 0;
  const Object* comm = od_.find(pdo_communication_index(direction, pdo.number));
  const Object* mapping = od_.find(pdo_mapping_index(direction, pdo.number));
  const Entry* cob = comm != nullptr ? comm->find(pdo_sub::kCobId) : nullptr;
  if (cob == nullptr) return false;
  const auto decoded = decode_pdo_cob_id(static_cast<std::uint32_t>(cob->as_unsigned()));
  if (!decoded) {
    if ((cob->as_unsigned() & kInvalidBit) == 0) {
      pdo.valid = true;
      pdo.problem = decoded.error().reason;
    }
    return false;
  }
  pdo.valid = decoded->valid;
  pdo.format = decoded->extended ? can::IdFormat::extended : can::IdFormat::standard;
  pdo.can_id = decoded->can_id;
  const Entry* type = comm->find(pdo_sub::kTransmissionType);
  pdo.type = type != nullptr ? static_cast<std::uint8_t>(type->as_unsigned()) : 0xFF;
  const Entry* timer = comm->find(pdo_sub::kEventTimer);
  pdo.event_timer =
      timer != nullptr
          ? can::Duration(event_timer(static_cast<std::uint16_t>(timer->as_unsigned())))
          : can::Duration::zero();
  if (!pdo.valid) return false;
  const auto fail = [&](std::string why) {
    pdo.problem = std::move(why);
    pdo.slots.clear();
    return false;
  };
  if (!is_valid_transmission_type(pdo.type, direction)) {
    return fail(fmt::format("transmission type {} is not valid", pdo.type));
  }
  if (!decoded->extended && is_restricted_cob_id(decoded->can_id)) {
    return fail(fmt::format("CAN-ID {:03X}h is restricted", decoded->can_id));
  }
  if (mapping == nullptr) return fail("no mapping record");
  const Entry* count = mapping->find(0);
  const unsigned mapped = count != nullptr ? static_cast<unsigned>(count->as_unsigned()) : 0;
  unsigned offset = 0;
  for (unsigned sub = 1; sub <= mapped; ++sub) {
    const Entry* slot = mapping->find(static_cast<std::uint8_t>(sub));
    if (slot == nullptr) return fail(fmt::format("mapping sub-index {} does not exist", sub));
    const auto value = static_cast<std::uint32_t>(slot->as_unsigned());
    const auto checked = check_pdo_mapping_entry(od_, direction, value, dummy_mapping_);
    if (!checked) {
      return fail(fmt::format("mapping entry {} ({:08X}h): {}", sub, value,
                              describe_sdo_abort(static_cast<std::uint32_t>(checked.error()))));
    }
    if (offset + *checked > kMaxPdoBits) {
      return fail(fmt::format("mapping longer than {} bits", kMaxPdoBits));
    }
    Slot s;
    s.index = static_cast<std::uint16_t>(value >> 16);
    s.sub_index = static_cast<std::uint8_t>(value >> 8);
    s.bits = static_cast<std::uint8_t>(*checked);
    s.offset = static_cast<std::uint8_t>(offset);
    if (!dummy_bits(s.index)) {
      s.entry = od_.find(s.index, s.sub_index);
      s.bytes = info(s.entry->type()).size;
    } else {
      s.bytes = static_cast<std::uint8_t>(*checked / 8);
    }
    pdo.slots.push_back(s);
    offset += *checked;
  }
  pdo.length = static_cast<std::uint8_t>((offset + 7) / 8);
  pdo.active = !pdo.slots.empty();
  return pdo.active;
}

void PdoService::configure(Rpdo& pdo) {
  configure_common(pdo, PdoDirection::receive);
  stop(pdo);
  set_error(pdo.short_error, false, kLengthError);
  set_error(pdo.long_error, false, kLengthExceeded);
  set_error(pdo.timeout_error, false, kRpdoTimeout);
}

void PdoService::configure(Tpdo& pdo) {
  configure_common(pdo, PdoDirection::transmit);
  const Object* comm = od_.find(pdo_communication_index(PdoDirection::transmit, pdo.number));
  if (comm == nullptr) return;
  const Entry* cob = comm->find(pdo_sub::kCobId);
  pdo.rtr_allowed = cob != nullptr && (cob->as_unsigned() & 0x40000000u) == 0;
  const Entry* inhibit = comm->find(pdo_sub::kInhibitTime);
  pdo.inhibit =
      inhibit != nullptr
          ? can::Duration(inhibit_time(static_cast<std::uint16_t>(inhibit->as_unsigned())))
          : can::Duration::zero();
  const Entry* start = comm->find(pdo_sub::kSyncStartValue);
  pdo.sync_start = start != nullptr ? static_cast<std::uint8_t>(start->as_unsigned()) : 0;
  pdo.change_mask = ~std::uint64_t{0};
  if (change_mask_index_ != 0) {
    const auto index = static_cast<std::uint16_t>(change_mask_index_ + pdo.number - 1U);
    const Entry* low = od_.find(index, 1);
    const Entry* high = od_.find(index, 2);
    if (low != nullptr && high != nullptr) {
      pdo.change_mask = (low->as_unsigned() & 0xFFFFFFFFu) | (high->as_unsigned() << 32);
    }
  }
}

bool PdoService::changed(const Tpdo& pdo, const std::array<std::uint8_t, 8>& payload) const {
  return ((from_bytes(payload) ^ from_bytes(pdo.last_sent)) & pdo.change_mask) != 0;
}

void PdoService::start(Rpdo& pdo, can::TimePoint) {
  pdo.pending = false;
  pdo.deadline = can::kForever;  // monitoring starts with the first RPDO received
}

void PdoService::stop(Rpdo& pdo) {
  pdo.pending = false;
  pdo.deadline = can::kForever;
}

void PdoService::start(Tpdo& pdo, can::TimePoint now) {
  // The count of a type n TPDO: its first transmission at the n-th SYNC, or at the first one.
  pdo.sync_count = first_sync_phase_ && pdo.type >= 1 && pdo.type <= 240 ? pdo.type - 1U : 0U;
  pdo.started = false;
  pdo.event = pdo.type >= 254;  // entering Operational is an event for event-driven TPDOs
  pdo.sent_once = false;
  pdo.sampled = false;
  pdo.inhibit_until = can::TimePoint::min();
  pdo.event_due = pdo.event_timer > can::Duration::zero() ? now + pdo.event_timer : can::kForever;
}

void PdoService::reload(can::TimePoint now) {
  window_entry_ = od_.find(kSyncWindowLengthIndex, 0);
  for (Rpdo& pdo : rpdos_) {
    configure(pdo);
    if (running_ && pdo.active) start(pdo, now);
  }
  for (Tpdo& pdo : tpdos_) {
    configure(pdo);
    if (running_ && pdo.active) start(pdo, now);
  }
}

void PdoService::set_nmt_state(NmtState state, can::TimePoint now) {
  const bool run = nmt_allows(state, NmtService::pdo);
  state_ = state;
  if (run == running_) return;
  running_ = run;
  last_sync_.reset();
  sync_rpdos_stopped_ = false;
  held_.clear();
  held_next_ = 0;
  in_flight_.reset();
  for (Rpdo& pdo : rpdos_) {
    if (run) {
      start(pdo, now);
    } else {
      stop(pdo);
    }
  }
  for (Tpdo& pdo : tpdos_) {
    if (run) start(pdo, now);
  }
}

void PdoService::bind() {
  const auto observe = [this](std::uint16_t index, auto reconfigure) {
    Object* object = od_.find(index);
    if (object == nullptr) return;
    for (Entry& e : object->entries()) {
      e.set_write_observer([reconfigure](ObjectDictionary&, Entry&) { reconfigure(); });
      bound_.emplace_back(index, e.sub_index());
    }
  };
  for (std::size_t i = 0; i < rpdos_.size(); ++i) {
    const auto reconfigure = [this, i] {
      Rpdo& pdo = rpdos_[i];
      configure(pdo);
      if (running_ && pdo.active) start(pdo, clock_.now());
    };
    observe(pdo_communication_index(PdoDirection::receive, rpdos_[i].number), reconfigure);
    observe(pdo_mapping_index(PdoDirection::receive, rpdos_[i].number), reconfigure);
  }
  for (std::size_t i = 0; i < tpdos_.size(); ++i) {
    const auto reconfigure = [this, i] {
      Tpdo& pdo = tpdos_[i];
      configure(pdo);
      if (running_ && pdo.active) start(pdo, clock_.now());
    };
    observe(pdo_communication_index(PdoDirection::transmit, tpdos_[i].number), reconfigure);
    observe(pdo_mapping_index(PdoDirection::transmit, tpdos_[i].number), reconfigure);
    if (change_mask_index_ != 0) {
      observe(static_cast<std::uint16_t>(change_mask_index_ + tpdos_[i].number - 1U), reconfigure);
    }
  }
}

void PdoService::unbind() {
  for (const auto& [index, sub_index] : bound_) {
    if (Entry* e = od_.find(index, sub_index)) e->set_write_observer({});
  }
  bound_.clear();
}

// ---------------------------------------------------------------------------------------------
// Service: running

void PdoService::begin_output() {
  frames_.clear();
  if (errors_delivered_) {
    errors_.clear();
    errors_delivered_ = false;
  }
}

PdoOutput PdoService::output(bool taken) {
  errors_delivered_ = true;
  return {taken, frames_, errors_};
}

void PdoService::set_error(bool& flag, bool active, std::uint16_t code) {
  if (flag == active) return;
  flag = active;
  unsigned& count = error_counts_[error_slot(code)];
  if (active) {
    if (count++ == 0) errors_.push_back({code, true});
  } else if (count > 0 && --count == 0) {
    errors_.push_back({code, false});
  }
}

std::array<std::uint8_t, 8> PdoService::pack(const Tpdo& pdo) const {
  std::uint64_t payload = 0;
  for (const Slot& slot : pdo.slots) {
    if (slot.entry == nullptr) continue;
    const std::uint64_t value = load_unsigned(slot.entry->bytes()) & mask_of(slot.bits);
    payload |= value << slot.offset;
  }
  return to_bytes(payload);
}

void PdoService::emit(const Common& pdo, const std::array<std::uint8_t, 8>& payload) {
  can::Frame frame;
  frame.id = pdo.can_id;
  frame.format = pdo.format;
  frame.kind = can::FrameKind::data;
  frame.dlc = pdo.length;
  std::copy_n(payload.begin(), pdo.length, frame.data.begin());
  frames_.push_back(frame);
  ++stats_.tpdos_sent;
}

void PdoService::transmit(Tpdo& pdo, const std::array<std::uint8_t, 8>& payload, can::TimePoint now,
                          bool event_driven) {
  emit(pdo, payload);
  pdo.last_sent = payload;
  pdo.sent_once = true;
  pdo.event = false;
  if (event_driven) {
    pdo.inhibit_until = now + pdo.inhibit;
    pdo.event_due = pdo.event_timer > can::Duration::zero() ? now + pdo.event_timer : can::kForever;
  }
}

void PdoService::apply(Rpdo& pdo, const std::array<std::uint8_t, 8>& data) {
  const std::uint64_t payload = from_bytes(data);
  for (const Slot& slot : pdo.slots) {
    if (slot.entry == nullptr) continue;  // dummy entry
    const std::uint64_t value = (payload >> slot.offset) & mask_of(slot.bits);
    std::array<std::uint8_t, 8> bytes{};
    store_unsigned(value, std::span(bytes).first(slot.bytes));
    if (!od_.write(slot.index, slot.sub_index, std::span(bytes).first(slot.bytes))) {
      ++stats_.write_refusals;
    }
  }
  ++stats_.rpdos_applied;
}

void PdoService::receive(Rpdo& pdo, const can::Frame& frame, can::TimePoint now) {
  ++stats_.rpdos_received;
  if (pdo.event_timer > can::Duration::zero() &&
      !(rpdo_deadline_not_restarted_ && pdo.deadline != can::kForever)) {  // fault injection
    pdo.deadline = now + pdo.event_timer;
  }
  set_error(pdo.timeout_error, false, kRpdoTimeout);
  const std::size_t length = frame.length();
  if (length < pdo.length) {
    ++stats_.length_errors;
    set_error(pdo.long_error, false, kLengthExceeded);
    set_error(pdo.short_error, true, kLengthError);
    return;
  }
  set_error(pdo.short_error, false, kLengthError);
  if (length > pdo.length) ++stats_.length_errors;
  set_error(pdo.long_error, length > pdo.length, kLengthExceeded);
  if (pdo.type <= 240 && (window_closed(now) || sync_rpdos_stopped_)) {
    // 1007h: "all synchronous RPDOs may be discarded until the next SYNC message is received".
    ++stats_.sync_rpdos_discarded;
    sync_rpdos_stopped_ = sync_window_rpdo_not_resumed_;  // fault injection only
    return;
  }
  if (pdo.type <= 240) {
    pdo.pending = true;
    pdo.pending_data = frame.data;
  } else {
    apply(pdo, frame.data);
  }
}

PdoOutput PdoService::on_frame(const can::Frame& frame, can::TimePoint now) {
  begin_output();
  if (frame.is_error() || (!running_ && !(rtr_in_any_state_ && frame.is_remote()))) {
    return output();
  }
  bool taken = false;
  if (frame.is_remote()) {
    for (Tpdo& pdo : tpdos_) {
      if (!pdo.active || pdo.can_id != frame.id || pdo.format != frame.format) continue;
      taken = true;
      if (!pdo.rtr_allowed) continue;
      const auto payload = pdo.type == 252 && pdo.sampled ? pdo.sample : pack(pdo);
      emit(pdo, payload);
      ++stats_.rtr_answered;
    }
    return output(taken);
  }
  for (Rpdo& pdo : rpdos_) {
    if (!pdo.active || pdo.can_id != frame.id || pdo.format != frame.format) continue;
    taken = true;
    receive(pdo, frame, now);
  }
  return output(taken);
}

can::Duration PdoService::sync_window() const {
  if (window_entry_ == nullptr) return can::Duration::zero();
  return std::chrono::microseconds(window_entry_->as_unsigned());
}

bool PdoService::window_closed(can::TimePoint now) const {
  if (!last_sync_) return false;
  const can::Duration window = sync_window();
  return window > can::Duration::zero() && now >= *last_sync_ + window;
}

void PdoService::send_all_held() {
  for (; held_next_ < held_.size(); ++held_next_) {
    frames_.push_back(held_[held_next_]);
    ++stats_.tpdos_sent;
  }
  held_.clear();
  held_next_ = 0;
  in_flight_.reset();
}

void PdoService::release_held(can::TimePoint now) {
  if (held_next_ >= held_.size()) return;
  // 1007h set to 0 while TPDOs were held: no window any more, they all go. With the fault
  // injection sync-window-tpdo-sent-late, what is held goes out late too.
  if (sync_window() == can::Duration::zero() ||
      (window_closed(now) && sync_window_tpdos_sent_late_)) {
    send_all_held();
    return;
  }
  if (window_closed(now)) {
    // 1007h: "If the synchronous window length expires all synchronous TPDOs shall be
    // discarded": the ones not handed to the controller yet are not sent late.
    stats_.sync_tpdos_discarded += held_.size() - held_next_;
    held_.clear();
    held_next_ = 0;
    return;
  }
  in_flight_ = held_[held_next_++];
  frames_.push_back(*in_flight_);
  ++stats_.tpdos_sent;
  if (held_next_ == held_.size()) {
    held_.clear();
    held_next_ = 0;
  }
}

PdoOutput PdoService::on_sent(const can::Frame& frame, can::TimePoint now) {
  begin_output();
  if (!running_ || !in_flight_ || frame != *in_flight_) return output();
  in_flight_.reset();
  release_held(now);
  return output();
}

PdoOutput PdoService::on_sync(std::optional<std::uint8_t> counter, can::TimePoint now) {
  begin_output();
  if (!running_) {
    // Fault injection only (sync-tpdo-acyclic-in-stopped, -in-pre-operational).
    if (sync_acyclic_in_stopped_ && state_ == NmtState::stopped) {
      sync_outside_operational(counter, true, now);
    } else if (sync_acyclic_in_pre_operational_ && state_ == NmtState::pre_operational) {
      sync_outside_operational(counter, false, now);
    }
    return output();
  }
  last_sync_ = now;
  // What the last window did not send is gone ("discarded"), and so is the wait for its echo.
  if (held_next_ < held_.size()) stats_.sync_tpdos_discarded += held_.size() - held_next_;
  held_.clear();
  held_next_ = 0;
  in_flight_.reset();
  for (Rpdo& pdo : rpdos_) {
    if (!pdo.active || !pdo.pending || pdo.type > 240) continue;
    pdo.pending = false;
    apply(pdo, pdo.pending_data);
  }
  for (Tpdo& pdo : tpdos_) {
    if (!pdo.active) continue;
    if (pdo.type == 0) {
      const auto payload = pack(pdo);
      if (pdo.event || !pdo.sent_once || changed(pdo, payload)) {
        transmit(pdo, payload, now, false);
      }
    } else if (pdo.type <= 240) {
      if (pdo.sync_start != 0 && counter && !pdo.started) {
        if (*counter != pdo.sync_start) continue;
        pdo.started = true;
        pdo.sync_count = 0;
        transmit(pdo, pack(pdo), now, false);
        continue;
      }
      if (++pdo.sync_count >= pdo.type) {
        pdo.sync_count = 0;
        transmit(pdo, pack(pdo), now, false);
      }
    } else if (pdo.type == 252) {
      pdo.sample = pack(pdo);
      pdo.sampled = true;
    }
  }
  if (sync_tpdo_only_first_ && frames_.size() > 1) {
    // Fault injection only (sync-tpdo-only-first): the others due at this SYNC are dropped.
    stats_.tpdos_sent -= frames_.size() - 1;
    frames_.resize(1);
  }
  if (sync_window() > can::Duration::zero() && frames_.size() > 1) {
    // A window: the TPDOs go to the controller one after the other (on_sent), each only while
    // the window is open.
    held_.assign(frames_.begin() + 1, frames_.end());
    stats_.tpdos_sent -= held_.size();
    frames_.resize(1);
  }
  if (sync_window() > can::Duration::zero() && !frames_.empty()) in_flight_ = frames_.front();
  return output();
}

void PdoService::sync_outside_operational(std::optional<std::uint8_t> counter, bool start_values,
                                          can::TimePoint now) {
  for (Tpdo& pdo : tpdos_) {
    if (!pdo.active || pdo.type > 240) continue;
    const auto payload = pack(pdo);
    if (pdo.type == 0) {
      if (pdo.event || !pdo.sent_once || changed(pdo, payload)) transmit(pdo, payload, now, false);
    } else if (start_values && pdo.sync_start != 0 && counter && !pdo.started &&
               *counter == pdo.sync_start) {
      pdo.started = true;
      pdo.sync_count = 0;
      transmit(pdo, payload, now, false);
    }
  }
}

PdoOutput PdoService::on_time(can::TimePoint now) {
  begin_output();
  if (!running_) return output();
  if (held_next_ < held_.size() && (sync_window() == can::Duration::zero() || window_closed(now))) {
    release_held(now);
  }
  for (Rpdo& pdo : rpdos_) {
    if (!pdo.active || pdo.deadline > now) continue;
    pdo.deadline = can::kForever;
    if (!pdo.timeout_error) ++stats_.rpdo_timeouts;
    set_error(pdo.timeout_error, true, kRpdoTimeout);
  }
  for (Tpdo& pdo : tpdos_) {
    if (!pdo.active || pdo.type < 254) continue;
    // The event timer elapsed at event_due: it restarts from then, not from when its owner got
    // round to it (a process woken late), so that lateness does not add up period by period.
    // Late by a whole period or more, or held by the inhibit time, it restarts from now.
    const bool timer_elapsed = pdo.event_due <= now;
    const can::TimePoint elapsed_at = pdo.event_due;
    const bool held = pdo.inhibit_until > elapsed_at;
    if (timer_elapsed) pdo.event = true;
    const auto payload = pack(pdo);
    if (!pdo.sent_once || changed(pdo, payload)) pdo.event = true;
    if (pdo.event && now >= pdo.inhibit_until) {
      transmit(pdo, payload, now, true);
      if (timer_elapsed && !held && now - elapsed_at < pdo.event_timer)
        pdo.event_due = elapsed_at + pdo.event_timer;
    }
  }
  return output();
}

can::TimePoint PdoService::next_deadline() const {
  can::TimePoint at = can::kForever;
  if (!running_) return at;
  // The end of the window (or at once, 1007h having been set to 0 meanwhile): on_time then
  // discards (or hands out) what is held.
  if (held_next_ < held_.size() && last_sync_) at = *last_sync_ + sync_window();
  for (const Rpdo& pdo : rpdos_) {
    if (pdo.active) at = std::min(at, pdo.deadline);
  }
  for (const Tpdo& pdo : tpdos_) {
    if (!pdo.active || pdo.type < 254) continue;
    // A pending event waits only for the inhibit time; its event timer has already fired (an
    // event timer shorter than the inhibit time must not wake the owner at a past instant).
    if (pdo.event) {
      at = std::min(at, std::max(pdo.inhibit_until, can::TimePoint{}));
    } else {
      at = std::min(at, pdo.event_due);
    }
  }
  return at;
}

bool PdoService::trigger(std::uint16_t number) {
  for (Tpdo& pdo : tpdos_) {
    if (pdo.number != number) continue;
    if (!pdo.active) return false;
    pdo.event = true;
    return true;
  }
  return false;
}

PdoOutput PdoService::clear_errors() {
  begin_output();
  for (Rpdo& pdo : rpdos_) {
    set_error(pdo.short_error, false, kLengthError);
    set_error(pdo.long_error, false, kLengthExceeded);
    set_error(pdo.timeout_error, false, kRpdoTimeout);
    pdo.deadline = can::kForever;
  }
  return output();
}

bool PdoService::is_active(PdoDirection direction, std::uint16_t number) const {
  if (direction == PdoDirection::receive) {
    for (const Rpdo& pdo : rpdos_) {
      if (pdo.number == number) return pdo.active;
    }
  } else {
    for (const Tpdo& pdo : tpdos_) {
      if (pdo.number == number) return pdo.active;
    }
  }
  return false;
}

std::optional<std::string> PdoService::configuration_problem(PdoDirection direction,
                                                             std::uint16_t number) const {
  if (direction == PdoDirection::receive) {
    for (const Rpdo& pdo : rpdos_) {
      if (pdo.number == number) return pdo.problem;
    }
  } else {
    for (const Tpdo& pdo : tpdos_) {
      if (pdo.number == number) return pdo.problem;
    }
  }
  return std::nullopt;
}

}  // namespace drivecheck::cia301

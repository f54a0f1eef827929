#include "protocol/ethercat/coe_sdo_info.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {

using cia301::SdoAbort;

namespace {

void put16(std::uint16_t v, std::vector<std::uint8_t>& out) {
  out.push_back(static_cast<std::uint8_t>(v & 0xFF));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
}
std::uint16_t get16(std::span<const std::uint8_t> b, std::size_t at) {
  return static_cast<std::uint16_t>(b[at] | (b[at + 1] << 8));
}

std::vector<std::uint8_t> message(SdoInfoOpcode opcode, bool incomplete, std::uint16_t left,
                                  std::span<const std::uint8_t> payload) {
  std::vector<std::uint8_t> out(kCoeHeaderSize);
  CoeHeader h;
  h.service = static_cast<std::uint8_t>(CoeService::sdo_information);
  encode_coe_header(h, std::span<std::uint8_t, 2>(out.data(), 2));
  out.push_back(
      static_cast<std::uint8_t>(static_cast<std::uint8_t>(opcode) | (incomplete ? 0x80 : 0x00)));
  out.push_back(0);
  put16(left, out);
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

std::vector<std::vector<std::uint8_t>> fragments(SdoInfoOpcode opcode,
                                                 const std::vector<std::uint8_t>& payload,
                                                 std::size_t read_size) {
  const std::size_t overhead = kMailboxHeaderSize + kCoeHeaderSize + kSdoInfoHeaderSize;
  const std::size_t room = read_size > overhead + 2 ? read_size - overhead : 2;
  const std::size_t count = std::max<std::size_t>(1, (payload.size() + room - 1) / room);
  std::vector<std::vector<std::uint8_t>> out;
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t from = i * room;
    const std::size_t to = std::min(payload.size(), from + room);
    const std::span<const std::uint8_t> part(payload.data() + from, to - from);
    out.push_back(message(opcode, i + 1 < count, static_cast<std::uint16_t>(count - 1 - i), part));
  }
  return out;
}

std::vector<std::vector<std::uint8_t>> error(SdoAbort code) {
  std::vector<std::uint8_t> payload;
  const auto v = static_cast<std::uint32_t>(code);
  for (int i = 0; i < 4; ++i)
    payload.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  return {message(SdoInfoOpcode::error_request, false, 0, payload)};
}

bool in_list(const cia301::Object& object, OdListType list) {
  for (const cia301::Entry& entry : object.entries()) {
    const auto access = object_access_bits(entry);
    switch (list) {
      case OdListType::all_objects:
        return true;
      case OdListType::rxpdo_mappable:
        if (access & 0x40) return true;
        break;
      case OdListType::txpdo_mappable:
        if (access & 0x80) return true;
        break;
      case OdListType::device_replacement:
      case OdListType::startup_parameters:
        if (entry.store_group() != cia301::kStoreNone) return true;
        break;
      case OdListType::list_lengths:
        return false;
    }
  }
  return false;
}

std::vector<std::uint16_t> list_of(const cia301::ObjectDictionary& od, OdListType list,
                                   const SdoInfoHidden& hidden) {
  std::vector<std::uint16_t> out;
  for (const cia301::Object& object : od.objects()) {
    if (hidden && hidden(object.index())) continue;
    if (in_list(object, list)) out.push_back(object.index());
  }
  return out;
}

std::uint16_t object_data_type(const cia301::Object& object) {
  if (object.code() == cia301::ObjectCode::record) return 0;
  if (cia301::has_sub_entries(object.code())) {
    const cia301::Entry* first = object.find(1);
    return first ? static_cast<std::uint16_t>(first->type()) : 0;
  }
  const cia301::Entry* only = object.find(0);
  return only ? static_cast<std::uint16_t>(only->type()) : 0;
}

}  // namespace

std::uint16_t object_access_bits(const cia301::Entry& entry) {
  std::uint16_t bits = 0;
  const auto access = entry.access();
  if (cia301::is_readable(access)) bits |= 0x07;
  if (cia301::is_writable(access)) bits |= 0x38;
  if (entry.pdo_mappable()) {
    if (access == cia301::AccessType::rww || access == cia301::AccessType::rw) bits |= 0x40;
    if (access == cia301::AccessType::rwr || access == cia301::AccessType::ro ||
        access == cia301::AccessType::rw) {
      bits |= 0x80;
    }
  }
  if (entry.store_group() != cia301::kStoreNone) bits |= 0x0100;
  return bits;
}

std::vector<std::vector<std::uint8_t>> answer_sdo_information(cia301::ObjectDictionary& od,
                                                              std::span<const std::uint8_t> data,
                                                              std::size_t read_size,
                                                              const SdoInfoHidden& hidden) {
  if (data.size() < kCoeHeaderSize + kSdoInfoHeaderSize + 2) {
    return error(SdoAbort::invalid_command_specifier);
  }
  const auto body = data.subspan(kCoeHeaderSize + kSdoInfoHeaderSize);
  const std::uint8_t opcode = data[kCoeHeaderSize] & 0x7F;
  std::vector<std::uint8_t> payload;
  switch (opcode) {
    case static_cast<std::uint8_t>(SdoInfoOpcode::get_od_list_request): {
      const std::uint16_t type = get16(body, 0);
      if (type > static_cast<std::uint16_t>(OdListType::startup_parameters)) {
        return error(SdoAbort::unsupported_access);
      }
      put16(type, payload);
      if (type == static_cast<std::uint16_t>(OdListType::list_lengths)) {
        for (std::uint16_t t = 1; t <= 5; ++t) {
          put16(static_cast<std::uint16_t>(list_of(od, static_cast<OdListType>(t), hidden).size()),
                payload);
        }
      } else {
        for (std::uint16_t index : list_of(od, static_cast<OdListType>(type), hidden)) {
          put16(index, payload);
        }
      }
      return fragments(SdoInfoOpcode::get_od_list_response, payload, read_size);
    }
    case static_cast<std::uint8_t>(SdoInfoOpcode::get_object_description_request): {
      const std::uint16_t index = get16(body, 0);
      const cia301::Object* object = hidden && hidden(index) ? nullptr : od.find(index);
      if (object == nullptr) return error(SdoAbort::object_does_not_exist);
      put16(object->index(), payload);
      put16(object_data_type(*object), payload);
      const auto entries = object->entries();
      payload.push_back(entries.empty() ? 0 : entries.back().sub_index());
      payload.push_back(static_cast<std::uint8_t>(object->code()));
      payload.insert(payload.end(), object->name().begin(), object->name().end());
      return fragments(SdoInfoOpcode::get_object_description_response, payload, read_size);
    }
    case static_cast<std::uint8_t>(SdoInfoOpcode::get_entry_description_request): {
      if (body.size() < 4) return error(SdoAbort::invalid_command_specifier);
      const std::uint16_t index = get16(body, 0);
      const std::uint8_t sub = body[2];
      const std::uint8_t wanted = body[3];
      if (od.find(index) == nullptr || (hidden && hidden(index))) {
        return error(SdoAbort::object_does_not_exist);
      }
      const cia301::Entry* entry = od.find(index, sub);
      if (entry == nullptr) return error(SdoAbort::sub_index_does_not_exist);
      const auto& def = entry->definition();
      std::vector<std::uint8_t> values;
      std::uint8_t info = 0;
      const bool fixed = cia301::info(entry->type()).size != 0;
      if ((wanted & 0x10) && fixed) {
        const auto bytes = entry->default_bytes(od.node_id());
        values.insert(values.end(), bytes.begin(), bytes.end());
        info |= 0x10;
      }
      for (const auto& [bit, limit] : {std::pair{0x20, &def.low_limit}, {0x40, &def.high_limit}}) {
        if (!(wanted & bit) || limit->empty() || !fixed) continue;
        if (auto bytes = cia301::encode(entry->type(), *limit)) {
          values.insert(values.end(), bytes->begin(), bytes->end());
          info = static_cast<std::uint8_t>(info | bit);
        }
      }
      put16(index, payload);
      payload.push_back(sub);
      payload.push_back(info);
      put16(static_cast<std::uint16_t>(entry->type()), payload);
      const auto bits = cia301::info(entry->type()).bit_size;
      put16(static_cast<std::uint16_t>(bits != 0 ? bits : entry->bytes().size() * 8), payload);
      put16(object_access_bits(*entry), payload);
      payload.insert(payload.end(), values.begin(), values.end());
      payload.insert(payload.end(), entry->name().begin(), entry->name().end());
      return fragments(SdoInfoOpcode::get_entry_description_response, payload, read_size);
    }
    default:
      return error(SdoAbort::invalid_command_specifier);
  }
}

std::vector<std::uint8_t> sdo_info_od_list_request(OdListType list) {
  std::vector<std::uint8_t> payload;
  put16(static_cast<std::uint16_t>(list), payload);
  return message(SdoInfoOpcode::get_od_list_request, false, 0, payload);
}

std::vector<std::uint8_t> sdo_info_object_request(std::uint16_t index) {
  std::vector<std::uint8_t> payload;
  put16(index, payload);
  return message(SdoInfoOpcode::get_object_description_request, false, 0, payload);
}

std::vector<std::uint8_t> sdo_info_entry_request(std::uint16_t index, std::uint8_t sub_index,
                                                 std::uint8_t value_info) {
  std::vector<std::uint8_t> payload;
  put16(index, payload);
  payload.push_back(sub_index);
  payload.push_back(value_info);
  return message(SdoInfoOpcode::get_entry_description_request, false, 0, payload);
}

Expected<std::optional<SdoInfoMessage>, std::string> SdoInfoAssembler::add(
    std::span<const std::uint8_t> data) {
  if (data.size() < kCoeHeaderSize + kSdoInfoHeaderSize) {
    reset();
    return Unexpected(std::string("shorter than an SDO information header"));
  }
  if (decode_coe_header(data.first<kCoeHeaderSize>()).service !=
      static_cast<std::uint8_t>(CoeService::sdo_information)) {
    reset();
    return Unexpected(std::string("not SDO information (CoE service)"));
  }
  const std::uint8_t opcode = data[kCoeHeaderSize] & 0x7F;
  const bool incomplete = (data[kCoeHeaderSize] & 0x80) != 0;
  const std::uint16_t left = get16(data, kCoeHeaderSize + 2);
  const auto body = data.subspan(kCoeHeaderSize + kSdoInfoHeaderSize);
  if (partial_) {
    if (opcode != partial_->opcode || left != expected_left_) {
      reset();
      return Unexpected(fmt::format(
          "fragment of opcode {} with {} left does not continue the previous one", opcode, left));
    }
  } else {
    partial_ = SdoInfoMessage{opcode, {}};
  }
  partial_->data.insert(partial_->data.end(), body.begin(), body.end());
  if (incomplete) {
    if (left == 0) {
      reset();
      return Unexpected(std::string("an incomplete fragment with no fragments left"));
    }
    expected_left_ = static_cast<std::uint16_t>(left - 1);
    return std::optional<SdoInfoMessage>{};
  }
  std::optional<SdoInfoMessage> done = std::move(partial_);
  reset();
  return done;
}

void SdoInfoAssembler::reset() {
  partial_.reset();
  expected_left_ = 0;
}

namespace {
Expected<void, std::string> expect(const SdoInfoMessage& m, SdoInfoOpcode opcode,
                                   std::size_t minimum) {
  if (m.opcode == static_cast<std::uint8_t>(SdoInfoOpcode::error_request)) {
    return Unexpected(std::string("an SDO information error"));
  }
  if (m.opcode != static_cast<std::uint8_t>(opcode)) {
    return Unexpected(
        fmt::format("opcode {} where {} was expected", m.opcode, static_cast<int>(opcode)));
  }
  if (m.data.size() < minimum) {
    return Unexpected(fmt::format("{} octets, at least {} expected", m.data.size(), minimum));
  }
  return {};
}
}  // namespace

Expected<std::vector<std::uint16_t>, std::string> parse_od_list(const SdoInfoMessage& m) {
  if (auto ok = expect(m, SdoInfoOpcode::get_od_list_response, 2); !ok) {
    return Unexpected(ok.error());
  }
  if (m.data.size() % 2 != 0) return Unexpected(std::string("an odd number of octets"));
  std::vector<std::uint16_t> out;
  for (std::size_t at = 2; at + 1 < m.data.size(); at += 2)
    out.push_back(get16(m.data, at));
  return out;
}

Expected<ObjectDescription, std::string> parse_object_description(const SdoInfoMessage& m) {
  if (auto ok = expect(m, SdoInfoOpcode::get_object_description_response, 6); !ok) {
    return Unexpected(ok.error());
  }
  return ObjectDescription{get16(m.data, 0), get16(m.data, 2), m.data[4], m.data[5],
                           std::string(m.data.begin() + 6, m.data.end())};
}

Expected<EntryDescription, std::string> parse_entry_description(const SdoInfoMessage& m) {
  if (auto ok = expect(m, SdoInfoOpcode::get_entry_description_response, 10); !ok) {
    return Unexpected(ok.error());
  }
  return EntryDescription{get16(m.data, 0),
                          m.data[2],
                          m.data[3],
                          get16(m.data, 4),
                          get16(m.data, 6),
                          get16(m.data, 8),
                          std::vector<std::uint8_t>(m.data.begin() + 10, m.data.end())};
}

Expected<std::uint32_t, std::string> parse_sdo_info_error(const SdoInfoMessage& m) {
  if (m.opcode != static_cast<std::uint8_t>(SdoInfoOpcode::error_request)) {
    return Unexpected(std::string("not an SDO information error"));
  }
  if (m.data.size() < 4) return Unexpected(std::string("shorter than an abort code"));
  return static_cast<std::uint32_t>(m.data[0] | (m.data[1] << 8) | (m.data[2] << 16) |
                                    (static_cast<std::uint32_t>(m.data[3]) << 24));
}

}  // namespace drivecheck::ethercat

// A small object dictionary for the CoE tests: a record, a VAR, a long string, a domain, a
// bit-packed record and the RxPDO assignment.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::ethercat::test {

inline cia301::ObjectDictionary make_test_dictionary() {
  using cia301::AccessType;
  using cia301::DataType;
  using cia301::EntryDefinition;
  using cia301::ObjectCode;
  using cia301::ObjectDefinition;
  using cia301::Value;
  cia301::ObjectDictionary od;
  auto add = [&](ObjectDefinition def) {
    if (!od.add_object(std::move(def))) std::abort();
  };
  // 1018h identity: vendor 1Dh (Festo, 000 L2392), product 12345678h, revision, serial.
  add({0x1018,
       "Identity",
       ObjectCode::record,
       {EntryDefinition::highest_sub_index(4),
        EntryDefinition::unsigned_entry(1, "Vendor", DataType::unsigned32, AccessType::ro, 0x1D),
        EntryDefinition::unsigned_entry(2, "Product", DataType::unsigned32, AccessType::ro,
                                        0x12345678),
        EntryDefinition::unsigned_entry(3, "Revision", DataType::unsigned32, AccessType::ro, 2),
        EntryDefinition::unsigned_entry(4, "Serial", DataType::unsigned32, AccessType::ro, 7)}});
  if (!od.add_var(0x6040, "Controlword", DataType::unsigned16, AccessType::rw,
                  Value::of_unsigned(0), true)) {
    std::abort();
  }
  const std::string name(40, 'N');
  if (!od.add_var(0x1008, "Device name", DataType::visible_string, AccessType::constant,
                  Value::of_string(name))) {
    std::abort();
  }
  {
    EntryDefinition domain = EntryDefinition::make(0, "Blob", DataType::domain, AccessType::rw,
                                                   Value::of_bytes({}), false);
    domain.max_size = 1000;
    add({0x2000, "Blob", ObjectCode::domain, {domain}});
  }
  add({0x2001,
       "Bits",
       ObjectCode::record,
       {EntryDefinition::highest_sub_index(3),
        EntryDefinition::make(1, "A", DataType::boolean, AccessType::rw, Value::of_unsigned(1),
                              false),
        EntryDefinition::make(2, "B", DataType::boolean, AccessType::rw, Value::of_unsigned(0),
                              false),
        EntryDefinition::unsigned_entry(3, "Word", DataType::unsigned16, AccessType::rw, 0xBEEF)}});
  add({0x2002,
       "Named",
       ObjectCode::record,
       {EntryDefinition::highest_sub_index(2),
        EntryDefinition::unsigned_entry(1, "Value", DataType::unsigned8, AccessType::rw, 5),
        EntryDefinition::make(2, "Text", DataType::visible_string, AccessType::rw,
                              Value::of_string("abc"), false)}});
  {
    EntryDefinition sub0 =
        EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 1);
    std::vector<EntryDefinition> entries{sub0};
    for (std::uint8_t i = 1; i <= 4; ++i) {
      entries.push_back(EntryDefinition::unsigned_entry(i, "RxPDO", DataType::unsigned16,
                                                        AccessType::rw, 0x1600u + i - 1));
    }
    add({0x1C12, "RxPDO assign", ObjectCode::array, std::move(entries)});
  }
  return od;
}

}  // namespace drivecheck::ethercat::test

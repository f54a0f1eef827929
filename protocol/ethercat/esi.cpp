#include "protocol/ethercat/esi.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <climits>
#include <cstdint>
#include <fstream>
#include <map>
#include <pugixml.hpp>
#include <sstream>

namespace drivecheck::ethercat {
namespace {

// Line numbers from offsets into the text the parser was given.
class Lines {
 public:
  explicit Lines(std::string_view text) {
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\n') starts_.push_back(i + 1);
    }
  }
  int at(std::ptrdiff_t offset) const {
    if (offset < 0) return 0;
    const auto it =
        std::upper_bound(starts_.begin(), starts_.end(), static_cast<std::size_t>(offset));
    return static_cast<int>(it - starts_.begin()) + 1;
  }

 private:
  std::vector<std::size_t> starts_;
};

// A failure while walking the document: the element's line and the message.
struct Failure {
  int line = 0;
  std::string message;
};

template <typename T>
using Result = Expected<T, Failure>;

std::string_view trim(std::string_view s) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && space(s.front()))
    s.remove_prefix(1);
  while (!s.empty() && space(s.back()))
    s.remove_suffix(1);
  return s;
}

class Walker {
 public:
  explicit Walker(const Lines& lines) : lines_(lines) {}

  int line(const pugi::xml_node& node) const { return lines_.at(node.offset_debug()); }

  // ETG.2000 HexDecValue: "#x..." hexadecimal, else decimal; at most `max`.
  Result<std::uint64_t> number(std::string_view text, const pugi::xml_node& where,
                               std::string_view what, std::uint64_t max) const {
    std::string_view t = trim(text);
    int base = 10;
    if (t.size() >= 2 && t[0] == '#' && (t[1] == 'x' || t[1] == 'X')) {
      t.remove_prefix(2);
      base = 16;
    }
    std::uint64_t value = 0;
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value, base);
    if (t.empty() || ec != std::errc() || end != t.data() + t.size()) {
      return Unexpected(
          Failure{line(where), fmt::format("{} '{}' is not a number (decimal, or #x hexadecimal)",
                                           what, std::string(trim(text)))});
    }
    if (value > max) {
      return Unexpected(Failure{line(where), fmt::format("{} '{}' is out of range (at most {:#x})",
                                                         what, std::string(trim(text)), max)});
    }
    return value;
  }

  // The number in child element `name` of `node` (required).
  Result<std::uint64_t> child_number(const pugi::xml_node& node, const char* name,
                                     std::uint64_t max) const {
    const pugi::xml_node child = node.child(name);
    if (!child) {
      return Unexpected(Failure{line(node), fmt::format("<{}> has no <{}>", node.name(), name)});
    }
    return number(child.text().get(), child, fmt::format("<{}>", name), max);
  }

  // An optional numeric attribute.
  Result<std::optional<std::uint64_t>> attribute_number(const pugi::xml_node& node,
                                                        const char* name, std::uint64_t max) const {
    const pugi::xml_attribute a = node.attribute(name);
    if (!a) return std::optional<std::uint64_t>();
    auto v = number(a.value(), node, fmt::format("{}@{}", node.name(), name), max);
    if (!v) return Unexpected(v.error());
    return std::optional<std::uint64_t>(*v);
  }

  // ETG.2000 boolean attributes: "1"/"true" or "0"/"false".
  Result<bool> flag(const pugi::xml_node& node, const char* name) const {
    const pugi::xml_attribute a = node.attribute(name);
    if (!a) return false;
    const std::string_view v = trim(a.value());
    if (v == "1" || v == "true") return true;
    if (v == "0" || v == "false") return false;
    return Unexpected(Failure{line(node), fmt::format("{}@{} '{}' is not a boolean (0, 1, "
                                                      "true, false)",
                                                      node.name(), name, std::string(v))});
  }

  Result<std::vector<std::uint8_t>> hex_binary(const pugi::xml_node& node) const {
    const std::string_view t = trim(node.text().get());
    if (t.size() % 2 != 0) {
      return Unexpected(
          Failure{line(node), fmt::format("<{}> '{}' is no hexBinary (an odd number of digits)",
                                          node.name(), std::string(t))});
    }
    std::vector<std::uint8_t> out;
    for (std::size_t i = 0; i < t.size(); i += 2) {
      std::uint8_t byte = 0;
      const auto [end, ec] = std::from_chars(t.data() + i, t.data() + i + 2, byte, 16);
      if (ec != std::errc() || end != t.data() + i + 2) {
        return Unexpected(Failure{
            line(node), fmt::format("<{}> '{}' is no hexBinary", node.name(), std::string(t))});
      }
      out.push_back(byte);
    }
    return out;
  }

  // ETG.2000 Flags/PdoMapping (EtherCATBase.xsd enumeration: T R TR RT t r tr rt).
  Result<std::optional<EsiPdoMapping>> pdo_mapping(const pugi::xml_node& flags) const {
    const pugi::xml_node m = flags.child("PdoMapping");
    if (!m) return std::optional<EsiPdoMapping>();
    const std::string_view v = trim(m.text().get());
    static constexpr std::array<std::string_view, 8> kValues = {"R", "T", "RT", "TR",
                                                                "r", "t", "rt", "tr"};
    if (std::find(kValues.begin(), kValues.end(), v) == kValues.end()) {
      return Unexpected(Failure{
          line(m), fmt::format("<PdoMapping> '{}' is none of R, T, RT, TR (or the same in lower "
                               "case: ETG.2000 EtherCATBase.xsd)",
                               std::string(v))});
    }
    EsiPdoMapping mapping;
    mapping.text = v;
    mapping.line = line(m);
    mapping.rx = v.find_first_of("Rr") != std::string_view::npos;
    mapping.tx = v.find_first_of("Tt") != std::string_view::npos;
    return std::optional<EsiPdoMapping>(std::move(mapping));
  }

  // An xs:int (signed decimal) in element `node`'s text.
  Result<std::int64_t> signed_number(const pugi::xml_node& node, std::string_view what) const {
    const std::string_view t = trim(node.text().get());
    std::int64_t value = 0;
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value, 10);
    if (t.empty() || ec != std::errc() || end != t.data() + t.size() || value < INT32_MIN ||
        value > INT32_MAX) {
      return Unexpected(Failure{line(node), fmt::format("{} '{}' is not an xs:int (a signed "
                                                        "decimal of 32 bits)",
                                                        what, std::string(t))});
    }
    return value;
  }

  Result<std::optional<EsiAccess>> access(const pugi::xml_node& flags, std::string& read_r,
                                          std::string& write_r) const {
    const pugi::xml_node a = flags.child("Access");
    if (!a) return std::optional<EsiAccess>();
    read_r = a.attribute("ReadRestrictions").value();
    write_r = a.attribute("WriteRestrictions").value();
    const std::string_view v = trim(a.text().get());
    if (v == "ro") return std::optional<EsiAccess>(EsiAccess::ro);
    if (v == "rw") return std::optional<EsiAccess>(EsiAccess::rw);
    if (v == "wo") return std::optional<EsiAccess>(EsiAccess::wo);
    return Unexpected(
        Failure{line(a), fmt::format("<Access> '{}' is none of ro, rw, wo", std::string(v))});
  }

 private:
  const Lines& lines_;
};

struct DataType {
  std::string name;
  std::string base_type;
  std::uint32_t bit_size = 0;
  std::optional<std::uint32_t> lower_bound;  // ArrayInfo
  std::optional<std::uint32_t> elements;
  std::vector<pugi::xml_node> sub_items;
  pugi::xml_node node;
};

Result<EsiPdo> read_pdo(const Walker& w, const pugi::xml_node& node) {
  EsiPdo pdo;
  pdo.line = w.line(node);
  auto index = w.child_number(node, "Index", 0xFFFF);
  if (!index) return Unexpected(index.error());
  pdo.index = static_cast<std::uint16_t>(*index);
  pdo.name = trim(node.child("Name").text().get());
  auto sm = w.attribute_number(node, "Sm", 0xFF);
  if (!sm) return Unexpected(sm.error());
  if (*sm) pdo.sm = static_cast<std::uint8_t>(**sm);
  auto fixed = w.flag(node, "Fixed");
  if (!fixed) return Unexpected(fixed.error());
  pdo.fixed = *fixed;
  auto mandatory = w.flag(node, "Mandatory");
  if (!mandatory) return Unexpected(mandatory.error());
  pdo.mandatory = *mandatory;
  for (const pugi::xml_node& e : node.children("Entry")) {
    EsiPdoEntry entry;
    entry.line = w.line(e);
    auto ei = w.child_number(e, "Index", 0xFFFF);
    if (!ei) return Unexpected(ei.error());
    entry.index = static_cast<std::uint16_t>(*ei);
    auto bits = w.child_number(e, "BitLen", 0xFF);
    if (!bits) return Unexpected(bits.error());
    entry.bit_length = static_cast<std::uint8_t>(*bits);
    if (entry.index != 0) {  // a gap (Index 0) needs no SubIndex
      auto sub = w.child_number(e, "SubIndex", 0xFF);
      if (!sub) return Unexpected(sub.error());
      entry.sub_index = static_cast<std::uint8_t>(*sub);
    }
    entry.name = trim(e.child("Name").text().get());
    entry.data_type = trim(e.child("DataType").text().get());
    pdo.entries.push_back(std::move(entry));
  }
  return pdo;
}

// One sub-item of a structured DataType (with SubIdx), or the elements of an ARRAY sub-item.
Result<void> expand_sub_item(const Walker& w, const std::map<std::string, DataType>& types,
                             const pugi::xml_node& item, std::vector<EsiSubItem>& out) {
  EsiSubItem sub;
  sub.line = w.line(item);
  sub.name = trim(item.child("Name").text().get());
  sub.type = trim(item.child("Type").text().get());
  if (auto bits = w.child_number(item, "BitSize", 0xFFFFFFFF)) {
    sub.bit_size = static_cast<std::uint32_t>(*bits);
  } else {
    return Unexpected(bits.error());
  }
  if (const pugi::xml_node flags = item.child("Flags")) {
    auto a = w.access(flags, sub.read_restrictions, sub.write_restrictions);
    if (!a) return Unexpected(a.error());
    sub.access = *a;
    auto mapping = w.pdo_mapping(flags);
    if (!mapping) return Unexpected(mapping.error());
    sub.pdo_mapping = std::move(*mapping);
  }
  if (item.child("SubIdx")) {
    auto idx = w.child_number(item, "SubIdx", 0xFF);
    if (!idx) return Unexpected(idx.error());
    sub.sub_index = static_cast<std::uint8_t>(*idx);
    out.push_back(std::move(sub));
    return {};
  }
  // No SubIdx: the elements of an ARRAY type (ETG.2000 ArrayInfo).
  const auto array = types.find(sub.type);
  if (array == types.end() || !array->second.elements || !array->second.lower_bound) {
    return Unexpected(Failure{
        sub.line, fmt::format("<SubItem> '{}' has no <SubIdx> and its type '{}' is no ARRAY "
                              "DataType (with <ArrayInfo>)",
                              sub.name, sub.type)});
  }
  const DataType& t = array->second;
  if (*t.lower_bound + *t.elements > 0x100 || *t.elements == 0) {
    return Unexpected(Failure{w.line(t.node), fmt::format("DataType '{}': ArrayInfo LBound {} "
                                                          "Elements {} leave sub-index 0..FFh",
                                                          t.name, *t.lower_bound, *t.elements)});
  }
  const auto base = types.find(t.base_type);
  const std::uint32_t element_bits = base != types.end() && base->second.bit_size != 0
                                         ? base->second.bit_size
                                         : t.bit_size / *t.elements;
  for (std::uint32_t i = 0; i < *t.elements; ++i) {
    EsiSubItem element = sub;
    element.sub_index = static_cast<std::uint8_t>(*t.lower_bound + i);
    element.name = fmt::format("{} {}", sub.name, i + 1);
    element.type = t.base_type;
    element.bit_size = element_bits;
    out.push_back(std::move(element));
  }
  return {};
}

Result<EsiObject> read_object(const Walker& w, const std::map<std::string, DataType>& types,
                              const pugi::xml_node& node) {
  EsiObject object;
  object.line = w.line(node);
  auto index = w.child_number(node, "Index", 0xFFFF);
  if (!index) return Unexpected(index.error());
  object.index = static_cast<std::uint16_t>(*index);
  object.name = trim(node.child("Name").text().get());
  object.type = trim(node.child("Type").text().get());
  if (object.type.empty()) {
    return Unexpected(
        Failure{object.line, fmt::format("<Object> {:04X}h has no <Type>", object.index)});
  }
  if (node.child("BitSize")) {
    auto bits = w.child_number(node, "BitSize", 0xFFFFFFFF);
    if (!bits) return Unexpected(bits.error());
    object.bit_size = static_cast<std::uint32_t>(*bits);
  }
  const pugi::xml_node info = node.child("Info");
  std::optional<EsiPdoMapping> object_mapping;  // the Object's Flags/PdoMapping
  if (const pugi::xml_node flags = node.child("Flags")) {
    auto mapping = w.pdo_mapping(flags);
    if (!mapping) return Unexpected(mapping.error());
    object_mapping = std::move(*mapping);
  }
  const auto type = types.find(object.type);
  if (type != types.end() && !type->second.sub_items.empty()) {
    object.structured = true;
    for (const pugi::xml_node& item : type->second.sub_items) {
      if (auto r = expand_sub_item(w, types, item, object.entries); !r) {
        return Unexpected(r.error());
      }
    }
    // A sub-item without its own PdoMapping takes the Object's (where the Object gives one).
    for (EsiSubItem& entry : object.entries) {
      if (!entry.pdo_mapping) entry.pdo_mapping = object_mapping;
    }
    // Defaults: Info/SubItem by Name, else by position.
    std::size_t position = 0;
    for (const pugi::xml_node& given : info.children("SubItem")) {
      const std::string name(trim(given.child("Name").text().get()));
      EsiSubItem* target = nullptr;
      for (EsiSubItem& e : object.entries) {
        if (!name.empty() && e.name == name) target = &e;
      }
      if (target == nullptr && position < object.entries.size()) {
        target = &object.entries[position];
      }
      ++position;
      if (target == nullptr) continue;
      if (const pugi::xml_node data = given.child("Info").child("DefaultData")) {
        auto bytes = w.hex_binary(data);
        if (!bytes) return Unexpected(bytes.error());
        target->default_data = std::move(*bytes);
      }
    }
    return object;
  }
  EsiSubItem var;
  var.line = object.line;
  var.name = object.name;
  var.type = object.type;
  var.bit_size = object.bit_size;
  var.pdo_mapping = std::move(object_mapping);
  if (const pugi::xml_node flags = node.child("Flags")) {
    auto a = w.access(flags, var.read_restrictions, var.write_restrictions);
    if (!a) return Unexpected(a.error());
    var.access = *a;
  }
  if (const pugi::xml_node data = info.child("DefaultData")) {
    auto bytes = w.hex_binary(data);
    if (!bytes) return Unexpected(bytes.error());
    var.default_data = std::move(*bytes);
  }
  object.entries.push_back(std::move(var));
  return object;
}

Result<std::map<std::string, DataType>> read_data_types(const Walker& w,
                                                        const pugi::xml_node& dictionary) {
  std::map<std::string, DataType> types;
  for (const pugi::xml_node& node : dictionary.child("DataTypes").children("DataType")) {
    DataType t;
    t.node = node;
    t.name = trim(node.child("Name").text().get());
    if (t.name.empty()) return Unexpected(Failure{w.line(node), "<DataType> has no <Name>"});
    t.base_type = trim(node.child("BaseType").text().get());
    if (node.child("BitSize")) {
      auto bits = w.child_number(node, "BitSize", 0xFFFFFFFF);
      if (!bits) return Unexpected(bits.error());
      t.bit_size = static_cast<std::uint32_t>(*bits);
    }
    if (const pugi::xml_node array = node.child("ArrayInfo")) {
      auto lower = w.child_number(array, "LBound", 0xFF);
      if (!lower) return Unexpected(lower.error());
      auto elements = w.child_number(array, "Elements", 0x100);
      if (!elements) return Unexpected(elements.error());
      t.lower_bound = static_cast<std::uint32_t>(*lower);
      t.elements = static_cast<std::uint32_t>(*elements);
    }
    for (const pugi::xml_node& item : node.children("SubItem"))
      t.sub_items.push_back(item);
    const std::string name = t.name;
    types.insert_or_assign(name, std::move(t));
  }
  return types;
}

Result<std::optional<EsiDcTime>> read_dc_time(const Walker& w, const pugi::xml_node& op_mode,
                                              const char* name) {
  const pugi::xml_node node = op_mode.child(name);
  if (!node) return std::optional<EsiDcTime>();
  EsiDcTime time;
  auto value = w.signed_number(node, fmt::format("<{}>", name));
  if (!value) return Unexpected(value.error());
  time.value = *value;
  if (const pugi::xml_attribute factor = node.attribute("Factor")) {
    const std::string_view text = trim(factor.value());
    std::int64_t f = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), f, 10);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || f < INT32_MIN ||
        f > INT32_MAX) {
      return Unexpected(Failure{
          w.line(node), fmt::format("{}@Factor '{}' is not an xs:int", name, std::string(text))});
    }
    time.factor = f;
  }
  if (node.attribute("Input")) {
    auto input = w.flag(node, "Input");
    if (!input) return Unexpected(input.error());
    time.input = *input;
  }
  return std::optional<EsiDcTime>(time);
}

Result<std::vector<EsiDcOpMode>> read_dc(const Walker& w, const pugi::xml_node& dc) {
  std::vector<EsiDcOpMode> out;
  for (const pugi::xml_node& node : dc.children("OpMode")) {
    EsiDcOpMode mode;
    mode.line = w.line(node);
    if (!node.child("Name")) return Unexpected(Failure{mode.line, "<OpMode> has no <Name>"});
    mode.name = trim(node.child("Name").text().get());
    mode.desc = trim(node.child("Desc").text().get());
    auto assign = w.child_number(node, "AssignActivate", 0xFFFF);
    if (!assign) return Unexpected(assign.error());
    mode.assign_activate = static_cast<std::uint16_t>(*assign);
    for (auto [name, field] : {std::pair{"CycleTimeSync0", &mode.cycle_time_sync0},
                               std::pair{"ShiftTimeSync0", &mode.shift_time_sync0},
                               std::pair{"CycleTimeSync1", &mode.cycle_time_sync1},
                               std::pair{"ShiftTimeSync1", &mode.shift_time_sync1}}) {
      auto time = read_dc_time(w, node, name);
      if (!time) return Unexpected(time.error());
      *field = *time;
    }
    out.push_back(std::move(mode));
  }
  return out;
}

// An optional HexDecValue attribute of at most 32 bits.
Result<std::optional<std::uint32_t>> attribute_u32(const Walker& w, const pugi::xml_node& node,
                                                   const char* name) {
  auto v = w.attribute_number(node, name, 0xFFFFFFFF);
  if (!v) return Unexpected(v.error());
  if (!*v) return std::optional<std::uint32_t>();
  return std::optional<std::uint32_t>(static_cast<std::uint32_t>(**v));
}

Result<EsiSlots> read_slots(const Walker& w, const pugi::xml_node& node) {
  EsiSlots slots;
  slots.line = w.line(node);
  for (auto [name, field] : {std::pair{"MaxSlotCount", &slots.max_slot_count},
                             std::pair{"SlotPdoIncrement", &slots.pdo_increment},
                             std::pair{"SlotIndexIncrement", &slots.index_increment}}) {
    auto v = attribute_u32(w, node, name);
    if (!v) return Unexpected(v.error());
    *field = *v;
  }
  for (const pugi::xml_node& s : node.children("Slot")) {
    EsiSlot slot;
    slot.line = w.line(s);
    slot.name = trim(s.child("Name").text().get());
    for (auto [name, field] : {std::pair{"MinInstances", &slot.min_instances},
                               std::pair{"MaxInstances", &slot.max_instances}}) {
      auto v = attribute_u32(w, s, name);
      if (!v) return Unexpected(v.error());
      if (!*v) {
        return Unexpected(Failure{slot.line, fmt::format("<Slot> has no {} (required)", name)});
      }
      *field = **v;
    }
    if (slot.min_instances > slot.max_instances) {
      return Unexpected(Failure{slot.line, fmt::format("<Slot> MinInstances {} exceeds "
                                                       "MaxInstances {}",
                                                       slot.min_instances, slot.max_instances)});
    }
    for (auto [name, field] : {std::pair{"SlotGroup", &slot.slot_group},
                               std::pair{"SlotPdoIncrement", &slot.pdo_increment},
                               std::pair{"SlotIndexIncrement", &slot.index_increment}}) {
      auto v = attribute_u32(w, s, name);
      if (!v) return Unexpected(v.error());
      *field = *v;
    }
    for (const pugi::xml_node& ident : s.children("ModuleIdent")) {
      auto v = w.number(ident.text().get(), ident, "<ModuleIdent>", 0xFFFFFFFF);
      if (!v) return Unexpected(v.error());
      slot.module_idents.push_back(static_cast<std::uint32_t>(*v));
      if (ident.attribute("Default")) {
        // Default is a HexDecValue in the schema: non-zero marks the slot's default module.
        auto d = w.attribute_number(ident, "Default", 0xFFFFFFFF);
        if (!d) return Unexpected(d.error());
        if (**d != 0) slot.default_ident = static_cast<std::uint32_t>(*v);
      }
    }
    for (const pugi::xml_node& c : s.children("ModuleClass")) {
      const std::string_view text = trim(c.child("Class").text().get());
      if (text.empty()) {
        return Unexpected(Failure{w.line(c), "<ModuleClass> has no <Class>"});
      }
      slot.module_classes.emplace_back(text);
    }
    if (slot.module_idents.empty() && slot.module_classes.empty()) {
      return Unexpected(
          Failure{slot.line, "<Slot> names no module (no <ModuleIdent>, no <ModuleClass>)"});
    }
    slots.slots.push_back(std::move(slot));
  }
  return slots;
}

Result<EsiModule> read_module(const Walker& w, const pugi::xml_node& node) {
  EsiModule module;
  module.line = w.line(node);
  const pugi::xml_node type = node.child("Type");
  if (!type) return Unexpected(Failure{module.line, "<Module> has no <Type>"});
  auto ident = w.attribute_number(type, "ModuleIdent", 0xFFFFFFFF);
  if (!ident) return Unexpected(ident.error());
  if (!*ident) return Unexpected(Failure{w.line(type), "<Type> has no ModuleIdent (required)"});
  module.ident = static_cast<std::uint32_t>(**ident);
  module.module_class = trim(type.attribute("ModuleClass").value());
  module.type = trim(type.text().get());
  module.name = trim(node.child("Name").text().get());
  for (const auto& [element, list] :
       {std::pair{"RxPdo", &module.rx_pdos}, std::pair{"TxPdo", &module.tx_pdos}}) {
    for (const pugi::xml_node& p : node.children(element)) {
      auto pdo = read_pdo(w, p);
      if (!pdo) return Unexpected(pdo.error());
      list->push_back(std::move(*pdo));
    }
  }
  module.dc_op_mode_name = trim(node.child("DcOpModeName").text().get());
  return module;
}

Result<EsiDevice> read_device(const Walker& w, const pugi::xml_node& node) {
  EsiDevice device;
  device.line = w.line(node);
  const pugi::xml_node type = node.child("Type");
  if (!type) return Unexpected(Failure{device.line, "<Device> has no <Type>"});
  device.type = trim(type.text().get());
  auto product = w.attribute_number(type, "ProductCode", 0xFFFFFFFF);
  if (!product) return Unexpected(product.error());
  if (!*product) return Unexpected(Failure{w.line(type), "<Type> has no ProductCode"});
  device.product_code = static_cast<std::uint32_t>(**product);
  auto revision = w.attribute_number(type, "RevisionNo", 0xFFFFFFFF);
  if (!revision) return Unexpected(revision.error());
  device.revision_number = static_cast<std::uint32_t>(revision->value_or(0));
  device.name = trim(node.child("Name").text().get());
  if (const pugi::xml_node coe = node.child("Mailbox").child("CoE")) {
    EsiCoe c;
    for (auto [attribute, field] :
         {std::pair{"SdoInfo", &c.sdo_info}, std::pair{"PdoAssign", &c.pdo_assign},
          std::pair{"PdoConfig", &c.pdo_config}, std::pair{"CompleteAccess", &c.complete_access}}) {
      auto v = w.flag(coe, attribute);
      if (!v) return Unexpected(v.error());
      *field = *v;
    }
    device.coe = c;
  }
  for (const pugi::xml_node& sm : node.children("Sm")) {
    EsiSyncManager s;
    s.line = w.line(sm);
    s.type = trim(sm.text().get());
    auto start = w.attribute_number(sm, "StartAddress", 0xFFFF);
    if (!start) return Unexpected(start.error());
    if (*start) s.start_address = static_cast<std::uint16_t>(**start);
    auto size = w.attribute_number(sm, "DefaultSize", 0xFFFF);
    if (!size) return Unexpected(size.error());
    if (*size) s.default_size = static_cast<std::uint16_t>(**size);
    auto control = w.attribute_number(sm, "ControlByte", 0xFF);
    if (!control) return Unexpected(control.error());
    if (*control) s.control_byte = static_cast<std::uint8_t>(**control);
    auto enable = w.attribute_number(sm, "Enable", 0xFF);
    if (!enable) return Unexpected(enable.error());
    s.enable = enable->value_or(0) != 0;
    device.sync_managers.push_back(std::move(s));
  }
  for (const auto& [element, list] :
       {std::pair{"RxPdo", &device.rx_pdos}, std::pair{"TxPdo", &device.tx_pdos}}) {
    for (const pugi::xml_node& p : node.children(element)) {
      auto pdo = read_pdo(w, p);
      if (!pdo) return Unexpected(pdo.error());
      list->push_back(std::move(*pdo));
    }
  }
  if (const pugi::xml_node dc = node.child("Dc")) {
    auto modes = read_dc(w, dc);
    if (!modes) return Unexpected(modes.error());
    device.dc_op_modes = std::move(*modes);
  }
  if (const pugi::xml_node slots = node.child("Slots")) {
    auto read = read_slots(w, slots);
    if (!read) return Unexpected(read.error());
    device.slots = std::move(*read);
  }
  const pugi::xml_node profile = node.child("Profile");
  if (const pugi::xml_node file = profile.child("DictionaryFile")) {
    return Unexpected(Failure{w.line(file),
                              "<DictionaryFile>: an external dictionary is not read (put the "
                              "<Dictionary> into the ESI)"});
  }
  if (const pugi::xml_node dictionary = profile.child("Dictionary")) {
    auto types = read_data_types(w, dictionary);
    if (!types) return Unexpected(types.error());
    for (const pugi::xml_node& o : dictionary.child("Objects").children("Object")) {
      auto object = read_object(w, *types, o);
      if (!object) return Unexpected(object.error());
      if (device.find(object->index) != nullptr) {
        return Unexpected(
            Failure{object->line, fmt::format("<Object> {:04X}h is there twice", object->index)});
      }
      device.objects.push_back(std::move(*object));
    }
  }
  return device;
}

}  // namespace

std::string_view to_string(EsiAccess access) {
  switch (access) {
    case EsiAccess::ro:
      return "ro";
    case EsiAccess::rw:
      return "rw";
    case EsiAccess::wo:
      return "wo";
  }
  return "?";
}

const EsiObject* EsiDevice::find(std::uint16_t index) const {
  for (const EsiObject& o : objects) {
    if (o.index == index) return &o;
  }
  return nullptr;
}

const EsiSubItem* EsiDevice::find(std::uint16_t index, std::uint8_t sub) const {
  const EsiObject* o = find(index);
  if (o == nullptr) return nullptr;
  for (const EsiSubItem& e : o->entries) {
    if (e.sub_index == sub) return &e;
  }
  return nullptr;
}

const EsiModule* EsiFile::find_module(std::uint32_t ident) const {
  for (const EsiModule& m : modules) {
    if (m.ident == ident) return &m;
  }
  return nullptr;
}

std::vector<const EsiPdo*> EsiDevice::default_rx_assignment() const {
  std::vector<const EsiPdo*> out;
  for (const EsiPdo& p : rx_pdos) {
    if (p.sm) out.push_back(&p);
  }
  return out;
}

std::vector<const EsiPdo*> EsiDevice::default_tx_assignment() const {
  std::vector<const EsiPdo*> out;
  for (const EsiPdo& p : tx_pdos) {
    if (p.sm) out.push_back(&p);
  }
  return out;
}

Expected<EsiFile, TextError> read_esi(std::string_view text, const std::string& file) {
  const Lines lines(text);
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed =
      doc.load_buffer(text.data(), text.size(), pugi::parse_default, pugi::encoding_utf8);
  if (!parsed) {
    return Unexpected(TextError{file, lines.at(parsed.offset),
                                fmt::format("not well-formed XML: {}", parsed.description())});
  }
  const Walker w(lines);
  const pugi::xml_node root = doc.child("EtherCATInfo");
  if (!root) {
    const pugi::xml_node first = doc.first_child();
    return Unexpected(TextError{file, first ? w.line(first) : 1,
                                "no <EtherCATInfo> root element: not an ESI (ETG.2000)"});
  }
  EsiFile esi;
  esi.file = file;
  const pugi::xml_node vendor = root.child("Vendor");
  if (!vendor) return Unexpected(TextError{file, w.line(root), "<EtherCATInfo> has no <Vendor>"});
  auto id = w.child_number(vendor, "Id", 0xFFFFFFFF);
  if (!id) return Unexpected(TextError{file, id.error().line, id.error().message});
  esi.vendor_id = static_cast<std::uint32_t>(*id);
  esi.vendor_name = trim(vendor.child("Name").text().get());
  const pugi::xml_node devices = root.child("Descriptions").child("Devices");
  for (const pugi::xml_node& node : devices.children("Device")) {
    auto device = read_device(w, node);
    if (!device) return Unexpected(TextError{file, device.error().line, device.error().message});
    esi.devices.push_back(std::move(*device));
  }
  for (const pugi::xml_node& node :
       root.child("Descriptions").child("Modules").children("Module")) {
    auto module = read_module(w, node);
    if (!module) return Unexpected(TextError{file, module.error().line, module.error().message});
    if (esi.find_module(module->ident) != nullptr) {
      return Unexpected(TextError{
          file, module->line,
          fmt::format("<Module> with ModuleIdent {:08X}h is there twice", module->ident)});
    }
    esi.modules.push_back(std::move(*module));
  }
  if (esi.devices.empty()) {
    return Unexpected(TextError{file, w.line(root),
                                "no <Descriptions>/<Devices>/<Device>: the ESI describes no "
                                "device"});
  }
  return esi;
}

Expected<EsiFile, TextError> read_esi_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Unexpected(TextError{path, 0, "cannot open the file"});
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Unexpected(TextError{path, 0, "cannot read the file"});
  return read_esi(text.str(), path);
}

const EsiDevice* find_esi_device(const EsiFile& esi, std::optional<std::uint32_t> product_code,
                                 std::optional<std::uint32_t> revision) {
  if (!product_code) return esi.devices.size() == 1 ? &esi.devices.front() : nullptr;
  const EsiDevice* same_product = nullptr;
  for (const EsiDevice& d : esi.devices) {
    if (d.product_code != *product_code) continue;
    if (revision && d.revision_number == *revision) return &d;
    if (same_product == nullptr) same_product = &d;
  }
  return same_product;
}

std::string esi_hex_binary(std::uint64_t value, unsigned bytes) {
  std::string out;
  for (unsigned i = 0; i < bytes; ++i)
    out += fmt::format("{:02X}", static_cast<unsigned>((value >> (8 * i)) & 0xFFu));
  return out;
}

}  // namespace drivecheck::ethercat

#include "protocol/cia306/eds_lint.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <set>

namespace drivecheck::cia306 {
namespace {

constexpr LintRule kLintRules[] = {
#define DRIVECHECK_EDS_LINT_RULE(id, severity, clause, what) {id, Severity::severity, clause, what},
#include "protocol/cia306/eds_lint_rules.inc"
#undef DRIVECHECK_EDS_LINT_RULE
};
constexpr LintRule kReaderRule{
    "reader", Severity::warning, "CiA 306 (sections, keys and value syntax of an EDS/DCF)",
    "the file's syntax needs no tolerance (e.g. hex without 0x, TRUE/FALSE, empty values)"};

using cia301::AccessType;
using cia301::DataType;

// One entry as the device would have it (CompactSubObj expanded).
struct EntryView {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  const EntryKeys* keys = nullptr;  // nullptr: the implicit sub 0 of CompactSubObj
  std::optional<DataType> type;
  std::optional<AccessType> access;
  bool pdo = false;
  std::optional<std::string> default_text;
  std::optional<std::string> value_text;  // DCF ParameterValue / [xxxxValue]
  int line = 0;                           // the section (or the object's, for compact)
  int default_line = 0;
  int value_line = 0;
};

struct KnownType {
  std::uint16_t first, last;  // index range
  int sub;                    // -1: every sub-index >= 1
  DataType type;
};

// CiA 301 §7.5.2: the data types of the communication objects drivecheck relies on.
constexpr KnownType kKnownTypes[] = {
    {0x1000, 0x1000, 0, DataType::unsigned32},     {0x1001, 0x1001, 0, DataType::unsigned8},
    {0x1002, 0x1002, 0, DataType::unsigned32},     {0x1003, 0x1003, -1, DataType::unsigned32},
    {0x1005, 0x1005, 0, DataType::unsigned32},     {0x1006, 0x1006, 0, DataType::unsigned32},
    {0x1007, 0x1007, 0, DataType::unsigned32},     {0x1008, 0x1008, 0, DataType::visible_string},
    {0x1009, 0x1009, 0, DataType::visible_string}, {0x100A, 0x100A, 0, DataType::visible_string},
    {0x100C, 0x100C, 0, DataType::unsigned16},     {0x100D, 0x100D, 0, DataType::unsigned8},
    {0x1010, 0x1011, -1, DataType::unsigned32},    {0x1012, 0x1013, 0, DataType::unsigned32},
    {0x1014, 0x1014, 0, DataType::unsigned32},     {0x1015, 0x1015, 0, DataType::unsigned16},
    {0x1016, 0x1016, -1, DataType::unsigned32},    {0x1017, 0x1017, 0, DataType::unsigned16},
    {0x1018, 0x1018, -1, DataType::unsigned32},    {0x1019, 0x1019, 0, DataType::unsigned8},
    {0x1200, 0x127F, 1, DataType::unsigned32},     {0x1200, 0x127F, 2, DataType::unsigned32},
    {0x1200, 0x127F, 3, DataType::unsigned8},      {0x1400, 0x15FF, 1, DataType::unsigned32},
    {0x1400, 0x15FF, 2, DataType::unsigned8},      {0x1400, 0x15FF, 3, DataType::unsigned16},
    {0x1400, 0x15FF, 5, DataType::unsigned16},     {0x1600, 0x17FF, -1, DataType::unsigned32},
    {0x1800, 0x19FF, 1, DataType::unsigned32},     {0x1800, 0x19FF, 2, DataType::unsigned8},
    {0x1800, 0x19FF, 3, DataType::unsigned16},     {0x1800, 0x19FF, 5, DataType::unsigned16},
    {0x1800, 0x19FF, 6, DataType::unsigned8},      {0x1A00, 0x1BFF, -1, DataType::unsigned32},
};

class Linter {
 public:
  Linter(const Eds& eds, const std::string& file) : eds_(eds), file_(file) {}

  std::vector<Diagnostic> run() {
    build_views();
    check_mandatory();
    check_lists();
    check_structures();
    check_entries();
    check_pdos();
    check_dummy_usage();
    check_device_info();
    check_file_info();
    check_dcf();
    std::stable_sort(out_.begin(), out_.end(), [](const Diagnostic& a, const Diagnostic& b) {
      return a.where.line < b.where.line;
    });
    return std::move(out_);
  }

 private:
  void report(Severity s, int line, std::string_view id, std::string message) {
    out_.push_back({s, std::string(id), TextError{file_, line, std::move(message)}});
  }
  void error(int line, std::string_view id, std::string message) {
    report(Severity::error, line, id, std::move(message));
  }
  void warning(int line, std::string_view id, std::string message) {
    report(Severity::warning, line, id, std::move(message));
  }

  static EntryView view_of(std::uint16_t index, std::uint8_t sub, const EntryKeys& k) {
    EntryView v;
    v.index = index;
    v.sub = sub;
    v.keys = &k;
    v.type = k.basic_type();
    v.access = k.access_type;
    v.pdo = k.pdo_mapping;
    v.default_text = k.default_value;
    v.value_text = k.parameter_value;
    v.line = k.lines.section;
    v.default_line = k.lines.at("defaultvalue");
    v.value_line = k.lines.at("parametervalue");
    return v;
  }

  void build_views() {
    for (const auto& o : eds_.objects) {
      if (o.keys.object_type == cia301::ObjectCode::null_object) continue;
      if (!cia301::has_sub_entries(o.keys.object_type)) {
        views_[{o.index, 0}] = view_of(o.index, 0, o.keys);
      } else if (o.compact_sub_obj) {
        EntryView count;
        count.index = o.index;
        count.type = DataType::unsigned8;
        count.access = AccessType::ro;
        count.default_text = fmt::format("{}", *o.compact_sub_obj);
        count.line = count.default_line = count.value_line = o.keys.lines.section;
        views_[{o.index, 0}] = count;
        for (unsigned sub = 1; sub <= *o.compact_sub_obj; ++sub) {
          auto v = view_of(o.index, static_cast<std::uint8_t>(sub), o.keys);
          v.value_text.reset();
          for (const auto& item : o.values) {
            if (item.sub_index == sub) {
              v.value_text = item.text;
              v.value_line = item.line;
            }
          }
          views_[{o.index, static_cast<std::uint8_t>(sub)}] = v;
        }
      } else {
        for (const auto& s : o.subs)
          views_[{o.index, s.sub_index}] = view_of(o.index, s.sub_index, s.keys);
      }
    }
  }

  const EntryView* view(std::uint16_t index, std::uint8_t sub) const {
    const auto it = views_.find({index, sub});
    return it == views_.end() ? nullptr : &it->second;
  }

  // The value of a text for node-IDs 1 and 127 (both when $NODEID is used), or nothing when
  // it does not parse (the reader reported that).
  std::vector<cia301::Value> values(const std::optional<std::string>& text,
                                    std::optional<DataType> type) const {
    if (!text || !type || text->empty()) return {};
    const auto parsed = cia301::parse_value_text(*type, *text);
    if (!parsed) return {};
    std::vector<cia301::Value> out;
    for (const std::uint8_t node : {std::uint8_t{1}, std::uint8_t{127}}) {
      auto v = cia301::resolve(*type, *parsed, node);
      if (v) out.push_back(std::move(*v));
      if (!parsed->node_id_relative) break;
    }
    return out;
  }

  std::optional<std::uint64_t> unsigned_value(const std::optional<std::string>& text,
                                              std::optional<DataType> type) const {
    const auto v = values(text, type);
    if (v.empty() || v[0].kind() != cia301::Value::Kind::unsigned_integer) return std::nullopt;
    return v[0].as_unsigned();
  }

  // <0, 0, >0 like a three-way compare; nullopt for values of other kinds or NaN.
  static std::optional<int> compare(const cia301::Value& a, const cia301::Value& b) {
    if (a.kind() != b.kind()) return std::nullopt;
    switch (a.kind()) {
      case cia301::Value::Kind::unsigned_integer:
        return a.as_unsigned() < b.as_unsigned() ? -1 : (a.as_unsigned() > b.as_unsigned() ? 1 : 0);
      case cia301::Value::Kind::signed_integer:
        return a.as_signed() < b.as_signed() ? -1 : (a.as_signed() > b.as_signed() ? 1 : 0);
      case cia301::Value::Kind::real:
        if (a.as_real() < b.as_real()) return -1;
        if (a.as_real() > b.as_real()) return 1;
        if (a.as_real() == b.as_real()) return 0;
        return std::nullopt;
      default:
        return std::nullopt;
    }
  }

  static std::string describe(const EntryView& v) {
    return v.sub == 0 && !v.keys ? fmt::format("{:04X}h sub 0", v.index)
                                 : fmt::format("{:04X}h sub {}", v.index, v.sub);
  }

  void check_mandatory() {
    for (const std::uint16_t index : {0x1000, 0x1001, 0x1018}) {
      const auto* o = eds_.find(index);
      if (o == nullptr) {
        error(0, "mandatory-object-missing",
              fmt::format("mandatory object {:04X}h is missing (CiA 301 §7.5.2)", index));
      } else if (o->list != ObjectList::mandatory) {
        warning(o->list_line ? o->list_line : o->keys.lines.section, "mandatory-list",
                fmt::format("mandatory object {:04X}h is listed in [{}], not [MandatoryObjects]",
                            index, section_name(o->list)));
      }
    }
    const bool heartbeat = eds_.find(0x1017) != nullptr;
    const bool guard_time = eds_.find(0x100C) != nullptr;
    const bool life_time = eds_.find(0x100D) != nullptr;
    if (guard_time != life_time) {
      const auto* o = eds_.find(guard_time ? 0x100C : 0x100D);
      error(o->keys.lines.section, "guarding-incomplete",
            fmt::format(
                "{:04X}h without {:04X}h: node guarding needs guard time and life time factor",
                guard_time ? 0x100C : 0x100D, guard_time ? 0x100D : 0x100C));
    }
    if (!heartbeat && !(guard_time && life_time)) {
      error(0, "error-control-missing",
            "no error control: neither 1017h (producer heartbeat time) nor 100Ch/100Dh (node "
            "guarding)");
    }
    if (const auto* identity = eds_.find(0x1018);
        identity != nullptr && view(0x1018, 1) == nullptr) {
      error(identity->keys.lines.section, "identity-vendor-id-missing",
            "1018h has no sub-index 1 (vendor-ID), which CiA 301 makes mandatory");
    }
    const auto& di = eds_.device_info;
    const std::pair<const std::optional<std::uint32_t>*, std::pair<std::uint8_t, std::string_view>>
        ids[] = {{&di.vendor_number, {1, "VendorNumber"}},
                 {&di.product_number, {2, "ProductNumber"}},
                 {&di.revision_number, {3, "RevisionNumber"}}};
    for (const auto& [field, what] : ids) {
      const auto* v = view(0x1018, what.first);
      if (v == nullptr || !*field) continue;
      const auto value = unsigned_value(v->default_text, v->type);
      if (value && *value != **field) {
        warning(di.lines.at(detail_lower(what.second)), "identity-mismatch",
                fmt::format("[DeviceInfo] {}=0x{:X} but 1018h sub {} defaults to 0x{:X}",
                            what.second, **field, what.first, *value));
      }
    }
  }

  static std::string detail_lower(std::string_view s) {
    std::string out(s);
    for (auto& c : out) {
      if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
    }
    return out;
  }

  void check_lists() {
    for (const auto& o : eds_.objects) {
      const int line = o.list_line ? o.list_line : o.keys.lines.section;
      const bool manufacturer_area = o.index >= 0x2000 && o.index <= 0x5FFF;
      const bool mandatory = o.index == 0x1000 || o.index == 0x1001 || o.index == 0x1018;
      if (o.list == ObjectList::manufacturer && !manufacturer_area) {
        warning(
            line, "wrong-object-list",
            fmt::format("{:04X}h is listed in [ManufacturerObjects] but lies outside 2000h-5FFFh",
                        o.index));
      } else if (o.list != ObjectList::manufacturer && manufacturer_area) {
        warning(
            line, "wrong-object-list",
            fmt::format("{:04X}h lies in the manufacturer area 2000h-5FFFh but is listed in [{}]",
                        o.index, section_name(o.list)));
      } else if (o.list == ObjectList::mandatory && !mandatory) {
        warning(line, "mandatory-list",
                fmt::format(
                    "{:04X}h is not a CiA 301 mandatory object but is listed in [MandatoryObjects]",
                    o.index));
      }
    }
  }

  void check_structures() {
    for (const auto& o : eds_.objects) {
      if (!cia301::has_sub_entries(o.keys.object_type)) continue;
      const EntryView* sub0 = view(o.index, 0);
      std::uint8_t highest = 0;
      std::optional<DataType> element;
      bool mixed = false;
      const auto first = views_.lower_bound({o.index, std::uint8_t{1}});
      const auto last = views_.upper_bound({o.index, std::uint8_t{0xFF}});
      for (auto it = first; it != last; ++it) {
        const auto& [key, v] = *it;
        highest = std::max(highest, key.second);
        if (o.keys.object_type == cia301::ObjectCode::array && v.type) {
          if (element && *element != *v.type) mixed = true;
          element = v.type;
        }
      }
      if (mixed) {
        error(o.keys.lines.section, "array-mixed-types",
              fmt::format("ARRAY {:04X}h has sub-objects of different data types", o.index));
      }
      if (sub0 == nullptr) continue;  // the reader reported it
      if (sub0->type && *sub0->type != DataType::unsigned8) {
        error(sub0->keys ? sub0->keys->lines.at("datatype") : sub0->line, "sub0-data-type",
              fmt::format("{:04X}h sub 0 is {}, CiA 301 makes it UNSIGNED8", o.index,
                          cia301::info(*sub0->type).name));
        continue;
      }
      const auto count = unsigned_value(sub0->default_text, DataType::unsigned8);
      if (!count || !sub0->access) continue;
      if (cia301::is_writable(*sub0->access)) {
        if (*count > highest) {
          error(sub0->default_line, "sub0-inconsistent",
                fmt::format("{:04X}h sub 0 defaults to {} but the highest sub-index is {}", o.index,
                            *count, highest));
        }
      } else if (*count != highest) {
        error(sub0->default_line, "sub0-inconsistent",
              fmt::format(
                  "{:04X}h sub 0 (highest sub-index supported) defaults to {} but the highest "
                  "sub-index is {}",
                  o.index, *count, highest));
      }
    }
  }

  void check_entries() {
    for (const auto& [key, v] : views_) {
      if (v.keys == nullptr || !v.type) continue;
      const auto& k = *v.keys;
      const bool numeric = cia301::is_numeric(*v.type);
      if (!numeric && (k.low_limit || k.high_limit)) {
        warning(k.lines.at(k.low_limit ? "lowlimit" : "highlimit"), "limits-on-non-numeric",
                fmt::format("{} has limits but is {}", describe(v), cia301::info(*v.type).name));
      }
      if (v.pdo && cia301::is_variable_length(*v.type)) {
        warning(k.lines.at("pdomapping"), "mappable-variable-length",
                fmt::format("{} is {} but PDOMapping=1", describe(v), cia301::info(*v.type).name));
      }
      for (const auto& known : kKnownTypes) {
        const bool sub_match = known.sub == -1 ? key.second >= 1 : key.second == known.sub;
        if (key.first >= known.first && key.first <= known.last && sub_match &&
            *v.type != known.type) {
          error(k.lines.at("datatype"), "data-type-mismatch",
                fmt::format("{} is {}, CiA 301 defines it as {}", describe(v),
                            cia301::info(*v.type).name, cia301::info(known.type).name));
        }
      }
      if ((key.first == 0x1000 || key.first == 0x1001 ||
           (key.first == 0x1018 && key.second >= 1)) &&
          v.access && cia301::is_writable(*v.access)) {
        error(k.lines.at("accesstype"), "access-type-mismatch",
              fmt::format("{} is {}, CiA 301 makes it read-only", describe(v),
                          cia301::to_string(*v.access)));
      }
      if (!numeric) continue;
      const auto low = values(k.low_limit, v.type);
      const auto high = values(k.high_limit, v.type);
      if (!low.empty() && !high.empty()) {
        const auto c = compare(low.front(), high.back());
        if (c && *c > 0) {
          error(k.lines.at("lowlimit"), "limits-inverted",
                fmt::format("{} LowLimit {} is above HighLimit {}", describe(v), *k.low_limit,
                            *k.high_limit));
          continue;
        }
      }
      check_range(v, v.default_text, v.default_line, "DefaultValue", "default-out-of-range", low,
                  high);
      check_range(v, v.value_text, v.value_line, "ParameterValue", "value-out-of-range", low, high);
    }
  }

  void check_range(const EntryView& v, const std::optional<std::string>& text, int line,
                   std::string_view what, std::string_view id,
                   const std::vector<cia301::Value>& low, const std::vector<cia301::Value>& high) {
    for (const auto& value : values(text, v.type)) {
      for (const auto& l : low) {
        const auto c = compare(value, l);
        if (c && *c < 0) {
          error(line, id,
                fmt::format("{} {} '{}' is below LowLimit '{}'", describe(v), what, *text,
                            *v.keys->low_limit));
          return;
        }
      }
      for (const auto& h : high) {
        const auto c = compare(value, h);
        if (c && *c > 0) {
          error(line, id,
                fmt::format("{} {} '{}' is above HighLimit '{}'", describe(v), what, *text,
                            *v.keys->high_limit));
          return;
        }
      }
    }
  }

  void check_pdos() {
    std::uint32_t rx = 0;
    std::uint32_t tx = 0;
    for (const auto& o : eds_.objects) {
      const bool rx_comm = o.index >= 0x1400 && o.index <= 0x15FF;
      const bool tx_comm = o.index >= 0x1800 && o.index <= 0x19FF;
      const bool rx_map = o.index >= 0x1600 && o.index <= 0x17FF;
      const bool tx_map = o.index >= 0x1A00 && o.index <= 0x1BFF;
      rx += rx_comm ? 1 : 0;
      tx += tx_comm ? 1 : 0;
      if (rx_comm || tx_comm || rx_map || tx_map) {
        const std::uint16_t partner = (rx_comm || tx_comm) ? o.index + 0x200 : o.index - 0x200;
        if (eds_.find(partner) == nullptr) {
          error(o.keys.lines.section, "pdo-without-communication",
                fmt::format("{} {:04X}h has no {} object {:04X}h",
                            (rx_comm || tx_comm) ? "PDO communication" : "PDO mapping", o.index,
                            (rx_comm || tx_comm) ? "mapping" : "communication", partner));
        }
      }
      if (rx_map || tx_map) check_mapping(o, rx_map);
    }
    const auto& di = eds_.device_info;
    const std::tuple<const std::optional<std::uint32_t>*, std::uint32_t, std::string_view,
                     std::string_view>
        counts[] = {{&di.nr_of_rxpdo, rx, "NrOfRXPDO", "1400h-15FFh"},
                    {&di.nr_of_txpdo, tx, "NrOfTXPDO", "1800h-19FFh"}};
    for (const auto& [field, actual, key, range] : counts) {
      if (!*field) {
        if (di.lines.section != 0) {
          warning(di.lines.section, "device-info-missing-key",
                  fmt::format("[DeviceInfo] has no {}", key));
        }
      } else if (**field != actual) {
        error(di.lines.at(detail_lower(key)), "pdo-count-mismatch",
              fmt::format("[DeviceInfo] {}={} but {} PDO communication objects ({}) exist", key,
                          **field, actual, range));
      }
    }
  }

  void check_mapping(const EdsObject& o, bool rpdo) {
    const EntryView* sub0 = view(o.index, 0);
    if (sub0 == nullptr) return;
    const auto count = unsigned_value(sub0->value_text ? sub0->value_text : sub0->default_text,
                                      DataType::unsigned8);
    if (!count) return;
    std::uint32_t bits = 0;
    const std::string_view pdo = rpdo ? "RPDO" : "TPDO";
    for (std::uint64_t sub = 1; sub <= *count; ++sub) {
      const EntryView* e = view(o.index, static_cast<std::uint8_t>(sub));
      if (e == nullptr) {
        error(sub0->default_line, "pdo-mapping-entry-missing",
              fmt::format("{:04X}h sub 0 maps {} entries but sub-index {} does not exist", o.index,
                          *count, sub));
        continue;
      }
      const auto& text = e->value_text ? e->value_text : e->default_text;
      const int line = e->value_text ? e->value_line : e->default_line;
      const auto value = unsigned_value(text, DataType::unsigned32);
      if (!value) continue;
      const auto index = static_cast<std::uint16_t>(*value >> 16);
      const auto target_sub = static_cast<std::uint8_t>((*value >> 8) & 0xFF);
      const auto length = static_cast<std::uint32_t>(*value & 0xFF);
      bits += length;
      const std::string where =
          fmt::format("{} mapping {:04X}h sub {} (0x{:08X})", pdo, o.index, sub, *value);
      if (*value == 0) {
        error(line, "pdo-mapping-target-missing",
              fmt::format("{} maps nothing but is counted by sub 0", where));
        continue;
      }
      if (index >= 0x0001 && index <= 0x0007) {
        const auto type = *cia301::find_data_type(index);
        if (!eds_.dummy_usage[index].value_or(false)) {
          error(line, "pdo-mapping-dummy-disabled",
                fmt::format("{} maps dummy {:04X}h ({}) but [DummyUsage] Dummy{:04X} is not 1",
                            where, index, type.name, index));
        }
        if (length != type.bit_size && !(type.type == DataType::boolean && length == 8)) {
          error(line, "pdo-mapping-length",
                fmt::format("{} gives {} bits for {} ({} bits)", where, length, type.name,
                            type.bit_size));
        }
        continue;
      }
      const EntryView* target = view(index, target_sub);
      if (target == nullptr) {
        error(
            line, "pdo-mapping-target-missing",
            fmt::format("{} names {:04X}h sub {}, which does not exist", where, index, target_sub));
        continue;
      }
      if (!target->pdo) {
        error(line, "pdo-mapping-not-mappable",
              fmt::format("{} names {:04X}h sub {}, which has PDOMapping=0", where, index,
                          target_sub));
      }
      if (target->type) {
        const auto& ti = cia301::info(*target->type);
        const bool fits = ti.bit_size != 0 &&
                          (length == ti.bit_size || (ti.type == DataType::boolean && length == 8));
        if (!fits) {
          error(line, "pdo-mapping-length",
                fmt::format("{} gives {} bits, {:04X}h sub {} is {} ({} bits)", where, length,
                            index, target_sub, ti.name, ti.bit_size));
        }
      }
      if (target->access) {
        const auto a = *target->access;
        if (rpdo && !cia301::is_writable(a)) {
          error(line, "pdo-mapping-direction",
                fmt::format("{} names {:04X}h sub {}, which is {}: an RPDO cannot write it", where,
                            index, target_sub, cia301::to_string(a)));
        } else if (!rpdo && !cia301::is_readable(a)) {
          error(line, "pdo-mapping-direction",
                fmt::format("{} names {:04X}h sub {}, which is wo: a TPDO cannot read it", where,
                            index, target_sub));
        } else if ((rpdo && a == AccessType::rwr) || (!rpdo && a == AccessType::rww)) {
          warning(line, "pdo-mapping-direction-hint",
                  fmt::format("{} names {:04X}h sub {}, which is {} (meant for {})", where, index,
                              target_sub, cia301::to_string(a), rpdo ? "TPDOs" : "RPDOs"));
        }
      }
    }
    if (bits > 64) {
      error(sub0->default_line, "pdo-mapping-too-long",
            fmt::format("{} mapping {:04X}h maps {} bits, more than the 64 of a CAN frame", pdo,
                        o.index, bits));
    }
  }

  // [DummyUsage] against the rest of the file (CiA 306 [DummyUsage], [DeviceInfo] Granularity;
  // CiA 301 §7.5.2.36: a dummy entry is an RPDO mapping entry): a declared dummy that the
  // mapping granularity cannot place, or that no RPDO can ever map.
  void check_dummy_usage() {
    const auto& di = eds_.device_info;
    bool any_rpdo = false;
    std::array<bool, 8> in_default_rpdo{};
    for (const auto& o : eds_.objects) {
      if (o.index < 0x1600 || o.index > 0x17FF) continue;
      any_rpdo = true;
      for (const auto& sub : o.subs) {
        if (sub.sub_index == 0) continue;
        const auto& text =
            sub.keys.parameter_value ? sub.keys.parameter_value : sub.keys.default_value;
        const auto value = unsigned_value(text, DataType::unsigned32);
        if (!value) continue;
        const auto index = *value >> 16;
        if (index >= 1 && index <= 7) in_default_rpdo[index] = true;
      }
    }
    for (std::uint16_t type = 1; type <= 7; ++type) {
      if (!eds_.dummy_usage[type].value_or(false)) continue;
      const int line = eds_.dummy_usage_lines.at(fmt::format("dummy{:04x}", type));
      const auto info = *cia301::find_data_type(type);
      if (di.granularity && *di.granularity > 0 && *di.granularity <= 64 &&
          info.bit_size % *di.granularity != 0) {
        error(line, "dummy-usage-granularity",
              fmt::format("[DummyUsage] Dummy{:04X}=1 declares the {}-bit dummy {:04X}h ({}) but "
                          "[DeviceInfo] Granularity={} maps in steps of {} bits: it cannot be "
                          "mapped",
                          type, info.bit_size, type, info.name, *di.granularity, *di.granularity));
      }
      if (!any_rpdo) {
        warning(line, "dummy-usage-unusable",
                fmt::format("[DummyUsage] Dummy{:04X}=1 but the file describes no RPDO mapping "
                            "(1600h-17FFh): a dummy is an RPDO mapping entry",
                            type));
      } else if (di.granularity && *di.granularity == 0 && !in_default_rpdo[type]) {
        warning(line, "dummy-usage-unusable",
                fmt::format("[DummyUsage] Dummy{:04X}=1 but [DeviceInfo] Granularity=0 (the "
                            "mapping cannot be changed) and no default RPDO mapping holds "
                            "{:04X}h: no RPDO can map it",
                            type, type));
      }
    }
  }

  void check_device_info() {
    const auto& di = eds_.device_info;
    if (di.lines.section == 0) return;  // the reader reported the missing section
    if (di.granularity && *di.granularity > 64) {
      error(di.lines.at("granularity"), "device-info-range",
            fmt::format("[DeviceInfo] Granularity={} is above 64", *di.granularity));
    }
    const std::pair<bool, std::string_view> required[] = {
        {di.vendor_name.has_value(), "VendorName"}, {di.product_name.has_value(), "ProductName"}};
    for (const auto& [present, key] : required) {
      if (!present)
        warning(di.lines.section, "device-info-missing-key",
                fmt::format("[DeviceInfo] has no {}", key));
    }
    const std::optional<bool> rates[] = {di.baud_rate_10,  di.baud_rate_20,  di.baud_rate_50,
                                         di.baud_rate_125, di.baud_rate_250, di.baud_rate_500,
                                         di.baud_rate_800, di.baud_rate_1000};
    if (std::none_of(std::begin(rates), std::end(rates),
                     [](const auto& r) { return r.value_or(false); })) {
      warning(di.lines.section, "no-baud-rate",
              "[DeviceInfo] declares no supported bit rate (BaudRate_x=1)");
    }
  }

  static bool digits(std::string_view s, std::size_t n) {
    return s.size() == n &&
           std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  }

  void check_file_info() {
    const auto& fi = eds_.file_info;
    if (fi.lines.section == 0) return;
    if (!fi.eds_version) {
      warning(fi.lines.section, "file-info-format", "[FileInfo] has no EDSVersion");
    } else if (*fi.eds_version != "4.0" && *fi.eds_version != "3.0" && *fi.eds_version != "4") {
      warning(fi.lines.at("edsversion"), "file-info-format",
              fmt::format("[FileInfo] EDSVersion '{}' is not 4.0", *fi.eds_version));
    }
    for (const auto& [value, key] : {std::pair{&fi.file_version, "FileVersion"},
                                     std::pair{&fi.file_revision, "FileRevision"}}) {
      if (!*value) continue;
      const auto n = cia301::parse_cia306_unsigned(**value);
      if (!n || *n > 255) {
        warning(fi.lines.at(detail_lower(key)), "file-info-format",
                fmt::format("[FileInfo] {} '{}' is not an UNSIGNED8", key, **value));
      }
    }
    for (const auto& [value, key] : {std::pair{&fi.creation_date, "CreationDate"},
                                     std::pair{&fi.modification_date, "ModificationDate"}}) {
      if (!*value) continue;
      const std::string_view d = **value;
      if (!(d.size() == 10 && digits(d.substr(0, 2), 2) && d[2] == '-' &&
            digits(d.substr(3, 2), 2) && d[5] == '-' && digits(d.substr(6), 4))) {
        warning(fi.lines.at(detail_lower(key)), "file-info-format",
                fmt::format("[FileInfo] {} '{}' is not mm-dd-yyyy", key, d));
      }
    }
    for (const auto& [value, key] : {std::pair{&fi.creation_time, "CreationTime"},
                                     std::pair{&fi.modification_time, "ModificationTime"}}) {
      if (!*value) continue;
      const std::string_view t = **value;
      const bool ok = t.size() == 7 && digits(t.substr(0, 2), 2) && t[2] == ':' &&
                      digits(t.substr(3, 2), 2) &&
                      (t.substr(5) == "AM" || t.substr(5) == "PM" || t.substr(5) == "am" ||
                       t.substr(5) == "pm");
      if (!ok) {
        warning(fi.lines.at(detail_lower(key)), "file-info-format",
                fmt::format("[FileInfo] {} '{}' is not hh:mmAM/PM", key, t));
      }
    }
  }

  void check_dcf() {
    if (!eds_.commissioning) return;
    const auto& c = *eds_.commissioning;
    if (!c.node_id || *c.node_id < 1 || *c.node_id > 127) {
      error(c.lines.at("nodeid"), "dcf-node-id",
            c.node_id ? fmt::format("[DeviceComissioning] NodeID={} is outside 1..127", *c.node_id)
                      : std::string("[DeviceComissioning] has no NodeID"));
    }
    if (c.baudrate) {
      const auto& di = eds_.device_info;
      const std::pair<std::uint32_t, std::optional<bool>> rates[] = {
          {10, di.baud_rate_10},   {20, di.baud_rate_20},    {50, di.baud_rate_50},
          {125, di.baud_rate_125}, {250, di.baud_rate_250},  {500, di.baud_rate_500},
          {800, di.baud_rate_800}, {1000, di.baud_rate_1000}};
      const auto it = std::find_if(std::begin(rates), std::end(rates),
                                   [&](const auto& r) { return r.first == *c.baudrate; });
      if (it == std::end(rates)) {
        error(c.lines.at("baudrate"), "dcf-baudrate",
              fmt::format("[DeviceComissioning] Baudrate={} is not a CiA 301 bit rate in kbit/s",
                          *c.baudrate));
      } else if (!it->second.value_or(false)) {
        error(c.lines.at("baudrate"), "dcf-baudrate",
              fmt::format("[DeviceComissioning] Baudrate={} but [DeviceInfo] BaudRate_{} is not 1",
                          *c.baudrate, *c.baudrate));
      }
    }
  }

  const Eds& eds_;
  const std::string& file_;
  std::map<std::pair<std::uint16_t, std::uint8_t>, EntryView> views_;
  std::vector<Diagnostic> out_;
};

}  // namespace

std::span<const LintRule> lint_rules() {
  return kLintRules;
}

const LintRule& reader_rule() {
  return kReaderRule;
}

std::vector<Diagnostic> lint_eds(const Eds& eds, const std::string& file) {
  return Linter(eds, file).run();
}

std::vector<Diagnostic> lint_eds_text(std::string_view text, const std::string& file) {
  auto read = read_eds(text, file);
  auto out = std::move(read.diagnostics);
  auto more = lint_eds(read.eds, file);
  out.insert(out.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
  std::stable_sort(out.begin(), out.end(), [](const Diagnostic& a, const Diagnostic& b) {
    return a.where.line < b.where.line;
  });
  return out;
}

Expected<std::vector<Diagnostic>, TextError> lint_eds_file(const std::string& path) {
  auto read = read_eds_file(path);
  if (!read) return Unexpected(read.error());
  auto out = std::move(read->diagnostics);
  auto more = lint_eds(read->eds, path);
  out.insert(out.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
  std::stable_sort(out.begin(), out.end(), [](const Diagnostic& a, const Diagnostic& b) {
    return a.where.line < b.where.line;
  });
  return out;
}

}  // namespace drivecheck::cia306

// EDS/DCF model <-> CiA 301 object dictionary.
#include <fmt/format.h>

#include "protocol/cia306/eds.hpp"

namespace drivecheck::cia306 {
namespace {

using cia301::DataType;

class Builder {
 public:
  Builder(const Eds& eds, std::uint8_t node_id, const std::string& file)
      : eds_(eds), node_id_(node_id), file_(file) {}

  Expected<cia301::ObjectDictionary, std::vector<Diagnostic>> run() {
    if (node_id_ == 0 && eds_.commissioning && eds_.commissioning->node_id &&
        *eds_.commissioning->node_id >= 1 && *eds_.commissioning->node_id <= 127) {
      node_id_ = static_cast<std::uint8_t>(*eds_.commissioning->node_id);
    }
    cia301::ObjectDictionary od(node_id_ == 0 ? 1 : node_id_);
    for (const auto& object : eds_.objects)
      add(od, object);
    if (!errors_.empty()) return Unexpected(std::move(errors_));
    return od;
  }

 private:
  void error(int line, std::string message) {
    errors_.push_back({Severity::error, "dictionary", TextError{file_, line, std::move(message)}});
  }

  // A value text for an entry, or nullopt (reported) when it cannot be used.
  std::optional<cia301::ValueText> value_text(const std::string& text, DataType type, int line,
                                              std::string_view what) {
    if (text.empty() && cia301::is_numeric(type)) return cia301::ValueText{};
    auto parsed = cia301::parse_value_text(type, text);
    if (!parsed) {
      error(line, fmt::format("{} '{}': {}", what, text, parsed.error()));
      return std::nullopt;
    }
    if (parsed->node_id_relative && node_id_ == 0) {
      error(line, fmt::format("{} '{}' needs a node-ID (none given, no DCF NodeID)", what, text));
      return std::nullopt;
    }
    return std::move(*parsed);
  }

  std::optional<cia301::Value> resolved(const std::optional<std::string>& text, DataType type,
                                        int line, std::string_view what) {
    if (!text) return cia301::Value();
    auto vt = value_text(*text, type, line, what);
    if (!vt) return std::nullopt;
    auto v = cia301::resolve(type, *vt, node_id_);
    if (!v) {
      error(line, fmt::format("{} '{}': {}", what, *text, v.error()));
      return std::nullopt;
    }
    return std::move(*v);
  }

  std::optional<cia301::EntryDefinition> entry(const EntryKeys& k, std::uint8_t sub,
                                               std::string name) {
    const auto type = k.basic_type();
    if (!type) {
      error(k.lines.at("datatype"), fmt::format("{}: no basic DataType", name));
      return std::nullopt;
    }
    if (!k.access_type) {
      error(k.lines.at("accesstype"), fmt::format("{}: no AccessType", name));
      return std::nullopt;
    }
    cia301::EntryDefinition def;
    def.sub_index = sub;
    def.name = std::move(name);
    def.type = *type;
    def.access = *k.access_type;
    def.pdo_mappable = k.pdo_mapping;
    def.obj_flags = k.obj_flags.value_or(0);
    if (k.default_value) {
      auto vt = value_text(*k.default_value, *type, k.lines.at("defaultvalue"), "DefaultValue");
      if (!vt) return std::nullopt;
      def.default_value = vt->value;
      def.default_adds_node_id = vt->node_id_relative;
    }
    auto low = resolved(k.low_limit, *type, k.lines.at("lowlimit"), "LowLimit");
    auto high = resolved(k.high_limit, *type, k.lines.at("highlimit"), "HighLimit");
    if (!low || !high) return std::nullopt;
    def.low_limit = std::move(*low);
    def.high_limit = std::move(*high);
    return def;
  }

  struct CurrentValue {
    std::uint8_t sub;
    cia301::Value value;
    int line;
  };

  void add(cia301::ObjectDictionary& od, const EdsObject& o) {
    cia301::ObjectDefinition def;
    def.index = o.index;
    def.name = o.keys.parameter_name;
    def.code = o.keys.object_type;
    std::vector<CurrentValue> current;
    const auto before = errors_.size();
    auto take_value = [&](const EntryKeys& k, std::uint8_t sub) {
      const auto type = k.basic_type();
      if (!k.parameter_value || !type) return;
      auto v = resolved(k.parameter_value, *type, k.lines.at("parametervalue"), "ParameterValue");
      if (v && !v->empty()) current.push_back({sub, std::move(*v), k.lines.at("parametervalue")});
    };
    if (def.code == cia301::ObjectCode::null_object) {
      // no entries
    } else if (!cia301::has_sub_entries(def.code)) {
      if (auto e = entry(o.keys, 0, o.keys.parameter_name)) def.entries.push_back(std::move(*e));
      take_value(o.keys, 0);
    } else if (o.compact_sub_obj) {
      const std::uint8_t n = *o.compact_sub_obj;
      cia301::EntryDefinition count;
      count.sub_index = 0;
      count.name = "NrOfObjects";
      count.type = DataType::unsigned8;
      count.access = cia301::AccessType::ro;
      count.default_value = cia301::Value::of_unsigned(n);
      def.entries.push_back(std::move(count));
      const auto type = o.keys.basic_type();
      for (unsigned sub = 1; sub <= n; ++sub) {
        std::string name = fmt::format("{}{}", o.keys.parameter_name, sub);
        for (const auto& item : o.names) {
          if (item.sub_index == sub) name = item.text;
        }
        auto e = entry(o.keys, static_cast<std::uint8_t>(sub), std::move(name));
        if (!e) break;
        def.entries.push_back(std::move(*e));
      }
      for (const auto& item : o.values) {
        if (!type) break;
        auto v = resolved(item.text, *type, item.line, "value");
        if (v && !v->empty()) current.push_back({item.sub_index, std::move(*v), item.line});
      }
    } else {
      for (const auto& sub : o.subs) {
        if (auto e = entry(sub.keys, sub.sub_index, sub.keys.parameter_name)) {
          def.entries.push_back(std::move(*e));
        }
        take_value(sub.keys, sub.sub_index);
      }
    }
    if (errors_.size() != before) return;
    auto added = od.add_object(std::move(def));
    if (!added) {
      error(o.keys.lines.section, added.error());
      return;
    }
    for (const auto& c : current) {
      cia301::Entry* e = (*added)->find(c.sub);
      if (e == nullptr || !e->assign(c.value)) {
        error(c.line, fmt::format("{:04X}h sub {}: value does not fit", o.index, c.sub));
      }
    }
  }

  const Eds& eds_;
  std::uint8_t node_id_;
  const std::string& file_;
  std::vector<Diagnostic> errors_;
};

cia301::Value default_or_zero(const cia301::EntryDefinition& def) {
  if (!def.default_value.empty()) return def.default_value;
  const auto size = cia301::info(def.type).size;
  if (size == 0) return cia301::Value::of_bytes({});
  const std::vector<std::uint8_t> zeros(size, 0);
  auto v = cia301::decode(def.type, zeros);
  return v ? *v : cia301::Value();
}

EntryKeys keys_of(const cia301::EntryDefinition& def, std::string name, cia301::ObjectCode code) {
  EntryKeys k;
  k.parameter_name = std::move(name);
  k.object_type = code;
  k.data_type = static_cast<std::uint16_t>(def.type);
  k.access_type = def.access;
  k.default_value =
      cia301::format_value_text(def.type, default_or_zero(def), def.default_adds_node_id);
  if (!def.low_limit.empty()) k.low_limit = cia301::format_value_text(def.type, def.low_limit);
  if (!def.high_limit.empty()) k.high_limit = cia301::format_value_text(def.type, def.high_limit);
  k.pdo_mapping = def.pdo_mappable;
  if (def.obj_flags != 0) k.obj_flags = def.obj_flags;
  return k;
}

}  // namespace

Expected<cia301::ObjectDictionary, std::vector<Diagnostic>> to_object_dictionary(
    const Eds& eds, std::uint8_t node_id, const std::string& file) {
  return Builder(eds, node_id, file).run();
}

Eds from_object_dictionary(const cia301::ObjectDictionary& od, FileInfo file_info,
                           DeviceInfo device_info) {
  Eds eds;
  eds.file_info = std::move(file_info);
  if (!eds.file_info.eds_version) eds.file_info.eds_version = "4.0";
  eds.device_info = std::move(device_info);
  std::uint32_t rx = 0;
  std::uint32_t tx = 0;
  for (const auto& object : od.objects()) {
    EdsObject o;
    o.index = object.index();
    o.list = default_list(o.index);
    if (o.index >= 0x1400 && o.index <= 0x15FF) ++rx;
    if (o.index >= 0x1800 && o.index <= 0x19FF) ++tx;
    const auto entries = object.entries();
    if (cia301::has_sub_entries(object.code())) {
      o.keys.parameter_name = object.name();
      o.keys.object_type = object.code();
      o.sub_number = static_cast<std::uint16_t>(entries.size());
      for (const auto& e : entries) {
        o.subs.push_back(
            {e.sub_index(), keys_of(e.definition(), e.name(), cia301::ObjectCode::var)});
      }
    } else if (!entries.empty()) {
      o.keys = keys_of(entries[0].definition(), object.name(), object.code());
    } else {
      o.keys.parameter_name = object.name();
      o.keys.object_type = object.code();
    }
    eds.objects.push_back(std::move(o));
  }
  if (!eds.device_info.nr_of_rxpdo) eds.device_info.nr_of_rxpdo = rx;
  if (!eds.device_info.nr_of_txpdo) eds.device_info.nr_of_txpdo = tx;
  return eds;
}

}  // namespace drivecheck::cia306

// CiA 306 writer: one canonical text per model (see eds.hpp).
//
// Layout: [FileInfo], [DeviceInfo], [DummyUsage], [Comments], [DeviceComissioning] (DCF),
// then for each of [MandatoryObjects], [OptionalObjects], [ManufacturerObjects] the list
// followed by its objects in ascending index, each object as [xxxx], [xxxxsubN]...,
// [xxxxName], [xxxxValue], [xxxxDenotation]; the sections drivecheck does not interpret last.
#include <fmt/format.h>

#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_fields.hpp"

namespace drivecheck::cia306 {
namespace {

class Writer {
 public:
  explicit Writer(const WriteOptions& options) : eol_(options.crlf ? "\r\n" : "\n") {}

  void section(std::string_view name) {
    if (!out_.empty()) out_ += eol_;
    out_ += '[';
    out_ += name;
    out_ += ']';
    out_ += eol_;
  }
  void key(std::string_view name, std::string_view value) {
    out_ += name;
    out_ += '=';
    out_ += value;
    out_ += eol_;
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
  std::string_view eol_;
};

template <class S, std::size_t N>
void write_fields(Writer& w, const S& s, const detail::Field<S> (&fields)[N]) {
  for (const auto& field : fields) {
    if (const auto* str = std::get_if<std::optional<std::string> S::*>(&field.member)) {
      if (s.*(*str)) w.key(field.key, *(s.*(*str)));
    } else if (const auto* u = std::get_if<std::optional<std::uint32_t> S::*>(&field.member)) {
      if (s.*(*u)) {
        w.key(field.key, field.style == detail::NumberStyle::hex ? fmt::format("0x{:X}", *(s.*(*u)))
                                                                 : fmt::format("{}", *(s.*(*u))));
      }
    } else if (const auto* b = std::get_if<std::optional<bool> S::*>(&field.member)) {
      if (s.*(*b)) w.key(field.key, *(s.*(*b)) ? "1" : "0");
    }
  }
  for (const auto& extra : s.extra)
    w.key(extra.name, extra.value);
}

void write_entry(Writer& w, const EntryKeys& k, bool structured) {
  w.key("ParameterName", k.parameter_name);
  w.key("ObjectType", fmt::format("0x{:X}", static_cast<unsigned>(k.object_type)));
  if (k.data_type) w.key("DataType", fmt::format("0x{:04X}", *k.data_type));
  if (k.access_type) w.key("AccessType", cia301::to_string(*k.access_type));
  if (k.default_value) w.key("DefaultValue", *k.default_value);
  if (k.low_limit) w.key("LowLimit", *k.low_limit);
  if (k.high_limit) w.key("HighLimit", *k.high_limit);
  if (!structured || k.pdo_mapping) w.key("PDOMapping", k.pdo_mapping ? "1" : "0");
  if (k.obj_flags) w.key("ObjFlags", fmt::format("0x{:X}", *k.obj_flags));
}

void write_entry_tail(Writer& w, const EntryKeys& k) {
  if (k.parameter_value) w.key("ParameterValue", *k.parameter_value);
  if (k.denotation) w.key("Denotation", *k.denotation);
  for (const auto& extra : k.extra)
    w.key(extra.name, extra.value);
}

void write_compact(Writer& w, std::uint16_t index, std::string_view suffix,
                   const std::vector<CompactItem>& items) {
  if (items.empty()) return;
  w.section(fmt::format("{:04X}{}", index, suffix));
  w.key("NrOfEntries", fmt::format("{}", items.size()));
  for (const auto& item : items)
    w.key(fmt::format("{}", item.sub_index), item.text);
}

void write_object(Writer& w, const EdsObject& o) {
  const bool structured = cia301::has_sub_entries(o.keys.object_type);
  w.section(fmt::format("{:04X}", o.index));
  write_entry(w, o.keys, structured && !o.compact_sub_obj);
  if (o.sub_number) w.key("SubNumber", fmt::format("0x{:X}", *o.sub_number));
  if (o.compact_sub_obj) w.key("CompactSubObj", fmt::format("0x{:X}", *o.compact_sub_obj));
  write_entry_tail(w, o.keys);
  for (const auto& sub : o.subs) {
    w.section(fmt::format("{:04X}sub{:X}", o.index, sub.sub_index));
    write_entry(w, sub.keys, false);
    write_entry_tail(w, sub.keys);
  }
  write_compact(w, o.index, "Name", o.names);
  write_compact(w, o.index, "Value", o.values);
  write_compact(w, o.index, "Denotation", o.denotations);
}

}  // namespace

std::string write_eds(const Eds& eds, const WriteOptions& options) {
  Writer w(options);
  w.section("FileInfo");
  write_fields(w, eds.file_info, detail::kFileInfoFields);
  w.section("DeviceInfo");
  write_fields(w, eds.device_info, detail::kDeviceInfoFields);
  bool any_dummy = false;
  for (const auto& d : eds.dummy_usage)
    any_dummy = any_dummy || d.has_value();
  if (any_dummy) {
    w.section("DummyUsage");
    for (std::size_t i = 1; i < eds.dummy_usage.size(); ++i) {
      if (eds.dummy_usage[i]) w.key(fmt::format("Dummy{:04X}", i), *eds.dummy_usage[i] ? "1" : "0");
    }
  }
  if (!eds.comments.empty()) {
    w.section("Comments");
    w.key("Lines", fmt::format("{}", eds.comments.size()));
    for (std::size_t i = 0; i < eds.comments.size(); ++i) {
      w.key(fmt::format("Line{}", i + 1), eds.comments[i]);
    }
  }
  if (eds.commissioning) {
    w.section("DeviceComissioning");
    write_fields(w, *eds.commissioning, detail::kCommissioningFields);
  }
  for (const auto list : {ObjectList::mandatory, ObjectList::optional, ObjectList::manufacturer}) {
    std::vector<const EdsObject*> members;
    for (const auto& o : eds.objects) {
      if (o.list == list) members.push_back(&o);
    }
    if (members.empty()) continue;
    w.section(section_name(list));
    w.key("SupportedObjects", fmt::format("{}", members.size()));
    for (std::size_t i = 0; i < members.size(); ++i) {
      w.key(fmt::format("{}", i + 1), fmt::format("0x{:04X}", members[i]->index));
    }
    for (const auto* o : members)
      write_object(w, *o);
  }
  for (const auto& raw : eds.other_sections) {
    w.section(raw.name);
    for (const auto& k : raw.keys)
      w.key(k.name, k.value);
  }
  return w.take();
}

}  // namespace drivecheck::cia306

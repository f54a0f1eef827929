// CiA 306 EDS/DCF reader: INI lexing, section classification, then one interpretation step
// per section kind. See eds.hpp for what is tolerated and what is an error.
#include <fmt/format.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <map>
#include <set>
#include <unordered_map>

#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_fields.hpp"

namespace drivecheck::cia306 {

namespace detail {

std::string to_lower(std::string_view text) {
  std::string out(text);
  for (auto& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return out;
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    char x = a[i];
    char y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

}  // namespace detail

using detail::iequals;
using detail::to_lower;

std::string Diagnostic::to_string() const {
  std::string where_text = where.file;
  if (where.line > 0)
    where_text += (where_text.empty() ? "line " : ":") + std::to_string(where.line);
  return fmt::format("{}{}{}: {} [{}]", where_text, where_text.empty() ? "" : ": ",
                     severity == Severity::error ? "error" : "warning", where.message, id);
}

bool has_errors(const std::vector<Diagnostic>& diagnostics) {
  return std::any_of(diagnostics.begin(), diagnostics.end(),
                     [](const Diagnostic& d) { return d.severity == Severity::error; });
}

int SourceLines::at(std::string_view key) const {
  for (const auto& [name, line] : keys) {
    if (name == key) return line;
  }
  return section;
}

bool SourceLines::has(std::string_view key) const {
  for (const auto& entry : keys) {
    if (entry.first == key) return true;
  }
  return false;
}

std::optional<cia301::DataType> EntryKeys::basic_type() const {
  if (!data_type) return std::nullopt;
  const auto row = cia301::find_data_type(*data_type);
  if (!row) return std::nullopt;
  return row->type;
}

const SubObject* EdsObject::find(std::uint8_t sub_index) const {
  for (const auto& s : subs) {
    if (s.sub_index == sub_index) return &s;
  }
  return nullptr;
}

std::string_view section_name(ObjectList list) {
  switch (list) {
    case ObjectList::mandatory:
      return "MandatoryObjects";
    case ObjectList::optional:
      return "OptionalObjects";
    case ObjectList::manufacturer:
      return "ManufacturerObjects";
  }
  return "?";
}

ObjectList default_list(std::uint16_t index) {
  if (index == 0x1000 || index == 0x1001 || index == 0x1018) return ObjectList::mandatory;
  if (index >= 0x2000 && index <= 0x5FFF) return ObjectList::manufacturer;
  return ObjectList::optional;
}

const EdsObject* Eds::find(std::uint16_t index) const {
  const auto it = std::lower_bound(objects.begin(), objects.end(), index,
                                   [](const EdsObject& o, std::uint16_t i) { return o.index < i; });
  return (it != objects.end() && it->index == index) ? &*it : nullptr;
}

EdsObject* Eds::find(std::uint16_t index) {
  return const_cast<EdsObject*>(std::as_const(*this).find(index));
}

namespace {

// ---- INI lexing ----------------------------------------------------------------------------

struct RawKey {
  std::string_view name;
  std::string_view value;
  int line = 0;
};

struct Section {
  std::string_view name;  // as written, trimmed
  int line = 0;
  std::vector<RawKey> keys;
};

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
    s.remove_suffix(1);
  return s;
}

// A value without its trailing comment: ';' after whitespace starts one.
std::string_view strip_comment(std::string_view value) {
  for (std::size_t i = 1; i < value.size(); ++i) {
    if (value[i] == ';' && (value[i - 1] == ' ' || value[i - 1] == '\t')) {
      return trim(value.substr(0, i));
    }
  }
  return value;
}

bool is_hex(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}
bool is_digit(char c) {
  return c >= '0' && c <= '9';
}

std::optional<std::uint32_t> hex_number(std::string_view text) {
  if (text.empty() || text.size() > 8) return std::nullopt;
  std::uint32_t v = 0;
  for (const char c : text) {
    if (!is_hex(c)) return std::nullopt;
    const int d = is_digit(c) ? c - '0' : (c | 0x20) - 'a' + 10;
    v = v * 16 + static_cast<std::uint32_t>(d);
  }
  return v;
}

std::optional<std::uint32_t> decimal_number(std::string_view text) {
  if (text.empty() || text.size() > 9) return std::nullopt;
  std::uint32_t v = 0;
  for (const char c : text) {
    if (!is_digit(c)) return std::nullopt;
    v = v * 10 + static_cast<std::uint32_t>(c - '0');
  }
  return v;
}

// ---- Section classification ----------------------------------------------------------------

enum class Kind : std::uint8_t {
  file_info,
  device_info,
  dummy_usage,
  comments,
  commissioning,
  list,
  object,
  sub_object,
  compact_names,
  compact_values,
  compact_denotations,
  known_other,
  unknown,
};

struct Classified {
  Kind kind = Kind::unknown;
  std::uint16_t index = 0;
  std::uint8_t sub_index = 0;
  ObjectList list = ObjectList::optional;
  bool misspelt = false;  // [DeviceCommissioning]
  std::string dedupe_key;
};

Classified classify(std::string_view name) {
  Classified c;
  const std::string lower = to_lower(name);
  c.dedupe_key = lower;
  const std::string_view n = lower;
  if (n == "fileinfo") {
    c.kind = Kind::file_info;
  } else if (n == "deviceinfo") {
    c.kind = Kind::device_info;
  } else if (n == "dummyusage") {
    c.kind = Kind::dummy_usage;
  } else if (n == "comments") {
    c.kind = Kind::comments;
  } else if (n == "devicecomissioning" || n == "devicecommissioning") {
    c.kind = Kind::commissioning;
    c.misspelt = n == "devicecommissioning";
    c.dedupe_key = "devicecomissioning";
  } else if (n == "mandatoryobjects") {
    c.kind = Kind::list;
    c.list = ObjectList::mandatory;
  } else if (n == "optionalobjects") {
    c.kind = Kind::list;
    c.list = ObjectList::optional;
  } else if (n == "manufacturerobjects") {
    c.kind = Kind::list;
    c.list = ObjectList::manufacturer;
  } else if (n.size() >= 4 && hex_number(n.substr(0, 4))) {
    c.index = static_cast<std::uint16_t>(*hex_number(n.substr(0, 4)));
    const std::string_view rest = n.substr(4);
    if (rest.empty()) {
      c.kind = Kind::object;
      c.dedupe_key = fmt::format("{:04x}", c.index);
    } else if (rest.starts_with("sub") && rest.size() > 3 && rest.size() <= 6) {
      const auto sub = hex_number(rest.substr(3));
      if (sub && *sub <= 0xFF) {
        c.kind = Kind::sub_object;
        c.sub_index = static_cast<std::uint8_t>(*sub);
        c.dedupe_key = fmt::format("{:04x}sub{:x}", c.index, c.sub_index);
      }
    } else if (rest == "name") {
      c.kind = Kind::compact_names;
    } else if (rest == "value") {
      c.kind = Kind::compact_values;
    } else if (rest == "denotation") {
      c.kind = Kind::compact_denotations;
    }
  }
  if (c.kind == Kind::unknown) {
    const bool module_section = n.size() > 1 && n[0] == 'm' && is_digit(n[1]);
    if (n == "tools" || n.starts_with("tool") || n == "supportedmodules" ||
        n == "connectedmodules" || n == "dynamicchannels" || module_section) {
      c.kind = Kind::known_other;
    }
  }
  return c;
}

// ---- The reader ----------------------------------------------------------------------------

class Reader {
 public:
  Reader(std::string_view text, const std::string& file) : text_(text), file_(file) {}

  ReadResult run() {
    lex();
    classify_sections();
    read_lists();
    read_objects();
    read_others();
    std::stable_sort(
        result_.diagnostics.begin(), result_.diagnostics.end(),
        [](const Diagnostic& a, const Diagnostic& b) { return a.where.line < b.where.line; });
    return std::move(result_);
  }

 private:
  void report(Severity severity, int line, std::string_view id, std::string message) {
    result_.diagnostics.push_back(
        {severity, std::string(id), TextError{file_, line, std::move(message)}});
  }
  void error(int line, std::string_view id, std::string message) {
    report(Severity::error, line, id, std::move(message));
  }
  void warning(int line, std::string_view id, std::string message) {
    report(Severity::warning, line, id, std::move(message));
  }

  void lex() {
    std::string_view text = text_;
    if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
    int line_no = 0;
    std::size_t pos = 0;
    Section* current = nullptr;
    while (pos < text.size()) {
      std::size_t end = pos;
      while (end < text.size() && text[end] != '\n' && text[end] != '\r')
        ++end;
      std::string_view line = trim(text.substr(pos, end - pos));
      ++line_no;
      if (end < text.size() && text[end] == '\r' && end + 1 < text.size() &&
          text[end + 1] == '\n') {
        ++end;
      }
      pos = end + 1;
      if (line.empty() || line.front() == ';') continue;
      if (line.front() == '[') {
        const auto close = line.find(']');
        std::string_view after =
            close == std::string_view::npos ? "" : trim(line.substr(close + 1));
        if (close == std::string_view::npos || (!after.empty() && after.front() != ';')) {
          error(line_no, "syntax", fmt::format("'{}' is not a section header '[name]'", line));
          current = nullptr;
          skipping_ = true;
          continue;
        }
        sections_.push_back({trim(line.substr(1, close - 1)), line_no, {}});
        current = &sections_.back();
        skipping_ = false;
        continue;
      }
      const auto eq = line.find('=');
      if (eq == std::string_view::npos) {
        error(line_no, "syntax",
              fmt::format("'{}' is neither 'key=value', '[section]' nor a ';' comment", line));
        continue;
      }
      const std::string_view key = trim(line.substr(0, eq));
      const std::string_view value = strip_comment(trim(line.substr(eq + 1)));
      if (key.empty()) {
        error(line_no, "syntax", "'=' without a key");
        continue;
      }
      if (current == nullptr) {
        if (!skipping_)
          error(line_no, "syntax", fmt::format("key '{}' before the first section", key));
        continue;
      }
      current->keys.push_back({key, value, line_no});
    }
  }

  // Removes repeated keys of a section (first one wins) and reports them.
  void dedupe_keys(Section& section) {
    auto& keys = section.keys;
    std::vector<RawKey> unique;
    unique.reserve(keys.size());
    if (keys.size() <= 24) {
      for (const auto& k : keys) {
        const auto it = std::find_if(unique.begin(), unique.end(),
                                     [&](const RawKey& u) { return iequals(u.name, k.name); });
        if (it == unique.end()) {
          unique.push_back(k);
        } else {
          duplicate_key(section, *it, k);
        }
      }
    } else {
      std::unordered_map<std::string, std::size_t> seen;
      for (const auto& k : keys) {
        const auto [it, inserted] = seen.emplace(to_lower(k.name), unique.size());
        if (inserted) {
          unique.push_back(k);
        } else {
          duplicate_key(section, unique[it->second], k);
        }
      }
    }
    keys = std::move(unique);
  }

  void duplicate_key(const Section& section, const RawKey& first, const RawKey& repeat) {
    if (first.value == repeat.value) {
      warning(repeat.line, "duplicate-key",
              fmt::format("key '{}' of [{}] repeats line {} with the same value", repeat.name,
                          section.name, first.line));
    } else {
      error(repeat.line, "duplicate-key",
            fmt::format("key '{}' of [{}] repeats line {} with another value ('{}' vs '{}'); "
                        "the first is used",
                        repeat.name, section.name, first.line, first.value, repeat.value));
    }
  }

  void classify_sections() {
    std::unordered_map<std::string, int> seen;
    for (auto& section : sections_) {
      Classified c = classify(section.name);
      const auto [it, inserted] = seen.emplace(c.dedupe_key, section.line);
      if (!inserted) {
        error(section.line, "duplicate-section",
              fmt::format("section [{}] repeats the one at line {}; the repeat is ignored",
                          section.name, it->second));
        continue;
      }
      dedupe_keys(section);
      if (c.kind == Kind::unknown) {
        warning(section.line, "unknown-section",
                fmt::format("unknown section [{}] (kept as is)", section.name));
      }
      if (c.misspelt) {
        warning(section.line, "nonstandard-spelling",
                "CiA 306 spells this section [DeviceComissioning] (one 'm')");
      }
      switch (c.kind) {
        case Kind::object:
          object_sections_[c.index] = &section;
          break;
        case Kind::sub_object:
          sub_sections_[c.index][c.sub_index] = &section;
          break;
        case Kind::compact_names:
          name_sections_[c.index] = &section;
          break;
        case Kind::compact_values:
          value_sections_[c.index] = &section;
          break;
        case Kind::compact_denotations:
          denotation_sections_[c.index] = &section;
          break;
        case Kind::list:
          list_sections_[static_cast<int>(c.list)] = &section;
          break;
        case Kind::file_info:
          file_info_ = &section;
          break;
        case Kind::device_info:
          device_info_ = &section;
          break;
        case Kind::dummy_usage:
          dummy_usage_ = &section;
          break;
        case Kind::comments:
          comments_ = &section;
          break;
        case Kind::commissioning:
          commissioning_ = &section;
          break;
        case Kind::known_other:
        case Kind::unknown:
          others_.push_back(&section);
          break;
      }
    }
  }

  // An object index in a SupportedObjects list (see the ambiguity rule in eds.hpp).
  std::optional<std::uint16_t> list_index(const RawKey& key) {
    const std::string_view v = key.value;
    const auto cia = cia301::parse_cia306_unsigned(v);
    const bool prefixed = v.size() > 2 && v[0] == '0' && (v[1] == 'x' || v[1] == 'X');
    std::optional<std::uint32_t> hex = prefixed ? std::nullopt : hex_number(v);
    if (hex && *hex > 0xFFFF) hex.reset();
    std::optional<std::uint16_t> standard;
    if (cia && *cia <= 0xFFFF) standard = static_cast<std::uint16_t>(*cia);
    if (!standard && !hex) {
      error(key.line, "bad-value", fmt::format("'{}' is not an object index", v));
      return std::nullopt;
    }
    if (standard && hex && *standard == *hex) return standard;
    const bool standard_has = standard && object_sections_.count(*standard) != 0;
    const bool hex_has = hex && object_sections_.count(static_cast<std::uint16_t>(*hex)) != 0;
    if (standard_has && hex_has) {
      error(key.line, "ambiguous-index",
            fmt::format("'{}' names object {:04X}h read as CiA 306 says, or {:04X}h read as hex; "
                        "both have a section: write 0x{:04X}",
                        v, *standard, *hex, *hex));
      return std::nullopt;
    }
    if (hex_has || (!standard && hex)) {
      warning(
          key.line, "hex-without-prefix",
          fmt::format("'{}' read as {:04X}h (hex without 0x: that object has a section)", v, *hex));
      return static_cast<std::uint16_t>(*hex);
    }
    return standard;
  }

  void read_lists() {
    std::set<std::uint16_t> listed;
    for (int l = 0; l < 3; ++l) {
      const Section* section = list_sections_[l];
      if (section == nullptr) continue;
      const auto list = static_cast<ObjectList>(l);
      std::optional<std::uint32_t> count;
      std::map<std::uint32_t, const RawKey*> entries;
      for (const auto& key : section->keys) {
        if (iequals(key.name, "SupportedObjects")) {
          const auto n = cia301::parse_cia306_unsigned(key.value);
          if (!n || *n > 0xFFFF) {
            error(key.line, "bad-value",
                  fmt::format("SupportedObjects '{}' is not a count", key.value));
          } else {
            count = static_cast<std::uint32_t>(*n);
          }
          continue;
        }
        const auto number = decimal_number(key.name);
        if (!number || *number == 0) {
          error(
              key.line, "bad-list-entry",
              fmt::format("key '{}' in [{}] is not an entry number 1..n", key.name, section->name));
          continue;
        }
        entries[*number] = &key;
      }
      if (!count) {
        error(section->line, "missing-key",
              fmt::format("[{}] has no SupportedObjects", section->name));
        count = static_cast<std::uint32_t>(entries.size());
      }
      // One diagnostic per run of missing entry numbers: SupportedObjects=65535 with no
      // entries is one error, not 65535 (~0.4 s per such file under the fuzz build's ASan).
      std::uint32_t expected = 1;  // the next entry number a complete list has
      const auto report_missing = [&](std::uint32_t first, std::uint32_t last) {
        if (first == last) {
          error(section->line, "list-count-mismatch",
                fmt::format("[{}] SupportedObjects={} but entry {} is missing", section->name,
                            *count, first));
        } else if (first < last) {
          error(section->line, "list-count-mismatch",
                fmt::format("[{}] SupportedObjects={} but entries {}..{} are missing",
                            section->name, *count, first, last));
        }
      };
      for (const auto& entry : entries) {
        if (entry.first > *count) break;
        report_missing(expected, entry.first - 1);
        expected = entry.first + 1;
      }
      report_missing(expected, *count);
      for (const auto& [number, key] : entries) {
        if (number > *count) {
          error(key->line, "list-count-mismatch",
                fmt::format("entry {} of [{}] is past SupportedObjects={}", number, section->name,
                            *count));
        }
        const auto index = list_index(*key);
        if (!index) continue;
        if (!listed.insert(*index).second) {
          error(key->line, "duplicate-listing",
                fmt::format("object {:04X}h is listed more than once", *index));
          continue;
        }
        if (object_sections_.count(*index) == 0) {
          error(key->line, "missing-object-section",
                fmt::format("object {:04X}h is listed in [{}] but has no section [{:04X}]", *index,
                            section->name, *index));
          continue;
        }
        listing_[*index] = {list, key->line};
      }
    }
  }

  // ---- entries ----

  // A data type index from DataType text; reports and returns nullopt when unusable.
  std::optional<std::uint16_t> data_type_index(const RawKey& key) {
    const std::string_view v = key.value;
    const bool prefixed = v.size() > 2 && v[0] == '0' && (v[1] == 'x' || v[1] == 'X');
    const auto standard = cia301::parse_cia306_unsigned(v);
    const auto hex = prefixed ? std::nullopt : hex_number(v);
    if (standard && hex && *standard != *hex) {
      error(key.line, "ambiguous-data-type",
            fmt::format("DataType '{}' reads {:04X}h as CiA 306 says (leading 0 = octal, else "
                        "decimal) but {:04X}h as hex; write it with 0x",
                        v, *standard, *hex));
      return std::nullopt;
    }
    if (!standard && hex) {
      warning(key.line, "hex-without-prefix",
              fmt::format("DataType '{}' read as hex {:04X}h", v, *hex));
      return static_cast<std::uint16_t>(*hex);
    }
    if (!standard || *standard > 0xFFFF) {
      error(key.line, "bad-value", fmt::format("DataType '{}' is not a number", v));
      return std::nullopt;
    }
    return static_cast<std::uint16_t>(*standard);
  }

  std::optional<std::uint32_t> u32_value(const RawKey& key) {
    // Real vendor EDS files (CANopenNode's example among them) leave these empty: CiA 306
    // wants a number, but the EDS still describes the objects; the device tells in 1018h.
    if (key.value.empty() &&
        (iequals(key.name, "VendorNumber") || iequals(key.name, "ProductNumber"))) {
      warning(key.line, "identity-empty",
              fmt::format("{} is empty (CiA 306 wants the number that 1018h holds)", key.name));
      return std::nullopt;
    }
    const auto n = cia301::parse_cia306_unsigned(key.value);
    if (!n || *n > 0xFFFFFFFF) {
      error(key.line, "bad-value",
            fmt::format("{} '{}' is not an UNSIGNED32 number", key.name, key.value));
      return std::nullopt;
    }
    return static_cast<std::uint32_t>(*n);
  }

  std::optional<bool> bool_value(const RawKey& key) {
    if (key.value == "0" || key.value == "1") return key.value == "1";
    const auto n = cia301::parse_cia306_unsigned(key.value);
    if (n && *n <= 1) return *n == 1;
    error(key.line, "bad-value", fmt::format("{} '{}' is neither 0 nor 1", key.name, key.value));
    return std::nullopt;
  }

  struct ParsedEntry {
    EntryKeys keys;
    std::optional<std::uint16_t> sub_number;
    std::optional<std::uint8_t> compact_sub_obj;
    const RawKey* sub_number_key = nullptr;
    const RawKey* compact_key = nullptr;
    bool object_type_ok = true;
  };

  // The keys of an object (is_object) or sub-object section.
  ParsedEntry parse_entry(const Section& section, bool is_object) {
    ParsedEntry p;
    EntryKeys& k = p.keys;
    k.lines.section = section.line;
    k.lines.keys.reserve(section.keys.size());
    bool has_name = false;
    for (const auto& key : section.keys) {
      const std::string lower = to_lower(key.name);
      k.lines.add(lower, key.line);
      const std::string value(key.value);
      if (lower == "parametername") {
        k.parameter_name = value;
        has_name = true;
      } else if (lower == "objecttype") {
        const auto n = cia301::parse_cia306_unsigned(key.value);
        const auto code = n ? cia301::to_object_code(static_cast<std::uint32_t>(*n)) : std::nullopt;
        if (!code) {
          error(
              key.line, "bad-object-type",
              fmt::format("ObjectType '{}' is not 0x0, 0x2, 0x5, 0x6, 0x7, 0x8 or 0x9", key.value));
          p.object_type_ok = false;
        } else {
          k.object_type = *code;
        }
      } else if (lower == "datatype") {
        k.data_type = data_type_index(key);
      } else if (lower == "accesstype") {
        k.access_type = cia301::parse_access_type(key.value);
        if (!k.access_type) {
          error(key.line, "bad-access-type",
                fmt::format("AccessType '{}' is not ro, wo, rw, rwr, rww or const", key.value));
        }
      } else if (lower == "defaultvalue") {
        k.default_value = value;
      } else if (lower == "lowlimit") {
        k.low_limit = value;
      } else if (lower == "highlimit") {
        k.high_limit = value;
      } else if (lower == "pdomapping") {
        k.pdo_mapping = bool_value(key).value_or(false);
      } else if (lower == "objflags") {
        k.obj_flags = u32_value(key);
      } else if (lower == "parametervalue") {
        k.parameter_value = value;
      } else if (lower == "denotation") {
        k.denotation = value;
      } else if (is_object && lower == "subnumber") {
        p.sub_number_key = &key;
        const auto n = cia301::parse_cia306_unsigned(key.value);
        if (!n || *n > 0x100) {
          error(key.line, "bad-value", fmt::format("SubNumber '{}' is not 0..256", key.value));
        } else {
          p.sub_number = static_cast<std::uint16_t>(*n);
        }
      } else if (is_object && lower == "compactsubobj") {
        p.compact_key = &key;
        const auto n = cia301::parse_cia306_unsigned(key.value);
        if (!n || *n > 0xFE) {
          error(key.line, "bad-value", fmt::format("CompactSubObj '{}' is not 0..254", key.value));
        } else {
          p.compact_sub_obj = static_cast<std::uint8_t>(*n);
        }
      } else {
        if (lower != "uploadfile" && lower != "downloadfile") {
          warning(key.line, "unknown-key",
                  fmt::format("unknown key '{}' in [{}] (kept as is)", key.name, section.name));
        }
        k.extra.push_back({std::string(key.name), value});
      }
    }
    if (!has_name) {
      error(section.line, "missing-key", fmt::format("[{}] has no ParameterName", section.name));
    }
    return p;
  }

  // Checks a value text against a type; reports parse errors and tolerances.
  void check_value_text(const EntryKeys& keys, std::string_view key_lower,
                        std::string_view key_name, const std::optional<std::string>& text,
                        cia301::DataType type) {
    if (!text) return;
    const int line = keys.lines.at(key_lower);
    if (text->empty() && cia301::is_numeric(type)) {
      warning(line, "empty-value",
              fmt::format("empty {} for {} (read as absent)", key_name, cia301::info(type).name));
      return;
    }
    const auto parsed = cia301::parse_value_text(type, *text);
    if (!parsed) {
      error(line, "bad-value",
            fmt::format("{} '{}' is not valid for {}: {}", key_name, *text, cia301::info(type).name,
                        parsed.error()));
      return;
    }
    if (parsed->hex_without_prefix) {
      warning(line, "hex-without-prefix", fmt::format("{} '{}' read as hex", key_name, *text));
    }
    if (parsed->nonstandard_spelling) {
      warning(line, "nonstandard-spelling",
              fmt::format("{} '{}' is not CiA 306 notation for {}", key_name, *text,
                          cia301::info(type).name));
    }
  }

  // Validates the keys of one entry (a VAR-like object or a sub-object).
  void check_entry(const EntryKeys& keys, std::string_view section_name_text) {
    if (!keys.data_type) {
      if (!keys.lines.has("datatype")) {
        error(keys.lines.section, "missing-key",
              fmt::format("[{}] has no DataType", section_name_text));
      }
    } else if (!keys.basic_type()) {
      error(keys.lines.at("datatype"), "unknown-data-type",
            fmt::format("DataType 0x{:04X} of [{}] is not a CiA 301 basic data type",
                        *keys.data_type, section_name_text));
    }
    if (!keys.access_type && !keys.lines.has("accesstype")) {
      error(keys.lines.section, "missing-key",
            fmt::format("[{}] has no AccessType", section_name_text));
    }
    const auto type = keys.basic_type();
    if (!type) return;
    check_value_text(keys, "defaultvalue", "DefaultValue", keys.default_value, *type);
    check_value_text(keys, "lowlimit", "LowLimit", keys.low_limit, *type);
    check_value_text(keys, "highlimit", "HighLimit", keys.high_limit, *type);
    check_value_text(keys, "parametervalue", "ParameterValue", keys.parameter_value, *type);
  }

  std::vector<CompactItem> read_compact(const Section& section, std::uint8_t count,
                                        std::optional<cia301::DataType> type, bool values) {
    std::vector<CompactItem> items;
    std::optional<std::uint64_t> declared;
    int declared_line = section.line;
    for (const auto& key : section.keys) {
      if (iequals(key.name, "NrOfEntries")) {
        declared = cia301::parse_cia306_unsigned(key.value);
        declared_line = key.line;
        if (!declared)
          error(key.line, "bad-value", fmt::format("NrOfEntries '{}' is not a count", key.value));
        continue;
      }
      const auto sub = decimal_number(key.name);
      if (!sub || *sub == 0 || *sub > count) {
        error(key.line, "bad-compact-entry",
              fmt::format("key '{}' in [{}] is not a sub-index 1..{} (decimal)", key.name,
                          section.name, count));
        continue;
      }
      if (values && type) {
        const auto parsed = cia301::parse_value_text(*type, key.value);
        if (!parsed) {
          error(key.line, "bad-value",
                fmt::format("value '{}' of sub-index {} is not valid for {}: {}", key.value, *sub,
                            cia301::info(*type).name, parsed.error()));
          continue;
        }
      }
      items.push_back({static_cast<std::uint8_t>(*sub), std::string(key.value), key.line});
    }
    if (!declared) {
      error(section.line, "missing-key", fmt::format("[{}] has no NrOfEntries", section.name));
    } else if (*declared != items.size()) {
      error(
          declared_line, "count-mismatch",
          fmt::format("[{}] NrOfEntries={} but {} usable entr{} follow{}", section.name, *declared,
                      items.size(), items.size() == 1 ? "y" : "ies", items.size() == 1 ? "s" : ""));
    }
    std::sort(items.begin(), items.end(),
              [](const CompactItem& a, const CompactItem& b) { return a.sub_index < b.sub_index; });
    return items;
  }

  void read_objects() {
    for (const auto& [index, section] : object_sections_) {
      const std::string name = fmt::format("{:04X}", index);
      EdsObject object;
      object.index = index;
      const auto listed = listing_.find(index);
      if (listed == listing_.end()) {
        error(section->line, "unlisted-object-section",
              fmt::format("section [{}] is not listed in [MandatoryObjects], [OptionalObjects] or "
                          "[ManufacturerObjects]",
                          section->name));
        object.list = default_list(index);
      } else {
        object.list = listed->second.list;
        object.list_line = listed->second.line;
      }
      ParsedEntry parsed = parse_entry(*section, true);
      object.keys = std::move(parsed.keys);
      object.sub_number = parsed.sub_number;
      object.compact_sub_obj = parsed.compact_sub_obj;
      const auto code = object.keys.object_type;
      const auto subs_it = sub_sections_.find(index);
      const bool has_subs = subs_it != sub_sections_.end();
      if (cia301::has_sub_entries(code)) {
        read_structured(object, parsed, *section, has_subs ? &subs_it->second : nullptr);
      } else if (code == cia301::ObjectCode::null_object) {
        if (has_subs) {
          error(section->line, "sub-sections-on-var",
                fmt::format("[{}] is a NULL object but has sub-object sections", section->name));
        }
      } else {
        if (code == cia301::ObjectCode::domain && !object.keys.data_type &&
            !object.keys.lines.has("datatype")) {
          warning(section->line, "missing-key",
                  fmt::format("[{}] DOMAIN object has no DataType (DOMAIN 0x000F assumed)",
                              section->name));
          object.keys.data_type = static_cast<std::uint16_t>(cia301::DataType::domain);
        }
        check_entry(object.keys, section->name);
        if (parsed.sub_number_key != nullptr || parsed.compact_key != nullptr) {
          const RawKey* key = parsed.sub_number_key ? parsed.sub_number_key : parsed.compact_key;
          warning(key->line, "ignored-key",
                  fmt::format("{} on a {} object is ignored", key->name, cia301::to_string(code)));
          object.sub_number.reset();
          object.compact_sub_obj.reset();
        }
        if (has_subs) {
          error(subs_it->second.begin()->second->line, "sub-sections-on-var",
                fmt::format("[{}] is a {} object; its sub-object sections are ignored",
                            section->name, cia301::to_string(code)));
        }
      }
      if (object.compact_sub_obj == std::nullopt) {
        for (auto* compact : {&name_sections_, &value_sections_, &denotation_sections_}) {
          const auto it = compact->find(index);
          if (it != compact->end()) {
            warning(
                it->second->line, "ignored-section",
                fmt::format("[{}] is ignored: [{}] has no CompactSubObj", it->second->name, name));
          }
        }
      }
      result_.eds.objects.push_back(std::move(object));
    }
    for (const auto& [index, subs] : sub_sections_) {
      if (object_sections_.count(index) == 0) {
        error(
            subs.begin()->second->line, "orphan-sub-section",
            fmt::format("[{}] has no object section [{:04X}]", subs.begin()->second->name, index));
      }
    }
    for (auto* compact : {&name_sections_, &value_sections_, &denotation_sections_}) {
      for (const auto& [index, section] : *compact) {
        if (object_sections_.count(index) == 0) {
          error(section->line, "orphan-sub-section",
                fmt::format("[{}] has no object section [{:04X}]", section->name, index));
        }
      }
    }
  }

  void read_structured(EdsObject& object, const ParsedEntry& parsed, const Section& section,
                       const std::map<std::uint8_t, Section*>* subs) {
    const auto code = object.keys.object_type;
    if (object.compact_sub_obj) {
      if (code != cia301::ObjectCode::array) {
        error(parsed.compact_key->line, "compact-not-array",
              fmt::format("CompactSubObj on [{}], a {} (CiA 306 allows it on ARRAY only)",
                          section.name, cia301::to_string(code)));
      }
      if (subs != nullptr) {
        error(subs->begin()->second->line, "compact-with-sub-sections",
              fmt::format("[{}] has CompactSubObj and sub-object sections: which one describes the "
                          "array is ambiguous",
                          section.name));
      }
      if (parsed.sub_number_key != nullptr) {
        warning(parsed.sub_number_key->line, "ignored-key",
                fmt::format("SubNumber on [{}] is ignored: CompactSubObj gives the sub-objects",
                            section.name));
        object.sub_number.reset();
      }
      check_entry(object.keys, section.name);
      const auto type = object.keys.basic_type();
      const auto n = *object.compact_sub_obj;
      if (const auto it = name_sections_.find(object.index); it != name_sections_.end()) {
        object.names = read_compact(*it->second, n, std::nullopt, false);
        object.names_line = it->second->line;
      }
      if (const auto it = value_sections_.find(object.index); it != value_sections_.end()) {
        object.values = read_compact(*it->second, n, type, true);
        object.values_line = it->second->line;
      }
      if (const auto it = denotation_sections_.find(object.index);
          it != denotation_sections_.end()) {
        object.denotations = read_compact(*it->second, n, std::nullopt, false);
        object.denotations_line = it->second->line;
      }
      return;
    }
    if (!object.sub_number && parsed.sub_number_key == nullptr) {
      error(section.line, "missing-key",
            fmt::format("[{}] is a {} without SubNumber or CompactSubObj", section.name,
                        cia301::to_string(code)));
    }
    const std::size_t count = subs == nullptr ? 0 : subs->size();
    if (object.sub_number && *object.sub_number != count) {
      error(parsed.sub_number_key->line, "subnumber-mismatch",
            fmt::format("[{}] SubNumber={} but {} sub-object section{} follow{}", section.name,
                        *object.sub_number, count, count == 1 ? "" : "s", count == 1 ? "s" : ""));
    }
    if (subs == nullptr) return;
    if (subs->count(0) == 0) {
      error(section.line, "missing-sub0",
            fmt::format("[{}] has no [{}sub0] (highest sub-index supported)", section.name,
                        section.name));
    }
    for (const auto& [sub, sub_section] : *subs) {
      ParsedEntry entry = parse_entry(*sub_section, false);
      if (!entry.object_type_ok) continue;
      if (entry.keys.object_type != cia301::ObjectCode::var &&
          entry.keys.object_type != cia301::ObjectCode::domain) {
        warning(entry.keys.lines.at("objecttype"), "bad-object-type",
                fmt::format("[{}] is a sub-object but ObjectType is {}", sub_section->name,
                            cia301::to_string(entry.keys.object_type)));
      }
      check_entry(entry.keys, sub_section->name);
      object.subs.push_back({sub, std::move(entry.keys)});
    }
  }

  template <class S, std::size_t N>
  void read_fields(const Section& section, S& out, const detail::Field<S> (&fields)[N]) {
    out.lines.section = section.line;
    for (const auto& key : section.keys) {
      out.lines.add(to_lower(key.name), key.line);
      const auto field =
          std::find_if(std::begin(fields), std::end(fields),
                       [&](const detail::Field<S>& f) { return iequals(f.key, key.name); });
      if (field == std::end(fields)) {
        out.extra.push_back({std::string(key.name), std::string(key.value)});
        continue;
      }
      if (const auto* s = std::get_if<std::optional<std::string> S::*>(&field->member)) {
        out.*(*s) = std::string(key.value);
      } else if (const auto* u = std::get_if<std::optional<std::uint32_t> S::*>(&field->member)) {
        out.*(*u) = u32_value(key);
      } else if (const auto* b = std::get_if<std::optional<bool> S::*>(&field->member)) {
        out.*(*b) = bool_value(key);
      }
    }
  }

  void read_others() {
    auto& eds = result_.eds;
    if (file_info_ != nullptr) {
      read_fields(*file_info_, eds.file_info, detail::kFileInfoFields);
    } else {
      error(1, "missing-section", "no [FileInfo] section");
    }
    if (device_info_ != nullptr) {
      read_fields(*device_info_, eds.device_info, detail::kDeviceInfoFields);
    } else {
      error(1, "missing-section", "no [DeviceInfo] section");
    }
    if (commissioning_ != nullptr) {
      eds.commissioning.emplace();
      read_fields(*commissioning_, *eds.commissioning, detail::kCommissioningFields);
    }
    if (dummy_usage_ != nullptr) {
      eds.dummy_usage_lines.section = dummy_usage_->line;
      for (const auto& key : dummy_usage_->keys) {
        const auto lower = to_lower(key.name);
        const auto type = lower.size() == 9 && lower.starts_with("dummy")
                              ? hex_number(lower.substr(5))
                              : std::nullopt;
        if (!type || *type < 1 || *type > 7) {
          // CiA 306 [DummyUsage] lists the data types 0001h-0007h only: another key is a
          // malformed line (a typo would silently leave that dummy undeclared).
          error(key.line, "bad-key",
                fmt::format("'{}' in [DummyUsage] is not one of Dummy0001..Dummy0007 (CiA 306: "
                            "the dummy data types 0001h-0007h)",
                            key.name));
          continue;
        }
        eds.dummy_usage[*type] = bool_value(key);
        eds.dummy_usage_lines.add(fmt::format("dummy{:04x}", *type), key.line);
      }
    }
    if (comments_ != nullptr) {
      std::optional<std::uint64_t> lines;
      std::map<std::uint32_t, std::string> text;
      for (const auto& key : comments_->keys) {
        if (iequals(key.name, "Lines")) {
          lines = cia301::parse_cia306_unsigned(key.value);
          continue;
        }
        const auto lower = to_lower(key.name);
        const auto n = lower.starts_with("line") ? decimal_number(lower.substr(4)) : std::nullopt;
        if (!n || *n == 0) {
          warning(key.line, "unknown-key",
                  fmt::format("'{}' in [Comments] is not LineN (ignored)", key.name));
          continue;
        }
        text[*n] = std::string(key.value);
      }
      std::uint32_t expected = 1;
      for (auto& [n, line] : text) {
        if (n != expected) {
          warning(comments_->line, "count-mismatch",
                  fmt::format("[Comments] has no Line{}", expected));
          expected = n;
        }
        ++expected;
        eds.comments.push_back(std::move(line));
      }
      if (!lines || *lines != text.size()) {
        warning(comments_->line, "count-mismatch",
                fmt::format("[Comments] Lines does not match the {} comment lines", text.size()));
      }
    }
    for (const Section* section : others_) {
      RawSection raw{std::string(section->name), {}, section->line};
      for (const auto& key : section->keys)
        raw.keys.push_back({std::string(key.name), std::string(key.value)});
      eds.other_sections.push_back(std::move(raw));
    }
    if (list_sections_[0] == nullptr && list_sections_[1] == nullptr &&
        list_sections_[2] == nullptr && !object_sections_.empty()) {
      error(
          1, "missing-section",
          "no [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects]: no object is listed");
    }
  }

  struct Listing {
    ObjectList list = ObjectList::optional;
    int line = 0;
  };

  std::string_view text_;
  const std::string& file_;
  ReadResult result_;
  std::vector<Section> sections_;  // complete before any pointer into it is taken
  bool skipping_ = false;
  std::map<std::uint16_t, Section*> object_sections_;
  std::map<std::uint16_t, std::map<std::uint8_t, Section*>> sub_sections_;
  std::map<std::uint16_t, Section*> name_sections_, value_sections_, denotation_sections_;
  std::array<Section*, 3> list_sections_{};
  std::map<std::uint16_t, Listing> listing_;
  Section* file_info_ = nullptr;
  Section* device_info_ = nullptr;
  Section* dummy_usage_ = nullptr;
  Section* comments_ = nullptr;
  Section* commissioning_ = nullptr;
  std::vector<Section*> others_;
};

}  // namespace

ReadResult read_eds(std::string_view text, const std::string& file) {
  return Reader(text, file).run();
}

Expected<ReadResult, TextError> read_eds_file(const std::string& path) {
  constexpr std::size_t kMaxSize = 64u << 20;
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    return Unexpected(TextError{path, 0, std::strerror(errno)});
  }
  if (S_ISDIR(st.st_mode)) return Unexpected(TextError{path, 0, "is a directory"});
  if (static_cast<std::size_t>(st.st_size) > kMaxSize) {
    return Unexpected(TextError{path, 0, "larger than 64 MiB: not an EDS"});
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return Unexpected(TextError{path, 0, std::strerror(errno)});
  std::string text;
  char buffer[65536];
  std::size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0 && text.size() <= kMaxSize) {
    text.append(buffer, n);
  }
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return Unexpected(TextError{path, 0, "read error"});
  if (text.size() > kMaxSize)
    return Unexpected(TextError{path, 0, "larger than 64 MiB: not an EDS"});
  if (text.find('\0') != std::string::npos) {
    return Unexpected(TextError{path, 0, "contains NUL bytes: a binary file, not an EDS"});
  }
  return read_eds(text, path);
}

}  // namespace drivecheck::cia306

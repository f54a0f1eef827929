#include "protocol/cia301/data_type.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

namespace drivecheck::cia301 {
namespace {

constexpr TypeClass kBool = TypeClass::boolean;
constexpr TypeClass kInt = TypeClass::signed_integer;
constexpr TypeClass kUns = TypeClass::unsigned_integer;

// CiA 301 §7.4.7.1, Table 44 (basic data types only), in index order.
constexpr std::array<DataTypeInfo, 25> kTable{{
    {DataType::boolean, "BOOLEAN", 1, 1, kBool},
    {DataType::integer8, "INTEGER8", 1, 8, kInt},
    {DataType::integer16, "INTEGER16", 2, 16, kInt},
    {DataType::integer32, "INTEGER32", 4, 32, kInt},
    {DataType::unsigned8, "UNSIGNED8", 1, 8, kUns},
    {DataType::unsigned16, "UNSIGNED16", 2, 16, kUns},
    {DataType::unsigned32, "UNSIGNED32", 4, 32, kUns},
    {DataType::real32, "REAL32", 4, 32, TypeClass::real},
    {DataType::visible_string, "VISIBLE_STRING", 0, 0, TypeClass::visible_string},
    {DataType::octet_string, "OCTET_STRING", 0, 0, TypeClass::octet_string},
    {DataType::unicode_string, "UNICODE_STRING", 0, 0, TypeClass::unicode_string},
    {DataType::time_of_day, "TIME_OF_DAY", 6, 48, kUns},
    {DataType::time_difference, "TIME_DIFFERENCE", 6, 48, kUns},
    {DataType::domain, "DOMAIN", 0, 0, TypeClass::octet_string},
    {DataType::integer24, "INTEGER24", 3, 24, kInt},
    {DataType::real64, "REAL64", 8, 64, TypeClass::real},
    {DataType::integer40, "INTEGER40", 5, 40, kInt},
    {DataType::integer48, "INTEGER48", 6, 48, kInt},
    {DataType::integer56, "INTEGER56", 7, 56, kInt},
    {DataType::integer64, "INTEGER64", 8, 64, kInt},
    {DataType::unsigned24, "UNSIGNED24", 3, 24, kUns},
    {DataType::unsigned40, "UNSIGNED40", 5, 40, kUns},
    {DataType::unsigned48, "UNSIGNED48", 6, 48, kUns},
    {DataType::unsigned56, "UNSIGNED56", 7, 56, kUns},
    {DataType::unsigned64, "UNSIGNED64", 8, 64, kUns},
}};

char lower(char c) {
  return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(),
                                            [](char x, char y) { return lower(x) == lower(y); });
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
    s.remove_suffix(1);
  return s;
}

bool is_hex_digit(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return c - 'A' + 10;
}

std::uint64_t max_unsigned(std::uint8_t size) {
  return size >= 8 ? std::numeric_limits<std::uint64_t>::max()
                   : (std::uint64_t{1} << (8 * size)) - 1;
}
std::int64_t max_signed(std::uint8_t size) {
  return static_cast<std::int64_t>(max_unsigned(size) >> 1);
}
std::int64_t min_signed(std::uint8_t size) {
  return -max_signed(size) - 1;
}

// An unsigned magnitude in CiA 306 notation. `hex_without_prefix` is set when the text only
// reads as hex ("1A").
struct Magnitude {
  std::uint64_t value = 0;
  bool hex = false;  // written as hex (0x or tolerated): a bit pattern for signed types
  bool hex_without_prefix = false;
};

Expected<Magnitude, std::string> parse_magnitude(std::string_view text) {
  if (text.empty()) return Unexpected(std::string("empty number"));
  Magnitude m;
  int base = 10;
  std::string_view digits = text;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    digits = text.substr(2);
  } else if (text.size() > 1 && text[0] == '0') {
    base = 8;
    digits = text.substr(1);
  }
  if (base == 16 && digits.empty()) return Unexpected(std::string("no hex digits after 0x"));
  if (base != 16 && std::all_of(digits.begin(), digits.end(), is_hex_digit) &&
      std::any_of(digits.begin(), digits.end(), [](char c) { return !(c >= '0' && c <= '9'); })) {
    base = 16;  // "1A", "FF": only hex makes sense
    digits = text;
    m.hex_without_prefix = true;
  }
  std::uint64_t value = 0;
  const auto* first = digits.data();
  const auto* last = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(first, last, value, base);
  if (ec == std::errc::result_out_of_range) {
    return Unexpected(fmt::format("'{}' is too large for 64 bits", text));
  }
  if (ec != std::errc() || ptr != last) {
    if (base == 8) {
      return Unexpected(
          fmt::format("'{}' is not an octal number (CiA 306 reads a leading 0 as octal)", text));
    }
    return Unexpected(fmt::format("'{}' is not a number", text));
  }
  m.value = value;
  m.hex = base == 16;
  return m;
}

struct IntegerText {
  std::uint64_t bits = 0;  // unsigned value, or the two's complement bits of a signed one
  bool negative = false;
  bool hex_without_prefix = false;
};

// An integer of `info`'s type: decimal with optional sign, hex or octal bit patterns.
Expected<IntegerText, std::string> parse_integer(const DataTypeInfo& type, std::string_view text) {
  bool negative = false;
  if (!text.empty() && (text.front() == '-' || text.front() == '+')) {
    negative = text.front() == '-';
    text = trim(text.substr(1));
  }
  auto magnitude = parse_magnitude(text);
  if (!magnitude) return Unexpected(magnitude.error());
  IntegerText out;
  out.hex_without_prefix = magnitude->hex_without_prefix;
  const std::uint64_t m = magnitude->value;
  if (type.type_class == TypeClass::signed_integer) {
    if (negative) {
      const auto limit = static_cast<std::uint64_t>(max_signed(type.size)) + 1;
      if (m > limit) return Unexpected(fmt::format("-{} is below the {} range", text, type.name));
      out.bits = ~m + 1;  // two's complement, 64 bits wide
      out.negative = m != 0;
    } else if (magnitude->hex || (text.size() > 1 && text[0] == '0')) {
      // A hex or octal bit pattern of the type's width: 0xFFFF is -1 for INTEGER16.
      if (m > max_unsigned(type.size)) {
        return Unexpected(fmt::format("{} does not fit {}", text, type.name));
      }
      const unsigned shift = 64 - 8u * type.size;
      out.bits = static_cast<std::uint64_t>(static_cast<std::int64_t>(m << shift) >> shift);
      out.negative = static_cast<std::int64_t>(out.bits) < 0;
    } else {
      if (m > static_cast<std::uint64_t>(max_signed(type.size))) {
        return Unexpected(fmt::format("{} is above the {} range", text, type.name));
      }
      out.bits = m;
    }
    return out;
  }
  if (negative && m != 0) {
    return Unexpected(fmt::format("-{} is negative, {} is unsigned", text, type.name));
  }
  const std::uint64_t max = type.type_class == TypeClass::boolean ? 1 : max_unsigned(type.size);
  if (m > max) return Unexpected(fmt::format("{} does not fit {}", text, type.name));
  out.bits = m;
  return out;
}

bool contains_nodeid(std::string_view text, std::size_t& pos) {
  constexpr std::string_view kToken = "$nodeid";
  for (std::size_t i = 0; i + kToken.size() <= text.size(); ++i) {
    if (iequals(text.substr(i, kToken.size()), kToken)) {
      pos = i;
      return true;
    }
  }
  return false;
}

Expected<std::vector<std::uint8_t>, std::string> parse_hex_bytes(std::string_view text) {
  std::vector<std::uint8_t> bytes;
  int pending = -1;
  if (text.size() >= 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X'))
    text.remove_prefix(2);
  for (const char c : text) {
    if (c == ' ' || c == '\t') {
      if (pending >= 0) return Unexpected(std::string("odd number of hex digits in a byte"));
      continue;
    }
    if (!is_hex_digit(c)) return Unexpected(fmt::format("'{}' is not a hex digit", c));
    if (pending < 0) {
      pending = hex_value(c);
    } else {
      bytes.push_back(static_cast<std::uint8_t>(pending * 16 + hex_value(c)));
      pending = -1;
    }
  }
  if (pending >= 0) return Unexpected(std::string("odd number of hex digits"));
  return bytes;
}

Expected<std::vector<std::uint8_t>, std::string> utf8_to_utf16le(std::string_view text) {
  std::vector<std::uint8_t> out;
  std::size_t i = 0;
  auto put = [&out](std::uint32_t unit) {
    out.push_back(static_cast<std::uint8_t>(unit & 0xFF));
    out.push_back(static_cast<std::uint8_t>(unit >> 8));
  };
  while (i < text.size()) {
    const auto b0 = static_cast<std::uint8_t>(text[i]);
    std::uint32_t cp = 0;
    std::size_t len = 0;
    if (b0 < 0x80) {
      cp = b0;
      len = 1;
    } else if ((b0 & 0xE0) == 0xC0) {
      cp = b0 & 0x1Fu;
      len = 2;
    } else if ((b0 & 0xF0) == 0xE0) {
      cp = b0 & 0x0Fu;
      len = 3;
    } else if ((b0 & 0xF8) == 0xF0) {
      cp = b0 & 0x07u;
      len = 4;
    } else {
      return Unexpected(fmt::format("byte {:02X}h at offset {} is not UTF-8", b0, i));
    }
    if (i + len > text.size()) return Unexpected(std::string("truncated UTF-8 sequence"));
    for (std::size_t k = 1; k < len; ++k) {
      const auto b = static_cast<std::uint8_t>(text[i + k]);
      if ((b & 0xC0) != 0x80) return Unexpected(fmt::format("bad UTF-8 sequence at offset {}", i));
      cp = (cp << 6) | (b & 0x3Fu);
    }
    constexpr std::uint32_t kMin[] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < kMin[len] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) {
      return Unexpected(fmt::format("invalid UTF-8 sequence at offset {}", i));
    }
    if (cp >= 0x10000) {
      cp -= 0x10000;
      put(0xD800 + (cp >> 10));
      put(0xDC00 + (cp & 0x3FF));
    } else {
      put(cp);
    }
    i += len;
  }
  return out;
}

std::string utf16le_to_utf8(std::span<const std::uint8_t> bytes) {
  std::string out;
  auto emit = [&out](std::uint32_t cp) {
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xF0 | (cp >> 18));
      out += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  };
  for (std::size_t i = 0; i + 1 < bytes.size(); i += 2) {
    std::uint32_t unit = bytes[i] | (std::uint32_t{bytes[i + 1]} << 8);
    if (unit >= 0xD800 && unit <= 0xDBFF && i + 3 < bytes.size()) {
      const std::uint32_t low = bytes[i + 2] | (std::uint32_t{bytes[i + 3]} << 8);
      if (low >= 0xDC00 && low <= 0xDFFF) {
        emit(0x10000 + ((unit - 0xD800) << 10) + (low - 0xDC00));
        i += 2;
        continue;
      }
    }
    if (unit >= 0xD800 && unit <= 0xDFFF) unit = 0xFFFD;  // lone surrogate
    emit(unit);
  }
  return out;
}

Expected<ValueText, std::string> parse_real(const DataTypeInfo& type, std::string_view text) {
  ValueText out;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    // Tolerated: the IEEE 754 bit pattern in hex.
    auto m = parse_magnitude(text);
    if (!m) return Unexpected(m.error());
    if (m->value > max_unsigned(type.size)) {
      return Unexpected(fmt::format("{} does not fit {}", text, type.name));
    }
    double v = 0;
    if (type.size == 4) {
      v = std::bit_cast<float>(static_cast<std::uint32_t>(m->value));
    } else {
      v = std::bit_cast<double>(m->value);
    }
    out.value = Value::of_real(v);
    out.nonstandard_spelling = true;
    return out;
  }
  std::string_view digits = text;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  double v = 0;
  const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (digits.empty() || ec == std::errc::invalid_argument || ptr != digits.data() + digits.size()) {
    return Unexpected(fmt::format("'{}' is not a floating point number", text));
  }
  if (ec == std::errc::result_out_of_range ||
      (type.size == 4 && std::isfinite(v) && std::fabs(v) > std::numeric_limits<float>::max())) {
    return Unexpected(fmt::format("{} is out of the {} range", text, type.name));
  }
  if (type.size == 4) v = static_cast<double>(static_cast<float>(v));
  out.value = Value::of_real(v);
  return out;
}

}  // namespace

std::span<const DataTypeInfo> data_type_table() {
  return kTable;
}

std::optional<DataTypeInfo> find_data_type(std::uint16_t index) {
  for (const auto& row : kTable) {
    if (static_cast<std::uint16_t>(row.type) == index) return row;
  }
  return std::nullopt;
}

const DataTypeInfo& info(DataType type) {
  for (const auto& row : kTable) {
    if (row.type == type) return row;
  }
  return kTable[0];  // unreachable for enumerators
}

std::optional<ObjectCode> to_object_code(std::uint32_t value) {
  switch (value) {
    case 0x0:
    case 0x2:
    case 0x5:
    case 0x6:
    case 0x7:
    case 0x8:
    case 0x9:
      return static_cast<ObjectCode>(value);
    default:
      return std::nullopt;
  }
}

std::string_view to_string(ObjectCode code) {
  switch (code) {
    case ObjectCode::null_object:
      return "NULL";
    case ObjectCode::domain:
      return "DOMAIN";
    case ObjectCode::deftype:
      return "DEFTYPE";
    case ObjectCode::defstruct:
      return "DEFSTRUCT";
    case ObjectCode::var:
      return "VAR";
    case ObjectCode::array:
      return "ARRAY";
    case ObjectCode::record:
      return "RECORD";
  }
  return "?";
}

std::string_view to_string(AccessType access) {
  switch (access) {
    case AccessType::ro:
      return "ro";
    case AccessType::wo:
      return "wo";
    case AccessType::rw:
      return "rw";
    case AccessType::rwr:
      return "rwr";
    case AccessType::rww:
      return "rww";
    case AccessType::constant:
      return "const";
  }
  return "?";
}

std::optional<AccessType> parse_access_type(std::string_view text) {
  constexpr AccessType kAll[] = {AccessType::ro,  AccessType::wo,  AccessType::rw,
                                 AccessType::rwr, AccessType::rww, AccessType::constant};
  for (const auto a : kAll) {
    if (iequals(text, to_string(a))) return a;
  }
  return std::nullopt;
}

Value Value::of_string(std::string_view text) {
  return of_bytes(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

std::string_view Value::as_string_view() const {
  const auto& b = as_bytes();
  return {reinterpret_cast<const char*>(b.data()), b.size()};
}

Value::Kind value_kind(DataType type) {
  switch (info(type).type_class) {
    case TypeClass::boolean:
    case TypeClass::unsigned_integer:
      return Value::Kind::unsigned_integer;
    case TypeClass::signed_integer:
      return Value::Kind::signed_integer;
    case TypeClass::real:
      return Value::Kind::real;
    default:
      return Value::Kind::bytes;
  }
}

Expected<void, std::string> check_value(DataType type, const Value& value) {
  const auto& ti = info(type);
  if (value.kind() != value_kind(type)) {
    return Unexpected(fmt::format("value kind does not match {}", ti.name));
  }
  switch (ti.type_class) {
    case TypeClass::boolean:
      if (value.as_unsigned() > 1)
        return Unexpected(fmt::format("{} is not a BOOLEAN", value.as_unsigned()));
      break;
    case TypeClass::unsigned_integer:
      if (value.as_unsigned() > max_unsigned(ti.size)) {
        return Unexpected(fmt::format("{} does not fit {}", value.as_unsigned(), ti.name));
      }
      break;
    case TypeClass::signed_integer:
      if (value.as_signed() > max_signed(ti.size) || value.as_signed() < min_signed(ti.size)) {
        return Unexpected(fmt::format("{} does not fit {}", value.as_signed(), ti.name));
      }
      break;
    case TypeClass::real:
      if (ti.size == 4 && std::isfinite(value.as_real()) &&
          std::fabs(value.as_real()) > std::numeric_limits<float>::max()) {
        return Unexpected(fmt::format("{} does not fit REAL32", value.as_real()));
      }
      break;
    case TypeClass::unicode_string:
      if (value.as_bytes().size() % 2 != 0) {
        return Unexpected(std::string("UNICODE_STRING has an odd number of bytes"));
      }
      break;
    default:
      break;
  }
  return {};
}

std::uint64_t load_unsigned(std::span<const std::uint8_t> bytes) {
  std::uint64_t v = 0;
  for (std::size_t i = bytes.size(); i-- > 0;)
    v = (v << 8) | bytes[i];
  return v;
}

std::int64_t load_signed(std::span<const std::uint8_t> bytes) {
  if (bytes.empty()) return 0;
  const std::uint64_t v = load_unsigned(bytes);
  const unsigned shift = 64 - 8u * static_cast<unsigned>(bytes.size());
  return static_cast<std::int64_t>(v << shift) >> shift;
}

void store_unsigned(std::uint64_t value, std::span<std::uint8_t> out) {
  for (auto& b : out) {
    b = static_cast<std::uint8_t>(value & 0xFF);
    value >>= 8;
  }
}

Expected<void, std::string> encode(DataType type, const Value& value,
                                   std::vector<std::uint8_t>& out) {
  if (auto ok = check_value(type, value); !ok) return ok;
  const auto& ti = info(type);
  std::array<std::uint8_t, 8> buf{};
  switch (value.kind()) {
    case Value::Kind::unsigned_integer:
      store_unsigned(value.as_unsigned(), std::span(buf).first(ti.size));
      break;
    case Value::Kind::signed_integer:
      store_unsigned(static_cast<std::uint64_t>(value.as_signed()), std::span(buf).first(ti.size));
      break;
    case Value::Kind::real:
      if (ti.size == 4) {
        store_unsigned(std::bit_cast<std::uint32_t>(static_cast<float>(value.as_real())),
                       std::span(buf).first(4));
      } else {
        store_unsigned(std::bit_cast<std::uint64_t>(value.as_real()), std::span(buf).first(8));
      }
      break;
    case Value::Kind::bytes:
      out.insert(out.end(), value.as_bytes().begin(), value.as_bytes().end());
      return {};
    case Value::Kind::empty:
      return Unexpected(std::string("empty value"));
  }
  out.insert(out.end(), buf.begin(), buf.begin() + ti.size);
  return {};
}

Expected<std::vector<std::uint8_t>, std::string> encode(DataType type, const Value& value) {
  std::vector<std::uint8_t> out;
  if (auto ok = encode(type, value, out); !ok) return Unexpected(ok.error());
  return out;
}

Expected<Value, std::string> decode(DataType type, std::span<const std::uint8_t> bytes) {
  const auto& ti = info(type);
  if (ti.size != 0 && bytes.size() != ti.size) {
    return Unexpected(fmt::format("{} needs {} bytes, got {}", ti.name, ti.size, bytes.size()));
  }
  switch (ti.type_class) {
    case TypeClass::boolean:
      if (bytes[0] > 1) return Unexpected(fmt::format("{:02X}h is not a BOOLEAN", bytes[0]));
      return Value::of_unsigned(bytes[0]);
    case TypeClass::unsigned_integer:
      return Value::of_unsigned(load_unsigned(bytes));
    case TypeClass::signed_integer:
      return Value::of_signed(load_signed(bytes));
    case TypeClass::real:
      if (ti.size == 4) {
        return Value::of_real(
            std::bit_cast<float>(static_cast<std::uint32_t>(load_unsigned(bytes))));
      }
      return Value::of_real(std::bit_cast<double>(load_unsigned(bytes)));
    case TypeClass::unicode_string:
      if (bytes.size() % 2 != 0) {
        return Unexpected(std::string("UNICODE_STRING has an odd number of bytes"));
      }
      return Value::of_bytes(bytes);
    default:
      return Value::of_bytes(bytes);
  }
}

Expected<ValueText, std::string> parse_value_text(DataType type, std::string_view text) {
  const auto& ti = info(type);
  text = trim(text);
  ValueText out;
  switch (ti.type_class) {
    case TypeClass::visible_string:
      out.value = Value::of_string(text);
      return out;
    case TypeClass::octet_string: {
      auto bytes = parse_hex_bytes(text);
      if (!bytes) return Unexpected(fmt::format("{} value: {}", ti.name, bytes.error()));
      out.value = Value::of_bytes(*bytes);
      return out;
    }
    case TypeClass::unicode_string: {
      auto bytes = utf8_to_utf16le(text);
      if (!bytes) return Unexpected(fmt::format("UNICODE_STRING value: {}", bytes.error()));
      out.value = Value::of_bytes(*bytes);
      return out;
    }
    case TypeClass::real:
      return parse_real(ti, text);
    default:
      break;
  }
  if (ti.type_class == TypeClass::boolean && (iequals(text, "true") || iequals(text, "false"))) {
    out.value = Value::of_unsigned(iequals(text, "true") ? 1 : 0);
    out.nonstandard_spelling = true;
    return out;
  }
  // Integers, possibly with $NODEID.
  std::string compact;
  for (const char c : text) {
    if (c != ' ' && c != '\t') compact += c;
  }
  std::string_view number = compact;
  std::size_t pos = 0;
  if (contains_nodeid(compact, pos)) {
    out.node_id_relative = true;
    constexpr std::size_t kLen = 7;  // "$NODEID"
    const std::string_view before = std::string_view(compact).substr(0, pos);
    const std::string_view after = std::string_view(compact).substr(pos + kLen);
    if (before.empty() && after.empty()) {
      number = "0";
    } else if (before.empty() && after.front() == '+') {
      number = after.substr(1);
    } else if (after.empty() && before.back() == '+') {
      number = before.substr(0, before.size() - 1);
    } else {
      return Unexpected(
          fmt::format("'{}' is not a $NODEID expression ($NODEID, $NODEID+n or n+$NODEID)", text));
    }
    std::size_t again = 0;
    if (number.empty() || contains_nodeid(number, again) || number.front() == '-' ||
        number.front() == '+') {
      return Unexpected(
          fmt::format("'{}' is not a $NODEID expression ($NODEID, $NODEID+n or n+$NODEID)", text));
    }
  }
  auto integer = parse_integer(ti, number);
  if (!integer) return Unexpected(integer.error());
  out.hex_without_prefix = integer->hex_without_prefix;
  if (ti.type_class == TypeClass::signed_integer) {
    out.value = Value::of_signed(static_cast<std::int64_t>(integer->bits));
  } else {
    out.value = Value::of_unsigned(integer->bits);
  }
  return out;
}

Expected<Value, std::string> resolve(DataType type, const ValueText& text, std::uint8_t node_id) {
  if (!text.node_id_relative) return text.value;
  Value v;
  if (text.value.kind() == Value::Kind::unsigned_integer) {
    if (text.value.as_unsigned() > std::numeric_limits<std::uint64_t>::max() - node_id) {
      return Unexpected(fmt::format("with node-ID {}: the value overflows 64 bits", node_id));
    }
    v = Value::of_unsigned(text.value.as_unsigned() + node_id);
  } else if (text.value.kind() == Value::Kind::signed_integer) {
    if (text.value.as_signed() > std::numeric_limits<std::int64_t>::max() - node_id) {
      return Unexpected(fmt::format("with node-ID {}: the value overflows 64 bits", node_id));
    }
    v = Value::of_signed(text.value.as_signed() + node_id);
  } else {
    return Unexpected(std::string("$NODEID on a non-integer value"));
  }
  if (auto ok = check_value(type, v); !ok) {
    return Unexpected(fmt::format("with node-ID {}: {}", node_id, ok.error()));
  }
  return v;
}

std::string format_value_text(DataType type, const Value& value, bool node_id_relative) {
  const auto& ti = info(type);
  std::string text;
  switch (value.kind()) {
    case Value::Kind::empty:
      return "";
    case Value::Kind::unsigned_integer:
      if (ti.type_class == TypeClass::boolean) {
        text = fmt::format("{}", value.as_unsigned() != 0 ? 1 : 0);
      } else {
        text = fmt::format("0x{:X}", value.as_unsigned());
      }
      break;
    case Value::Kind::signed_integer:
      text = fmt::format("{}", value.as_signed());
      break;
    case Value::Kind::real:
      if (ti.size == 4) return fmt::format("{}", static_cast<float>(value.as_real()));
      return fmt::format("{}", value.as_real());
    case Value::Kind::bytes:
      if (ti.type_class == TypeClass::visible_string) return std::string(value.as_string_view());
      if (ti.type_class == TypeClass::unicode_string) return utf16le_to_utf8(value.as_bytes());
      for (const auto b : value.as_bytes())
        text += fmt::format("{:02X}", b);
      return text;
  }
  if (!node_id_relative) return text;
  const bool zero = value.kind() == Value::Kind::unsigned_integer ? value.as_unsigned() == 0
                                                                  : value.as_signed() == 0;
  return zero ? std::string("$NODEID") : fmt::format("$NODEID+{}", text);
}

std::optional<std::uint64_t> parse_cia306_unsigned(std::string_view text) {
  text = trim(text);
  auto m = parse_magnitude(text);
  if (!m || m->hex_without_prefix) return std::nullopt;
  return m->value;
}

}  // namespace drivecheck::cia301

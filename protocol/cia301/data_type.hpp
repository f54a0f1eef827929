// CiA 301 data types (§7.1, object dictionary indices 0001h-001Bh), object codes (§7.4.3,
// Table 42), access attributes (§7.4.5 and CiA 306 AccessType), typed values with their
// little-endian encoding (§7.1.4-§7.1.6) and the value text of CiA 306 EDS files.
//
// Encoding on the wire (and in the object dictionary's storage) is little endian, the low
// byte first; signed integers are two's complement of the type's width:
//
//   UNSIGNED16 0x6041       -> 41 60
//   INTEGER24  -2           -> FE FF FF
//   REAL32     1.0          -> 00 00 80 3F   (IEEE 754 binary32)
//   TIME_OF_DAY             -> ms since midnight in bits 0..27 (28..31 reserved 0),
//                              days since 1984-01-01 in bits 32..47: 6 bytes, handled here
//                              as the UNSIGNED48 (ms | days << 32)
//
// EDS value text (CiA 306 §4.6, values of DefaultValue, LowLimit, HighLimit, ParameterValue):
//   integers          decimal "123", "-5"; hex "0x7B" (any case); octal "0173" (leading 0);
//                     "$NODEID+0x180", "0x180+$NODEID", "$NODEID" (integers only)
//   BOOLEAN           0 or 1
//   REAL32/REAL64     decimal floating point "1.5", "-2e-3"
//   VISIBLE_STRING    the text itself
//   OCTET_STRING,     hex digits, two per byte, optionally space separated: "01 A2 FF"
//   DOMAIN
//   UNICODE_STRING    UTF-8 text in the file, UTF-16LE in the dictionary
//   TIME_OF_DAY/_DIFFERENCE  an integer, as UNSIGNED48 above
// Tolerances (reported to the caller as flags, the reader turns them into warnings): hex
// digits without the 0x prefix ("1A"), "TRUE"/"FALSE" for BOOLEAN, a hex bit pattern
// ("0x3F800000") for REAL32/REAL64.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

// Basic data types and their object dictionary index (CiA 301 §7.4.7.1, Table 44).
enum class DataType : std::uint16_t {
  boolean = 0x0001,
  integer8 = 0x0002,
  integer16 = 0x0003,
  integer32 = 0x0004,
  unsigned8 = 0x0005,
  unsigned16 = 0x0006,
  unsigned32 = 0x0007,
  real32 = 0x0008,
  visible_string = 0x0009,
  octet_string = 0x000A,
  unicode_string = 0x000B,
  time_of_day = 0x000C,
  time_difference = 0x000D,
  domain = 0x000F,
  integer24 = 0x0010,
  real64 = 0x0011,
  integer40 = 0x0012,
  integer48 = 0x0013,
  integer56 = 0x0014,
  integer64 = 0x0015,
  unsigned24 = 0x0016,
  unsigned40 = 0x0018,
  unsigned48 = 0x0019,
  unsigned56 = 0x001A,
  unsigned64 = 0x001B,
};

// How a data type's bytes are interpreted.
enum class TypeClass : std::uint8_t {
  boolean,
  signed_integer,
  unsigned_integer,  // also TIME_OF_DAY / TIME_DIFFERENCE (as UNSIGNED48)
  real,
  visible_string,
  octet_string,  // also DOMAIN
  unicode_string,
};

struct DataTypeInfo {
  DataType type;
  std::string_view name;  // CiA 301 spelling: "UNSIGNED16"
  std::uint8_t size;      // bytes in an SDO transfer; 0 for variable-length types
  std::uint8_t bit_size;  // bits in a PDO mapping (BOOLEAN: 1); 0 for variable-length
  TypeClass type_class;
};

// The table row of a basic data type index; nullopt for anything else (0000h, 000Eh, 0017h,
// the complex types 0020h-0025h, ...).
std::optional<DataTypeInfo> find_data_type(std::uint16_t index);
// The row of a known enumerator (always found).
const DataTypeInfo& info(DataType type);
std::span<const DataTypeInfo> data_type_table();

inline bool is_integer(DataType type) {
  const auto c = info(type).type_class;
  return c == TypeClass::signed_integer || c == TypeClass::unsigned_integer ||
         c == TypeClass::boolean;
}
inline bool is_numeric(DataType type) {
  return is_integer(type) || info(type).type_class == TypeClass::real;
}
inline bool is_variable_length(DataType type) {
  return info(type).size == 0;
}

// Object codes (CiA 301 §7.4.3, Table 42; the ObjectType key of CiA 306).
enum class ObjectCode : std::uint8_t {
  null_object = 0x0,
  domain = 0x2,
  deftype = 0x5,
  defstruct = 0x6,
  var = 0x7,
  array = 0x8,
  record = 0x9,
};
std::optional<ObjectCode> to_object_code(std::uint32_t value);
std::string_view to_string(ObjectCode code);  // "VAR", "ARRAY", ...
// ARRAY, RECORD and DEFSTRUCT have sub-index 0 "highest sub-index supported" plus entries;
// every other code is one entry at sub-index 0.
inline bool has_sub_entries(ObjectCode code) {
  return code == ObjectCode::array || code == ObjectCode::record || code == ObjectCode::defstruct;
}

// Access types (CiA 306 AccessType; CiA 301 §7.4.5): rwr = read/write, mapped to TPDOs
// (process input), rww = read/write, mapped to RPDOs (process output); const = read only and
// never changes.
enum class AccessType : std::uint8_t { ro, wo, rw, rwr, rww, constant };
std::string_view to_string(AccessType access);  // "ro", "wo", "rw", "rwr", "rww", "const"
// Case-insensitive; nullopt for anything else.
std::optional<AccessType> parse_access_type(std::string_view text);
inline bool is_readable(AccessType access) {
  return access != AccessType::wo;
}
inline bool is_writable(AccessType access) {
  return access != AccessType::ro && access != AccessType::constant;
}

// A typed value: the integers (as 64 bits, with the signedness of their type), a floating
// point number, or bytes (strings and domains). Constructing an integer or real Value never
// allocates.
class Value {
 public:
  enum class Kind : std::uint8_t { empty, unsigned_integer, signed_integer, real, bytes };

  Value() = default;
  static Value of_unsigned(std::uint64_t v) { return Value(Storage(std::in_place_index<1>, v)); }
  static Value of_signed(std::int64_t v) { return Value(Storage(std::in_place_index<2>, v)); }
  static Value of_real(double v) { return Value(Storage(std::in_place_index<3>, v)); }
  static Value of_bytes(std::span<const std::uint8_t> v) {
    return Value(Storage(std::in_place_index<4>, std::vector<std::uint8_t>(v.begin(), v.end())));
  }
  static Value of_string(std::string_view text);

  Kind kind() const { return static_cast<Kind>(storage_.index()); }
  bool empty() const { return kind() == Kind::empty; }
  // Preconditions: kind() is the one asked for.
  std::uint64_t as_unsigned() const { return std::get<1>(storage_); }
  std::int64_t as_signed() const { return std::get<2>(storage_); }
  double as_real() const { return std::get<3>(storage_); }
  const std::vector<std::uint8_t>& as_bytes() const { return std::get<4>(storage_); }
  std::string_view as_string_view() const;

  friend bool operator==(const Value&, const Value&) = default;

 private:
  using Storage =
      std::variant<std::monostate, std::uint64_t, std::int64_t, double, std::vector<std::uint8_t>>;
  explicit Value(Storage s) : storage_(std::move(s)) {}
  Storage storage_;
};

// The Value kind a data type uses (BOOLEAN and TIME_* are unsigned integers).
Value::Kind value_kind(DataType type);

// Checks that a value has the kind and range of a data type ("300 does not fit UNSIGNED8").
Expected<void, std::string> check_value(DataType type, const Value& value);

// Little-endian encoding of a value of a type; a value that does not fit its type is an
// error. Fixed-size types append exactly info(type).size bytes.
Expected<void, std::string> encode(DataType type, const Value& value,
                                   std::vector<std::uint8_t>& out);
Expected<std::vector<std::uint8_t>, std::string> encode(DataType type, const Value& value);

// Decodes exactly the bytes of one value (a fixed-size type needs exactly its size).
Expected<Value, std::string> decode(DataType type, std::span<const std::uint8_t> bytes);

// Integer decoding for the hot paths (no Value): the bytes of a signed or unsigned integer
// type, sign-extended for signed types. Precondition: bytes.size() == info(type).size <= 8.
std::uint64_t load_unsigned(std::span<const std::uint8_t> bytes);
std::int64_t load_signed(std::span<const std::uint8_t> bytes);
void store_unsigned(std::uint64_t value, std::span<std::uint8_t> out);  // out.size() bytes, LE

// EDS value text (see the file comment).
struct ValueText {
  Value value;                        // for $NODEID forms: the constant part
  bool node_id_relative = false;      // the text added $NODEID
  bool hex_without_prefix = false;    // tolerance used: "1A" read as 0x1A
  bool nonstandard_spelling = false;  // tolerance used: TRUE/FALSE, hex bit pattern of a REAL
};
Expected<ValueText, std::string> parse_value_text(DataType type, std::string_view text);
// The value of a ValueText for a node (adds node_id when node_id_relative); range-checked.
Expected<Value, std::string> resolve(DataType type, const ValueText& text, std::uint8_t node_id);

// Canonical EDS text: unsigned integers "0x" + upper-case hex, signed integers decimal,
// BOOLEAN 0/1, reals the shortest text that reads back to the same value, VISIBLE_STRING
// as is, OCTET_STRING/DOMAIN as upper-case hex pairs without spaces, UNICODE_STRING as UTF-8.
// With node_id_relative: "$NODEID+0x180".
std::string format_value_text(DataType type, const Value& value, bool node_id_relative = false);

// A plain CiA 306 unsigned number: decimal, 0x hex or leading-0 octal, nothing else
// (used for the numbers of keys such as SubNumber, ObjFlags, NrOfRXPDO).
std::optional<std::uint64_t> parse_cia306_unsigned(std::string_view text);

}  // namespace drivecheck::cia301

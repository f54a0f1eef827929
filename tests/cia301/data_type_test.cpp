#include "protocol/cia301/data_type.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace drivecheck::cia301 {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes encoded(DataType type, const Value& value) {
  auto bytes = encode(type, value);
  EXPECT_TRUE(bytes) << bytes.error();
  return bytes ? *bytes : Bytes{};
}

TEST(DataTypeTable, HasCiA301IndicesAndSizes) {
  // Given the CiA 301 Table 44 indices
  // When they are looked up
  // Then each has its CiA name and size, and reserved indices are unknown
  EXPECT_EQ(find_data_type(0x0006)->name, "UNSIGNED16");
  EXPECT_EQ(find_data_type(0x0006)->size, 2);
  EXPECT_EQ(find_data_type(0x0010)->name, "INTEGER24");
  EXPECT_EQ(find_data_type(0x0010)->size, 3);
  EXPECT_EQ(find_data_type(0x0011)->name, "REAL64");
  EXPECT_EQ(find_data_type(0x001B)->size, 8);
  EXPECT_EQ(find_data_type(0x0009)->size, 0);  // VISIBLE_STRING: variable
  EXPECT_EQ(find_data_type(0x000C)->size, 6);  // TIME_OF_DAY
  EXPECT_EQ(find_data_type(0x0001)->bit_size, 1);
  EXPECT_FALSE(find_data_type(0x0000));
  EXPECT_FALSE(find_data_type(0x000E));
  EXPECT_FALSE(find_data_type(0x0017));
  EXPECT_FALSE(find_data_type(0x0020));  // PDO_COMMUNICATION_PARAMETER is not basic
  EXPECT_EQ(data_type_table().size(), 25u);
}

TEST(ValueEncoding, IsLittleEndianTwosComplement) {
  // Given values of several types
  // When encoded
  // Then the bytes are little endian, signed values two's complement of the type's width
  EXPECT_EQ(encoded(DataType::unsigned16, Value::of_unsigned(0x6041)), (Bytes{0x41, 0x60}));
  EXPECT_EQ(encoded(DataType::integer24, Value::of_signed(-2)), (Bytes{0xFE, 0xFF, 0xFF}));
  EXPECT_EQ(encoded(DataType::integer8, Value::of_signed(-128)), (Bytes{0x80}));
  EXPECT_EQ(encoded(DataType::real32, Value::of_real(1.0)), (Bytes{0x00, 0x00, 0x80, 0x3F}));
  EXPECT_EQ(encoded(DataType::unsigned40, Value::of_unsigned(0x0102030405)),
            (Bytes{0x05, 0x04, 0x03, 0x02, 0x01}));
  EXPECT_EQ(encoded(DataType::visible_string, Value::of_string("XS")), (Bytes{'X', 'S'}));
}

TEST(ValueEncoding, DecodeReversesEncode) {
  // Given encoded bytes of every fixed-size integer type at its extremes
  // When decoded
  // Then the value comes back, and a wrong byte count is an error
  for (const auto& row : data_type_table()) {
    if (row.type_class != TypeClass::signed_integer &&
        row.type_class != TypeClass::unsigned_integer) {
      continue;
    }
    const Value v =
        row.type_class == TypeClass::signed_integer
            ? Value::of_signed(row.size == 8 ? std::numeric_limits<std::int64_t>::min()
                                             : -(std::int64_t{1} << (8 * row.size - 1)))
            : Value::of_unsigned(row.size == 8 ? ~std::uint64_t{0}
                                               : (std::uint64_t{1} << (8 * row.size)) - 1);
    const auto bytes = encoded(row.type, v);
    ASSERT_EQ(bytes.size(), row.size) << row.name;
    const auto back = decode(row.type, bytes);
    ASSERT_TRUE(back) << row.name;
    EXPECT_EQ(*back, v) << row.name;
  }
  EXPECT_FALSE(decode(DataType::unsigned16, Bytes{0x01}));
  EXPECT_FALSE(decode(DataType::boolean, Bytes{0x02}));
  EXPECT_FALSE(decode(DataType::unicode_string, Bytes{0x41}));
}

TEST(ValueEncoding, RejectsValuesOutsideTheType) {
  // Given values too large for their type, or of the wrong kind
  // When encoded
  // Then each is an error
  EXPECT_FALSE(encode(DataType::unsigned8, Value::of_unsigned(256)));
  EXPECT_FALSE(encode(DataType::integer16, Value::of_signed(40000)));
  EXPECT_FALSE(encode(DataType::integer16, Value::of_signed(-32769)));
  EXPECT_FALSE(encode(DataType::boolean, Value::of_unsigned(2)));
  EXPECT_FALSE(encode(DataType::unsigned32, Value::of_signed(1)));
  EXPECT_FALSE(encode(DataType::real32, Value::of_real(1e39)));
}

Value text_value(DataType type, std::string_view text) {
  auto parsed = parse_value_text(type, text);
  EXPECT_TRUE(parsed) << text << ": " << (parsed ? "" : parsed.error());
  return parsed ? parsed->value : Value();
}

TEST(ValueText, ReadsCiA306Numbers) {
  // Given CiA 306 number spellings
  // When parsed for their type
  // Then decimal, 0x hex (any case) and leading-0 octal give the values CiA 306 defines
  EXPECT_EQ(text_value(DataType::unsigned16, "123"), Value::of_unsigned(123));
  EXPECT_EQ(text_value(DataType::unsigned16, "0x7b"), Value::of_unsigned(123));
  EXPECT_EQ(text_value(DataType::unsigned16, "0X7B"), Value::of_unsigned(123));
  EXPECT_EQ(text_value(DataType::unsigned16, "0173"), Value::of_unsigned(123));
  EXPECT_EQ(text_value(DataType::unsigned16, "0"), Value::of_unsigned(0));
  EXPECT_EQ(text_value(DataType::unsigned16, " 7 "), Value::of_unsigned(7));
  EXPECT_EQ(text_value(DataType::integer8, "-5"), Value::of_signed(-5));
  EXPECT_EQ(text_value(DataType::integer16, "0xFFFF"), Value::of_signed(-1));
  EXPECT_EQ(text_value(DataType::integer8, "0x80"), Value::of_signed(-128));
  EXPECT_EQ(text_value(DataType::integer64, "-9223372036854775808"),
            Value::of_signed(std::numeric_limits<std::int64_t>::min()));
  EXPECT_EQ(text_value(DataType::unsigned64, "0xFFFFFFFFFFFFFFFF"),
            Value::of_unsigned(~std::uint64_t{0}));
  EXPECT_EQ(text_value(DataType::boolean, "1"), Value::of_unsigned(1));
  const auto hex = parse_value_text(DataType::unsigned16, "1A");
  ASSERT_TRUE(hex);
  EXPECT_EQ(hex->value, Value::of_unsigned(0x1A));
  EXPECT_TRUE(hex->hex_without_prefix);
}

TEST(ValueText, RejectsBadNumbersWithAReason) {
  // Given numbers that do not fit or do not parse
  // When parsed
  // Then each is an error that says why
  const auto octal = parse_value_text(DataType::unsigned16, "089");
  ASSERT_FALSE(octal);
  EXPECT_EQ(octal.error(), "'089' is not an octal number (CiA 306 reads a leading 0 as octal)");
  EXPECT_EQ(parse_value_text(DataType::unsigned8, "256").error(), "256 does not fit UNSIGNED8");
  EXPECT_EQ(parse_value_text(DataType::unsigned8, "-1").error(),
            "-1 is negative, UNSIGNED8 is unsigned");
  EXPECT_EQ(parse_value_text(DataType::integer8, "128").error(), "128 is above the INTEGER8 range");
  EXPECT_EQ(parse_value_text(DataType::integer8, "-129").error(),
            "-129 is below the INTEGER8 range");
  EXPECT_EQ(parse_value_text(DataType::boolean, "2").error(), "2 does not fit BOOLEAN");
  EXPECT_FALSE(parse_value_text(DataType::unsigned32, ""));
  EXPECT_FALSE(parse_value_text(DataType::unsigned32, "0x"));
  EXPECT_FALSE(parse_value_text(DataType::unsigned32, "12abc!"));
  EXPECT_FALSE(parse_value_text(DataType::unsigned64, "0x1FFFFFFFFFFFFFFFF"));
}

TEST(ValueText, ReadsEveryNodeIdForm) {
  // Given the $NODEID spellings CiA 306 tools write
  // When parsed and resolved for node 5
  // Then each adds the node-ID to its constant
  for (const char* text :
       {"$NODEID+0x180", "0x180+$NODEID", "$nodeid + 0x180", " 384 + $NodeId "}) {
    const auto parsed = parse_value_text(DataType::unsigned32, text);
    ASSERT_TRUE(parsed) << text;
    EXPECT_TRUE(parsed->node_id_relative) << text;
    EXPECT_EQ(parsed->value, Value::of_unsigned(0x180)) << text;
    EXPECT_EQ(*resolve(DataType::unsigned32, *parsed, 5), Value::of_unsigned(0x185)) << text;
  }
  const auto alone = parse_value_text(DataType::unsigned8, "$NODEID");
  ASSERT_TRUE(alone);
  EXPECT_EQ(*resolve(DataType::unsigned8, *alone, 127), Value::of_unsigned(127));
  for (const char* text :
       {"$NODEID-1", "$NODEID+$NODEID", "2*$NODEID", "$NODEID+", "+$NODEID", "$NODEID0x180"}) {
    EXPECT_FALSE(parse_value_text(DataType::unsigned32, text)) << text;
  }
  const auto near_max = parse_value_text(DataType::unsigned8, "$NODEID+250");
  ASSERT_TRUE(near_max);
  EXPECT_FALSE(resolve(DataType::unsigned8, *near_max, 10));
  const auto wraps = parse_value_text(DataType::unsigned64, "$NODEID+0xFFFFFFFFFFFFFFFF");
  ASSERT_TRUE(wraps);
  EXPECT_FALSE(resolve(DataType::unsigned64, *wraps, 1));
}

TEST(ValueText, ReadsRealsStringsAndBytes) {
  // Given value text of the non-integer families
  // When parsed
  // Then reals, strings, octet strings and unicode strings get their values
  EXPECT_EQ(text_value(DataType::real32, "1.5"), Value::of_real(1.5));
  EXPECT_EQ(text_value(DataType::real64, "-2e-3"), Value::of_real(-2e-3));
  EXPECT_EQ(text_value(DataType::real32, "0.1"), Value::of_real(static_cast<double>(0.1f)));
  const auto pattern = parse_value_text(DataType::real32, "0x3F800000");
  ASSERT_TRUE(pattern);
  EXPECT_EQ(pattern->value, Value::of_real(1.0));
  EXPECT_TRUE(pattern->nonstandard_spelling);
  EXPECT_FALSE(parse_value_text(DataType::real32, "fast"));
  EXPECT_FALSE(parse_value_text(DataType::real32, "1e39"));
  EXPECT_EQ(text_value(DataType::visible_string, "Servo drive 7"),
            Value::of_string("Servo drive 7"));
  EXPECT_EQ(text_value(DataType::octet_string, "01 a2FF"),
            Value::of_bytes(Bytes{0x01, 0xA2, 0xFF}));
  EXPECT_EQ(text_value(DataType::domain, ""), Value::of_bytes(Bytes{}));
  EXPECT_FALSE(parse_value_text(DataType::octet_string, "0A1"));
  EXPECT_FALSE(parse_value_text(DataType::octet_string, "0G"));
  EXPECT_EQ(text_value(DataType::unicode_string, "A\xC3\x9C"),
            Value::of_bytes(Bytes{0x41, 0x00, 0xDC, 0x00}));
  EXPECT_FALSE(parse_value_text(DataType::unicode_string, "\xFF"));
}

TEST(ValueText, FormatsCanonicallyAndReadsBack) {
  // Given typed values
  // When formatted as EDS text and parsed again
  // Then the text is canonical and the value is unchanged
  EXPECT_EQ(format_value_text(DataType::unsigned32, Value::of_unsigned(0x180)), "0x180");
  EXPECT_EQ(format_value_text(DataType::unsigned32, Value::of_unsigned(0x180), true),
            "$NODEID+0x180");
  EXPECT_EQ(format_value_text(DataType::unsigned8, Value::of_unsigned(0), true), "$NODEID");
  EXPECT_EQ(format_value_text(DataType::integer16, Value::of_signed(-1)), "-1");
  EXPECT_EQ(format_value_text(DataType::boolean, Value::of_unsigned(1)), "1");
  EXPECT_EQ(format_value_text(DataType::real32, Value::of_real(static_cast<double>(0.1f))), "0.1");
  EXPECT_EQ(format_value_text(DataType::octet_string, Value::of_bytes(Bytes{0x01, 0xA2})), "01A2");
  const std::pair<DataType, Value> cases[] = {
      {DataType::unsigned64, Value::of_unsigned(~std::uint64_t{0})},
      {DataType::integer56, Value::of_signed(-(std::int64_t{1} << 55))},
      {DataType::real64, Value::of_real(0.1)},
      {DataType::real32, Value::of_real(static_cast<double>(3.14159f))},
      {DataType::real64, Value::of_real(-1e300)},
      {DataType::visible_string, Value::of_string("a = b")},
      {DataType::unicode_string,
       Value::of_bytes(Bytes{0x41, 0x00, 0x3D, 0xD8, 0x00, 0xDE})},  // A, U+1F600
      {DataType::time_of_day, Value::of_unsigned(0x123404D2A8C0)},
  };
  for (const auto& [type, value] : cases) {
    const auto text = format_value_text(type, value);
    const auto back = parse_value_text(type, text);
    ASSERT_TRUE(back) << text;
    EXPECT_EQ(back->value, value) << info(type).name << " " << text;
  }
}

TEST(AccessTypes, ParseCaseInsensitively) {
  // Given CiA 306 AccessType spellings
  // When parsed
  // Then the six access types are recognised and anything else is not
  EXPECT_EQ(parse_access_type("RW"), AccessType::rw);
  EXPECT_EQ(parse_access_type("Const"), AccessType::constant);
  EXPECT_EQ(parse_access_type("rwr"), AccessType::rwr);
  EXPECT_FALSE(parse_access_type("r"));
  EXPECT_FALSE(parse_access_type("readwrite"));
  EXPECT_TRUE(is_writable(AccessType::rww));
  EXPECT_FALSE(is_writable(AccessType::constant));
  EXPECT_FALSE(is_readable(AccessType::wo));
  EXPECT_EQ(to_string(AccessType::constant), "const");
}

TEST(ObjectCodes, AreTheCiA301Values) {
  // Given the numeric object codes of CiA 301 Table 42
  // When converted
  // Then the defined ones map to their names and the gaps do not
  EXPECT_EQ(to_object_code(0x7), ObjectCode::var);
  EXPECT_EQ(to_object_code(0x9), ObjectCode::record);
  EXPECT_EQ(to_string(ObjectCode::deftype), "DEFTYPE");
  EXPECT_FALSE(to_object_code(0x3));
  EXPECT_FALSE(to_object_code(0xA));
  EXPECT_TRUE(has_sub_entries(ObjectCode::array));
  EXPECT_FALSE(has_sub_entries(ObjectCode::domain));
}

}  // namespace
}  // namespace drivecheck::cia301

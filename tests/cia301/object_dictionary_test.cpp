#include "protocol/cia301/object_dictionary.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <vector>

// Counts heap allocations so that a test can prove the SDO hot path does not allocate.
namespace {
std::atomic<std::size_t> g_allocations{0};
}  // namespace

// gcc flags free() of operator new's memory; here both sides are ours (malloc/free).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
#pragma GCC diagnostic pop

namespace drivecheck::cia301 {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes bytes_of(Expected<std::span<const std::uint8_t>, SdoAbort> read) {
  EXPECT_TRUE(read) << (read ? "" : describe_sdo_abort(static_cast<std::uint32_t>(read.error())));
  return read ? Bytes(read->begin(), read->end()) : Bytes{};
}

EntryDefinition entry(std::uint8_t sub, std::string name, DataType type, AccessType access,
                      Value default_value = {}) {
  EntryDefinition e;
  e.sub_index = sub;
  e.name = std::move(name);
  e.type = type;
  e.access = access;
  e.default_value = std::move(default_value);
  return e;
}

// A small servo drive dictionary.
class ObjectDictionaryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(od_.add_var(0x1000, "Device type", DataType::unsigned32, AccessType::ro,
                            Value::of_unsigned(0x00020192)));
    ASSERT_TRUE(od_.add_var(0x1008, "Manufacturer device name", DataType::visible_string,
                            AccessType::constant, Value::of_string("XS-400")));
    ASSERT_TRUE(
        od_.add_var(0x1017, "Producer heartbeat time", DataType::unsigned16, AccessType::rw));
    auto cob_emcy =
        entry(0, "COB-ID EMCY", DataType::unsigned32, AccessType::rw, Value::of_unsigned(0x80));
    cob_emcy.default_adds_node_id = true;
    ASSERT_TRUE(od_.add_object({0x1014, "COB-ID EMCY", ObjectCode::var, {cob_emcy}}));
    ASSERT_TRUE(od_.add_object({0x1018,
                                "Identity object",
                                ObjectCode::record,
                                {entry(0, "Highest sub-index supported", DataType::unsigned8,
                                       AccessType::ro, Value::of_unsigned(1)),
                                 entry(1, "Vendor-ID", DataType::unsigned32, AccessType::ro,
                                       Value::of_unsigned(0x1A2))}}));
    ASSERT_TRUE(
        od_.add_var(0x6040, "Controlword", DataType::unsigned16, AccessType::rww, {}, true));
    ASSERT_TRUE(od_.add_var(0x6041, "Statusword", DataType::unsigned16, AccessType::ro, {}, true));
    auto modes =
        entry(0, "Modes of operation", DataType::integer8, AccessType::rw, Value::of_signed(0));
    modes.low_limit = Value::of_signed(-3);
    modes.high_limit = Value::of_signed(10);
    ASSERT_TRUE(od_.add_object({0x6060, "Modes of operation", ObjectCode::var, {modes}}));
    ASSERT_TRUE(od_.add_var(0x607A, "Target position", DataType::integer32, AccessType::rw));
    ASSERT_TRUE(od_.add_var(0x2000, "Password", DataType::unsigned32, AccessType::wo));
    ASSERT_TRUE(od_.add_var(0x2001, "Enable", DataType::boolean, AccessType::rw));
    ASSERT_TRUE(od_.add_var(0x2002, "Label", DataType::unicode_string, AccessType::rw));
    auto name =
        entry(0, "Axis name", DataType::visible_string, AccessType::rw, Value::of_string("X"));
    name.max_size = 8;
    ASSERT_TRUE(od_.add_object({0x2003, "Axis name", ObjectCode::var, {name}}));
    auto gain = entry(0, "Gain", DataType::real32, AccessType::rw, Value::of_real(1.0));
    gain.low_limit = Value::of_real(0.0);
    gain.high_limit = Value::of_real(100.0);
    ASSERT_TRUE(od_.add_object({0x2004, "Gain", ObjectCode::var, {gain}}));
  }

  ObjectDictionary od_{5};
};

TEST_F(ObjectDictionaryTest, ReadGivesLittleEndianBytes) {
  // Given 1000h with default 00020192h
  // When an SDO server reads it
  // Then the bytes are little endian
  EXPECT_EQ(bytes_of(od_.read(0x1000, 0)), (Bytes{0x92, 0x01, 0x02, 0x00}));
  EXPECT_EQ(bytes_of(od_.read(0x1008, 0)), (Bytes{'X', 'S', '-', '4', '0', '0'}));
  EXPECT_EQ(bytes_of(od_.read(0x1018, 1)), (Bytes{0xA2, 0x01, 0x00, 0x00}));
}

TEST_F(ObjectDictionaryTest, MissingObjectOrSubIndexAborts) {
  // Given indices and sub-indices the dictionary does not have
  // When read or written
  // Then the abort is 06020000h for the object and 06090011h for the sub-index
  EXPECT_EQ(od_.read(0x1234, 0).error(), SdoAbort::object_does_not_exist);
  EXPECT_EQ(od_.write(0x1234, 0, Bytes{1}).error(), SdoAbort::object_does_not_exist);
  EXPECT_EQ(od_.read(0x1018, 9).error(), SdoAbort::sub_index_does_not_exist);
  EXPECT_EQ(od_.read(0x6041, 1).error(), SdoAbort::sub_index_does_not_exist);  // VAR, sub 1
  EXPECT_EQ(od_.write(0x6041, 1, Bytes{1, 2}).error(), SdoAbort::sub_index_does_not_exist);
}

TEST_F(ObjectDictionaryTest, AccessTypeMisuseAborts) {
  // Given a wo, a ro and a const entry
  // When the wo one is read and the others written
  // Then 06010001h and 06010002h (const counts as read only)
  EXPECT_EQ(od_.read(0x2000, 0).error(), SdoAbort::read_write_only);
  // Festo's example: a 32-bit write to statusword 6041h (ro)
  EXPECT_EQ(od_.write(0x6041, 0, Bytes{0, 0, 0, 0}).error(), SdoAbort::write_read_only);
  EXPECT_EQ(od_.write(0x6041, 0, Bytes{0, 0}).error(), SdoAbort::write_read_only);
  EXPECT_EQ(od_.write(0x1008, 0, Bytes{'A'}).error(), SdoAbort::write_read_only);
  EXPECT_TRUE(od_.write(0x2000, 0, Bytes{1, 2, 3, 4}));
}

TEST_F(ObjectDictionaryTest, WrongLengthAborts) {
  // Given fixed-size, bounded and UNICODE entries
  // When written with the wrong number of bytes
  // Then too long is 06070012h, too short 06070013h, an odd UNICODE length 06070010h
  EXPECT_EQ(od_.write(0x6040, 0, Bytes{0x0F, 0, 0, 0}).error(), SdoAbort::length_too_high);
  EXPECT_EQ(od_.write(0x6040, 0, Bytes{0x0F}).error(), SdoAbort::length_too_low);
  EXPECT_EQ(od_.write(0x607A, 0, Bytes{}).error(), SdoAbort::length_too_low);
  EXPECT_EQ(od_.write(0x2003, 0, Bytes(9, 'a')).error(), SdoAbort::length_too_high);
  EXPECT_TRUE(od_.write(0x2003, 0, Bytes(8, 'a')));
  EXPECT_EQ(od_.write(0x2002, 0, Bytes{0x41, 0x00, 0x42}).error(), SdoAbort::length_mismatch);
  EXPECT_TRUE(od_.write(0x2002, 0, Bytes{0x41, 0x00}));
}

TEST_F(ObjectDictionaryTest, ValuesOutsideLimitsAbort) {
  // Given 6060h limited to -3..10 and a REAL32 gain limited to 0..100
  // When values outside are written
  // Then 06090031h above, 06090032h below, 06090030h for NaN and a BOOLEAN of 2
  EXPECT_EQ(od_.write(0x6060, 0, Bytes{11}).error(), SdoAbort::value_too_high);
  EXPECT_EQ(od_.write(0x6060, 0, Bytes{0xFC}).error(), SdoAbort::value_too_low);  // -4
  EXPECT_TRUE(od_.write(0x6060, 0, Bytes{0xFD}));                                 // -3
  EXPECT_TRUE(od_.write(0x6060, 0, Bytes{10}));
  EXPECT_EQ(od_.write(0x2004, 0, Bytes{0x00, 0x00, 0xC9, 0x42}).error(),
            SdoAbort::value_too_high);  // 100.5
  EXPECT_EQ(od_.write(0x2004, 0, Bytes{0x00, 0x00, 0x80, 0xBF}).error(),
            SdoAbort::value_too_low);  // -1.0
  EXPECT_EQ(od_.write(0x2004, 0, Bytes{0x00, 0x00, 0xC0, 0x7F}).error(),
            SdoAbort::invalid_value);  // NaN
  EXPECT_EQ(od_.write(0x2001, 0, Bytes{2}).error(), SdoAbort::invalid_value);
  EXPECT_TRUE(od_.write(0x2001, 0, Bytes{1}));
}

TEST_F(ObjectDictionaryTest, WriteStoresAndAbortLeavesValue) {
  // Given 607Ah at 0
  // When written successfully, then with a refused length
  // Then the first value is read back and the refused write changed nothing
  ASSERT_TRUE(od_.write(0x607A, 0, Bytes{0x10, 0x27, 0x00, 0x00}));
  EXPECT_EQ(od_.get(0x607A, 0).value(), Value::of_signed(10000));
  EXPECT_FALSE(od_.write(0x607A, 0, Bytes{1, 2}));
  EXPECT_EQ(bytes_of(od_.read(0x607A, 0)), (Bytes{0x10, 0x27, 0x00, 0x00}));
  EXPECT_EQ(od_.write(0x6060, 0, Bytes{11}).error(), SdoAbort::value_too_high);
  EXPECT_EQ(od_.get(0x6060, 0).value(), Value::of_signed(0));
}

TEST_F(ObjectDictionaryTest, ValidatorRefusesAndObserverReacts) {
  // Given 6040h with a validator refusing 0xFFFF and an observer counting writes
  // When 0xFFFF and then 0x000F are written
  // Then the first aborts with the validator's code without calling the observer
  int observed = 0;
  Entry* controlword = od_.find(0x6040, 0);
  ASSERT_NE(controlword, nullptr);
  controlword->set_write_validator(
      [](const ObjectDictionary&, const Entry&,
         std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        if (load_unsigned(data) == 0xFFFF)
          return Unexpected(SdoAbort::general_parameter_incompatibility);
        return {};
      });
  controlword->set_write_observer([&observed](ObjectDictionary& od, Entry& e) {
    ++observed;
    // React: mirror the low byte into the statusword, as an application would.
    (void)od.set(0x6041, 0, Value::of_unsigned(e.as_unsigned() & 0xFF));
  });
  EXPECT_EQ(od_.write(0x6040, 0, Bytes{0xFF, 0xFF}).error(),
            SdoAbort::general_parameter_incompatibility);
  EXPECT_EQ(observed, 0);
  ASSERT_TRUE(od_.write(0x6040, 0, Bytes{0x0F, 0x00}));
  EXPECT_EQ(observed, 1);
  EXPECT_EQ(od_.get(0x6041, 0).value(), Value::of_unsigned(0x0F));
}

TEST(ObjectDictionaryHooks, ErrorHistoryWriteZeroClears) {
  // Given 1003h with two recorded errors, sub 0 writable only with 0 (CiA 301 §7.5.2.4)
  // When 1 and then 0 are written to sub 0
  // Then 1 aborts with 06090030h, 0 clears the history, and reading past it aborts 08000024h
  ObjectDictionary od;
  std::vector<EntryDefinition> entries{
      entry(0, "Number of errors", DataType::unsigned8, AccessType::rw, Value::of_unsigned(2))};
  for (std::uint8_t i = 1; i <= 4; ++i) {
    entries.push_back(entry(i, "Standard error field", DataType::unsigned32, AccessType::ro));
  }
  auto added =
      od.add_object({0x1003, "Pre-defined error field", ObjectCode::array, std::move(entries)});
  ASSERT_TRUE(added);
  Object& history = **added;
  history.find(1)->assign_unsigned(0x00008130);
  history.find(2)->assign_unsigned(0x00002310);
  history.find(0)->set_write_validator(
      [](const ObjectDictionary&, const Entry&,
         std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        if (data[0] != 0) return Unexpected(SdoAbort::invalid_value);
        return {};
      });
  history.find(0)->set_write_observer([](ObjectDictionary& dict, Entry&) {
    for (std::uint8_t sub = 1; sub <= 4; ++sub)
      dict.find(0x1003, sub)->assign_unsigned(0);
  });
  for (std::uint8_t sub = 1; sub <= 4; ++sub) {
    history.find(sub)->set_read_hook(
        [sub](ObjectDictionary& dict, Entry&) -> Expected<void, SdoAbort> {
          if (sub > dict.find(0x1003, 0)->as_unsigned())
            return Unexpected(SdoAbort::no_data_available);
          return {};
        });
  }
  EXPECT_EQ(bytes_of(od.read(0x1003, 2)), (Bytes{0x10, 0x23, 0x00, 0x00}));
  EXPECT_EQ(od.read(0x1003, 3).error(), SdoAbort::no_data_available);
  EXPECT_EQ(od.write(0x1003, 0, Bytes{1}).error(), SdoAbort::invalid_value);
  ASSERT_TRUE(od.write(0x1003, 0, Bytes{0}));
  EXPECT_EQ(od.read(0x1003, 1).error(), SdoAbort::no_data_available);
  EXPECT_EQ(od.get(0x1003, 1).value(), Value::of_unsigned(0));
}

TEST_F(ObjectDictionaryTest, ReadHookRefreshesTheValue) {
  // Given a statusword whose value lives in the application
  // When it is read through the SDO path
  // Then the hook's fresh value is returned
  std::uint16_t application_status = 0x0237;
  od_.find(0x6041, 0)->set_read_hook(
      [&application_status](ObjectDictionary&, Entry& e) -> Expected<void, SdoAbort> {
        e.assign_unsigned(application_status);
        return {};
      });
  EXPECT_EQ(bytes_of(od_.read(0x6041, 0)), (Bytes{0x37, 0x02}));
  application_status = 0x0631;
  EXPECT_EQ(bytes_of(od_.read(0x6041, 0)), (Bytes{0x31, 0x06}));
}

TEST_F(ObjectDictionaryTest, ApplicationSetIgnoresAccessButChecksType) {
  // Given the ro statusword
  // When the application sets it, then sets values of the wrong kind or size
  // Then the first succeeds and the others are refused with 06090030h
  ASSERT_TRUE(od_.set(0x6041, 0, Value::of_unsigned(0x0637)));
  EXPECT_EQ(bytes_of(od_.read(0x6041, 0)), (Bytes{0x37, 0x06}));
  EXPECT_EQ(od_.set(0x6041, 0, Value::of_signed(1)).error(), SdoAbort::invalid_value);
  EXPECT_EQ(od_.set(0x6041, 0, Value::of_unsigned(0x10000)).error(), SdoAbort::invalid_value);
  EXPECT_EQ(od_.set(0x9999, 0, Value::of_unsigned(1)).error(), SdoAbort::object_does_not_exist);
}

TEST_F(ObjectDictionaryTest, NodeIdDefaultsFollowTheNodeId) {
  // Given 1014h = $NODEID+0x80 in a dictionary for node 5
  // When the node-ID changes to 7 and the communication defaults are restored
  // Then the COB-ID follows: 85h, then 87h
  EXPECT_EQ(od_.get(0x1014, 0).value(), Value::of_unsigned(0x85));
  od_.set_node_id(7);
  EXPECT_EQ(od_.get(0x1014, 0).value(), Value::of_unsigned(0x85));
  od_.restore_defaults(kStoreCommunication);
  EXPECT_EQ(od_.get(0x1014, 0).value(), Value::of_unsigned(0x87));
}

TEST_F(ObjectDictionaryTest, StoreAndRestoreByGroup) {
  // Given changed communication (1017h) and application (607Ah) parameters
  // When saved, the communication defaults restored, then the saved values loaded
  // Then only 1017h returns to its default, and loading brings both back
  ASSERT_TRUE(od_.write(0x1017, 0, Bytes{0xE8, 0x03}));
  ASSERT_TRUE(od_.write(0x607A, 0, Bytes{5, 0, 0, 0}));
  const auto saved = od_.save(kStoreAll);
  const auto has = [&saved](std::uint16_t index) {
    return std::any_of(saved.begin(), saved.end(),
                       [index](const auto& s) { return s.index == index; });
  };
  EXPECT_TRUE(has(0x1017));
  EXPECT_TRUE(has(0x607A));
  EXPECT_TRUE(has(0x2003));   // manufacturer group
  EXPECT_FALSE(has(0x1000));  // read only: never stored
  EXPECT_FALSE(has(0x6041));
  EXPECT_EQ(od_.find(0x607A, 0)->store_group(), kStoreApplication);
  EXPECT_EQ(od_.find(0x2003, 0)->store_group(), kStoreManufacturer);
  od_.restore_defaults(kStoreCommunication);
  EXPECT_EQ(od_.get(0x1017, 0).value(), Value::of_unsigned(0));
  EXPECT_EQ(od_.get(0x607A, 0).value(), Value::of_signed(5));
  od_.restore_defaults(kStoreAll);
  EXPECT_EQ(od_.get(0x607A, 0).value(), Value::of_signed(0));
  EXPECT_EQ(od_.load(saved), saved.size());
  EXPECT_EQ(od_.get(0x1017, 0).value(), Value::of_unsigned(1000));
  EXPECT_EQ(od_.get(0x607A, 0).value(), Value::of_signed(5));
}

TEST(ObjectDictionaryBuild, RejectsInconsistentDefinitions) {
  // Given object definitions that break CiA 301 structure rules
  // When added
  // Then each is refused with a message naming the object
  ObjectDictionary od;
  ASSERT_TRUE(od.add_var(0x1000, "Device type", DataType::unsigned32, AccessType::ro));
  EXPECT_EQ(od.add_var(0x1000, "Again", DataType::unsigned32, AccessType::ro).error(),
            "1000h: object already exists");
  EXPECT_FALSE(od.add_object({0x2000,
                              "VAR at sub 1",
                              ObjectCode::var,
                              {entry(1, "x", DataType::unsigned8, AccessType::rw)}}));
  EXPECT_FALSE(od.add_object({0x2001,
                              "RECORD without sub 0",
                              ObjectCode::record,
                              {entry(1, "x", DataType::unsigned8, AccessType::rw)}}));
  EXPECT_FALSE(od.add_object({0x2002,
                              "sub 0 not UNSIGNED8",
                              ObjectCode::array,
                              {entry(0, "n", DataType::unsigned16, AccessType::ro)}}));
  EXPECT_FALSE(od.add_object({0x2003,
                              "unsorted",
                              ObjectCode::array,
                              {entry(0, "n", DataType::unsigned8, AccessType::ro),
                               entry(2, "b", DataType::unsigned8, AccessType::rw),
                               entry(1, "a", DataType::unsigned8, AccessType::rw)}}));
  EXPECT_EQ(
      od.add_var(0x2004, "too big", DataType::unsigned8, AccessType::rw, Value::of_unsigned(300))
          .error(),
      "2004h sub 0: default: 300 does not fit UNSIGNED8");
  auto limited = entry(0, "limited string", DataType::visible_string, AccessType::rw);
  limited.low_limit = Value::of_unsigned(1);
  EXPECT_FALSE(od.add_object({0x2005, "limited string", ObjectCode::var, {limited}}));
  EXPECT_EQ(od.objects().size(), 1u);
}

TEST_F(ObjectDictionaryTest, ExpeditedAccessDoesNotAllocate) {
  // Given a built dictionary with hooks installed
  // When expedited-size entries are read and written many times
  // Then no heap allocation happens on that path
  od_.find(0x6041, 0)->set_read_hook([](ObjectDictionary&, Entry& e) -> Expected<void, SdoAbort> {
    e.assign_unsigned(0x0237);
    return {};
  });
  const std::uint8_t controlword[] = {0x0F, 0x00};
  const std::uint8_t too_long[] = {0x0F, 0x00, 0x00};
  const std::size_t before = g_allocations.load();
  std::uint64_t sum = 0;
  for (int i = 0; i < 1000; ++i) {
    sum += od_.read(0x6041, 0)->size();
    sum += od_.read(0x1018, 1)->size();
    sum += od_.write(0x6040, 0, controlword) ? 1 : 0;
    sum += od_.write(0x6040, 0, too_long) ? 0 : 1;
    sum += od_.read(0x1234, 0) ? 0 : 1;
  }
  EXPECT_EQ(g_allocations.load(), before);
  EXPECT_EQ(sum, 1000u * (2 + 4 + 1 + 1 + 1));
}

TEST_F(ObjectDictionaryTest, EveryStoreMovesTheRevisions) {
  // Given the dictionary and its 1017h entry
  Entry& heartbeat = *od_.find(0x1017, 0);
  const Entry& vendor = *od_.find(0x1018, 1);
  std::uint64_t od_revision = od_.revision();
  std::uint64_t revision = heartbeat.revision();
  const std::uint64_t vendor_revision = vendor.revision();
  // When its value is stored through each path, Then its revision and the dictionary's move
  const auto moved = [&](const char* path) {
    EXPECT_GT(heartbeat.revision(), revision) << path;
    EXPECT_GT(od_.revision(), od_revision) << path;
    revision = heartbeat.revision();
    od_revision = od_.revision();
  };
  ASSERT_TRUE(od_.write(0x1017, 0, Bytes{0x64, 0x00}));
  moved("SDO write");
  ASSERT_TRUE(od_.write(0x1017, 0, Bytes{0x64, 0x00}));
  moved("SDO write of the same bytes");
  ASSERT_TRUE(od_.set(0x1017, 0, Value::of_unsigned(200)));
  moved("set");
  ASSERT_TRUE(heartbeat.assign(Value::of_unsigned(300)));
  moved("assign");
  ASSERT_TRUE(heartbeat.assign_bytes(Bytes{0x01, 0x02}));
  moved("assign_bytes");
  heartbeat.assign_unsigned(400);
  moved("assign_unsigned");
  od_.restore_defaults(kStoreCommunication);
  moved("restore_defaults");
  EXPECT_EQ(od_.load({{0x1017, 0, Bytes{0x05, 0x00}}}), 1u);
  moved("load");
  const Entry saved = heartbeat;
  heartbeat = saved;
  moved("assignment of an entry");
  // And a failed write, a read and another entry's change leave this entry's revision alone
  EXPECT_FALSE(od_.write(0x1017, 0, Bytes{0x01}));
  (void)bytes_of(od_.read(0x1017, 0));
  ASSERT_TRUE(od_.write(0x6040, 0, Bytes{0x06, 0x00}));
  EXPECT_EQ(heartbeat.revision(), revision);
  EXPECT_EQ(vendor.revision(), vendor_revision);
}

TEST_F(ObjectDictionaryTest, RestoredDefaultsAreTheDefaultBytes) {
  // Given every writable entry changed
  for (const Object& object : od_.objects()) {
    for (const Entry& entry : object.entries()) {
      Entry& e = *od_.find(object.index(), entry.sub_index());
      if (e.store_group() == kStoreNone || e.bytes().empty()) continue;
      std::vector<std::uint8_t> changed(e.bytes().begin(), e.bytes().end());
      changed[0] ^= 0x01;
      ASSERT_TRUE(e.assign_bytes(changed));
    }
  }
  // When every group's defaults are restored
  od_.restore_defaults(kStoreAll);
  // Then every stored entry holds exactly its default bytes (node-ID applied)
  for (const Object& object : od_.objects()) {
    for (const Entry& entry : object.entries()) {
      if (entry.store_group() == kStoreNone) continue;
      const Bytes now(entry.bytes().begin(), entry.bytes().end());
      EXPECT_EQ(now, entry.default_bytes(od_.node_id()))
          << std::hex << object.index() << " sub " << int{entry.sub_index()};
    }
  }
}

TEST_F(ObjectDictionaryTest, RestoringUnchangedDefaultsStoresNothing) {
  // Given the communication defaults restored once, then 1017h written
  od_.restore_defaults(kStoreCommunication);
  ASSERT_TRUE(od_.write(0x1017, 0, Bytes{0x64, 0x00}));
  const Entry& heartbeat = *od_.find(0x1017, 0);
  const Entry& emcy = *od_.find(0x1014, 0);
  const std::uint64_t heartbeat_revision = heartbeat.revision();
  const std::uint64_t emcy_revision = emcy.revision();
  // When the defaults are restored again
  od_.restore_defaults(kStoreCommunication);
  // Then only the written entry is stored (its default is back), the untouched one is not
  EXPECT_GT(heartbeat.revision(), heartbeat_revision);
  EXPECT_EQ(bytes_of(od_.read(0x1017, 0)), (Bytes{0x00, 0x00}));
  EXPECT_EQ(emcy.revision(), emcy_revision);
  // And a new node-ID stores the $NODEID default again, with the new node-ID
  od_.set_node_id(0x22);
  od_.restore_defaults(kStoreCommunication);
  EXPECT_GT(emcy.revision(), emcy_revision);
  EXPECT_EQ(bytes_of(od_.read(0x1014, 0)), emcy.default_bytes(0x22));
  // And an entry assigned over (a store) is restored again even with its old bytes
  const std::uint64_t assigned = heartbeat.revision();
  Entry& target = *od_.find(0x1017, 0);
  const Entry saved = target;
  target = saved;
  od_.restore_defaults(kStoreCommunication);
  EXPECT_GT(heartbeat.revision(), assigned + 1);
}

TEST_F(ObjectDictionaryTest, CopiesCountOnTheirOwn) {
  // Given a copy and a moved copy of the dictionary
  ObjectDictionary copy = od_;
  ObjectDictionary moved = ObjectDictionary(od_);
  const std::uint64_t original = od_.revision();
  const std::uint64_t copied = copy.revision();
  const std::uint64_t moved_revision = moved.revision();
  // When the copy and the moved copy are written
  ASSERT_TRUE(copy.write(0x1017, 0, Bytes{0x0A, 0x00}));
  ASSERT_TRUE(moved.write(0x1017, 0, Bytes{0x0A, 0x00}));
  // Then only their own revisions move
  EXPECT_EQ(od_.revision(), original);
  EXPECT_GT(copy.revision(), copied);
  EXPECT_GT(moved.revision(), moved_revision);
  // And assigning a dictionary over another moves the target's revision
  const std::uint64_t before = copy.revision();
  copy = od_;
  EXPECT_GT(copy.revision(), before);
  ASSERT_TRUE(copy.write(0x1017, 0, Bytes{0x0B, 0x00}));
  EXPECT_EQ(od_.revision(), original);
}

}  // namespace
}  // namespace drivecheck::cia301

// The object dictionary (CiA 301 §7.4): index -> object (name, object code, sub-entries), each
// entry typed, with access type, PDO mappability, limits, a default and its current value as
// little-endian bytes, as an SDO server reads and writes them.
//
// SDO access (read/write) checks, in this order, and answers with the CiA 301 abort code
// (§7.2.4.3.17) of the first misuse:
//   no object at the index                    -> object_does_not_exist     0602 0000h
//   no entry at the sub-index                 -> sub_index_does_not_exist  0609 0011h
//   read of a wo entry                        -> read_write_only           0601 0001h
//   write of a ro or const entry              -> write_read_only           0601 0002h
//   write of a fixed-size type, too many bytes-> length_too_high           0607 0012h
//   write of a fixed-size type, too few bytes -> length_too_low            0607 0013h
//   write of a string/domain past max_size    -> length_too_high           0607 0012h
//   UNICODE_STRING of an odd number of bytes  -> length_mismatch           0607 0010h
//     (the length fits no value of the type at all, neither too long nor too short)
//   BOOLEAN byte other than 00h/01h           -> invalid_value             0609 0030h
//   integer/real above HighLimit              -> value_too_high            0609 0031h
//   integer/real below LowLimit               -> value_too_low             0609 0032h
//   REAL NaN where limits are set             -> invalid_value             0609 0030h
//   then the entry's write validator (any code it returns, e.g. PDO mapping rules)
// A successful write stores the bytes, then calls the entry's write observer.
// A read calls the entry's read hook (which may refresh the value or abort, e.g. 1003h
// sub-index past the number of errors: no_data_available) and returns a view of the bytes.
//
// Hot path: read and write of an existing fixed-size entry do not allocate (binary search
// over sorted objects and entries, bytes copied into storage sized at creation).
//
// Change tracking: every store into an entry's value (SDO write, Entry::assign*, set,
// restore_defaults, load, assignment of an Entry) increases the entry's revision() and the
// dictionary's revision(), whether or not the bytes differ. A dictionary whose revision() did not
// change has the same values; an entry whose revision() did not change has the same bytes. Each
// dictionary (copies too) counts on its own; a copy starts at the revisions of its original.
// restore_defaults skips (stores nothing into, counts nothing for) an entry that holds the
// default it stored itself, unchanged since (the same revision, for a $NODEID default the same
// node-ID): every reset restores its groups, and most entries were never written.
//
// Hooks may read and change any entry's value (set/get/write) but must not add objects:
// Object and Entry references stay valid until the next add_object.
//
// Store/restore (1010h/1011h): each writable entry belongs to a store group named by the
// 1010h/1011h sub-index that covers it: 2 communication (1000h-1FFFh), 3 application
// (6000h-9FFFh), 4 manufacturer (2000h-5FFFh) by default, 0 never stored (read-only entries,
// and 1003h, 1010h, 1011h). Sub-index 1 means every group.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

class ObjectDictionary;
class Entry;

// Called before an SDO read of the entry: may refresh its value, or refuse with an abort.
using ReadHook = std::function<Expected<void, SdoAbort>(ObjectDictionary&, Entry&)>;
// Called before a write is stored, after the type and limit checks: may refuse with an abort.
using WriteValidator = std::function<Expected<void, SdoAbort>(const ObjectDictionary&, const Entry&,
                                                              std::span<const std::uint8_t> data)>;
// Called after a write is stored: may react (change other entries, clear an array, ...).
using WriteObserver = std::function<void(ObjectDictionary&, Entry&)>;

inline constexpr std::uint8_t kStoreNone = 0;
inline constexpr std::uint8_t kStoreAll = 1;  // 1010h/1011h sub 1: all parameters
inline constexpr std::uint8_t kStoreCommunication = 2;
inline constexpr std::uint8_t kStoreApplication = 3;
inline constexpr std::uint8_t kStoreManufacturer = 4;

// What a description (an EDS, or code) says about one sub-index.
struct EntryDefinition {
  std::uint8_t sub_index = 0;
  std::string name;
  DataType type = DataType::unsigned8;
  AccessType access = AccessType::rw;
  bool pdo_mappable = false;
  Value default_value;                // empty: zero / no bytes (add_object stores that explicitly)
  bool default_adds_node_id = false;  // EDS "$NODEID+x": the value is default + node-ID
  Value low_limit;                    // empty: no limit (numeric types only)
  Value high_limit;
  std::uint32_t obj_flags = 0;  // CiA 306 ObjFlags (bit 0 refuse write, bit 1 refuse read)
  std::size_t max_size = 0;     // variable-length types: longest value accepted, 0 = any

  // An entry of an unsigned integer type with its default: the shape of most communication
  // objects (counts, COB-IDs, times).
  static EntryDefinition unsigned_entry(std::uint8_t sub_index, std::string name, DataType type,
                                        AccessType access, std::uint64_t default_value);
  // Any entry with its default value and PDO mapping flag (the application objects' shape).
  static EntryDefinition make(std::uint8_t sub_index, std::string name, DataType type,
                              AccessType access, Value default_value, bool pdo_mappable);
  // Sub-index 0 of an ARRAY/RECORD: "highest sub-index supported", UNSIGNED8 ro, = n.
  static EntryDefinition highest_sub_index(std::uint8_t n);

  friend bool operator==(const EntryDefinition&, const EntryDefinition&) = default;
};

struct ObjectDefinition {
  std::uint16_t index = 0;
  std::string name;
  ObjectCode code = ObjectCode::var;
  std::vector<EntryDefinition> entries;  // VAR/DOMAIN/DEFTYPE: sub 0 only; ARRAY/RECORD: sub 0..

  friend bool operator==(const ObjectDefinition&, const ObjectDefinition&) = default;
};

class Entry {
 public:
  const EntryDefinition& definition() const { return def_; }
  std::uint16_t index() const { return index_; }
  std::uint8_t sub_index() const { return def_.sub_index; }
  const std::string& name() const { return def_.name; }
  DataType type() const { return def_.type; }
  AccessType access() const { return def_.access; }
  bool pdo_mappable() const { return def_.pdo_mappable; }

  // The current value as it travels in an SDO (little endian).
  std::span<const std::uint8_t> bytes() const { return data_; }
  Value value() const;
  // Integer views of the current value (preconditions: an integer type).
  std::uint64_t as_unsigned() const { return load_unsigned(data_); }
  std::int64_t as_signed() const { return load_signed(data_); }

  // Application-side change of the value: type and range of the type are checked, access
  // and limits are not (a read-only statusword is changed this way). No hooks run.
  Expected<void, SdoAbort> assign(const Value& value);
  Expected<void, SdoAbort> assign_bytes(std::span<const std::uint8_t> bytes);
  // Fast path for integer entries; precondition: an integer type and a value that fits.
  void assign_unsigned(std::uint64_t value) {
    store_unsigned(value, data_);
    revision_.touch();
  }
  // Increases with every store into the value (see the file comment).
  std::uint64_t revision() const { return revision_.count; }

  // The default value (node-ID applied) as bytes.
  std::vector<std::uint8_t> default_bytes(std::uint8_t node_id) const;

  void set_read_hook(ReadHook hook) { read_hook_ = std::move(hook); }
  void set_write_validator(WriteValidator validator) { validator_ = std::move(validator); }
  void set_write_observer(WriteObserver observer) { observer_ = std::move(observer); }
  // The hooks set so far (empty when none), e.g. to chain a further check in front of one.
  const ReadHook& read_hook() const { return read_hook_; }
  const WriteValidator& write_validator() const { return validator_; }
  const WriteObserver& write_observer() const { return observer_; }
  std::uint8_t store_group() const { return store_group_; }
  void set_store_group(std::uint8_t group) { store_group_ = group; }

 private:
  friend class ObjectDictionary;
  EntryDefinition def_;
  std::uint16_t index_ = 0;
  std::uint8_t store_group_ = kStoreNone;
  // The entry's revision and the owning dictionary's counter. Copying an entry copies both (the
  // dictionary re-points its copies to itself); assigning one over another is a store into its
  // value: its own counters go up, it stays with its dictionary.
  struct Revision {
    std::uint64_t count = 0;
    std::uint64_t* dictionary = nullptr;
    Revision() = default;
    Revision(const Revision&) = default;
    Revision& operator=(const Revision&) {
      touch();
      return *this;
    }
    ~Revision() = default;
    void touch() {
      ++count;
      if (dictionary != nullptr) ++*dictionary;
    }
  };
  std::vector<std::uint8_t> data_;
  Revision revision_;
  // restore_defaults: the revision the entry had right after it last stored the default (0:
  // never; a revision is never 0 after a store), and the node-ID it applied. A copy keeps it
  // (same bytes, same revision); assigning an entry over another forgets it.
  struct RestoreMark {
    std::uint64_t revision = 0;
    std::uint8_t node_id = 0;
    RestoreMark() = default;
    RestoreMark(const RestoreMark&) = default;
    RestoreMark& operator=(const RestoreMark&) {
      revision = 0;
      return *this;
    }
    ~RestoreMark() = default;
  };
  RestoreMark restored_;
  ReadHook read_hook_;
  WriteValidator validator_;
  WriteObserver observer_;
};

class Object {
 public:
  std::uint16_t index() const { return index_; }
  const std::string& name() const { return name_; }
  ObjectCode code() const { return code_; }
  std::span<const Entry> entries() const { return entries_; }
  std::span<Entry> entries() { return entries_; }
  const Entry* find(std::uint8_t sub_index) const;
  Entry* find(std::uint8_t sub_index);
  ObjectDefinition definition() const;

 private:
  friend class ObjectDictionary;
  std::uint16_t index_ = 0;
  std::string name_;
  ObjectCode code_ = ObjectCode::var;
  std::vector<Entry> entries_;  // sorted by sub-index
};

class ObjectDictionary {
 public:
  explicit ObjectDictionary(std::uint8_t node_id = 1) : node_id_(node_id) {}
  ObjectDictionary(const ObjectDictionary& other);
  ObjectDictionary(ObjectDictionary&& other) noexcept;
  ObjectDictionary& operator=(const ObjectDictionary& other);
  ObjectDictionary& operator=(ObjectDictionary&& other) noexcept;
  ~ObjectDictionary() = default;

  // Increases with every store into any entry's value (see the file comment).
  std::uint64_t revision() const { return revision_; }

  // Adds an object; its entries start at their defaults. Errors: index taken, entries not
  // sorted/unique, a VAR with other than sub 0 only, an ARRAY/RECORD without an UNSIGNED8
  // sub 0, a default or limit that does not fit its type.
  Expected<Object*, std::string> add_object(ObjectDefinition definition);
  // Personality support (reference_drive/profile_objects.hpp): makes the ARRAY/RECORD `index`
  // end at sub-index `highest` (1..254): entries above it are dropped, `added` (sub-indices
  // 1..highest the object lacks, starting at their defaults) are inserted, and sub 0's value and
  // default become `highest`. Kept entries keep their value and hooks; Entry pointers into this
  // object are invalidated. Errors: no such object, not an ARRAY/RECORD, an added sub-index the
  // object has or outside 1..highest, a definition that does not fit its type.
  Expected<void, std::string> reshape_object(std::uint16_t index, std::uint8_t highest,
                                             std::vector<EntryDefinition> added);
  // Personality support (reference_drive/personality.hpp `absent_objects`): removes the objects
  // first..last (inclusive) and returns how many there were. Entry pointers into the removed
  // objects dangle; those into the others stay valid (each object keeps its entries). Call it
  // before services hold entries (ReferenceDrive: before they bind).
  std::size_t remove_objects(std::uint16_t first, std::uint16_t last);
  // Shorthand for a VAR at sub 0.
  Expected<Object*, std::string> add_var(std::uint16_t index, std::string name, DataType type,
                                         AccessType access, Value default_value = {},
                                         bool pdo_mappable = false);

  std::span<const Object> objects() const { return objects_; }
  const Object* find(std::uint16_t index) const;
  Object* find(std::uint16_t index);
  const Entry* find(std::uint16_t index, std::uint8_t sub_index) const;
  Entry* find(std::uint16_t index, std::uint8_t sub_index);
  // The entry or object_does_not_exist / sub_index_does_not_exist.
  Expected<Entry*, SdoAbort> locate(std::uint16_t index, std::uint8_t sub_index);
  std::size_t entry_count() const;

  // SDO server access (see the file comment for the abort codes).
  Expected<std::span<const std::uint8_t>, SdoAbort> read(std::uint16_t index,
                                                         std::uint8_t sub_index);
  Expected<void, SdoAbort> write(std::uint16_t index, std::uint8_t sub_index,
                                 std::span<const std::uint8_t> data);
  // Checks a write without storing it or running the observer (e.g. before a segmented
  // download is accepted, or for a PDO's mapped objects).
  Expected<void, SdoAbort> check_write(const Entry& entry,
                                       std::span<const std::uint8_t> data) const;

  // Application access: no access checks, no hooks (see Entry::assign).
  Expected<Value, SdoAbort> get(std::uint16_t index, std::uint8_t sub_index) const;
  Expected<void, SdoAbort> set(std::uint16_t index, std::uint8_t sub_index, const Value& value);

  std::uint8_t node_id() const { return node_id_; }
  // The node-ID the $NODEID defaults use; current values are not recomputed until
  // restore_defaults (as a device applies a new node-ID at reset communication).
  void set_node_id(std::uint8_t node_id) { node_id_ = node_id; }

  // Store/restore (see the file comment for groups).
  struct StoredEntry {
    std::uint16_t index = 0;
    std::uint8_t sub_index = 0;
    std::vector<std::uint8_t> bytes;
    friend bool operator==(const StoredEntry&, const StoredEntry&) = default;
  };
  using StoredParameters = std::vector<StoredEntry>;
  StoredParameters save(std::uint8_t group) const;
  // Sets the entries of a group back to their defaults (node-ID applied).
  void restore_defaults(std::uint8_t group);
  // Applies saved values; entries that no longer exist or whose size no longer fits are
  // skipped. Returns the number applied.
  std::size_t load(const StoredParameters& stored);

 private:
  // Points every entry's revision at this dictionary's counter (after a copy or move).
  void adopt_entries();
  // A checked definition's entry: explicit default, default bytes, storage for its largest
  // value, counted by this dictionary's revision.
  Entry make_entry(std::uint16_t index, EntryDefinition def);

  std::vector<Object> objects_;  // sorted by index
  std::uint8_t node_id_ = 1;
  std::uint64_t revision_ = 0;
};

}  // namespace drivecheck::cia301

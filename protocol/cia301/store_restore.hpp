// Store parameters 1010h and restore default parameters 1011h (CiA 301 §7.5.2.13-14) as a
// service over the object dictionary and an injected storage.
//
// Objects, ARRAY of UNSIGNED32, sub-index = the parameter group (object_dictionary.hpp says
// which entries belong to which group):
//   sub 00h  highest sub-index supported, UNSIGNED8 ro = 04h
//   sub 01h  all parameters                    rw
//   sub 02h  communication parameters (1000h-1FFFh)  rw
//   sub 03h  application parameters (6000h-9FFFh)    rw
//   sub 04h  manufacturer parameters (2000h-5FFFh)   rw
// Read: the device's capabilities, the same for every sub-index here:
//   1010h  bit 0 = 1 the device saves parameters on command, bit 1 = 0 it does not save
//          autonomously (00000001h)
//   1011h  bit 0 = 1 the device restores default parameters (00000001h)
// Write: a signature, ASCII little-endian, as an expedited download of 4 bytes:
//   1010h  "save" = 65766173h   (data bytes 73 61 76 65)
//   1011h  "load" = 64616F6Ch   (data bytes 6C 6F 61 64)
//   e.g. 601#23101001 73617665   (ccs=1 n=0 e=1 s=1, 1010h sub 1, "save")
// Aborts: another value -> 08000020h (data cannot be transferred or stored; CiA 301 §7.5.2.13;
// Festo 000 L501/L800 lists it for a wrong signature); the storage fails to write -> 06060000h
// (access failed due to a hardware error; Festo 000 L800 lists it for store/restore too); a
// write of other than 4 bytes -> 06070012h/06070013h (the object dictionary's length check).
//
// Save: the current values of the group's entries replace what the storage held for that
// group; the other groups' stored values stay. Restore defaults: the group's stored values are
// deleted; CiA 301: the defaults take effect after the next reset (reset node for application
// and manufacturer parameters, reset communication or reset node for communication
// parameters), not at once. At a reset the owner calls apply(group): the group's entries are
// set to their defaults and then to the stored values that exist.
//
// The save itself happens in the write validator of 1010h, the last point at which a failed
// storage can still be answered with an abort; the entry then reads its capability again.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kStoreParametersIndex = 0x1010;
inline constexpr std::uint16_t kRestoreDefaultParametersIndex = 0x1011;
inline constexpr std::uint32_t kSaveSignature = 0x65766173;        // "save"
inline constexpr std::uint32_t kLoadSignature = 0x64616F6C;        // "load"
inline constexpr std::uint32_t kStoreCapabilities = 0x00000001;    // on command
inline constexpr std::uint32_t kRestoreCapabilities = 0x00000001;  // restores defaults

// Where stored parameters live: memory (simulation, tests) or a file (a real process,
// reference_drive/parameter_file.hpp).
class ParameterStorage {
 public:
  virtual ~ParameterStorage() = default;
  // What was stored last; empty when nothing was. The error says why the stored data cannot be
  // read (for a file: "file:line: message").
  virtual Expected<ObjectDictionary::StoredParameters, std::string> read() = 0;
  // Replaces the stored data as a whole (all or nothing).
  virtual Expected<void, std::string> write(
      const ObjectDictionary::StoredParameters& parameters) = 0;
};

class MemoryParameterStorage final : public ParameterStorage {
 public:
  Expected<ObjectDictionary::StoredParameters, std::string> read() override { return stored_; }
  Expected<void, std::string> write(const ObjectDictionary::StoredParameters& parameters) override;

  const ObjectDictionary::StoredParameters& stored() const { return stored_; }
  std::uint64_t writes() const { return writes_; }
  // Tests: makes the next writes fail (a storage that broke).
  void set_failing(bool failing) { failing_ = failing; }

 private:
  ObjectDictionary::StoredParameters stored_;
  std::uint64_t writes_ = 0;
  bool failing_ = false;
};

// Adds 1010h and 1011h as above. Errors: an index is taken.
Expected<void, std::string> add_store_restore_objects(ObjectDictionary& od);

class StoreRestore {
 public:
  // Binds the validators of 1010h/1011h (both must exist, add_store_restore_objects) and reads
  // the storage. Error: the storage cannot be read. The dictionary and the storage must outlive
  // the service.
  static Expected<std::unique_ptr<StoreRestore>, std::string> create(ObjectDictionary& od,
                                                                     ParameterStorage& storage);
  ~StoreRestore();
  StoreRestore(const StoreRestore&) = delete;
  StoreRestore& operator=(const StoreRestore&) = delete;

  // A reset: the group's entries (kStoreAll: every group) back to their defaults, then the
  // stored values of the group applied. Returns the number of stored values applied.
  std::size_t apply(std::uint8_t group);

  // The commands, as a 1010h/1011h write performs them (the signature already checked).
  Expected<void, SdoAbort> save(std::uint8_t group);
  Expected<void, SdoAbort> restore_defaults(std::uint8_t group);

  // Asked before a restore command is carried out (after the signature check); an abort it
  // returns answers the 1011h write and nothing is restored. Empty (default): always carried out.
  using RestoreGuard = std::function<Expected<void, SdoAbort>()>;
  void set_restore_guard(RestoreGuard guard) { restore_guard_ = std::move(guard); }

  // What the storage holds now (as last read or written).
  const ObjectDictionary::StoredParameters& stored() const { return stored_; }
  // The storage's message of the last failed write (empty when none failed).
  const std::string& last_error() const { return last_error_; }

 private:
  StoreRestore(ObjectDictionary& od, ParameterStorage& storage) : od_(od), storage_(storage) {}
  void bind();
  void unbind();
  bool in_group(std::uint16_t index, std::uint8_t sub_index, std::uint8_t group) const;
  Expected<void, SdoAbort> commit(ObjectDictionary::StoredParameters next);

  ObjectDictionary& od_;
  ParameterStorage& storage_;
  ObjectDictionary::StoredParameters stored_;
  std::string last_error_;
  RestoreGuard restore_guard_;
};

}  // namespace drivecheck::cia301

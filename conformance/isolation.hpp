// Isolation (FORMAT.md "Isolation"): what a vector may change on the DUT, and how the engine
// puts it back. Pure functions over the vector model and byte values; the engine glue (reads,
// writes, the store, the leaks of a run) is in engine.cpp and setup.cpp.
//
// Per vector (engine.cpp):
//   1. after setup: snapshot_objects() are read (a read that fails leaves the object out);
//   2. steps, `finally:` steps, teardown; the engine notes every write the DUT confirmed
//      (written_object(): an sdo_write answered ok, or a confirmed SDO download a `send:` step
//      made) and every store (1010h sub n := "save" confirmed);
//   3. the same objects are read again, plan_restore() orders the writes that put back every
//      confirmed-written object whose value differs, and the engine makes them; when the
//      vector stored, it then stores again with the same 1010h sub-index, so that non-volatile
//      memory holds what it held before (the snapshot was taken after the vector's reset, so
//      its values are what non-volatile memory held).
//   4. a write or store that fails is a leak (a harness note; later failures become errors).
//
// Commands are not parameters and are never read back or written back: 1010h (store),
// 1011h (restore defaults), 1003h (writing 0 clears the error history), 6040h (controlword:
// the teardown owns the CiA 402 state), 1F51h (program control). The profile's commissioning
// writes are the profile's, not the vector's: they are not part of the snapshot.
#pragma once

#include <compare>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "conformance/vector.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::conformance {

struct ObjectRef {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  friend auto operator<=>(const ObjectRef&, const ObjectRef&) = default;
};
std::string to_string(const ObjectRef& ref);  // "1017h sub 0"

using Bytes = std::vector<std::uint8_t>;

// A command object (above): neither snapshot nor restored.
bool is_command_object(ObjectRef ref);

// The initiate SDO download (expedited, segmented or block) that `frame` carries when it is
// addressed to the DUT's default SDO server (600h + node), with the bytes of an expedited one.
struct SdoDownloadRequest {
  cia301::Multiplexer mux;
  std::optional<Bytes> expedited_data;
};
std::optional<SdoDownloadRequest> sdo_download_request(const can::Frame& frame, std::uint8_t node);

// The object a confirmed SDO download names: a frame from the DUT's default SDO server
// (580h + node) that is an initiate download response (scs 3) or a block download initiate
// response; nullopt for any other frame.
std::optional<ObjectRef> confirmed_download(const can::Frame& frame, std::uint8_t node);

// Every object the vector's steps and `finally:` steps may write, in index/sub order, commands
// left out. A PDO parameter brings along what its restore procedure needs: the PDO's COB-ID
// (communication parameter sub 1) and its mapping count (mapping parameter sub 0).
std::vector<ObjectRef> snapshot_objects(const Vector& vector, std::uint8_t node);

// A vector that writes 1011h ("load") restores factory defaults: it is about restore.
bool writes_restore_defaults(const Vector& vector, std::uint8_t node);

struct RestoreWrite {
  ObjectRef ref;
  Bytes data;
  std::string why;  // "value before the vector", "PDO 1800h invalid while it is restored", ...
  friend bool operator==(const RestoreWrite&, const RestoreWrite&) = default;
};

struct RestoreInput {
  std::map<ObjectRef, Bytes> before;  // the snapshot: every object readable before the steps
  std::map<ObjectRef, Bytes> after;   // the same objects after teardown (absent: unreadable)
  std::set<ObjectRef> written;        // objects the DUT confirmed a write of
  std::set<ObjectRef> read_only;      // known read-only (EDS, profile objects): skipped
};

struct RestorePlan {
  std::vector<RestoreWrite> writes;  // in the order the engine makes them
  std::vector<std::string> skipped;  // "6041h sub 0: read-only", one line each
};

// The writes that put back every written object whose value after differs from before (an
// object unreadable after is written back too: its value is unknown), in an order the DUT
// accepts (CiA 301):
//   - each PDO whose parameters changed (§7.5.2.35-38): COB-ID invalid (bit 31 := 1) first when
//     it is valid, the other communication sub-indices, mapping count 0, the mapping entries,
//     the mapping count, and the COB-ID last (its value before);
//   - SYNC 1005h, TIME 1012h and EMCY 1014h COB-IDs (§7.5.2.5, .15, .17): the identifier
//     bits may change only while the object does not exist (1005h bit 30 generate, 1012h bits
//     30/31, 1014h bit 31 invalid), so an existing one is disabled first;
//   - other objects in index order, the sub-indices above 0 before sub 0 (often a count);
//   - error control last, after what it monitors (§7.5.2.11-12, .19-20): 1016h, 100Ch, 100Dh,
//     1017h, values that switch monitoring off (0) before those that switch it on, so that two
//     1016h entries never name one node twice in between (§7.5.2.19: abort 06040043h).
// Not written: objects not written by the vector, equal values, read-only objects, commands,
// and objects unreadable before (no value to put back).
RestorePlan plan_restore(const RestoreInput& input);

}  // namespace drivecheck::conformance

// The signals of the timing diagram (one table: SDO samples and PDO samples take their names
// and signedness from it) and the thinning of a long vector's samples.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "conformance/result.hpp"

namespace drivecheck::conformance {

// A CiA 402 object the diagram draws. `bits`: a word of flags drawn bit by bit (controlword,
// statusword): every change of its value is an edge and is never thinned away.
struct SignalInfo {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::string_view name;
  bool is_signed = false;
  bool bits = false;
};

// The signal of an object (CiA 402-2 §8.4 object list), nullptr if the diagram does not draw it:
//   6040h controlword UNSIGNED16        6041h statusword UNSIGNED16
//   6060h modes of operation INTEGER8   6061h modes of operation display INTEGER8
//   6064h position actual INTEGER32     606Ch velocity actual INTEGER32
//   6077h torque actual INTEGER16       6071h target torque INTEGER16
//   607Ah target position INTEGER32     60FFh target velocity INTEGER32
const SignalInfo* signal_of(std::uint16_t index, std::uint8_t sub);
bool is_bit_signal(std::string_view name);

// Sign-extends the low `bits` bits of `raw` (1..64) if `is_signed`.
std::int64_t signal_value(std::uint64_t raw, unsigned bits, bool is_signed);

// Thins `samples` to about `max_samples` by time, returns how many were left out (0 when there
// were at most max_samples). Per signal: a bit signal keeps its first sample and every sample
// whose value differs from the one before (every edge of every bit) and its last; any other
// signal keeps, per time bucket (max_samples / 4 buckets over the vector's sample span), its
// first, lowest, highest and last sample. The order of the samples kept is unchanged. Edges are
// never dropped, so a bit signal that toggles more often than max_samples keeps them all.
std::size_t thin_samples(std::vector<Sample>& samples, std::size_t max_samples);

}  // namespace drivecheck::conformance

// The timing diagram's signal table and the thinning of samples (samples.hpp).
#include "conformance/samples.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <string>

namespace drivecheck::conformance {
namespace {

// Names as the report draws them; the first six existed before PDO samples and keep their
// names so that older JSON reports read the same.
constexpr std::array<SignalInfo, 10> kSignals{{
    {0x6040, 0, "controlword", false, true},
    {0x6041, 0, "statusword", false, true},
    {0x6064, 0, "position", true, false},
    {0x606C, 0, "velocity", true, false},
    {0x6061, 0, "mode", true, false},
    {0x6077, 0, "torque", true, false},
    {0x6060, 0, "mode command", true, false},
    {0x607A, 0, "target position", true, false},
    {0x60FF, 0, "target velocity", true, false},
    {0x6071, 0, "target torque", true, false},
}};

}  // namespace

const SignalInfo* signal_of(std::uint16_t index, std::uint8_t sub) {
  for (const auto& signal : kSignals)
    if (signal.index == index && signal.sub == sub) return &signal;
  return nullptr;
}

bool is_bit_signal(std::string_view name) {
  for (const auto& signal : kSignals)
    if (signal.name == name) return signal.bits;
  return false;
}

std::int64_t signal_value(std::uint64_t raw, unsigned bits, bool is_signed) {
  if (bits == 0 || bits >= 64) return static_cast<std::int64_t>(raw);
  raw &= (std::uint64_t{1} << bits) - 1;
  if (is_signed && (raw >> (bits - 1)) != 0) raw |= ~std::uint64_t{0} << bits;
  return static_cast<std::int64_t>(raw);
}

std::size_t thin_samples(std::vector<Sample>& samples, std::size_t max_samples) {
  if (samples.size() <= max_samples) return 0;
  std::int64_t t_min = INT64_MAX;
  std::int64_t t_max = INT64_MIN;
  for (const auto& sample : samples) {
    t_min = std::min(t_min, sample.at.time_since_epoch().count());
    t_max = std::max(t_max, sample.at.time_since_epoch().count());
  }
  const std::uint64_t buckets = std::max<std::size_t>(max_samples / 4, 1);
  // Unsigned: the span of any two int64 times fits.
  const std::uint64_t span = static_cast<std::uint64_t>(t_max) - static_cast<std::uint64_t>(t_min);
  const auto bucket_of = [&](const Sample& sample) -> std::uint64_t {
    const std::uint64_t offset = static_cast<std::uint64_t>(sample.at.time_since_epoch().count()) -
                                 static_cast<std::uint64_t>(t_min);
    if (span == 0) return 0;
    // offset * buckets / span without overflow: in long double.
    const auto b = static_cast<std::uint64_t>(static_cast<long double>(offset) *
                                              static_cast<long double>(buckets) /
                                              static_cast<long double>(span));
    return std::min(b, buckets - 1);
  };

  std::vector<bool> keep(samples.size(), false);
  struct Bucket {
    std::size_t first = 0, low = 0, high = 0, last = 0;
  };
  struct SignalState {
    bool bits = false;
    std::size_t last_index = 0;
    std::map<std::uint64_t, Bucket> buckets;
  };
  std::map<std::string, SignalState, std::less<>> signals;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& sample = samples[i];
    auto [it, inserted] = signals.try_emplace(sample.signal);
    SignalState& state = it->second;
    if (inserted) {
      state.bits = is_bit_signal(sample.signal);
      keep[i] = true;
    } else if (state.bits && samples[state.last_index].value != sample.value) {
      keep[i] = true;
    }
    state.last_index = i;
    if (state.bits) continue;
    auto [bucket_it, new_bucket] = state.buckets.try_emplace(bucket_of(sample), Bucket{i, i, i, i});
    Bucket& bucket = bucket_it->second;
    if (new_bucket) continue;
    if (sample.value < samples[bucket.low].value) bucket.low = i;
    if (sample.value > samples[bucket.high].value) bucket.high = i;
    bucket.last = i;
  }
  for (const auto& [name, state] : signals) {
    keep[state.last_index] = true;
    for (const auto& [b, bucket] : state.buckets) {
      for (const std::size_t i : {bucket.first, bucket.low, bucket.high, bucket.last})
        keep[i] = true;
    }
  }
  std::vector<Sample> kept;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (keep[i]) kept.push_back(std::move(samples[i]));
  const std::size_t elided = samples.size() - kept.size();
  samples = std::move(kept);
  return elided;
}

}  // namespace drivecheck::conformance

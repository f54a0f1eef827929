#include "cli/options.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <limits>

#include "protocol/can/candump_log.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::cli {

Expected<BusSpec, std::string> parse_bus_spec(std::string_view text) {
  if (text == "sim") return BusSpec{};
  constexpr std::string_view kSocketcan = "socketcan:";
  if (text.substr(0, kSocketcan.size()) == kSocketcan) {
    const std::string_view name = text.substr(kSocketcan.size());
    if (name.empty() || name.size() > can::kMaxInterfaceNameLength) {
      return Unexpected(fmt::format("interface name '{}' must have 1..{} characters", name,
                                    can::kMaxInterfaceNameLength));
    }
    for (const char c : name) {
      if (c <= 0x20 || c >= 0x7F || c == '/' || c == ':') {
        return Unexpected(fmt::format("'{}' is not a network interface name", name));
      }
    }
    return BusSpec{BusSpec::Kind::socketcan, std::string(name)};
  }
  return Unexpected(fmt::format("bus '{}' is neither 'sim' nor 'socketcan:IF'", text));
}

Expected<can::Duration, std::string> parse_duration(std::string_view text) {
  return profile::parse_duration(text, profile::DurationUnits::up_to_hours);
}

CLI::Validator bus_validator() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const auto spec = parse_bus_spec(value);
        return spec ? std::string() : spec.error();
      },
      "sim|socketcan:IF");
}

CLI::Validator duration_validator() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const auto duration = parse_duration(value);
        return duration ? std::string() : duration.error();
      },
      "DURATION");
}

CLI::Validator seed_validator() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        std::uint64_t seed = 0;
        for (const char c : value) {
          const auto digit = static_cast<std::uint64_t>(c - '0');
          if (c < '0' || c > '9') return fmt::format("seed '{}' is not a whole number", value);
          if (seed > (std::numeric_limits<std::uint64_t>::max() - digit) / 10) {
            return fmt::format("seed '{}' is above 2^64-1", value);
          }
          seed = seed * 10 + digit;
        }
        return value.empty() ? std::string("empty seed") : std::string();
      },
      "UINT64");
}

}  // namespace drivecheck::cli

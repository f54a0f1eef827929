#include "cli/options.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <limits>

#include "protocol/can/candump_log.hpp"

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
  std::size_t digits = 0;
  std::int64_t value = 0;
  for (; digits < text.size() && text[digits] >= '0' && text[digits] <= '9'; ++digits) {
    if (value > std::numeric_limits<std::int64_t>::max() / 10 - 1) {
      return Unexpected(fmt::format("duration '{}' is too long", text));
    }
    value = value * 10 + (text[digits] - '0');
  }
  if (digits == 0) {
    return Unexpected(fmt::format("duration '{}' must start with a whole number, e.g. 90s", text));
  }
  const std::string_view unit = text.substr(digits);
  struct Unit {
    std::string_view name;
    std::int64_t nanoseconds;
  };
  constexpr Unit kUnits[] = {{"ns", 1},
                             {"us", 1'000},
                             {"ms", 1'000'000},
                             {"s", 1'000'000'000},
                             {"min", 60'000'000'000},
                             {"h", 3'600'000'000'000}};
  for (const auto& u : kUnits) {
    if (unit != u.name) continue;
    if (value > std::numeric_limits<std::int64_t>::max() / u.nanoseconds) {
      return Unexpected(fmt::format("duration '{}' is too long", text));
    }
    return can::Duration(value * u.nanoseconds);
  }
  return Unexpected(fmt::format("duration '{}' needs a unit: ns, us, ms, s, min or h", text));
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

// Option values shared by several subcommands: the bus (`sim` | `socketcan:IF`), node ids
// and durations, each with a CLI11 validator so that a bad value is a usage error (exit 2)
// with a one-line message before any subcommand runs.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <string_view>

#include "protocol/can/bus.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cli {

struct BusSpec {
  enum class Kind { sim, socketcan };
  Kind kind = Kind::sim;
  std::string interface;  // socketcan only: 1..15 characters
};

// "sim" or "socketcan:IF".
Expected<BusSpec, std::string> parse_bus_spec(std::string_view text);

// A whole number with a unit: "500ms", "90s", "10min", "2h" (also "us", "ns").
Expected<can::Duration, std::string> parse_duration(std::string_view text);

// CLI11 validators for the two above ("" when valid, else the message).
CLI::Validator bus_validator();
CLI::Validator duration_validator();
// A whole number 0..2^64-1 (CLI11 would wrap "-5" around).
CLI::Validator seed_validator();

// CANopen node ids: 1..127 (CiA 301 §7.3.5).
inline constexpr int kMinNodeId = 1;
inline constexpr int kMaxNodeId = 127;

}  // namespace drivecheck::cli

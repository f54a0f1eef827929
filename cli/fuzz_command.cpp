// drivecheck fuzz: the live fuzzer against a drive on a bus.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "cli/options.hpp"

namespace drivecheck::cli {
namespace {

struct FuzzOptions {
  std::string bus;
  int node = 0;
  std::string duration = "60s";
  bool allow_motion = false;
};

}  // namespace

void add_fuzz_command(CLI::App& app) {
  auto options = std::make_shared<FuzzOptions>();
  CLI::App* cmd = app.add_subcommand("fuzz", "Fuzz a live drive's CANopen services");
  cmd->add_option("--bus", options->bus, "The bus: sim, or socketcan:IF")
      ->required()
      ->check(bus_validator());
  cmd->add_option("--node", options->node, "Node id of the drive")
      ->required()
      ->check(CLI::Range(kMinNodeId, kMaxNodeId));
  cmd->add_option("--duration", options->duration, "How long to fuzz, e.g. 90s, 10min, 2h")
      ->check(duration_validator())
      ->capture_default_str();
  cmd->add_flag("--allow-motion", options->allow_motion,
                "Also fuzz in Operation Enabled (the motor may move)");
  cmd->callback([options] { not_built_yet("fuzz", "the live fuzzer is not built yet"); });
}

}  // namespace drivecheck::cli

// drivecheck: the command line (DESIGN.md, "The CLI contract"). Builds the CLI11 app from one
// add_<name>_command per subcommand (cli/commands.hpp) and maps every outcome to an exit code:
// help and --version 0, usage errors 2 with a one-line message, a subcommand's own code as it
// raised it.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <string>

#include "cli/commands.hpp"

#ifndef DRIVECHECK_VERSION
#error "DRIVECHECK_VERSION must be defined by the build (cli/CMakeLists.txt)"
#endif

namespace {

// "drivecheck eds lint" for the deepest subcommand the parser got to.
std::string command_path(const CLI::App& app) {
  std::string path = app.get_name();
  const CLI::App* current = &app;
  while (!current->get_subcommands().empty()) {
    current = current->get_subcommands().front();
    path += " " + current->get_name();
  }
  return path;
}

std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!text.empty() && text.back() == ' ')
    text.pop_back();
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Conformance and fuzz test harness for CANopen servo drives (CiA 301, CiA 402)",
               "drivecheck");
  app.set_version_flag("--version", "drivecheck " DRIVECHECK_VERSION, "Print the version and exit");
  app.set_help_all_flag("--help-all", "Print the help of every subcommand and exit");
  app.require_subcommand(1);

  drivecheck::cli::add_run_command(app);
  drivecheck::cli::add_drive_command(app);
  drivecheck::cli::add_fuzz_command(app);
  drivecheck::cli::add_decode_command(app);
  drivecheck::cli::add_eds_command(app);
  drivecheck::cli::add_esi_command(app);
  drivecheck::cli::add_vectors_command(app);
  drivecheck::cli::add_report_command(app);
  drivecheck::cli::add_list_commands(app);
  // After the subcommands: they would inherit it.
  app.footer(
      "Exit codes: 0 all required vectors pass, 1 some fail, 2 bad input or usage,\n"
      "3 the drive stopped answering, 130 interrupted.");

  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {  // a subcommand's exit code, message already printed
    return e.get_exit_code();
  } catch (const CLI::Success& e) {  // --help, --help-all, --version
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string message = one_line(e.what());
    // CLI11 checks for a missing subcommand before it reports extra arguments; for
    // "drivecheck --bogus" the extra argument is the better message.
    const auto extras = app.remaining(true);
    if (e.get_name() == "RequiredError" && !extras.empty()) {
      message = fmt::format("The following argument was not expected: {}", extras.front());
    }
    fmt::print(stderr, "{}: {} (see --help)\n", command_path(app), message);
    return drivecheck::cli::kExitUsage;
  }
  return drivecheck::cli::kExitPass;
}

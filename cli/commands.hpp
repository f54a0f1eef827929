// The drivecheck subcommands (DESIGN.md, "The CLI contract"). main.cpp builds the CLI11 app
// and calls each add_<name>_command, one file per subcommand; each adds its subcommand, its
// options and a callback that runs after a successful parse. Option storage must outlive
// add_<name>_command: keep it in a shared_ptr that the callback captures (CLI11 writes into
// it during parse()).
//
// Exit codes: a callback that returns normally exits 0; any other code is raised with
// exit_with() (a CLI::RuntimeError, which main turns into the process exit code without
// printing anything). Messages go to stderr before that, one line, "drivecheck <command>: ..."
// or "file:line: ..." for bad input files.
#pragma once

#include <string>
#include <string_view>

namespace CLI {
class App;
}  // namespace CLI

namespace drivecheck::cli {

inline constexpr int kExitPass = 0;           // all required vectors pass / command done
inline constexpr int kExitFail = 1;           // some vectors (or lint checks) fail
inline constexpr int kExitUsage = 2;          // bad input or usage (file:line message)
inline constexpr int kExitDutLost = 3;        // the device under test stopped answering
inline constexpr int kExitInterrupted = 130;  // interrupted: safe state, partial reports

void add_run_command(CLI::App& app);
void add_drive_command(CLI::App& app);
void add_fuzz_command(CLI::App& app);
void add_decode_command(CLI::App& app);
void add_eds_command(CLI::App& app);
void add_esi_command(CLI::App& app);
void add_vectors_command(CLI::App& app);
void add_report_command(CLI::App& app);
// `profiles` and `deviations` (cli/list_commands.cpp).
void add_list_commands(CLI::App& app);

// A deprecated option name was used: "drivecheck <command>: --old is deprecated, use --new"
// on stderr (the run goes on).
void warn_deprecated_option(std::string_view command, std::string_view old_name,
                            std::string_view new_name);

// Ends the running subcommand with `code` (0 returns normally instead of throwing).
void exit_with(int code);

// Now in UTC, ISO 8601 to the second ("2026-11-21T13:45:00Z"): when a run or fuzz session began.
std::string utc_now();

// "drivecheck <command>: <message>" on stderr, then exit 2. `command` is the full path,
// e.g. "eds lint".
[[noreturn]] void usage_error(std::string_view command, std::string_view message);

}  // namespace drivecheck::cli

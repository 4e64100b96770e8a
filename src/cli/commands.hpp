#pragma once
// Registration of the subcommands. Each add_<name>_command() declares its options on `app`
// and, when its subcommand is chosen, stores the function to run in `runner`.
#include <CLI/CLI.hpp>
#include <functional>

namespace printtwin::cli {

struct CommandRunner {
  std::function<int()> run;  ///< returns the exit code
};

void add_check_command(CLI::App& app, CommandRunner& runner);
void add_slice_command(CLI::App& app, CommandRunner& runner);
void add_simulate_command(CLI::App& app, CommandRunner& runner);
void add_verify_command(CLI::App& app, CommandRunner& runner);
void add_compare_command(CLI::App& app, CommandRunner& runner);
void add_printers_command(CLI::App& app, CommandRunner& runner);

/// Registers every subcommand, in pipeline order (the order `--help` lists them).
inline void register_commands(CLI::App& app, CommandRunner& runner) {
  add_check_command(app, runner);
  add_slice_command(app, runner);
  add_simulate_command(app, runner);
  add_verify_command(app, runner);
  add_compare_command(app, runner);
  add_printers_command(app, runner);
}

}  // namespace printtwin::cli

#pragma once
// Registration of the subcommands. Each add_<name>_command() declares its options on `app`
// and, when its subcommand is chosen, stores the function to run in `runner`.
#include <string>

#include <CLI/CLI.hpp>
#include <functional>

namespace printtwin::cli {

struct CommandRunner {
  std::function<int()> run;  ///< returns the exit code
};

/// --slicer, --slicer-path, --slicer-timeout and --cura-definition of verify and compare
/// (external slicer back-ends, docs/compare.md); `slicer` and `path` are a string or a list.
template <class Slicers, class Paths>
void add_slicer_options(CLI::App* cmd, Slicers& slicer, Paths& path, double& timeout_s,
                        std::string& cura_definition, const std::string& slicer_help,
                        const std::string& path_help) {
  cmd->add_option("--slicer", slicer, slicer_help);
  cmd->add_option("--slicer-path", path, path_help);
  cmd->add_option("--slicer-timeout", timeout_s,
                  "stop a slicing run after this many seconds (default 600)");
  cmd->add_option(
      "--cura-definition,-j", cura_definition,
      "--slicer cura: the printer's .def.json (e.g. /usr/share/cura/resources/definitions/"
      "creality_ender3.def.json); --config and --set give the -s settings");
}

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

// printtwin command line: argv -> settings -> library call -> report -> exit code.
// Each subcommand lives in its own cmd_<name>.cpp and registers itself in commands.hpp.
#include <unistd.h>
#include <CLI/CLI.hpp>
#include <clocale>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "printtwin/io.hpp"
#include "printtwin/version.hpp"

namespace printtwin::cli {
bool show_progress() {
  const char* ci = std::getenv("CI");
  if (ci != nullptr && *ci != '\0' && std::string(ci) != "false") return false;
  return isatty(fileno(stderr)) != 0;
}
}  // namespace printtwin::cli

int main(int argc, char** argv) {
  std::setlocale(LC_ALL, "C");  // numbers are read and written the same in every locale
  using namespace printtwin::cli;
  CLI::App app{
      "printtwin: a digital twin of an FDM printer. Checks a mesh, slices it, runs the\n"
      "G-code on a simulated Ender-3, deposits the material as voxels and measures it\n"
      "against the design."};
  app.set_version_flag("--version", std::string("printtwin ") + printtwin::kVersion);
  app.require_subcommand(1);
  CommandRunner runner;
  register_commands(app, runner);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kUsage;
  }
  try {
    return runner.run ? runner.run() : kUsage;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "printtwin: internal error: out of memory\n");
    return kInternal;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "printtwin: internal error: %s\n", e.what());
    return kInternal;
  }
}

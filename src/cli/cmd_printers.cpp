// `printtwin printers [ID]`: the built-in printer library, or one printer's values and sources.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "printtwin/printer.hpp"

namespace printtwin::cli {

void add_printers_command(CLI::App& app, CommandRunner& runner) {
  auto id = std::make_shared<std::string>();
  auto* cmd = app.add_subcommand(
      "printers", "List the built-in printer library (--printer NAME), or show one printer");
  cmd->add_option("id", *id,
                  "a library printer: print its values as a JSON profile with its sources");
  cmd->callback([id, &runner] {
    runner.run = [id]() -> int {
      if (id->empty()) {
        std::fputs(printer_library_table().c_str(), stdout);
        return kPass;
      }
      const auto* p = find_library_printer(*id);
      if (p == nullptr)
        return report_error(
            usage_error("no library printer \"" + *id + "\" (printtwin printers lists them)"));
      std::printf("%s\n", printer_provenance_json(p->profile).c_str());
      for (const auto& s : p->sources) std::printf("source: %s\n", s.c_str());
      return kPass;
    };
  });
}

}  // namespace printtwin::cli

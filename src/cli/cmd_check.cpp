// `printtwin check part.stl`: printability of a mesh before slicing.
#include <cstdio>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin::cli {

namespace {
struct CheckOptions {
  std::string input;
};
}  // namespace

void add_check_command(CLI::App& app, CommandRunner& runner) {
  auto opts = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand("check", "Check whether a mesh is printable (no slicing)");
  cmd->add_option("mesh", opts->input, "STL, OBJ, PLY, OFF, 3MF or AMF file")->required();
  cmd->callback([opts, &runner] {
    runner.run = [opts]() -> int {
      auto mesh = load_mesh(opts->input);
      if (!mesh) return report_error(mesh.error());
      std::printf("%s: %zu triangles, %zu vertices, volume %.3f mm3\n", opts->input.c_str(),
                  mesh->triangles.size(), mesh->vertices_mm.size(), signed_volume_mm3(*mesh));
      return kPass;
    };
  });
}

}  // namespace printtwin::cli

#pragma once
// Shared test helpers: paths to fixtures, running the CLI, small meshes built in code.
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "printtwin/mesh.hpp"

namespace printtwin::test {

/// Path of a file in the source tree (e.g. "samples/cube_20mm.stl").
std::filesystem::path source_path(const std::string& relative);
/// The shared folder of real slicer files (PRINTTWIN_REALWORLD_DIR alone when set, else
/// <source>/../shared/realworld, else /work/shared/realworld); nullopt when absent (skip).
std::optional<std::filesystem::path> realworld_dir();
/// The JSON document in a file (a failed expectation and null when unreadable).
nlohmann::json read_json(const std::filesystem::path& path);
/// A fresh empty folder under the system temp dir, unique to this test process.
std::filesystem::path temp_dir(const std::string& name);

struct CliRun {
  int exit_code = -1;
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};
/// Runs the printtwin CLI with `args` (shell-quoted by the caller), CI=true.
CliRun run_cli(const std::string& args);

/// A zip archive of (name, bytes) entries, deflated when `deflate` (stored otherwise), as
/// 3MF writers make them: local headers, central directory, end record.
std::string make_zip(const std::vector<std::pair<std::string, std::string>>& entries, bool deflate);

/// verify() of the 10 mm cube that samples/gcode/prusa_cube10.gcode prints (0.2 mm voxels,
/// the mesh written into `dir`) against two G-code files holding that print in two forms:
/// expects the same report (pass, moves, layers, time, filament, deposit -> mesh RMS).
void expect_same_cube10_verify(const std::filesystem::path& a, const std::filesystem::path& b,
                               const std::filesystem::path& dir);

/// Closed outward-oriented cube of edge `size_mm` with its min corner at `min_mm`.
Mesh make_cube_mm(double size_mm, const Vec3& min_mm = Vec3::Zero());

/// make_cube_mm(size_mm) with its +z face on its own copies of the corners, `dz_mm` higher:
/// a seam of 8 open facet edges (4 on each side).
Mesh make_seam_cube_mm(double size_mm, double dz_mm);

}  // namespace printtwin::test

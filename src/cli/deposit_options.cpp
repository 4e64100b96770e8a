// The deposit stage of `printtwin simulate` (see deposit_options.hpp).
#include "cli/deposit_options.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>

#include "printtwin/io.hpp"

namespace printtwin::cli {

void add_deposit_options(CLI::App& cmd, DepositCliOptions& o) {
  cmd.add_option("--deposit", o.octomap_path,
                 "Deposit the material as voxels and write them as OctoMap .bt or .ot (coloured)");
  cmd.add_option(
      "--deposit-ply", o.ply_path,
      "Write the deposit's outer surface voxels as a PLY point cloud (layer, feature, line)");
  cmd.add_flag("--deposit-summary", o.deposit,
               "Deposit the material (summary, findings and JSON) without writing voxel files");
  cmd.add_flag("--conserve-volume,!--no-conserve-volume", o.conserve_volume,
               "Squeeze material a bead cannot place into free space beside and below it, the "
               "default (docs/deposit.md; --no-conserve-volume: lose it)");
  cmd.add_option("--voxel", o.voxel_mm, "Deposit voxel edge (mm)")
      ->capture_default_str()
      ->check(CLI::Range(0.001, 10.0));
  cmd.add_option("--max-memory", o.max_memory,
                 "Memory budget of the deposit (e.g. 2G, 512M); checked before allocating")
      ->capture_default_str();
  cmd.add_option("--support-fraction", o.support_fraction,
                 "Fraction of a bead's width that must rest on the bed or earlier deposit")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  cmd.add_option("--deposit-color", o.color, "Colour of .ot voxels: layer or feature")
      ->capture_default_str()
      ->check(CLI::IsMember({"layer", "feature"}));
  add_deposit_mesh_options(cmd, o.mesh);
}

void add_deposit_mesh_options(CLI::App& cmd, DepositMeshCliOptions& o) {
  cmd.add_option("--deposit-mesh", o.path,
                 "Write the as-printed part (the deposit's outer surface) as a closed mesh: .stl, "
                 ".3mf or .ply");
  cmd.add_option("--deposit-mesh-include", o.include,
                 "Keep these in the mesh too (comma list): skirt (and brim), support, purge (start "
                 "code, purge "
                 "lines, wipe tower), all");
  cmd.add_option("--deposit-mesh-max-triangles", o.max_triangles,
                 "Decimate the mesh to at most this many triangles (coarser cells; the error bound "
                 "is printed)");
  cmd.add_option("--deposit-mesh-surface", o.surface,
                 "layers: a slab per printed layer with the beads' round sides (falls back to "
                 "voxel where it cannot close); voxel: the voxel faces merged into rectangles")
      ->capture_default_str()
      ->check(CLI::IsMember({"layers", "voxel"}));
  cmd.add_option("--deposit-mesh-tolerance", o.tolerance_mm,
                 "layers: simplify each layer's outlines within this distance (mm)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 5.0));
  cmd.add_flag("--deposit-mesh-voxel-faces", o.voxel_faces,
               "Keep the mesh on the voxel faces (no sub-voxel smoothing onto the beads)");
  cmd.add_option("--deposit-mesh-smooth-max-triangles", o.smooth_max_triangles,
                 "Smooth meshes up to this many triangles (about 3.5 s of CPU per million; "
                 "0: any size)")
      ->capture_default_str();
}

Result<DepositMeshOptions> deposit_mesh_options(const DepositMeshCliOptions& o) {
  DepositMeshOptions out;
  if (o.path.empty()) return out;
  if (auto st = check_deposit_mesh_path(o.path); !st) return st.error();
  if (!o.include.empty())
    if (auto st = parse_deposit_mesh_include(o.include, out); !st) return st.error();
  out.max_triangles = o.max_triangles;
  out.smooth = !o.voxel_faces;
  out.surface = o.surface == "voxel" ? DepositMeshSurface::voxel : DepositMeshSurface::layers;
  out.outline_tolerance_mm = o.tolerance_mm;
  out.smooth_max_triangles = o.smooth_max_triangles;
  return out;
}

Result<std::size_t> parse_memory_size(const std::string& text) {
  std::string s;
  for (char c : text)
    if (c != ' ') s.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
  double value = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || !(value > 0))
    return usage_error("--max-memory expects a size such as 2G, 512M or 800000000, got '" + text +
                       "'");
  std::string unit(ptr, static_cast<std::size_t>(s.data() + s.size() - ptr));
  if (unit.size() > 1 && unit.back() == 'B') unit.pop_back();
  if (unit.size() > 1 && unit.back() == 'I') unit.pop_back();
  double scale = 1;
  if (unit == "K")
    scale = 1024.0;
  else if (unit == "M")
    scale = 1024.0 * 1024;
  else if (unit == "G")
    scale = 1024.0 * 1024 * 1024;
  else if (unit == "T")
    scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!unit.empty() && unit != "B")
    return usage_error("--max-memory: unknown unit '" + unit + "' (use K, M, G or T)");
  return static_cast<std::size_t>(std::min(value * scale, 1.0e18));
}

DepositStage::DepositStage(const DepositCliOptions& options, MoveSink* next)
    : options_(options), next_(next) {}

MoveSink* DepositStage::sink() { return options_.enabled() ? this : next_; }

void DepositStage::on_move(const Move& move) {
  moves_.push_back(move);
  if (next_ != nullptr) next_->on_move(move);
}
void DepositStage::on_segment(const MotionSegment& segment) {
  if (next_ != nullptr) next_->on_segment(segment);
}
void DepositStage::on_wait(double start_time_s, double duration_s, bool heating, long line) {
  if (next_ != nullptr) next_->on_wait(start_time_s, duration_s, heating, line);
}

Status DepositStage::run(const PrinterProfile& profile, SimulationResult& sim) {
  if (!options_.enabled()) return Ok{};
  auto budget = parse_memory_size(options_.max_memory);
  if (!budget) return budget.error();
  DepositSettings settings;
  settings.voxel_mm = options_.voxel_mm;
  settings.conserve_volume = options_.conserve_volume;
  settings.support_fraction = options_.support_fraction;
  settings.max_memory_bytes = *budget;
  auto deposit = deposit_moves(moves_, profile, settings);
  std::vector<SurfaceBead> beads;  // the mesh's vertices go onto these
  if (!options_.mesh.path.empty()) beads = surface_beads(moves_, profile);
  moves_ = {};
  if (!deposit) return deposit.error();
  if (!options_.octomap_path.empty()) {
    const auto coloring =
        options_.color == "feature" ? VoxelColoring::feature : VoxelColoring::layer;
    if (auto st = write_octomap(deposit->grid, options_.octomap_path, coloring); !st)
      return st.error();
  }
  if (!options_.ply_path.empty()) {
    if (auto st = write_deposit_ply(deposit->grid, options_.ply_path); !st) return st.error();
  }
  if (!options_.mesh.path.empty()) {
    auto mesh_options = deposit_mesh_options(options_.mesh);
    if (!mesh_options) return mesh_options.error();
    auto mesh = build_deposit_mesh(deposit->grid, *mesh_options, beads);
    if (!mesh) return mesh.error();
    if (auto st = write_deposit_mesh(*mesh, options_.mesh.path); !st) return st.error();
    mesh_summary_ = deposit_mesh_summary(*mesh, options_.mesh.path);
    mesh_json_ = deposit_mesh_json(*mesh, options_.mesh.path);
  }
  sim.findings.insert(sim.findings.end(), deposit->findings.begin(), deposit->findings.end());
  result_ = std::move(deposit).value();
  return Ok{};
}

std::string DepositStage::patch_json(const std::string& simulate_json) const {
  if (!result_) return simulate_json;
  auto j = nlohmann::json::parse(simulate_json, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return simulate_json;
  j["deposit"] = nlohmann::json::parse(deposit_json(*result_));
  if (!mesh_json_.empty()) j["deposit"]["mesh"] = nlohmann::json::parse(mesh_json_);
  return j.dump(2) + "\n";
}

std::string DepositStage::summary() const {
  if (!result_) return {};
  const DepositResult& d = *result_;
  const double ratio = d.extruded_mm3 > 0 ? d.volume_mm3 / d.extruded_mm3 : 0.0;
  std::size_t bridges = 0, cantilevers = 0;
  for (const auto& s : d.unsupported) (s.bridge ? bridges : cantilevers) += 1;
  std::string out =
      "deposit: " + std::to_string(d.voxels) + " voxels of " + format_number(d.voxel_mm) + " mm, " +
      format_fixed(d.volume_mm3, 1) + " mm3 (" + format_fixed(100 * ratio, 1) + " % of " +
      format_fixed(d.extruded_mm3, 1) + " mm3 extruded), overlap " +
      format_fixed(d.overlap_mm3, 1) + " mm3" +
      (options_.conserve_volume
           ? " (" + format_fixed(d.squeezed_mm3, 1) + " mm3 of it squeezed into free space nearby)"
           : std::string(" (lost; --conserve-volume places it)")) +
      "\n";
  out += "extrusion into air: " + format_fixed(d.unsupported_mm, 1) + " mm unsupported; " +
         std::to_string(bridges) + " bridged and " + std::to_string(cantilevers) +
         " cantilevered stretches of at least 1 mm\n";
  return out + mesh_summary_;
}

}  // namespace printtwin::cli

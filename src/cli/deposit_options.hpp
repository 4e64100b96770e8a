#pragma once
// The deposit options of `printtwin simulate` (--deposit, --deposit-ply, --voxel,
// --max-memory, --support-fraction, --deposit-color), kept apart from cmd_simulate.cpp so
// that the simulate command needs only a small hook:
//
//   DepositStage deposit(o->deposit, trace.get());            // before simulating
//   auto sim = simulate_gcode_file(..., deposit.sink());      // collects the Moves
//   if (auto st = deposit.run(*profile, *sim); !st) ...       // deposit, exports, findings
//   json = deposit.patch_json(simulation_to_json(...));       // adds the "deposit" object
#include <CLI/CLI.hpp>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "deposit/mesh_export.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"

namespace printtwin::cli {

/// --deposit-mesh, --deposit-mesh-include, --deposit-mesh-max-triangles,
/// --deposit-mesh-voxel-faces (simulate and verify).
struct DepositMeshCliOptions {
  std::string path;                ///< out.stl|out.3mf|out.ply
  std::string include;             ///< comma list: skirt, support, purge, all
  std::size_t max_triangles = 0;   ///< 0: full resolution
  bool voxel_faces = false;        ///< --deposit-mesh-voxel-faces: no sub-voxel smoothing
  std::string surface = "layers";  ///< --deposit-mesh-surface layers|voxel
  /// --deposit-mesh-tolerance: layers' outline simplification (mm)
  double tolerance_mm = DepositMeshOptions{}.outline_tolerance_mm;
  /// --deposit-mesh-smooth-max-triangles: larger meshes stay on the voxel faces (0: no limit)
  std::size_t smooth_max_triangles = DepositMeshOptions{}.smooth_max_triangles;
};

/// Declares the --deposit-mesh options on a subcommand.
void add_deposit_mesh_options(CLI::App& cmd, DepositMeshCliOptions& options);
/// The options as build_deposit_mesh takes them; usage errors for a bad extension or list.
[[nodiscard]] Result<DepositMeshOptions> deposit_mesh_options(const DepositMeshCliOptions& options);

struct DepositCliOptions {
  std::string octomap_path;       ///< --deposit out.bt|out.ot
  std::string ply_path;           ///< --deposit-ply out.ply
  double voxel_mm = 0.05;         ///< --voxel
  bool conserve_volume = true;    ///< --conserve-volume (the default) / --no-conserve-volume
  std::string max_memory = "2G";  ///< --max-memory (bytes, or with K/M/G suffix)
  double support_fraction = 0.5;  ///< --support-fraction
  std::string color = "layer";    ///< --deposit-color layer|feature (.ot)
  bool deposit = false;           ///< --deposit-summary: deposit without writing files
  DepositMeshCliOptions mesh;     ///< --deposit-mesh ...
  [[nodiscard]] bool enabled() const {
    return deposit || !octomap_path.empty() || !ply_path.empty() || !mesh.path.empty();
  }
};

/// Declares the deposit options on the simulate subcommand.
void add_deposit_options(CLI::App& cmd, DepositCliOptions& options);

/// Parses "2G", "512M", "1.5GiB", "800000000" into bytes.
[[nodiscard]] Result<std::size_t> parse_memory_size(const std::string& text);

/// Runs the deposit after the simulation: collects the Moves while simulating (forwarding
/// everything to `next`), then deposits, writes the files, and merges its findings.
class DepositStage final : public MoveSink {
 public:
  DepositStage(const DepositCliOptions& options, MoveSink* next);
  /// The sink to pass to simulate_gcode (this when depositing, else `next`).
  [[nodiscard]] MoveSink* sink();
  void on_move(const Move& move) override;
  void on_segment(const MotionSegment& segment) override;
  void on_wait(double start_time_s, double duration_s, bool heating, long line) override;

  /// Deposits, writes --deposit / --deposit-ply, appends the findings to `sim.findings`.
  /// Does nothing when no deposit option was given.
  [[nodiscard]] Status run(const PrinterProfile& profile, SimulationResult& sim);
  /// The simulate JSON with the "deposit" object added (unchanged without a deposit).
  [[nodiscard]] std::string patch_json(const std::string& simulate_json) const;
  /// Summary lines for stdout ("" without a deposit).
  [[nodiscard]] std::string summary() const;

 private:
  DepositCliOptions options_;
  MoveSink* next_;
  std::vector<Move> moves_;
  std::optional<DepositResult> result_;
  std::string mesh_summary_;
  std::string mesh_json_;
};

}  // namespace printtwin::cli

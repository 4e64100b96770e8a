#pragma once
// verify: the product's verdict. Runs check -> (slice) -> simulate -> deposit -> deviation on
// one part and aggregates everything a report needs into a plain VerifyReport value:
// inputs with their SHA-256, the settings used, a summary of every stage, the two-sided
// deviation, the findings of all stages and the pass/fail gates.
//
// VerifyReport is the interchange value between the pipeline and every report writer
// (report.json here; HTML, JUnit and Markdown in report.hpp). Fields are only ever added,
// never renamed or removed; `kVerifySchemaVersion` (docs/report-schema.md) is bumped when
// the JSON gains keys.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "printtwin/deviation_types.hpp"
#include "printtwin/finding.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

/// Version of the report.json layout written by `verify_report_json` (docs/report-schema.md).
inline constexpr int kVerifySchemaVersion = 1;

/// One input file, for provenance.
struct VerifyInput {
  std::string role;            ///< "mesh", "gcode" or "printer"
  std::string path;            ///< as given on the command line
  std::string sha256;          ///< lowercase hex of the file's bytes ("" for built-ins)
  std::uint64_t size_bytes = 0;
};

/// Acceptance limits. Every limit is on |d| in mm; unset optional limits default to
/// `tolerance_mm` for excess and deficit and are not checked for RMS.
struct VerifyGates {
  double tolerance_mm = 0.2;                ///< |d| above this is out of tolerance
  std::optional<double> max_excess_mm;      ///< limit on the largest positive deviation
  std::optional<double> max_deficit_mm;     ///< limit on the largest negative deviation (>0)
  std::optional<double> max_rms_mm;         ///< limit on the RMS of both directions
};

/// Outcome of one gate.
struct GateResult {
  std::string name;            ///< "max_excess", "max_deficit", "max_rms", "no_error_findings"
  double limit = 0;            ///< mm (count for no_error_findings)
  double value = 0;            ///< measured, mm (count for no_error_findings)
  bool pass = true;
};

/// Everything that changes the result, echoed into the report.
struct VerifySettings {
  VerifyGates gates;
  double voxel_mm = 0.05;                   ///< deposit voxel edge
  double mesh_sample_spacing_mm = 0;        ///< mesh->deposit sample spacing (0: 2 x voxel_mm)
  std::optional<Vec3> place_mm;             ///< --place override of the registration offset
  std::string printer = "ender3";           ///< profile name or path
  std::string gcode_source = "file";        ///< "file" or "printtwin slice"
  /// Without G-code: a PrusaSlicer .ini for printtwin's slicer (empty: its defaults).
  std::string slice_config_ini;
  /// Without G-code: slicer settings as (key, value), applied after the .ini
  /// (`set_slice_setting` keys, slice.hpp).
  std::vector<std::pair<std::string, std::string>> slice_overrides;
  std::uint64_t seed = 1;                   ///< seed of the mesh surface sampling
  int max_regions = 50;                     ///< largest regions kept in the report
};

/// Summary of the mesh check (check.hpp) and of the mesh itself.
struct CheckSummary {
  std::size_t triangles = 0;
  std::size_t vertices = 0;
  double volume_mm3 = 0;
  double area_mm2 = 0;
  Box3 bbox_mm;                             ///< in the mesh's own frame
  bool watertight = false;
  int errors = 0, warnings = 0, infos = 0;  ///< findings of the check stage by severity
};

/// Summary of the G-code run on the twin (simulate.hpp).
struct SimulationSummary {
  std::string slicer;                       ///< detected flavour ("PrusaSlicer", "Cura", ...)
  std::size_t gcode_lines = 0;
  std::size_t moves = 0;
  std::size_t extrusion_moves = 0;
  int layers = 0;
  double print_time_s = 0;                  ///< planned time, heating/dwell included
  double filament_mm = 0;                   ///< filament length pushed (net of retractions)
  double extruded_volume_mm3 = 0;
  Box3 extrusion_bbox_mm;                   ///< machine frame, all extrusions
  int errors = 0, warnings = 0, infos = 0;  ///< findings of the simulate stage by severity
};

/// Summary of the voxel deposit (deposit.hpp).
struct DepositSummary {
  double voxel_mm = 0;
  std::size_t voxels = 0;                   ///< occupied voxels
  std::size_t surface_voxels = 0;           ///< voxels of the outer surface
  double volume_mm3 = 0;                    ///< voxels * voxel_mm^3
  double extruded_volume_mm3 = 0;           ///< what the beads should hold
  Box3 bbox_mm;                             ///< occupied voxels, machine frame
  Box3 part_bbox_mm;                        ///< part only (skirt/brim/purge/support excluded)
  std::size_t memory_bytes = 0;
};

/// Wall time of one stage.
struct StageTiming {
  std::string stage;                        ///< "load", "check", "simulate", "deposit", ...
  double seconds = 0;
};

/// The whole verdict of one `verify` run.
struct VerifyReport {
  int schema_version = kVerifySchemaVersion;
  std::string tool_version;                 ///< printtwin::kVersion
  std::string part_name;                    ///< mesh file stem
  std::vector<VerifyInput> inputs;
  VerifySettings settings;

  CheckSummary check;
  SimulationSummary simulation;
  DepositSummary deposit;
  /// Deviation in the G-code (machine) frame; registration offset inside.
  DeviationResult deviation;
  /// Mesh as placed in the machine frame (vertex order kept, so
  /// `deviation.vertex_deviation_mm[i]` belongs to `placed_mesh.vertices_mm[i]`).
  Mesh placed_mesh;

  /// Findings of every stage (check, simulate, deposit) plus one `deviation_out_of_tolerance`
  /// finding per region, in stage order.
  std::vector<Finding> findings;
  std::vector<GateResult> gates;
  bool pass = false;                        ///< no error finding and every gate passes
  std::vector<StageTiming> timings;
};

/// What `verify` runs on.
struct VerifyOptions {
  std::filesystem::path mesh_path;
  /// G-code to verify. Empty: printtwin slices the mesh itself (when the slicer is built in;
  /// otherwise an usage error).
  std::filesystem::path gcode_path;
  VerifySettings settings;
};

/// Runs the pipeline. Errors: unreadable/invalid mesh, G-code or printer profile (bad_input),
/// impossible settings (usage). Print defects never error: they are findings and gates.
[[nodiscard]] Result<VerifyReport> verify(const VerifyOptions& options);

/// report.json text of a report (docs/report-schema.md). Deterministic: numbers via
/// to_chars, keys in a fixed order; timings are the only run-dependent values.
[[nodiscard]] std::string verify_report_json(const VerifyReport& report);

/// Writes report.json and deviation.ply into `out_dir` (created), atomically per file.
[[nodiscard]] Status write_verify_outputs(const VerifyReport& report,
                                          const std::filesystem::path& out_dir);

/// Evaluates the gates of `settings` on a deviation and findings; sets `gates` and `pass`.
void evaluate_gates(VerifyReport& report);

}  // namespace printtwin

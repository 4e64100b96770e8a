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
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/deviation_types.hpp"
#include "printtwin/finding.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"
#include "printtwin/slice.hpp"

namespace printtwin {

class DeviationTarget;  // deviation.hpp

/// Version of the report.json layout written by `verify_report_json` (docs/report-schema.md).
inline constexpr int kVerifySchemaVersion = 2;

/// One input file, for provenance.
struct VerifyInput {
  std::string role;    ///< "mesh", "gcode" or "printer"
  std::string path;    ///< as given on the command line
  std::string sha256;  ///< lowercase hex of the file's bytes ("" for built-ins)
  std::uint64_t size_bytes = 0;
};

/// Acceptance limits. Every limit is on |d| in mm; unset optional limits default to
/// `tolerance_mm` for excess and deficit and are not checked for RMS.
struct VerifyGates {
  double tolerance_mm = 0.2;             ///< |d| above this is out of tolerance
  std::optional<double> max_excess_mm;   ///< limit on the largest positive deviation
  std::optional<double> max_deficit_mm;  ///< limit on the largest negative deviation (>0)
  std::optional<double> max_rms_mm;      ///< limit on the RMS of both directions
};

/// Outcome of one gate.
struct GateResult {
  std::string name;  ///< "max_excess", "max_deficit", "max_rms", "no_error_findings"
  double limit = 0;  ///< mm (count for no_error_findings)
  double value = 0;  ///< measured, mm (count for no_error_findings)
  bool pass = true;
};

/// Everything that changes the result, echoed into the report.
struct VerifySettings {
  VerifyGates gates;
  double voxel_mm = 0.05;             ///< deposit voxel edge
  bool conserve_volume = true;        ///< DepositSettings::conserve_volume
  double mesh_sample_spacing_mm = 0;  ///< mesh->deposit sample spacing (0: 2 x voxel_mm)
  std::optional<Vec3> place_mm;       ///< --place override of the registration offset
  /// --place rotation (degrees about the machine's X, then Y, then Z axes, applied to the
  /// mesh before place_mm); only with place_mm.
  std::optional<Vec3> place_rotation_deg;
  /// --units: mesh units in mm (25.4 for inches, 1000 for metres); unset: searched.
  std::optional<double> mesh_scale;
  /// --object: the labelled object to measure (name or id); "": the one that fits best.
  std::string object;
  std::string printer = "auto";       ///< "auto", a profile name or a path (printer.hpp)
  std::string gcode_source = "file";  ///< "file" or "printtwin slice"
  /// Without G-code: a PrusaSlicer .ini for printtwin's slicer (empty: its defaults).
  std::string slice_config_ini;
  /// Without G-code: slicer settings as (key, value), applied after the .ini
  /// (`set_slice_setting` keys, slice.hpp).
  std::vector<std::pair<std::string, std::string>> slice_overrides;
  std::uint64_t seed = 1;  ///< seed of the mesh surface sampling
  int max_regions = 50;    ///< largest regions kept in the report
  /// Keep the deposit's voxels in VerifyReport::deposit_grid (e.g. for --deposit-mesh).
  bool keep_deposit_grid = false;
};

/// Summary of the mesh check (check.hpp) and of the mesh itself.
struct CheckSummary {
  std::size_t triangles = 0;
  std::size_t vertices = 0;
  double volume_mm3 = 0;
  double area_mm2 = 0;
  Box3 bbox_mm;  ///< in the mesh's own frame (scaled and turned as printed: measure_with)
  bool watertight = false;
  int errors = 0, warnings = 0, infos = 0;  ///< findings of the check stage by severity
};

/// Summary of the G-code run on the twin (simulate.hpp).
struct SimulationSummary {
  std::string slicer;  ///< detected flavour ("PrusaSlicer", "Cura", ...)
  std::size_t gcode_lines = 0;
  std::size_t moves = 0;
  std::size_t extrusion_moves = 0;
  int layers = 0;
  double print_time_s = 0;  ///< planned time, heating/dwell included
  double filament_mm = 0;   ///< filament length pushed (net of retractions)
  double extruded_volume_mm3 = 0;
  Box3 extrusion_bbox_mm;                   ///< machine frame, all extrusions
  int errors = 0, warnings = 0, infos = 0;  ///< findings of the simulate stage by severity
};

/// Summary of the voxel deposit (deposit.hpp).
struct DepositSummary {
  double voxel_mm = 0;
  std::size_t voxels = 0;          ///< occupied voxels
  std::size_t surface_voxels = 0;  ///< voxels of the outer surface
  double volume_mm3 = 0;           ///< voxels * voxel_mm^3
  double extruded_volume_mm3 = 0;  ///< what the beads should hold
  Box3 bbox_mm;                    ///< occupied voxels, machine frame
  Box3 part_bbox_mm;               ///< part only (skirt/brim/purge/support excluded)
  std::size_t memory_bytes = 0;
};

/// Wall time of one stage.
struct StageTiming {
  std::string stage;  ///< "load", "check", "simulate", "deposit", ...
  double seconds = 0;
};

/// The whole verdict of one `verify` run.
struct VerifyReport {
  int schema_version = kVerifySchemaVersion;
  std::string tool_version;  ///< printtwin::kVersion
  std::string part_name;     ///< mesh file stem
  std::vector<VerifyInput> inputs;
  VerifySettings settings;

  CheckSummary check;
  SimulationSummary simulation;
  DepositSummary deposit;
  /// Where the mesh sits in the G-code frame and how well it fits (registration).
  Registration registration;
  /// Deviation in the G-code (machine) frame; registration offset inside.
  DeviationResult deviation;
  /// Mesh as placed in the machine frame (vertex order kept, so
  /// `deviation.vertex_deviation_mm[i]` belongs to `placed_mesh.vertices_mm[i]`).
  Mesh placed_mesh;
  /// The printer the G-code ran on, with where each value came from (report.json "printer").
  PrinterProfile printer;

  /// Findings of every stage (check, simulate, deposit) plus one `deviation_out_of_tolerance`
  /// finding per region, in stage order.
  std::vector<Finding> findings;
  std::vector<GateResult> gates;
  bool pass = false;  ///< no error finding and every gate passes
  std::vector<StageTiming> timings;
  /// Wall time of the whole verify() call (0 when not measured, e.g. by verify_gcode). With
  /// --gcode the part's stages run beside the G-code's, so it is less than their sum.
  double elapsed_s = 0;
  /// The deposit's voxels, when settings.keep_deposit_grid (machine frame).
  std::shared_ptr<const VoxelGrid> deposit_grid;
  std::vector<SurfaceBead> deposit_beads;  ///< their beads, when keep_deposit_grid
};

/// The run's time as reports show it: `elapsed_s` when measured, else the sum of the stages.
[[nodiscard]] double total_time_s(const VerifyReport& report);

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
/// Same as prepare_part + (slice_for_verify or read_gcode_input) + verify_gcode; with a
/// G-code file the part's side and the G-code's side run side by side.
/// verify_to_folder (report.hpp) also writes the report folder.
[[nodiscard]] Result<VerifyReport> verify(const VerifyOptions& options);

// ---------------------------------------------------------------- the pipeline in parts
// `verify` is two halves: what depends only on the part (loaded, checked and indexed once:
// PreparedPart) and what every G-code of that part goes through (verify_gcode). `compare`
// runs one PreparedPart against many G-codes.

/// The part's side of a verification, built once and shared by every G-code measured
/// against it: the mesh in its own frame, its provenance, its printability check and the
/// design side of the deviation (Embree BVH, pseudo-normals, surface samples).
struct PreparedPart {
  std::string name;        ///< mesh file stem
  Mesh mesh;               ///< own frame (placed per G-code by registration)
  VerifyInput mesh_input;  ///< path, SHA-256 and size of the mesh file
  CheckSummary check;
  std::vector<Finding> check_findings;
  /// Design side of the deviation in the mesh's own frame (null: built per G-code).
  std::shared_ptr<const DeviationTarget> target;
  std::vector<StageTiming> timings;  ///< "load", "index", "check"
};

/// Reads, loads and checks the mesh and builds its deviation target with `settings`' sample
/// spacing (0: twice the voxel) and seed. Errors: unreadable or invalid mesh (bad input).
[[nodiscard]] Result<PreparedPart> prepare_part(const std::filesystem::path& mesh_path,
                                                const PrinterProfile& printer,
                                                const VerifySettings& settings);
/// The same from a mesh already in memory; `mesh_input` is echoed as the mesh's provenance.
[[nodiscard]] Result<PreparedPart> prepare_part(Mesh mesh, std::string name, VerifyInput mesh_input,
                                                const PrinterProfile& printer,
                                                const VerifySettings& settings);

/// One G-code to verify: its text and where it came from.
struct GcodeInput {
  std::string text;
  std::string name;                 ///< file path, or a label for a printtwin slice
  std::string source = "file";      ///< "file" or "printtwin slice"
  std::vector<VerifyInput> inputs;  ///< provenance (the G-code, a slicer .ini)
  std::vector<Finding> findings;    ///< the slicer's findings (printtwin slice)
  double slice_time_s = 0;          ///< printtwin slice: wall time of slicing
};

/// Reads a G-code file (bad input when unreadable).
[[nodiscard]] Result<GcodeInput> read_gcode_input(const std::filesystem::path& gcode_path);
/// Slices the part with printtwin's slicer (`settings` already complete and validated).
/// `label` names the G-code in findings ("<part>.gcode (printtwin slice)" when empty).
[[nodiscard]] Result<GcodeInput> slice_for_verify(const PreparedPart& part,
                                                  const PrinterProfile& printer,
                                                  const SliceSettings& settings,
                                                  std::string label = {});
/// Slicer settings of `verify` without `--gcode`: defaults, then `settings.slice_config_ini`,
/// then `settings.slice_overrides`, validated. The .ini joins `inputs` when given.
[[nodiscard]] Result<SliceSettings> verify_slice_settings(const VerifySettings& settings,
                                                          std::vector<VerifyInput>* inputs);

/// A G-code run on the twin and deposited: everything of a verification that does not need
/// the mesh (so it can run beside prepare_part).
struct PrintedGcode {
  std::string name;                 ///< GcodeInput::name
  std::string source = "file";      ///< GcodeInput::source
  std::vector<VerifyInput> inputs;  ///< provenance (GcodeInput::inputs)
  SimulationSummary simulation;
  PartExtent extent;               ///< the part's extrusions (registration)
  DepositResult deposit;           ///< its findings moved into `findings`
  std::vector<SurfaceBead> beads;  ///< the part's beads (surface_beads), for the surface
  /// The slicer's findings, then the simulation's, then the deposit's.
  std::vector<Finding> findings;
  std::vector<StageTiming> timings;  ///< slice (printtwin slice), simulate, deposit
  PrinterProfile printer;            ///< the printer it ran on (with value sources)
};

/// simulate -> deposit of one G-code. Errors: invalid G-code, or no extrusion of the part to
/// register against without `settings.place_mm` (bad input); settings out of range (usage).
/// `on_stage` (optional) is called with "simulate" and "deposit" as each starts.
[[nodiscard]] Result<PrintedGcode> print_gcode(
    const PrinterProfile& printer, const VerifySettings& settings, GcodeInput gcode,
    const std::function<void(std::string_view)>& on_stage = {});

/// registration -> deviation -> region findings -> gates of a printed G-code against a
/// prepared part (the second half of verify_gcode). `on_stage` gets "deviation".
[[nodiscard]] Result<VerifyReport> measure_printed(
    const PreparedPart& part, const VerifySettings& settings, PrintedGcode printed,
    bool include_part_timings = true, const std::function<void(std::string_view)>& on_stage = {});

/// print_gcode then measure_printed: simulate -> deposit -> registration -> deviation ->
/// region findings -> gates, for one G-code of a prepared part. The report's findings are the
/// part's check findings, then the slicer's, the simulation's, the deposit's and one per deviation
/// region; its timings are the part's (when `include_part_timings`) then slice, simulate, deposit,
/// deviation. `on_stage` (optional) is called with "simulate", "deposit", "deviation" as each
/// starts. Errors: invalid G-code (bad input), settings out of range (usage).
[[nodiscard]] Result<VerifyReport> verify_gcode(
    const PreparedPart& part, const PrinterProfile& printer, const VerifySettings& settings,
    GcodeInput gcode, bool include_part_timings = true,
    const std::function<void(std::string_view)>& on_stage = {});

/// report.json text of a report (docs/report-schema.md). Deterministic: numbers via
/// to_chars, keys in a fixed order; timings are the only run-dependent values.
[[nodiscard]] std::string verify_report_json(const VerifyReport& report);

/// Writes report.json and deviation.ply into `out_dir` (created), atomically per file.
[[nodiscard]] Status write_verify_outputs(const VerifyReport& report,
                                          const std::filesystem::path& out_dir);

/// Parses --place into `settings`: "x,y,z" (mm, the mesh translated), "x,y,z,rz" (also
/// rotated rz degrees about Z) or "x,y,z;rx,ry,rz" (rotated about the machine's X, then Y,
/// then Z axes, then translated). Errors name the option and the text (usage).
[[nodiscard]] Status parse_place_option(std::string_view text, VerifySettings& settings);
/// Parses --units into `settings.mesh_scale`: mm, cm, m, in (inch), um, or a number (mm per
/// mesh unit). Errors: anything else, or a number that is not finite and > 0 (usage).
[[nodiscard]] Status parse_units_option(std::string_view text, VerifySettings& settings);

/// Evaluates the gates of `settings` on a deviation and findings; sets `gates` and `pass`.
void evaluate_gates(VerifyReport& report);

}  // namespace printtwin

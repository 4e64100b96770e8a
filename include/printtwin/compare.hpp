#pragma once
// compare: runs variants of one part side by side and shows the trade-off between print
// time and deviation (`printtwin compare`, docs/compare.md).
//
//   SweepSpec --expand_variants--> [VariantSpec] --make_compare_plan--> ComparePlan
//   ComparePlan + share (k of n) --run_compare(SharedPart)--> CompareResult (one share)
//   [CompareResult] --merge_compare_results--> CompareResult (whole sweep, Pareto marked)
//   CompareResult --compare_json / compare_markdown / compare_html--> compare.{json,md,html}
//
// Variants
// - Slicer variants: printtwin's own slicer with settings from the defaults, then an optional
//   PrusaSlicer .ini (`--config`), then common `--set key=value`, then the swept values
//   (`--vary key=v1,v2,...`); several `--vary` make the cross product, first axis slowest.
//   Several `--config` make one variant each (times the cross product of the axes).
// - G-code variants: an external file (`--gcode prusa.gcode`), the same part from another
//   slicer. They follow the slicer variants in the variant list.
// The variant list is deterministic: the same command line gives the same indices, labels
// and plan id on every machine, which is what lets shards run apart and merge.
//
// Shared work
// Every variant runs the whole verify pipeline (slice -> simulate -> deposit -> deviation,
// report.json and the verify report folder), but what depends only on the part is built
// once per process and passed in (`SharedPart`): the loaded mesh, its printability check,
// the Embree BVH of the mesh and the slope class of every triangle. The variant report
// folders written by `printtwin compare` also share the heatmaps' BVH and traced views
// (ReportFolderWriter, report.hpp) while the variants' placed meshes are the same.
//
// Sharding
// Variants are independent. Share k of n (0-based k, as SLURM_ARRAY_TASK_ID and GitHub's
// strategy.job-index) holds the variants whose index i has i % n == k (round robin, so a
// sweep sorted by cost spreads evenly). Each share writes a compare JSON holding its rows,
// the variant count and the plan id; `merge_compare_results` checks that the shares come
// from the same plan, that every variant is present exactly once, and rebuilds the table.
//
// Pareto front
// A variant that ran is Pareto-optimal when no other variant that ran is at least as good on
// both objectives (print time, deviation RMS) and strictly better on one. Lower is better
// for both. Equal points are all optimal.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"
#include "printtwin/verify.hpp"

namespace printtwin {

/// Version of compare.json (docs/compare.md). New keys do not bump it; a key that changes
/// meaning or disappears does.
inline constexpr int kCompareSchemaVersion = 1;

/// PLA, the default filament density when the settings do not give one (g/cm^3).
inline constexpr double kDefaultFilamentDensityGCm3 = 1.24;

// ---------------------------------------------------------------- variants

/// A key/value setting as written on the command line (`layer_height`, `0.15`).
using SettingKV = std::pair<std::string, std::string>;

/// One axis of a sweep: `--vary layer_height=0.1,0.15,0.2`.
struct SweepAxis {
  std::string key;
  std::vector<std::string> values;
  bool operator==(const SweepAxis&) const = default;
};

/// Parses "key=v1,v2,...". Errors (usage): no '=', empty key, empty value, repeated value.
[[nodiscard]] Result<SweepAxis> parse_sweep_axis(std::string_view text);
/// Parses "key=value" (usage error without '=' or with an empty key).
[[nodiscard]] Result<SettingKV> parse_setting_kv(std::string_view text);

enum class VariantKind {
  slicer,  ///< printtwin's slicer with `config` + `settings`
  gcode,   ///< an external G-code file
};
[[nodiscard]] std::string_view to_string(VariantKind kind);

/// One variant of the sweep.
struct VariantSpec {
  int index = 0;      ///< 0-based position in the whole variant list
  std::string label;  ///< short, unique: "layer_height=0.1 fill_density=15"
  VariantKind kind = VariantKind::slicer;
  /// Slicer variants: which slicer makes the G-code: "printtwin" (built in), or an external
  /// program: "prusa-slicer", "cura" (CuraEngine), "slic3r" (slicer_backend.cpp).
  std::string slicer = "printtwin";
  std::string config_path;          ///< slicer's config applied first (slicer; may be empty)
  std::vector<SettingKV> settings;  ///< applied in order after the config (slicer)
  std::string gcode_path;           ///< the G-code file (gcode)
  bool operator==(const VariantSpec&) const = default;
};

/// What the command line asks for.
struct SweepSpec {
  /// `--slicer`: one variant set per slicer, in order (empty: printtwin).
  std::vector<std::string> slicers;
  std::vector<SettingKV> common_settings;  ///< `--set key=value`, for every slicer variant
  std::vector<SweepAxis> axes;             ///< `--vary`, crossed in order (first slowest)
  std::vector<std::string> configs;        ///< `--config a.ini`, one variant set each
  std::vector<std::string> gcodes;         ///< `--gcode x.gcode`, one variant each
  /// `--label`: names for the variants in list order; either none or one per variant.
  std::vector<std::string> labels;
};

/// Expands the spec into the ordered variant list:
///   for each config (or none) x for each combination of the axes: a slicer variant;
///   then one gcode variant per file.
/// With neither axes, configs nor gcodes, one slicer variant with the common settings.
/// Errors (usage): the same key swept twice, a label count that does not match, labels
/// that repeat, more than 10000 variants.
[[nodiscard]] Result<std::vector<VariantSpec>> expand_variants(const SweepSpec& spec);

/// Indices of share `k` (0-based) of `n`: every i in [0, count) with i % n == k.
/// Errors (usage): n < 1, k outside [0, n).
[[nodiscard]] Result<std::vector<int>> shard_indices(int variant_count, int k, int n);

// ---------------------------------------------------------------- the plan (manifest)

/// Everything every share must agree on. Written as a manifest by `--write-manifest` and
/// read back by `--manifest`, so that workers of a CI matrix or a batch array do not need the
/// whole command line.
struct ComparePlan {
  std::string mesh_path;         ///< as given (relative paths resolve against the worker's cwd)
  std::string mesh_sha256;       ///< of the mesh file; shares with another hash do not merge
  std::string printer = "auto";  ///< "auto", a profile name or a path (printer.hpp)
  /// External slicers: the program per slicer name (`--slicer-path`; machine specific, so
  /// not part of the plan id), the time limit of one slicing run, Cura's definition (-j).
  std::vector<std::pair<std::string, std::string>> slicer_paths;
  double slicer_timeout_s = 600;
  std::string cura_definition;
  VerifySettings verify;  ///< tolerance, voxel, gates shared by every variant
  double filament_density_g_cm3 = kDefaultFilamentDensityGCm3;  ///< for G-code variants
  std::vector<VariantSpec> variants;
};

/// Identity of a plan: SHA-256 of its canonical JSON without the mesh path (so workers that
/// see the mesh at another path still agree).
[[nodiscard]] std::string compare_plan_id(const ComparePlan& plan);
/// The manifest text (JSON, schema "printtwin.compare-plan").
[[nodiscard]] std::string compare_plan_json(const ComparePlan& plan);
/// Reads a manifest. Errors name `source` and the key that is wrong or missing (bad input).
[[nodiscard]] Result<ComparePlan> parse_compare_plan(std::string_view json_text,
                                                     std::string_view source);

// ---------------------------------------------------------------- results

/// One direction of the deviation, as the table shows it (mm).
struct DirectionFigures {
  std::size_t samples = 0;
  double rms_mm = 0;
  double p95_mm = 0;          ///< 95th percentile of |d|
  double max_excess_mm = 0;   ///< largest positive d (0 when none)
  double max_deficit_mm = 0;  ///< largest -d (>= 0; 0 when none)
  double within_tolerance_pct = 100;
  /// RMS of the samples on sloped surfaces only (normal between `kSlopeMinDeg` and
  /// `kSlopeMaxDeg` from vertical, up or down facing): where layer steps show.
  double slope_rms_mm = 0;
  std::size_t slope_samples = 0;
  bool operator==(const DirectionFigures&) const = default;
};

/// A surface counts as sloped when its normal is between these angles from the horizontal
/// plane (i.e. neither a vertical wall nor a flat top or bottom), degrees.
inline constexpr double kSlopeMinDeg = 5.0;
inline constexpr double kSlopeMaxDeg = 85.0;

/// A deviation region kept for the per-variant summary (largest few).
struct RegionBrief {
  std::string kind;  ///< "missing" or "excess"
  double worst_mm = 0;
  double area_mm2 = 0;
  int layer_min = -1, layer_max = -1;
  Vec3 worst_position_mm = Vec3::Zero();
  bool operator==(const RegionBrief&) const = default;
};

/// One row of the comparison.
struct VariantResult {
  VariantSpec variant;
  bool ran = false;  ///< false: `error` says why (bad G-code, settings, ...)
  std::string error;

  std::string slicer;  ///< "printtwin", "PrusaSlicer 2.5.0", ...
  /// External slicers: the exact command line that made the G-code (shell quoted), so the
  /// variant can be re-run by hand; "" for printtwin's slicer and G-code files.
  std::string command;
  int layers = 0;
  double layer_height_mm = 0;  ///< slicer variants: the setting; G-code: most common step
  double print_time_s = 0;     ///< simulated, heating and dwell included
  double filament_m = 0;       ///< net filament length
  double filament_g = 0;       ///< filament volume x density
  double filament_density_g_cm3 = kDefaultFilamentDensityGCm3;

  DirectionFigures deposit_to_mesh;
  DirectionFigures mesh_to_deposit;
  /// Deviation RMS of both directions: sqrt((rms_d2m^2 + rms_m2d^2) / 2). Pareto objective.
  double rms_mm = 0;
  /// Same on sloped surfaces only.
  double slope_rms_mm = 0;

  int missing_regions = 0, excess_regions = 0;
  int error_findings = 0, warning_findings = 0, info_findings = 0;
  std::vector<GateResult> gates;
  bool pass = false;
  std::vector<RegionBrief> top_regions;  ///< at most 5, largest first

  /// The variant's verify report folder, relative to the folder of the compare.json that
  /// lists it ("" when not written).
  std::string report_dir;
  double run_time_s = 0;  ///< wall time of this variant (run dependent)
  bool pareto = false;    ///< set by mark_pareto
  bool operator==(const VariantResult&) const = default;
};

/// What the part is, for the header of every output.
struct ComparePartInfo {
  std::string name;  ///< file stem
  std::string path;
  std::string sha256;
  std::size_t triangles = 0;
  double volume_mm3 = 0;
  double area_mm2 = 0;
  double sloped_area_mm2 = 0;  ///< area of the triangles counted as sloped
  Box3 bbox_mm;
  bool operator==(const ComparePartInfo&) const = default;
};

/// A whole comparison, or one share of it.
struct CompareResult {
  int schema_version = kCompareSchemaVersion;
  std::string tool_version;
  ComparePartInfo part;
  std::string printer;
  VerifySettings verify;  ///< gates and voxel every variant ran with
  std::string plan_id;
  int variant_count = 0;  ///< variants in the whole plan
  /// Set on a share's JSON ({k, n}); unset on a complete or merged comparison.
  std::optional<std::pair<int, int>> shard;
  std::vector<VariantResult> variants;  ///< sorted by variant index
  double shared_time_s = 0;             ///< load + check + BVH, once per process (run dependent)
  double total_time_s = 0;              ///< whole run (run dependent; sum of shares when merged)
  bool operator==(const CompareResult&) const = default;
};

/// Pareto flags of points (x, y), both minimised. NaN points are never optimal.
[[nodiscard]] std::vector<bool> pareto_front(std::span<const std::pair<double, double>> points);
/// Sets `pareto` on every variant: front over (print_time_s, rms_mm) among those that ran.
void mark_pareto(std::vector<VariantResult>& variants);

/// RMS of both directions with equal weight: sqrt((rms_a^2 + rms_b^2) / 2).
[[nodiscard]] double combined_rms_mm(double rms_a_mm, double rms_b_mm);

/// Figures of one variant from its verify report. `slope_of_triangle` (may be empty) flags
/// the sloped triangles of the mesh; `deposit_triangle` / `mesh_triangle` give the mesh
/// triangle nearest each deposit / mesh sample (may be empty: no slope figures).
[[nodiscard]] VariantResult summarize_variant(const VariantSpec& spec, const VerifyReport& report,
                                              std::span<const std::uint8_t> slope_of_triangle,
                                              std::span<const std::uint32_t> deposit_triangle,
                                              std::span<const std::uint32_t> mesh_triangle,
                                              double filament_density_g_cm3);

/// Merges shares: same plan id, part hash and variant count; each index once (a repeated
/// index with the same label is dropped as a duplicate upload). `require_complete`: every
/// index of the plan present, else an error listing the missing ones. Marks the Pareto front.
[[nodiscard]] Result<CompareResult> merge_compare_results(std::vector<CompareResult> shares,
                                                          bool require_complete = true);

// ---------------------------------------------------------------- outputs

/// compare.json text (schema "printtwin.compare", kCompareSchemaVersion). Deterministic:
/// fixed key order, numbers via to_chars; run times are the only run-dependent values.
[[nodiscard]] std::string compare_json(const CompareResult& result);
/// Reads compare.json text back (for --merge). Errors name `source` and the key.
[[nodiscard]] Result<CompareResult> parse_compare_json(std::string_view json_text,
                                                       std::string_view source);
/// compare.md: verdict line, the table, the Pareto-optimal variants.
[[nodiscard]] std::string compare_markdown(const CompareResult& result);

struct CompareHtmlOptions {
  std::string generated_utc;  ///< shown in the footer; empty: not stamped
};
/// Inline SVG chart: print time (x, minutes) against deviation RMS (y, mm), every variant a
/// point (green pass, red fail), the Pareto front drawn as a line through ringed points.
[[nodiscard]] std::string compare_chart_svg(const CompareResult& result);
/// compare.html: self-contained (inline CSS, SVG, a little JS for sorting; no network).
[[nodiscard]] std::string compare_html(const CompareResult& result,
                                       const CompareHtmlOptions& options = {});

/// Writes compare.json, compare.md and compare.html into `out_dir` (each atomically).
[[nodiscard]] Status write_compare_outputs(const CompareResult& result,
                                           const std::filesystem::path& out_dir,
                                           const CompareHtmlOptions& options = {});

/// File name of a share's JSON: "compare-<k>-of-<n>.json" (k 0-based).
[[nodiscard]] std::string shard_file_name(int k, int n);

// ---------------------------------------------------------------- external slicers

/// The slicers `--slicer` accepts: "printtwin", "prusa-slicer", "cura", "slic3r".
[[nodiscard]] bool is_known_slicer(std::string_view name);
/// Usage error for an unknown name (listing the known ones).
[[nodiscard]] Status check_slicer_name(std::string_view name);

/// An external slicer found on this machine.
struct SlicerProgram {
  std::string name;     ///< "prusa-slicer", "cura", "slic3r"
  std::string program;  ///< absolute path of the executable
  std::string version;  ///< "PrusaSlicer 2.5.0", "CuraEngine 4.13.0" ("" if unknown)
};

/// Finds the program of `name`: `path` when given (must be an executable file), else the
/// PATH (prusa-slicer / PrusaSlicer, CuraEngine, slic3r), and asks it for its version.
/// Errors (usage, exit 2): not installed, naming the Debian package that provides it.
[[nodiscard]] Result<SlicerProgram> find_slicer_program(std::string_view name,
                                                        std::string_view path);

/// `--slicer-path` values: "name=path" pairs, or one bare path when exactly one external
/// slicer is in `slicers`. Errors (usage): a bare path with several slicers, unknown name.
[[nodiscard]] Result<std::vector<SettingKV>> parse_slicer_paths(
    const std::vector<std::string>& values, const std::vector<std::string>& slicers);

/// The library printer (id) a Cura definition names by its "name" ("Creality Ender-3"), or
/// "" when the file is unreadable or names no library printer. A Cura G-code states only
/// its flavour, so this is the twin's printer for Cura variants under `--printer auto`.
[[nodiscard]] std::string cura_definition_printer(const std::string& definition_path);

/// What one external slicing run needs.
struct SlicerJob {
  std::string mesh_path;
  std::string config_path;          ///< PrusaSlicer/Slic3r .ini, Cura key=value file ("" none)
  std::vector<SettingKV> settings;  ///< applied after the config, later keys win
  std::string cura_definition;      ///< Cura: the printer's .def.json (-j)
  std::string out_gcode;
};

/// `settings` in the names of `slicer`: the settings PrusaSlicer/Slic3r and Cura share
/// (first layer height, perimeters/wall_line_count, top/bottom layers, fill_density/
/// infill_sparse_density with or without '%', the speeds, temperatures, skirts, retraction
/// length) are renamed from the other vocabulary; layer_height and every other key pass as
/// given. slicer_command applies it, so one --vary serves a mixed comparison.
[[nodiscard]] std::vector<SettingKV> slicer_settings(std::string_view slicer,
                                                     const std::vector<SettingKV>& settings);

/// The argument vector that slices `job` with `program` (argv[0] is the program).
/// PrusaSlicer/Slic3r: `--load <ini> --<key> <value> ... --export-gcode -o out part.stl`;
/// CuraEngine: `slice -v -j def.json -s key=value ... (config lines first) -l part -o out`.
/// Errors (usage): Cura without a definition; an unreadable Cura settings file (bad input).
[[nodiscard]] Result<std::vector<std::string>> slicer_command(const SlicerProgram& program,
                                                              const SlicerJob& job);
/// The effective settings of a job: the last value of each key, sorted by key; two variants
/// with the same slicer, config and effective settings make the same G-code.
[[nodiscard]] std::vector<SettingKV> effective_settings(const std::vector<SettingKV>& settings);
/// Variables the slicer needs (Cura: CURA_ENGINE_SEARCH_PATH, the definition's folder and
/// the extruders beside it, unless already set).
[[nodiscard]] std::vector<SettingKV> slicer_environment(const SlicerProgram& program,
                                                        const SlicerJob& job);
/// The command as a user re-runs it in a shell: variables first, then the quoted argv.
[[nodiscard]] Result<std::string> slicer_command_line(const SlicerProgram& program,
                                                      const SlicerJob& job);
/// One line a shell reads back as `argv` (single quotes where needed).
[[nodiscard]] std::string shell_quote(const std::vector<std::string>& argv);

/// How a child process ended.
struct ProcessRun {
  int exit_code = -1;  ///< -1: killed by a signal or not started
  bool timed_out = false;
  bool started = false;
  std::string output;  ///< stdout then stderr, at most 64 KiB of each (tail)
  double seconds = 0;
};
/// Runs `argv` (no shell) with `env` added to the environment, stops it (and its children)
/// after `timeout_s` seconds.
[[nodiscard]] ProcessRun run_process(const std::vector<std::string>& argv,
                                     const std::vector<SettingKV>& env, double timeout_s);

/// The config file to hand the slicer `slicer` for the user's `config_path`: the file itself,
/// or, for a PrusaSlicer 3MF project given to prusa-slicer or slic3r (whose --load reads
/// only .ini), the project's settings written to `extracted_ini`. Empty stays empty. Cura
/// reads no 3MF project: a zip given to it is an error that says so.
[[nodiscard]] Result<std::string> slicer_config_file(std::string_view slicer,
                                                     const std::string& config_path,
                                                     const std::filesystem::path& extracted_ini);

/// Slices `job` with `program`: runs the command, checks that a G-code was written.
/// Errors (bad input) quote the slicer's own last lines of output, or say it timed out.
/// `command_out` receives the quoted command line in every case.
[[nodiscard]] Status run_external_slicer(const SlicerProgram& program, const SlicerJob& job,
                                         double timeout_s, std::string* command_out = nullptr);

// ---------------------------------------------------------------- running

/// What every variant shares, built once: the part as `verify` prepares it (mesh in its own
/// frame, its check, the design side of the deviation: BVH, pseudo-normals, surface samples)
/// and the slope class of each triangle. Each variant's registration only translates the mesh, so
/// queries subtract the variant's offset.
struct SharedPart {
  PreparedPart prepared;
  ComparePartInfo info;
  std::vector<std::uint8_t> sloped;  ///< 1 per triangle counted as sloped
  double build_time_s = 0;
};

/// Loads and checks the mesh, builds the deviation target (with `settings`' sample
/// spacing and seed) and the slope classes.
[[nodiscard]] Result<SharedPart> prepare_shared_part(const std::filesystem::path& mesh_path,
                                                     const PrinterProfile& printer,
                                                     const VerifySettings& settings = {});
/// The same from a mesh already in memory (`name` for the report).
[[nodiscard]] Result<SharedPart> prepare_shared_part(Mesh mesh, std::string name,
                                                     const PrinterProfile& printer,
                                                     const VerifySettings& settings = {});

/// Progress of a run, reported after each variant.
struct CompareProgress {
  int done = 0;                         ///< variants finished in this run
  int total = 0;                        ///< variants of this run (the share)
  const VariantResult* last = nullptr;  ///< the variant that just finished
  std::string stage;                    ///< stage being entered for the next variant ("slice", ...)
};

struct CompareRunOptions {
  /// Output folder of the comparison; each variant's verify report goes to
  /// `out_dir/variants/<NN>-<slug>/` when `variant_reports` is set.
  std::filesystem::path out_dir;
  bool variant_reports = true;
  /// Called when a variant starts a stage and when it finishes (from the calling thread).
  std::function<void(const CompareProgress&)> progress;
  /// Writes one variant's report folder (report.html, ...). Empty: report.json and
  /// deviation.ply only (write_verify_outputs).
  std::function<Status(const VerifyReport&, const std::filesystem::path&)> write_variant_report;
};

/// Checks a plan before anything runs: every slicer variant's config is readable and its
/// settings apply and validate (usage error naming the variant and key), every G-code file
/// is readable (bad input).
[[nodiscard]] Status validate_plan(const ComparePlan& plan);

/// Runs one verify of `spec` on the shared part (slice or read G-code, simulate, deposit,
/// deviation, gates) and returns the VerifyReport. Errors are the variant's (bad G-code,
/// impossible settings); the caller records them as a row that did not run.
[[nodiscard]] Result<VerifyReport> run_variant_verify(
    const SharedPart& part, const PrinterProfile& printer, const ComparePlan& plan,
    const VariantSpec& spec, const std::function<void(std::string_view stage)>& on_stage = {});

/// The header of a comparison of `plan` on `part` with no rows yet (part, printer, gates,
/// plan id, variant count, shared time).
[[nodiscard]] CompareResult make_compare_result(const SharedPart& part, const ComparePlan& plan);

/// Runs the variants `indices` of the plan (all when empty) on the shared part, in index
/// order, marks the Pareto front among them and returns the rows. A variant that fails is a
/// row with `ran = false`; only an unusable plan (bad printer, indices out of range) errors.
[[nodiscard]] Result<CompareResult> run_compare(const SharedPart& part, const ComparePlan& plan,
                                                std::span<const int> indices,
                                                const CompareRunOptions& options);

}  // namespace printtwin

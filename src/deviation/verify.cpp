// verify(): check -> (slice) -> simulate -> deposit -> deviation, aggregated into a
// VerifyReport with gates and a verdict.
#include <chrono>
#include <cmath>
#include <sstream>

#include "printtwin/check.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"
#include "printtwin/slice.hpp"
#include "printtwin/verify.hpp"
#include "printtwin/version.hpp"

namespace printtwin {

namespace {

/// Collects every interpreted Move (the deposit and the registration need them all).
class CollectMoves final : public MoveSink {
 public:
  std::vector<Move> moves;
  void on_move(const Move& move) override { moves.push_back(move); }
};

class StageClock {
 public:
  explicit StageClock(std::vector<StageTiming>& out) : out_(out) {}
  void lap(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    out_.push_back({stage, std::chrono::duration<double>(now - last_).count()});
    last_ = now;
  }

 private:
  std::vector<StageTiming>& out_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

void count_severities(const std::vector<Finding>& findings, int& errors, int& warnings, int& infos) {
  for (const auto& f : findings) {
    if (f.severity == Severity::error) ++errors;
    else if (f.severity == Severity::warning) ++warnings;
    else ++infos;
  }
}

Result<VerifyInput> describe_input(const std::string& role, const std::filesystem::path& path,
                                   std::string* content = nullptr) {
  auto text = read_file(path);
  if (!text) return text.error();
  VerifyInput in{role, path.string(), sha256_hex(*text), text->size()};
  if (content != nullptr) *content = std::move(*text);
  return in;
}

std::string fmt_mm(double v) { return format_fixed(v, 3); }

}  // namespace

void evaluate_gates(VerifyReport& report) {
  const VerifyGates& g = report.settings.gates;
  const DeviationResult& d = report.deviation;
  report.gates.clear();
  int errors = 0;
  for (const auto& f : report.findings)
    if (f.severity == Severity::error) ++errors;
  report.gates.push_back({"no_error_findings", 0, static_cast<double>(errors), errors == 0});
  const double excess_limit = g.max_excess_mm.value_or(g.tolerance_mm);
  const double deficit_limit = g.max_deficit_mm.value_or(g.tolerance_mm);
  report.gates.push_back({"max_excess", excess_limit, d.max_excess_mm, d.max_excess_mm <= excess_limit});
  report.gates.push_back({"max_deficit", deficit_limit, d.max_deficit_mm, d.max_deficit_mm <= deficit_limit});
  if (g.max_rms_mm) {
    const double rms = std::max(d.deposit_to_mesh.rms_mm, d.mesh_to_deposit.rms_mm);
    report.gates.push_back({"max_rms", *g.max_rms_mm, rms, rms <= *g.max_rms_mm});
  }
  report.pass = true;
  for (const auto& gate : report.gates) report.pass = report.pass && gate.pass;
}

Result<VerifyReport> verify(const VerifyOptions& options) {
  const VerifySettings& settings = options.settings;
  if (!(settings.gates.tolerance_mm > 0)) return usage_error("--tolerance must be > 0 mm");
  for (const auto& limit : {settings.gates.max_excess_mm, settings.gates.max_deficit_mm, settings.gates.max_rms_mm})
    if (limit && !(*limit >= 0)) return usage_error("gate limits (--max-excess, --max-deficit, --max-rms) must be >= 0 mm");
  if (!(settings.voxel_mm >= 0.01 && settings.voxel_mm <= 1.0))
    return usage_error("--voxel must be between 0.01 and 1 mm, got " + format_number(settings.voxel_mm));

  VerifyReport report;
  report.tool_version = kVersion;
  report.settings = settings;
  report.part_name = options.mesh_path.stem().string();
  StageClock clock(report.timings);

  // Inputs.
  auto mesh_in = describe_input("mesh", options.mesh_path);
  if (!mesh_in) return mesh_in.error();
  report.inputs.push_back(*mesh_in);
  auto mesh = load_mesh(options.mesh_path);
  if (!mesh) return mesh.error();
  auto printer = load_printer_profile(settings.printer);
  if (!printer) return printer.error();
  if (std::filesystem::exists(settings.printer)) {
    auto printer_in = describe_input("printer", settings.printer);
    if (!printer_in) return printer_in.error();
    report.inputs.push_back(*printer_in);
  } else {
    report.inputs.push_back({"printer", settings.printer, "", 0});
  }
  clock.lap("load");

  // Check.
  CheckSettings check_settings;
  check_settings.self_intersections = mesh->triangles.size() <= 50000;
  auto check = check_printability(*mesh, *printer, check_settings);
  if (!check) return check.error();
  report.check.triangles = check->health.triangles;
  report.check.vertices = check->health.vertices;
  report.check.volume_mm3 = check->health.volume_mm3;
  report.check.area_mm2 = check->health.area_mm2;
  report.check.bbox_mm = check->health.bbox_mm;
  report.check.watertight = check->health.closed;
  count_severities(check->findings, report.check.errors, report.check.warnings, report.check.infos);
  report.findings.insert(report.findings.end(), check->findings.begin(), check->findings.end());
  clock.lap("check");

  // G-code: the given file, or our own slice of the mesh.
  std::string gcode_text;
  std::string gcode_name;
  const VerifySettings& vs = options.settings;
  if (!options.gcode_path.empty() && (!vs.slice_config_ini.empty() || !vs.slice_overrides.empty()))
    return usage_error("slicer settings (--set, --config) apply only when printtwin slices the part; "
                       "drop --gcode or the settings");
  if (!options.gcode_path.empty()) {
    auto gcode_in = describe_input("gcode", options.gcode_path, &gcode_text);
    if (!gcode_in) return gcode_in.error();
    report.inputs.push_back(*gcode_in);
    gcode_name = options.gcode_path.string();
  } else {
    SliceSettings slice_settings;
    if (!vs.slice_config_ini.empty()) {
      std::string ini_text;
      auto ini_in = describe_input("slice_config", vs.slice_config_ini, &ini_text);
      if (!ini_in) return ini_in.error();
      report.inputs.push_back(*ini_in);
      auto applied = apply_prusa_ini(slice_settings, ini_text, vs.slice_config_ini);
      if (!applied) return applied.error();
    }
    for (const auto& [key, value] : vs.slice_overrides)
      if (auto st = set_slice_setting(slice_settings, key, value); !st) return st.error();
    if (auto st = validate_slice_settings(slice_settings); !st) return st.error();
    auto sliced = slice_mesh(*mesh, *printer, slice_settings);
    if (!sliced) return sliced.error();
    gcode_text = std::move(sliced->gcode);
    gcode_name = report.part_name + ".gcode (printtwin slice)";
    report.settings.gcode_source = "printtwin slice";
    report.inputs.push_back({"gcode", gcode_name, sha256_hex(gcode_text), gcode_text.size()});
    report.findings.insert(report.findings.end(), sliced->findings.begin(), sliced->findings.end());
    clock.lap("slice");
  }

  // Simulate, collecting the moves.
  CollectMoves collector;
  SimulateOptions sim_options;
  sim_options.source_name = gcode_name;
  std::istringstream gcode_stream(std::move(gcode_text));
  auto sim = simulate_gcode(gcode_stream, *printer, sim_options, &collector);
  if (!sim) return sim.error();
  {
    SimulationSummary& s = report.simulation;
    s.slicer = sim->slicer;
    s.gcode_lines = static_cast<std::size_t>(sim->lines);
    s.moves = static_cast<std::size_t>(sim->moves);
    for (const auto& m : collector.moves) s.extrusion_moves += m.kind == MoveKind::extrude ? 1 : 0;
    s.layers = static_cast<int>(sim->layers.size());
    s.print_time_s = sim->print_time_s;
    s.filament_mm = sim->filament_mm;
    s.extruded_volume_mm3 = sim->filament_mm3;
    s.extrusion_bbox_mm = sim->extrusion_bounds_mm;
    count_severities(sim->findings, s.errors, s.warnings, s.infos);
    report.findings.insert(report.findings.end(), sim->findings.begin(), sim->findings.end());
  }
  clock.lap("simulate");

  // Deposit.
  DepositSettings dep_settings;
  dep_settings.voxel_mm = settings.voxel_mm;
  auto deposit = deposit_moves(collector.moves, *printer, dep_settings);
  if (!deposit) return deposit.error();
  report.deposit.voxel_mm = deposit->voxel_mm;
  report.deposit.voxels = deposit->voxels;
  report.deposit.volume_mm3 = deposit->volume_mm3;
  report.deposit.extruded_volume_mm3 = deposit->extruded_mm3;
  report.deposit.bbox_mm = deposit->bbox_mm;
  report.deposit.memory_bytes = deposit->memory_bytes;
  report.findings.insert(report.findings.end(), deposit->findings.begin(), deposit->findings.end());
  clock.lap("deposit");

  // Registration and deviation.
  const PartExtent part = find_part_extent(collector.moves);
  report.deposit.part_bbox_mm = part.bbox_mm;
  collector.moves = {};
  Vec3 offset = registration_offset(*mesh, part);
  std::string method = "auto (" + (part.method.empty() ? std::string("no extrusions") : part.method) + ")";
  if (settings.place_mm) {
    offset = *settings.place_mm;
    method = "--place";
  }
  report.placed_mesh = translated(std::move(*mesh), offset);
  DeviationSettings dev_settings;
  dev_settings.tolerance_mm = settings.gates.tolerance_mm;
  dev_settings.mesh_sample_spacing_mm = settings.mesh_sample_spacing_mm;
  dev_settings.seed = settings.seed;
  dev_settings.max_regions = settings.max_regions;
  dev_settings.keep_samples = true;
  auto dev = compute_deviation(report.placed_mesh, deposit->grid, dev_settings, part.bbox_mm);
  if (!dev) return dev.error();
  report.deviation = std::move(*dev);
  report.deviation.registration_offset_mm = offset;
  report.deviation.registration_method = method;
  report.deposit.surface_voxels = report.deviation.surface_voxels;
  clock.lap("deviation");

  // One finding per region, so CI logs and JUnit name every defect.
  for (const auto& r : report.deviation.regions) {
    Finding f;
    f.severity = Severity::warning;
    const bool missing = r.kind == RegionKind::missing;
    f.code = missing ? "deviation_missing" : "deviation_excess";
    f.message = std::string(missing ? "material missing" : "excess material") + ": " +
                format_fixed(r.area_mm2, 2) + " mm2, worst " + fmt_mm(r.worst_mm) + " mm, layers " +
                std::to_string(r.layer_min) + "-" + std::to_string(r.layer_max) + " (tolerance " +
                fmt_mm(settings.gates.tolerance_mm) + " mm)";
    f.position_mm = r.worst_position_mm;
    f.extent_mm = r.bbox_mm;
    if (!r.gcode_lines.empty()) f.line = r.gcode_lines.front();
    if (r.layer_min >= 0) f.layer = r.layer_min;
    f.value = r.worst_mm;
    f.count = static_cast<long>(r.samples);
    report.findings.push_back(std::move(f));
  }
  evaluate_gates(report);
  return report;
}

}  // namespace printtwin

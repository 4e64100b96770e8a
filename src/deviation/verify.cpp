// verify(): check -> (slice) -> simulate -> deposit -> deviation, aggregated into a
// VerifyReport with gates and a verdict.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <sstream>

#include <tbb/task_group.h>

#include "printtwin/bgcode.hpp"
#include "printtwin/check.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh_query.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/printer.hpp"
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

/// The transform of --place (rotation, then translation; --units scale first).
RigidTransform place_transform(const VerifySettings& settings) {
  RigidTransform t;
  if (settings.place_rotation_deg) t.rotation = rotation_from_xyz_deg(*settings.place_rotation_deg);
  t.scale = settings.mesh_scale.value_or(1.0);
  t.translation_mm = settings.place_mm.value_or(Vec3::Zero());
  return t;
}

/// Where the mesh sits in the G-code frame: --place (with its figures), else the search.
Result<Registration> place_part(const PreparedPart& part, const PartExtent& extent, const VerifySettings& settings) {
  RegistrationOptions options;
  options.scale = settings.mesh_scale;
  options.object = settings.object;
  std::optional<MeshQuery> own;
  if (!part.target) {
    auto built = MeshQuery::build(part.mesh);
    if (!built) return built.error();
    own.emplace(std::move(*built));
  }
  const MeshQuery& query = part.target ? part.target->query() : *own;
  if (settings.place_mm) {
    if (extent.objects.empty()) {
      Registration r;
      r.transform = place_transform(settings);
      r.method = "--place";
      return r;
    }
    return evaluate_registration(part.mesh, query, extent, place_transform(settings), options);
  }
  return register_mesh(part.mesh, query, extent, options);
}

Mesh placed(const Mesh& mesh, const RigidTransform& t) {
  return t.translation_only() ? translated(mesh, t.translation_mm) : transformed(mesh, t);
}

}  // namespace

double total_time_s(const VerifyReport& report) {
  if (report.elapsed_s > 0) return report.elapsed_s;
  double sum = 0;
  for (const auto& t : report.timings) sum += t.seconds;
  return sum;
}

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

namespace {

Status validate_verify_settings(const VerifySettings& settings) {
  if (!(settings.gates.tolerance_mm > 0)) return usage_error("--tolerance must be > 0 mm");
  for (const auto& limit : {settings.gates.max_excess_mm, settings.gates.max_deficit_mm, settings.gates.max_rms_mm})
    if (limit && !(*limit >= 0)) return usage_error("gate limits (--max-excess, --max-deficit, --max-rms) must be >= 0 mm");
  if (!(settings.voxel_mm >= 0.01 && settings.voxel_mm <= 1.0))
    return usage_error("--voxel must be between 0.01 and 1 mm, got " + format_number(settings.voxel_mm));
  return Ok{};
}

DeviationSettings deviation_settings_of(const VerifySettings& settings) {
  DeviationSettings d;
  d.tolerance_mm = settings.gates.tolerance_mm;
  d.mesh_sample_spacing_mm = settings.mesh_sample_spacing_mm;
  d.seed = settings.seed;
  d.max_regions = settings.max_regions;
  d.keep_samples = true;
  return d;
}

/// One finding per deviation region, so CI logs and JUnit name every defect.
Finding region_finding(const DeviationRegion& r, double tolerance_mm) {
  Finding f;
  f.severity = Severity::warning;
  const bool missing = r.kind == RegionKind::missing;
  f.code = missing ? "deviation_missing" : "deviation_excess";
  f.message = std::string(missing ? "material missing" : "excess material") + ": " +
              format_fixed(r.area_mm2, 2) + " mm2, worst " + fmt_mm(r.worst_mm) + " mm, layers " +
              std::to_string(r.layer_min) + "-" + std::to_string(r.layer_max) + " (tolerance " +
              fmt_mm(tolerance_mm) + " mm)";
  f.position_mm = r.worst_position_mm;
  f.extent_mm = r.bbox_mm;
  if (!r.gcode_lines.empty()) f.line = r.gcode_lines.front();
  if (r.layer_min >= 0) f.layer = r.layer_min;
  f.value = r.worst_mm;
  f.count = static_cast<long>(r.samples);
  return f;
}

/// The part's size against the printer's build volume (wherever the G-code places it).
Status check_fits_printer(const Mesh& mesh, const PrinterProfile& printer, const std::string& file) {
  const Vec3 size = bounding_box(mesh).size();
  const Vec3 room(printer.bed_max_x_mm - printer.bed_min_x_mm, printer.bed_max_y_mm - printer.bed_min_y_mm,
                  printer.max_z_mm);
  constexpr double eps = 1e-6;
  if (size.allFinite() && (size.array() <= room.array() + eps).all()) return Ok{};
  auto box = [](const Vec3& v) {
    return format_fixed(v.x(), 2) + " x " + format_fixed(v.y(), 2) + " x " + format_fixed(v.z(), 2) + " mm";
  };
  return bad_input("the part (" + box(size) + ") is larger than the build volume of " + printer.name + " (" +
                       box(room) + "): it cannot print, so there is nothing to verify",
                   file);
}

}  // namespace

Result<PreparedPart> prepare_part(Mesh mesh, std::string name, VerifyInput mesh_input,
                                  const PrinterProfile& printer, const VerifySettings& settings) {
  if (mesh.triangles.empty()) return bad_input("the mesh has no triangles", mesh_input.path);
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  // The fit first, as check and slice do: a part larger than the printer cannot print, and
  // its deviation samples could outgrow the memory.
  if (auto st = check_fits_printer(mesh, printer, mesh_input.path); !st) return st.error();
  PreparedPart part;
  part.name = std::move(name);
  part.mesh_input = std::move(mesh_input);
  StageClock clock(part.timings);
  // The deviation's design side first: its BVH also serves the check's thickness rays.
  auto target = DeviationTarget::build(mesh, deviation_settings_of(settings), settings.voxel_mm);
  if (!target) return target.error();
  part.target = std::make_shared<const DeviationTarget>(std::move(*target));
  clock.lap("index");
  CheckSettings check_settings;
  check_settings.mesh_query = &part.target->query();
  check_settings.thickness_beyond_limit = false;  // verify reports the thin-wall finding, not the thinnest wall
  auto check = check_printability(mesh, printer, check_settings);
  if (!check) return check.error();
  CheckSummary& c = part.check;
  c.triangles = check->health.triangles;
  c.vertices = check->health.vertices;
  c.volume_mm3 = check->health.volume_mm3;
  c.area_mm2 = check->health.area_mm2;
  c.bbox_mm = check->health.bbox_mm;
  c.watertight = check->health.closed;
  count_severities(check->findings, c.errors, c.warnings, c.infos);
  part.check_findings = std::move(check->findings);
  clock.lap("check");
  part.mesh = std::move(mesh);
  return part;
}

Result<PreparedPart> prepare_part(const std::filesystem::path& mesh_path, const PrinterProfile& printer,
                                  const VerifySettings& settings) {
  std::vector<StageTiming> load_timing;
  StageClock clock(load_timing);
  std::string bytes;  // read once: hashed for the provenance, then parsed
  auto mesh_in = describe_input("mesh", mesh_path, &bytes);
  if (!mesh_in) return mesh_in.error();
  auto mesh = load_mesh_from_memory(bytes, mesh_path);
  if (!mesh) return mesh.error();
  bytes = {};
  clock.lap("load");
  auto part = prepare_part(std::move(*mesh), mesh_path.stem().string(), std::move(*mesh_in), printer, settings);
  if (!part) return part.error();
  part->timings.insert(part->timings.begin(), load_timing.begin(), load_timing.end());
  return part;
}

Result<GcodeInput> read_gcode_input(const std::filesystem::path& gcode_path) {
  GcodeInput g;
  auto in = describe_input("gcode", gcode_path, &g.text);
  if (!in) return in.error();
  g.inputs.push_back(*in);
  g.name = gcode_path.string();
  g.source = "file";
  return g;
}

Result<SliceSettings> verify_slice_settings(const VerifySettings& settings, std::vector<VerifyInput>* inputs) {
  SliceSettings slice_settings;
  if (!settings.slice_config_ini.empty()) {
    std::string ini_text;
    auto ini_in = describe_input("slice_config", settings.slice_config_ini, &ini_text);
    if (!ini_in) return ini_in.error();
    if (inputs != nullptr) inputs->push_back(*ini_in);
    auto applied = apply_prusa_ini(slice_settings, ini_text, settings.slice_config_ini);
    if (!applied) return applied.error();
  }
  for (const auto& [key, value] : settings.slice_overrides)
    if (auto st = set_slice_setting(slice_settings, key, value); !st) return st.error();
  if (auto st = validate_slice_settings(slice_settings); !st) return st.error();
  return slice_settings;
}

Result<GcodeInput> slice_for_verify(const PreparedPart& part, const PrinterProfile& printer,
                                    const SliceSettings& settings, std::string label) {
  const auto t0 = std::chrono::steady_clock::now();
  auto sliced = slice_mesh(part.mesh, printer, settings);
  if (!sliced) return sliced.error();
  GcodeInput g;
  g.text = std::move(sliced->gcode);
  g.name = label.empty() ? part.name + ".gcode (printtwin slice)" : std::move(label);
  g.source = "printtwin slice";
  g.inputs.push_back({"gcode", g.name, sha256_hex(g.text), g.text.size()});
  g.findings = std::move(sliced->findings);
  g.slice_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return g;
}

Result<PrintedGcode> print_gcode(const PrinterProfile& printer, const VerifySettings& settings,
                                 GcodeInput gcode, const std::function<void(std::string_view)>& on_stage,
                                 const std::function<void(const PartExtent&)>& on_extent) {
  auto stage = [&](std::string_view name) {
    if (on_stage) on_stage(name);
  };
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  PrintedGcode printed;
  printed.name = gcode.name;
  printed.source = gcode.source;
  printed.inputs = std::move(gcode.inputs);
  printed.findings = std::move(gcode.findings);
  printed.printer = printer;
  if (gcode.source == "printtwin slice") printed.timings.push_back({"slice", gcode.slice_time_s});
  StageClock clock(printed.timings);

  // Simulate, collecting the moves.
  stage("simulate");
  CollectMoves collector;
  // About a move per line: reserved up front, the list is never copied as it grows (the
  // capacity no move reaches is never touched).
  collector.moves.reserve(static_cast<std::size_t>(std::count(gcode.text.begin(), gcode.text.end(), '\n')) + 1);
  SimulateOptions sim_options;
  sim_options.source_name = gcode.name;
  auto sim = [&]() -> Result<SimulationResult> {
    if (is_bgcode_input(gcode.text, gcode.name)) {  // binary G-code (bgcode.hpp): decoded block by block
      auto stream = BgcodeGcodeStream::from_memory(gcode.text, gcode.name);
      if (!stream) return stream.error();
      auto r = simulate_gcode(**stream, printer, sim_options, &collector);
      if ((*stream)->error()) return *(*stream)->error();
      return r;
    }
    std::istringstream gcode_stream(std::move(gcode.text));
    return simulate_gcode(gcode_stream, printer, sim_options, &collector);
  }();
  if (!sim) return sim.error();
  {
    SimulationSummary& s = printed.simulation;
    s.slicer = gcode.source == "printtwin slice" ? std::string("printtwin") : sim->slicer;
    s.gcode_lines = static_cast<std::size_t>(sim->lines);
    s.moves = static_cast<std::size_t>(sim->moves);
    for (const auto& m : collector.moves) s.extrusion_moves += m.kind == MoveKind::extrude ? 1 : 0;
    s.layers = static_cast<int>(sim->layers.size());
    s.print_time_s = sim->print_time_s;
    s.filament_mm = sim->filament_mm;
    s.extruded_volume_mm3 = sim->filament_mm3;
    s.extrusion_bbox_mm = sim->extrusion_bounds_mm;
    count_severities(sim->findings, s.errors, s.warnings, s.infos);
    printed.findings.insert(printed.findings.end(), sim->findings.begin(), sim->findings.end());
  }
  clock.lap("simulate");

  // Where the slicer put the part (the registration itself needs the mesh: measure_printed).
  printed.extent = find_part_extent(collector.moves, sim->object_names);
  if (!settings.place_mm && printed.extent.moves == 0)
    return bad_input("the G-code has no extrusion of the part to register the mesh against", gcode.name);
  if (on_extent) on_extent(printed.extent);

  // Deposit.
  stage("deposit");
  DepositSettings dep_settings;
  dep_settings.voxel_mm = settings.voxel_mm;
  auto deposit = deposit_moves(collector.moves, printer, dep_settings);
  if (!deposit) return deposit.error();
  printed.beads = surface_beads(collector.moves, printer);
  collector.moves = {};
  printed.findings.insert(printed.findings.end(), deposit->findings.begin(), deposit->findings.end());
  deposit->findings.clear();
  printed.deposit = std::move(*deposit);
  clock.lap("deposit");
  return printed;
}

namespace {

/// measure_printed with the registration when already known (verify() finds it while the
/// deposit runs).
Result<VerifyReport> measure_with(const PreparedPart& part, const VerifySettings& settings, PrintedGcode printed,
                                  bool include_part_timings, const std::function<void(std::string_view)>& on_stage,
                                  const Registration* known) {
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  VerifyReport report;
  report.tool_version = kVersion;
  report.settings = settings;
  report.settings.gcode_source = printed.source;
  report.part_name = part.name;
  report.inputs.push_back(part.mesh_input);
  if (std::filesystem::exists(settings.printer)) {
    auto printer_in = describe_input("printer", settings.printer);
    if (!printer_in) return printer_in.error();
    report.inputs.push_back(*printer_in);
  } else {
    report.inputs.push_back({"printer", settings.printer, "", 0});
  }
  for (auto& in : printed.inputs) report.inputs.push_back(std::move(in));
  if (include_part_timings) report.timings = part.timings;
  for (auto& t : printed.timings) report.timings.push_back(std::move(t));
  report.check = part.check;
  report.findings = part.check_findings;
  for (auto& f : printed.findings) report.findings.push_back(std::move(f));
  report.simulation = std::move(printed.simulation);
  report.printer = std::move(printed.printer);
  const DepositResult& deposit = printed.deposit;
  const PartExtent& extent = printed.extent;
  report.deposit.voxel_mm = deposit.voxel_mm;
  report.deposit.voxels = deposit.voxels;
  report.deposit.volume_mm3 = deposit.volume_mm3;
  report.deposit.extruded_volume_mm3 = deposit.extruded_mm3;
  report.deposit.bbox_mm = deposit.bbox_mm;
  report.deposit.memory_bytes = deposit.memory_bytes;
  StageClock clock(report.timings);

  // Registration: where the slicer put the part.
  if (!settings.place_mm && extent.moves == 0)
    return bad_input("the G-code has no extrusion of the part to register the mesh against", printed.name);
  if (known == nullptr) {
    auto found = place_part(part, extent, settings);
    if (!found) return found.error();
    report.registration = std::move(*found);
  } else {
    report.registration = *known;
  }
  const Registration& reg = report.registration;
  // Only the matched object's extrusions widen the analysed region.
  const Box3 part_box = reg.object_bbox_mm.empty() ? extent.bbox_mm : reg.object_bbox_mm;
  report.deposit.part_bbox_mm = part_box;
  if (!reg.matches) {
    Finding f;
    f.severity = Severity::error;
    f.code = "registration_mismatch";
    f.message = reg.mismatch;
    f.extent_mm = part_box;
    f.value = reg.residual_rms_mm;
    report.findings.push_back(std::move(f));
  }
  clock.lap("registration");
  report.timings.back().seconds = reg.seconds;  // found beside the deposit when known

  // Deviation.
  if (on_stage) on_stage("deviation");
  report.placed_mesh = placed(part.mesh, reg.transform);
  const DeviationSettings dev_settings = deviation_settings_of(settings);
  // The part's prepared target (built once, shared by compare's variants) when the mesh is
  // only translated, else one for this call.
  const Vec3 offset = reg.transform.translation_mm;
  auto dev = part.target && reg.transform.translation_only()
                 ? compute_deviation(*part.target, offset, deposit.grid, dev_settings, part_box, printed.beads)
                 : compute_deviation(report.placed_mesh, deposit.grid, dev_settings, part_box, printed.beads);
  if (!dev) return dev.error();
  report.deviation = std::move(*dev);
  report.deviation.registration_offset_mm = offset;
  report.deviation.registration_method = reg.method;
  report.deposit.surface_voxels = report.deviation.surface_voxels;
  clock.lap("deviation");

  for (const auto& r : report.deviation.regions)
    report.findings.push_back(region_finding(r, settings.gates.tolerance_mm));
  evaluate_gates(report);
  return report;
}

}  // namespace

Result<VerifyReport> measure_printed(const PreparedPart& part, const VerifySettings& settings, PrintedGcode printed,
                                     bool include_part_timings,
                                     const std::function<void(std::string_view)>& on_stage) {
  return measure_with(part, settings, std::move(printed), include_part_timings, on_stage, nullptr);
}

Result<VerifyReport> verify_gcode(const PreparedPart& part, const PrinterProfile& printer,
                                  const VerifySettings& settings, GcodeInput gcode,
                                  bool include_part_timings,
                                  const std::function<void(std::string_view)>& on_stage) {
  auto printed = print_gcode(printer, settings, std::move(gcode), on_stage);
  if (!printed) return printed.error();
  return measure_printed(part, settings, std::move(*printed), include_part_timings, on_stage);
}

namespace {

/// verify() without its clock.
Result<VerifyReport> verify_pipeline(const VerifyOptions& options) {
  const VerifySettings& settings = options.settings;
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  if (!options.gcode_path.empty() && (!settings.slice_config_ini.empty() || !settings.slice_overrides.empty()))
    return usage_error("slicer settings (--set, --config) apply only when printtwin slices the part; "
                       "drop --gcode or the settings");
  if (options.gcode_path.empty() && settings.mesh_scale && *settings.mesh_scale != 1.0)
    return usage_error("--units applies to a G-code from another slicer (--gcode); printtwin's slicer "
                       "slices the mesh in millimetres as it is");
  // --printer auto (the default) reads the printer from the G-code's embedded settings.
  auto resolved = resolve_printer(settings.printer, options.gcode_path);
  if (!resolved) return resolved.error();
  std::optional<PrinterProfile> printer(std::move(resolved->profile));
  if (!options.gcode_path.empty()) {
    // The part's side (load, index, check) and the G-code's side (read, simulate, deposit)
    // need nothing from each other: they run side by side. A bad mesh is reported before a
    // bad G-code, as when they ran one after the other.
    std::optional<Result<PreparedPart>> part;
    std::optional<Result<PrintedGcode>> printed;
    tbb::task_group both;
    // on_placed runs as a third task once both the mesh and the part's extent are known,
    // started by whichever of the two sides finishes its share last.
    std::mutex placing;
    std::optional<PartExtent> extent;
    std::optional<Result<Registration>> registration;
    const auto place_when_ready = [&] {  // under `placing`
      if (!part || !*part || !extent) return;
      both.run([&] {
        registration.emplace(place_part(**part, *extent, settings));
        if (options.on_placed && *registration) options.on_placed(placed((*part)->mesh, (*registration)->transform));
      });
    };
    both.run([&] {
      auto prepared = prepare_part(options.mesh_path, *printer, settings);
      const std::lock_guard lock(placing);
      part.emplace(std::move(prepared));
      place_when_ready();
    });
    both.run([&] {
      auto gcode = read_gcode_input(options.gcode_path);
      if (!gcode) {
        printed.emplace(gcode.error());
        return;
      }
      printed.emplace(print_gcode(*printer, settings, std::move(*gcode), {}, [&](const PartExtent& e) {
        const std::lock_guard lock(placing);
        extent = e;
        place_when_ready();
      }));
    });
    both.wait();
    if (!*part) return part->error();
    if (!*printed) return printed->error();
    const Registration* known = registration && *registration ? &**registration : nullptr;
    return measure_with(**part, settings, std::move(**printed), true, {}, known);
  }
  auto part = prepare_part(options.mesh_path, *printer, settings);
  if (!part) return part.error();
  std::vector<VerifyInput> ini_inputs;
  auto slice_settings = verify_slice_settings(settings, &ini_inputs);
  if (!slice_settings) return slice_settings.error();
  auto gcode = slice_for_verify(*part, *printer, *slice_settings);
  if (!gcode) return gcode.error();
  gcode->inputs.insert(gcode->inputs.begin(), ini_inputs.begin(), ini_inputs.end());
  return verify_gcode(*part, *printer, settings, std::move(*gcode));
}

}  // namespace

Result<VerifyReport> verify(const VerifyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  auto report = verify_pipeline(options);
  if (report) report->elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace printtwin

// The measuring side of verify: registration -> deviation -> region findings -> gates of a
// printed G-code against a prepared part.
#include <filesystem>

#include <memory>

#include "printtwin/io.hpp"
#include "printtwin/version.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {

using verify_detail::check_part;
using verify_detail::describe_input;
using verify_detail::deviation_settings_of;
using verify_detail::measure_with;
using verify_detail::place_part;
using verify_detail::placed;
using verify_detail::StageClock;
using verify_detail::validate_verify_settings;

namespace {

std::string fmt_mm(double v) { return format_fixed(v, 3); }

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

}  // namespace

namespace verify_detail {

Result<VerifyReport> measure_with(const PreparedPart& part, const VerifySettings& settings,
                                  PrintedGcode printed, bool include_part_timings,
                                  const std::function<void(std::string_view)>& on_stage,
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
    return bad_input("the G-code has no extrusion of the part to register the mesh against",
                     printed.name);
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
  // The G-code prints the mesh scaled (other units) or turned: the check's sizes, thickness
  // and overhangs are of the part as printed, so the mesh is checked again scaled and turned
  // as the registration found it (its own origin kept: positions stay in the mesh's frame).
  // A pose that does not match keeps the check of the mesh as given.
  if (reg.matches && !reg.transform.translation_only()) {
    const auto start = std::chrono::steady_clock::now();
    RigidTransform as_printed = reg.transform;
    as_printed.translation_mm = Vec3::Zero();
    std::vector<Finding> check_findings;
    if (auto st = check_part(transformed(part.mesh, as_printed), report.printer, nullptr,
                             report.check, check_findings);
        !st)
      return st.error();
    const auto first = report.findings.begin();
    report.findings.erase(first, first + static_cast<std::ptrdiff_t>(part.check_findings.size()));
    report.findings.insert(report.findings.begin(), check_findings.begin(), check_findings.end());
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    for (auto& t : report.timings)  // (the registration's lap is its own time, below)
      if (t.stage == "check") t.seconds += seconds;
  }
  clock.lap("registration");
  report.timings.back().seconds = reg.seconds;  // found beside the deposit when known

  // Deviation.
  if (on_stage) on_stage("deviation");
  report.placed_mesh = placed(part.mesh, reg.transform);
  DeviationSettings dev_settings = deviation_settings_of(settings);
  // --deposit-mesh builds on the deviation stage's filled volume when it is sealed as the
  // mesh seals it (the defaults).
  dev_settings.keep_filled_volume =
      settings.keep_deposit_grid && dev_settings.seal_gap_mm == DeviationSettings{}.seal_gap_mm &&
      dev_settings.groove_depth_mm == DeviationSettings{}.groove_depth_mm;
  // The part's prepared target (built once, shared by compare's variants) when the mesh is
  // only translated, else one for this call.
  const Vec3 offset = reg.transform.translation_mm;
  auto dev = part.target && reg.transform.translation_only()
                 ? compute_deviation(*part.target, offset, deposit.grid, dev_settings, part_box,
                                     printed.beads)
                 : compute_deviation(report.placed_mesh, deposit.grid, dev_settings, part_box,
                                     printed.beads);
  if (!dev) return dev.error();
  report.deviation = std::move(*dev);
  report.deviation.registration_offset_mm = offset;
  report.deviation.registration_method = reg.method;
  report.deposit.surface_voxels = report.deviation.surface_voxels;
  clock.lap("deviation");

  for (const auto& r : report.deviation.regions)
    report.findings.push_back(region_finding(r, settings.gates.tolerance_mm));
  evaluate_gates(report);
  if (settings.keep_deposit_grid) {
    report.deposit_grid = std::make_shared<const VoxelGrid>(std::move(printed.deposit.grid));
    report.deposit_beads = std::move(printed.beads);
  }
  return report;
}

}  // namespace verify_detail

Result<VerifyReport> measure_printed(const PreparedPart& part, const VerifySettings& settings,
                                     PrintedGcode printed, bool include_part_timings,
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
}  // namespace printtwin

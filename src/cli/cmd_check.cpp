// `printtwin check part.stl`: printability of a mesh before slicing.
//   exit 0 printable, 1 errors found, 2 usage, 3 bad input, 4 internal error.
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "printtwin/check.hpp"
#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/verify.hpp"

namespace printtwin::cli {

namespace {

struct CheckOptions {
  std::string input;
  std::string printer = "ender3";
  std::string json_out;
  std::string repair_out;
  double overhang_angle_deg = 45.0;
  double min_thickness_mm = 0.0;
  double line_width_mm = 0.0;
  double scale = 1.0;
  std::string units = "auto";
  std::string center;
  bool no_center = false;
  bool no_self_intersections = false;
};

std::string f2(double v) { return format_fixed(v, 2); }

Mesh scaled_mesh(Mesh m, double s) {
  for (auto& v : m.vertices_mm) v *= s;
  return m;
}

/// Index of the first finding that is not an error (findings are sorted errors first).
std::size_t first_warning(const std::vector<Finding>& fs) {
  std::size_t i = 0;
  while (i < fs.size() && fs[i].severity == Severity::error) ++i;
  return i;
}

/// "x,y" -> two numbers, or a usage error.
Result<Vec2> parse_center(const std::string& text) {
  const auto comma = text.find(',');
  if (comma == std::string::npos) return usage_error("--center expects x,y in mm, got '" + text + "'");
  try {
    std::size_t used_x = 0, used_y = 0;
    const std::string xs = text.substr(0, comma), ys = text.substr(comma + 1);
    const double x = std::stod(xs, &used_x);
    const double y = std::stod(ys, &used_y);
    if (used_x != xs.size() || used_y != ys.size() || !std::isfinite(x) || !std::isfinite(y))
      throw std::invalid_argument("trailing text");
    return Vec2(x, y);
  } catch (const std::exception&) {
    return usage_error("--center expects x,y in mm, got '" + text + "'");
  }
}

void print_text(const CheckOptions& o, const PrinterProfile& printer, const CheckReport& r,
                const RepairResult* repair) {
  const MeshHealth& h = r.health;
  const Vec3 size = h.bbox_mm.size();
  std::printf("printtwin check %s  (printer: %s)\n", o.input.c_str(), printer.name.c_str());
  std::printf("mesh       %zu triangles, %zu vertices, %zu shell%s, %s\n", h.triangles, h.vertices,
              h.shells, h.shells == 1 ? "" : "s", h.closed ? "closed" : "NOT closed");
  std::printf("           volume %s mm3, area %s mm2, size %s x %s x %s mm\n",
              f2(h.volume_mm3).c_str(), f2(h.area_mm2).c_str(), f2(size.x()).c_str(),
              f2(size.y()).c_str(), f2(size.z()).c_str());
  std::printf("health     open edges %zu, non-manifold edges %zu / vertices %zu, degenerate %zu, "
              "duplicate %zu, misoriented edges %zu, inverted shells %zu, self-intersections %s\n",
              h.boundary_edges, h.non_manifold_edges, h.non_manifold_vertices, h.degenerate_faces,
              h.duplicate_faces, h.inconsistent_edges, h.inverted_shells,
              h.self_intersections_checked ? std::to_string(h.self_intersections).c_str()
                                           : "not checked");
  const Placement& p = r.placement;
  std::printf("placement  x %s..%s, y %s..%s, z 0..%s mm: %s; %s mm2 on the bed\n",
              f2(p.bbox_mm.min.x()).c_str(), f2(p.bbox_mm.max.x()).c_str(),
              f2(p.bbox_mm.min.y()).c_str(), f2(p.bbox_mm.max.y()).c_str(),
              f2(p.bbox_mm.max.z()).c_str(),
              p.fits ? "fits the build volume" : "DOES NOT FIT the build volume",
              f2(p.footprint_area_mm2).c_str());
  if (r.thickness) {
    const auto& t = *r.thickness;
    std::printf("thickness  thinnest wall %s, narrowest gap %s (limits %s / %s mm)\n",
                std::isfinite(t.min_thickness_mm) ? (f2(t.min_thickness_mm) + " mm").c_str() : "-",
                std::isfinite(t.min_gap_mm) ? (f2(t.min_gap_mm) + " mm").c_str() : "-",
                f2(r.min_thickness_limit_mm).c_str(), f2(r.line_width_mm).c_str());
  }
  std::size_t counts[3] = {0, 0, 0};
  for (const auto& f : r.findings) ++counts[static_cast<int>(f.severity)];
  if (r.findings.empty()) std::printf("findings   none\n");
  else std::printf("findings\n");
  for (const auto& f : r.findings)
    std::printf("  %-7s %-24s %s\n", std::string(to_string(f.severity)).c_str(), f.code.c_str(),
                f.message.c_str());
  if (repair != nullptr) {
    std::printf("repair     wrote %s\n", o.repair_out.c_str());
    if (repair->changes.empty()) std::printf("           nothing to change\n");
    for (const auto& c : repair->changes) std::printf("           %s\n", c.message.c_str());
    const MeshHealth& a = repair->after;
    std::printf("           after: %zu triangles, %s, open edges %zu, non-manifold edges %zu\n",
                a.triangles, a.closed ? "closed" : "still NOT closed", a.boundary_edges,
                a.non_manifold_edges);
  }
  std::printf("result     %s (%zu error%s, %zu warning%s)\n",
              r.printable ? "PRINTABLE" : "NOT PRINTABLE", counts[2], counts[2] == 1 ? "" : "s",
              counts[1], counts[1] == 1 ? "" : "s");
}

int run_check(const CheckOptions& o) {
  if (auto st = check_output_paths({{o.json_out, "--json", OutputKind::file}, {o.repair_out, "--repair", OutputKind::file}});
      !st)
    return report_error(st.error());
  auto printer = load_printer_profile(o.printer);
  if (!printer) return report_error(printer.error());

  CheckSettings settings;
  settings.overhang_angle_deg = o.overhang_angle_deg;
  settings.min_thickness_mm = o.min_thickness_mm;
  settings.line_width_mm = o.line_width_mm;
  settings.self_intersections = !o.no_self_intersections;
  if (o.no_center && !o.center.empty())
    return report_error(usage_error("--center and --no-center exclude each other"));
  settings.center = !o.no_center;
  if (!o.center.empty()) {
    auto c = parse_center(o.center);
    if (!c) return report_error(c.error());
    settings.center_x_mm = c->x();
    settings.center_y_mm = c->y();
  }

  // --units: the names and numbers `verify --units` takes, or auto (judged by the size).
  std::optional<double> mm_per_unit;
  if (o.units != "auto") {
    VerifySettings units;
    if (auto st = parse_units_option(o.units, units); !st) return report_error(st.error());
    mm_per_unit = units.mesh_scale;
  }
  MeshLoadOptions load;
  load.scale = o.scale * mm_per_unit.value_or(1.0);
  auto mesh = load_mesh(o.input, load);
  if (!mesh) return report_error(mesh.error());
  std::string units_used = mm_per_unit ? o.units : "mm";
  std::optional<UnitGuess> guess;
  if (!mm_per_unit) {
    // Judged on the file's own numbers (before --scale), then applied.
    guess = guess_mesh_units(o.scale == 1.0 ? *mesh : scaled_mesh(*mesh, 1.0 / o.scale));
    if (guess) {
      *mesh = scaled_mesh(std::move(*mesh), guess->mm_per_unit);
      units_used = guess->unit;
    }
  }

  auto report = check_printability(*mesh, *printer, settings);
  if (!report) return report_error(report.error());
  if (guess) report->findings.insert(report->findings.begin() + static_cast<std::ptrdiff_t>(first_warning(report->findings)),
                                     units_guessed_finding(*guess, report->health.bbox_mm.size()));

  std::optional<RepairResult> repaired;
  if (!o.repair_out.empty()) {
    auto rr = repair_mesh(*mesh);
    if (!rr) {
      Error e = rr.error();
      if (e.file.empty()) e.file = o.input;
      return report_error(e);
    }
    if (auto s = save_stl(rr->mesh, o.repair_out); !s) return report_error(s.error());
    repaired = std::move(*rr);
  }

  print_text(o, *printer, *report, repaired ? &*repaired : nullptr);

  if (!o.json_out.empty()) {
    CheckSource source;
    source.file = o.input;
    if (auto bytes = read_file(o.input)) source.sha256 = sha256_hex(*bytes);
    source.units = units_used;
    source.scale = o.scale;
    source.printer = printer->name;
    const std::string text =
        check_report_to_json(*report, source, repaired ? &*repaired : nullptr, o.repair_out);
    if (auto s = write_file_atomic(o.json_out, text); !s) return report_error(s.error());
  }
  return report->printable ? kPass : kFail;
}

}  // namespace

void add_check_command(CLI::App& app, CommandRunner& runner) {
  auto opts = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand(
      "check", "Check whether a mesh is printable (no slicing). Exit 0 printable, 1 errors found,\n"
               "2 usage, 3 bad input, 4 internal error. Findings: docs/check.md");
  cmd->add_option("mesh", opts->input, "STL, OBJ, PLY, OFF, 3MF or AMF file")->required();
  cmd->add_option("--printer", opts->printer,
                  "ender3, ender3-marlin1, ender3-klipper, a library printer (printtwin printers), "
                  "a profile FILE.json or a Klipper printer.cfg")
      ->capture_default_str();
  cmd->add_option("--json", opts->json_out, "write the report as JSON (schema printtwin.check v1)");
  cmd->add_option("--repair", opts->repair_out,
                  "write a repaired mesh (binary STL) and list what changed");
  cmd->add_option("--overhang-angle", opts->overhang_angle_deg,
                  "overhang limit in degrees from vertical")
      ->check(CLI::Range(0.0, 90.0))
      ->capture_default_str();
  cmd->add_option("--min-thickness", opts->min_thickness_mm,
                  "thinnest wall allowed in mm (default: the nozzle diameter)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--line-width", opts->line_width_mm,
                  "line width in mm for gaps and small parts (default: 1.125 x nozzle)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--scale", opts->scale, "uniform scale applied after the unit conversion")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--units", opts->units,
                  "unit the file is written in: auto (judged by the size, stated as a finding), "
                  "mm, cm, m, in, um or the unit's length in mm")
      ->capture_default_str();
  cmd->add_option("--center", opts->center, "centre the part at x,y mm (default: bed centre)");
  cmd->add_flag("--no-center", opts->no_center, "keep x and y as in the file (only lift to z = 0)");
  cmd->add_flag("--no-self-intersections", opts->no_self_intersections,
                "skip the self-intersection test");
  cmd->callback([opts, &runner] { runner.run = [opts]() -> int { return run_check(*opts); }; });
}

}  // namespace printtwin::cli

// `printtwin verify part.stl [--gcode part.gcode]`: check -> (slice) -> simulate -> deposit
// -> deviation, report.json + deviation.ply, a summary table, exit 0 pass / 1 fail.
#include <cctype>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "cli/deposit_options.hpp"
#include "cli/manifest.hpp"
#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "printtwin/report.hpp"
#include "printtwin/verify.hpp"

namespace printtwin::cli {

namespace {

struct VerifyCliOptions {
  std::string mesh;
  std::string gcode;
  double tolerance_mm = 0.2;
  double max_excess_mm = -1, max_deficit_mm = -1, max_rms_mm = -1;
  std::string printer = "auto";
  double voxel_mm = 0.05;
  bool conserve_volume = true;
  double spacing_mm = 0;
  std::string place;
  std::string units;
  std::string object;
  std::string out;
  std::string deviation_ply;
  std::uint64_t seed = 1;
  std::string slice_config;
  std::vector<std::string> slice_sets;
  std::string slicer = "printtwin", slicer_path, cura_definition;
  double slicer_timeout_s = 600;
  DepositMeshCliOptions deposit_mesh;  // --deposit-mesh ... (deposit_options.hpp)
  bool quiet = false;
  std::string manifest, summary_out, junit_out;  ///< verify --manifest (verify_manifest.cpp)
};

void print_stats_row(const char* name, const DeviationStats& s) {
  std::printf("  %-16s %9s %9s %9s %9s %9s %8s%%\n", name, format_fixed(s.min_mm, 3).c_str(),
              format_fixed(s.max_mm, 3).c_str(), format_fixed(s.mean_mm, 3).c_str(),
              format_fixed(s.rms_mm, 3).c_str(), format_fixed(s.p95_abs_mm, 3).c_str(),
              format_fixed(s.within_tolerance_pct, 1).c_str());
}

void print_registration(const Registration& reg, const DeviationResult& d) {
  const RigidTransform& t = reg.transform;
  std::printf("  registration %s, offset %s, %s, %s mm", d.registration_method.c_str(),
              format_fixed(d.registration_offset_mm.x(), 3).c_str(),
              format_fixed(d.registration_offset_mm.y(), 3).c_str(),
              format_fixed(d.registration_offset_mm.z(), 3).c_str());
  if (!t.rotation.isIdentity(0)) {
    const Vec3 e = xyz_deg_of(t.rotation);
    std::printf(", rotated %s, %s, %s deg (about X, Y, Z)", format_fixed(e.x(), 2).c_str(),
                format_fixed(e.y(), 2).c_str(), format_fixed(e.z(), 2).c_str());
  }
  if (t.scale != 1.0) std::printf(", scale %s", format_number(t.scale).c_str());
  std::printf("\n");
  if (reg.wall_points > 0)
    std::printf(
        "  registration fit: walls %s mm RMS from the mesh, %s %% of the mesh covered%s%s\n",
        format_fixed(reg.residual_rms_mm, 3).c_str(), format_fixed(reg.coverage_pct, 1).c_str(),
        reg.object.empty() || reg.object_id < 0 ? "" : ", object ",
        reg.object.empty() || reg.object_id < 0 ? "" : reg.object.c_str());
  if (!reg.matches) std::printf("  %s\n", reg.mismatch.c_str());
}

void print_summary(const VerifyReport& r, const std::string& out_dir) {
  const DeviationResult& d = r.deviation;
  std::printf("printtwin verify %s: %s\n", r.part_name.c_str(), r.pass ? "PASS" : "FAIL");
  print_registration(r.registration, d);
  std::printf("  deposit %zu voxels of %s mm, volume %s mm3 vs mesh %s mm3\n", r.deposit.voxels,
              format_number(r.deposit.voxel_mm).c_str(),
              format_fixed(d.deposit_volume_mm3, 1).c_str(),
              format_fixed(d.mesh_volume_mm3, 1).c_str());
  std::printf("  %-16s %9s %9s %9s %9s %9s %9s\n", "deviation (mm)", "min", "max", "mean", "rms",
              "p95|d|", "in tol");
  print_stats_row("deposit->mesh", d.deposit_to_mesh);
  print_stats_row("mesh->deposit", d.mesh_to_deposit);
  for (const auto& g : r.gates)
    std::printf("  gate %-18s %-4s value %s limit %s\n", g.name.c_str(), g.pass ? "ok" : "FAIL",
                format_fixed(g.value, 3).c_str(), format_fixed(g.limit, 3).c_str());
  std::size_t shown = 0;
  for (const auto& reg : d.regions) {
    if (shown++ == 5) {
      std::printf("  ... %zu more regions in report.json\n", d.regions.size() - 5);
      break;
    }
    std::printf("  region %-7s %8s mm2 worst %7s mm layers %d-%d at (%s, %s, %s)\n",
                reg.kind == RegionKind::missing ? "missing" : "excess",
                format_fixed(reg.area_mm2, 2).c_str(), format_fixed(reg.worst_mm, 3).c_str(),
                reg.layer_min, reg.layer_max, format_fixed(reg.worst_position_mm.x(), 2).c_str(),
                format_fixed(reg.worst_position_mm.y(), 2).c_str(),
                format_fixed(reg.worst_position_mm.z(), 2).c_str());
  }
  std::printf("  report: %s/report.html (report.json, junit.xml, summary.md, deviation.ply)\n",
              out_dir.c_str());
}

/// --deposit-mesh under verify: the as-printed mesh with the deviation from the placed design
/// per vertex (PLY `quality`), linked from report.html. Returns the summary lines.
Result<std::string> write_verified_deposit_mesh(VerifyReport& report,
                                                const DepositMeshOptions& options,
                                                const std::string& path, const std::string& out_dir,
                                                ReportOptions& report_options) {
  if (!report.deposit_grid) return internal_error("verify kept no deposit grid for --deposit-mesh");
  auto mesh = build_deposit_mesh(*report.deposit_grid, options, report.deposit_beads,
                                 report.deviation.filled_volume.get());
  report.deviation.filled_volume.reset();
  report.deposit_grid.reset();
  report.deposit_beads = {};
  if (!mesh) return mesh.error();
  std::vector<float> deviation;  // PLY only: the other formats carry no per-vertex value
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".ply" && !mesh->mesh.vertices_mm.empty()) {
    auto d = signed_distances_to_mesh(report.placed_mesh, mesh->mesh.vertices_mm,
                                      4 * report.deposit.voxel_mm);
    if (!d) return d.error();
    deviation.assign(d->begin(), d->end());
  }
  if (auto st = write_deposit_mesh(*mesh, path, deviation); !st) return st.error();
  namespace fs = std::filesystem;
  const fs::path rel = fs::absolute(path).lexically_normal().lexically_relative(
      fs::absolute(out_dir).lexically_normal());
  report_options.deposit_mesh_href =
      rel.empty() ? fs::absolute(path).string() : rel.generic_string();
  report_options.deposit_mesh_text =
      std::to_string(mesh->mesh.triangles.size()) + " triangles, closed" +
      (mesh->cell_voxels > 1
           ? ", within " + format_fixed(mesh->error_bound_mm, 3) + " mm of the voxel surface"
       : mesh->smoothed_vertices > 0 ? ", on the bead surfaces where they explain the voxels"
                                     : ", on the voxel faces") +
      (deviation.empty() ? std::string() : "; deviation from the design per vertex (PLY quality)");
  return deposit_mesh_summary(*mesh, path);
}

// The command line's settings for the verify pipeline.
Status fill_verify_settings(const VerifyCliOptions& o, VerifySettings& s) {
  s.gates.tolerance_mm = o.tolerance_mm;
  if (o.max_excess_mm >= 0) s.gates.max_excess_mm = o.max_excess_mm;
  if (o.max_deficit_mm >= 0) s.gates.max_deficit_mm = o.max_deficit_mm;
  if (o.max_rms_mm >= 0) s.gates.max_rms_mm = o.max_rms_mm;
  s.printer = o.printer;
  s.voxel_mm = o.voxel_mm;
  s.conserve_volume = o.conserve_volume;
  s.mesh_sample_spacing_mm = o.spacing_mm;
  s.seed = o.seed;
  s.keep_deposit_grid = !o.deposit_mesh.path.empty();
  s.slice_config_ini = o.slice_config;
  for (const auto& kv : o.slice_sets) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0)
      return usage_error("--set expects key=value, got '" + kv + "'");
    s.slice_overrides.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
  }
  if (!o.place.empty())
    if (auto st = parse_place_option(o.place, s); !st) return st.error();
  if (!o.units.empty())
    if (auto st = parse_units_option(o.units, s); !st) return st.error();
  s.object = o.object;
  return Ok{};
}

// --slicer NAME: the external slicer writes the G-code beside the report; the twin then
// verifies it as any --gcode, on the printer its embedded settings name (--printer auto).
Status slice_with_external_slicer(const VerifyCliOptions& o, VerifyOptions& options) {
  VerifySettings& s = options.settings;
  if (!o.gcode.empty()) return usage_error("--slicer slices the part; do not give --gcode too");
  if (!(o.slicer_timeout_s > 0)) return usage_error("--slicer-timeout must be > 0 s");
  auto program = find_slicer_program(o.slicer, o.slicer_path);
  if (!program) return program.error();
  SlicerJob job;
  job.mesh_path = o.mesh;
  job.settings = s.slice_overrides;
  job.cura_definition = o.cura_definition;
  const std::filesystem::path dir =
      o.out.empty() ? std::filesystem::path("reports") / std::filesystem::path(o.mesh).stem()
                    : std::filesystem::path(o.out);
  const std::string stem = dir.filename().string() + "-" + o.slicer;
  job.out_gcode = (dir.parent_path() / (stem + ".gcode")).string();
  auto config = slicer_config_file(o.slicer, o.slice_config, dir.parent_path() / (stem + ".ini"));
  if (!config) return config.error();
  job.config_path = *config;
  std::string command;
  const Status sliced = run_external_slicer(*program, job, o.slicer_timeout_s, &command);
  if (!o.quiet) std::printf("sliced with %s: %s\n", program->version.c_str(), command.c_str());
  if (!sliced) return sliced.error();
  options.gcode_path = job.out_gcode;
  // A Cura G-code names no printer: under auto the definition's printer is the twin's.
  if (o.slicer == "cura" && (s.printer.empty() || s.printer == "auto"))
    if (auto id = cura_definition_printer(o.cura_definition); !id.empty()) s.printer = id;
  s.slice_config_ini.clear();
  s.slice_overrides.clear();
  return Ok{};
}

int run_verify(const VerifyCliOptions& o) {
  if (auto st = check_output_paths({{o.out, "--out", OutputKind::folder},
                                    {o.deviation_ply, "--deviation-ply", OutputKind::file},
                                    {o.deposit_mesh.path, "--deposit-mesh", OutputKind::file}});
      !st)
    return report_error(st.error());
  auto mesh_options = deposit_mesh_options(o.deposit_mesh);
  if (!mesh_options) return report_error(mesh_options.error());
  VerifyOptions options;
  options.mesh_path = o.mesh;
  options.gcode_path = o.gcode;
  VerifySettings& s = options.settings;
  if (auto st = fill_verify_settings(o, s); !st) return report_error(st.error());
  if (o.mesh.empty() == o.manifest.empty())
    return report_error(usage_error("give one part (mesh) or --manifest FILE"));
  if (!o.manifest.empty()) {
    if (o.slicer != "printtwin" || !o.gcode.empty() || !o.deviation_ply.empty())
      return report_error(
          usage_error("--manifest names each part's G-code; --gcode, --slicer and "
                      "--deviation-ply take one part"));
    return run_verify_manifest({o.manifest, o.out, o.summary_out, o.junit_out, o.quiet}, s);
  }
  if (!o.summary_out.empty() || !o.junit_out.empty())
    return report_error(
        usage_error("--summary and --junit go with --manifest (one part writes them into --out)"));
  if (auto st = check_slicer_name(o.slicer); !st) return report_error(st.error());
  if (o.slicer != "printtwin")
    if (auto st = slice_with_external_slicer(o, options); !st) return report_error(st.error());
  // The whole folder (report.html, junit.xml, summary.md, heatmaps) plus report.json and
  // deviation.ply, swapped into place only when complete.
  const std::string out_dir =
      o.out.empty()
          ? (std::filesystem::path("reports") / std::filesystem::path(o.mesh).stem()).string()
          : o.out;
  ReportOptions report_options;
  report_options.generated_utc = report_timestamp_utc();
  std::string mesh_summary;
  DerivedOutputs derived;
  if (!o.deposit_mesh.path.empty())
    derived = [&](VerifyReport& finished, ReportOptions& with_link) -> Status {
      auto written = write_verified_deposit_mesh(finished, *mesh_options, o.deposit_mesh.path,
                                                 out_dir, with_link);
      if (!written) return written.error();
      mesh_summary = *written;
      return Ok{};
    };
  auto report = verify_to_folder(options, out_dir, report_options, derived);
  if (!report) return report_error(report.error());
  if (!o.deviation_ply.empty()) {
    auto ply = read_file(std::filesystem::path(out_dir) / "deviation.ply");
    if (!ply) return report_error(ply.error());
    if (auto st = write_file_atomic(o.deviation_ply, *ply); !st) return report_error(st.error());
  }
  if (!o.quiet) print_summary(*report, out_dir);
  if (!o.quiet) std::fputs(mesh_summary.c_str(), stdout);
  return report->pass ? kPass : kFail;
}

}  // namespace

void add_verify_command(CLI::App& app, CommandRunner& runner) {
  auto o = std::make_shared<VerifyCliOptions>();
  auto* cmd = app.add_subcommand(
      "verify",
      "Check, simulate and deposit a part's G-code and measure the deposit against the mesh");
  cmd->add_option("mesh", o->mesh, "the designed part: STL, OBJ, PLY, OFF, 3MF or AMF");
  cmd->add_option(
      "--manifest", o->manifest,
      "verify every part a manifest lists against its \"gcode\" (docs/ci.md), instead of one part");
  cmd->add_option("--summary", o->summary_out, "with --manifest: write the Markdown summary table");
  cmd->add_option("--junit", o->junit_out,
                  "with --manifest: write a JUnit file with a test case per part");
  cmd->add_option("--gcode", o->gcode,
                  "G-code to verify (any slicer); without it printtwin slices the part");
  cmd->add_option("--tolerance", o->tolerance_mm, "deviation tolerance in mm (default 0.2)");
  cmd->add_option("--max-excess", o->max_excess_mm,
                  "largest allowed excess in mm (default: tolerance)");
  cmd->add_option("--max-deficit", o->max_deficit_mm,
                  "largest allowed deficit in mm (default: tolerance)");
  cmd->add_option("--max-rms", o->max_rms_mm,
                  "largest allowed RMS deviation in mm (default: not checked)");
  cmd->add_option(
      "--printer", o->printer,
      "auto (default: the printer the G-code's settings name), a library printer (printtwin "
      "printers), "
      "ender3, ender3-marlin1, ender3-klipper, a profile .json or a Klipper printer.cfg");
  cmd->add_option("--voxel", o->voxel_mm, "deposit voxel edge in mm (default 0.05)");
  cmd->add_flag("--conserve-volume,!--no-conserve-volume", o->conserve_volume,
                "squeeze material a bead cannot place into free space beside and below it, "
                "the default (docs/deposit.md; --no-conserve-volume: lose it)");
  cmd->add_option("--sample-spacing", o->spacing_mm,
                  "mesh surface sample spacing in mm (default: twice the voxel)");
  cmd->add_option(
      "--place", o->place,
      "place the mesh yourself (default: automatic): x,y,z mm, x,y,z,rz with a Z rotation in "
      "degrees, or \"x,y,z;rx,ry,rz\" (rotations about X, then Y, then Z, then the offset)");
  cmd->add_option(
      "--units", o->units,
      "mesh units: mm, cm, m, in, um or mm per unit (default: found by the registration)");
  cmd->add_option(
      "--object", o->object,
      "the labelled object of the G-code to measure, by name or id (default: the best fit)");
  cmd->add_option("--out", o->out, "output folder (default reports/<part>)");
  cmd->add_option("--deviation-ply", o->deviation_ply,
                  "also write the deviation-coloured mesh PLY here");
  cmd->add_option("--seed", o->seed, "seed of the mesh surface sampling (default 1)");
  cmd->add_option("--config", o->slice_config,
                  "without --gcode: PrusaSlicer .ini for printtwin's slicer (docs/slicer.md)");
  cmd->add_option(
      "--set", o->slice_sets,
      "without --gcode: slicer setting key=value (repeatable), e.g. --set layer_height=0.1");
  add_slicer_options(
      cmd, o->slicer, o->slicer_path, o->slicer_timeout_s, o->cura_definition,
      "without --gcode: who slices the part: printtwin (default), prusa-slicer, cura (CuraEngine) "
      "or slic3r; --config and --set then go to that slicer (docs/compare.md)",
      "the slicer's program (default: found on the PATH)");
  add_deposit_mesh_options(*cmd, o->deposit_mesh);
  cmd->add_flag("-q,--quiet", o->quiet, "no summary table");
  cmd->callback([o, &runner] { runner.run = [o]() -> int { return run_verify(*o); }; });
}

}  // namespace printtwin::cli

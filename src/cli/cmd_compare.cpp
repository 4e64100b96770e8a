// `printtwin compare part.stl --vary layer_height=0.1,0.2 ...`: variants side by side.
// Modes:
//   run        the part and the variant flags (or --manifest): every variant, or one share
//              with --variant K --of N (writes compare-K-of-N.json only);
//   --write-manifest plan.json   expand the variants, write the plan, run nothing;
//   --merge a.json b.json ...    rebuild the table, chart and Pareto front from shares.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "printtwin/report.hpp"

namespace printtwin::cli {

namespace {

namespace fs = std::filesystem;

struct CompareOptions {
  std::string mesh;
  std::vector<std::string> varies, sets, configs, gcodes, labels;
  std::vector<std::string> slicers, slicer_paths;
  double slicer_timeout_s = 600;
  std::string cura_definition;
  std::string printer = "auto";
  double tolerance_mm = 0.2;
  std::optional<double> max_excess_mm, max_deficit_mm, max_rms_mm;
  double voxel_mm = 0.05;
  double sample_spacing_mm = 0;
  std::vector<double> place;
  double filament_density = kDefaultFilamentDensityGCm3;
  std::string out;
  std::optional<int> shard_k, shard_n;
  std::string write_manifest, manifest;
  std::vector<std::string> merge;
  bool allow_missing = false;
  std::string variant_reports = "full";
  bool require_pass = false;
};

// A short fixed-width table on stdout; compare.md and compare.html hold the full one.
void print_table(const CompareResult& r, const fs::path& out_dir, const std::string& written) {
  std::size_t w = 7;
  for (const auto& v : r.variants)
    w = std::max(w, std::min<std::size_t>(v.variant.label.size(), 40));
  std::printf("%-3s  %-*s  %14s  %9s  %9s  %10s  %-6s %s\n", "#", static_cast<int>(w), "variant",
              "print time", "filament", "RMS mm", "slopes mm", "result", "");
  for (const auto& v : r.variants) {
    std::string label = v.variant.label.substr(0, 40);
    if (!v.ran) {
      std::printf("%-3d  %-*s  could not run: %s\n", v.variant.index, static_cast<int>(w),
                  label.c_str(), v.error.c_str());
      continue;
    }
    std::printf("%-3d  %-*s  %14s  %7s g  %9s  %10s  %-6s %s\n", v.variant.index,
                static_cast<int>(w), label.c_str(), format_duration(v.print_time_s).c_str(),
                format_fixed(v.filament_g, 1).c_str(), format_fixed(v.rms_mm, 4).c_str(),
                format_fixed(v.slope_rms_mm, 4).c_str(), v.pass ? "pass" : "FAIL",
                v.pareto ? "* Pareto" : "");
  }
  std::printf("wrote %s in %s\n", written.c_str(), out_dir.string().c_str());
}

int exit_code_of(const CompareResult& r, bool require_pass) {
  for (const auto& v : r.variants) {
    if (!v.ran) return kFail;
    if (require_pass && !v.pass) return kFail;
  }
  return kPass;
}

// Progress on stderr, only on a terminal outside CI.
std::function<void(const CompareProgress&)> progress_printer() {
  if (!show_progress()) return {};
  return [](const CompareProgress& p) {
    if (p.last == nullptr) {
      std::fprintf(stderr, "\r\033[K[%d/%d] %s", p.done + 1, p.total, p.stage.c_str());
    } else {
      const VariantResult& v = *p.last;
      if (v.ran)
        std::fprintf(stderr, "\r\033[K[%d/%d] %s: %s, RMS %s mm, %s (%s s)\n", p.done, p.total,
                     v.variant.label.c_str(), format_duration(v.print_time_s).c_str(),
                     format_fixed(v.rms_mm, 3).c_str(), v.pass ? "pass" : "fail",
                     format_fixed(v.run_time_s, 1).c_str());
      else
        std::fprintf(stderr, "\r\033[K[%d/%d] %s: could not run\n", p.done, p.total,
                     v.variant.label.c_str());
    }
    std::fflush(stderr);
  };
}

int run_merge(const CompareOptions& o) {
  std::vector<CompareResult> shares;
  std::vector<fs::path> dirs;
  for (const auto& path : o.merge) {
    auto text = read_file(path);
    if (!text) return report_error(text.error());
    auto share = parse_compare_json(*text, path);
    if (!share) return report_error(share.error());
    shares.push_back(std::move(*share));
    dirs.push_back(fs::path(path).parent_path());
  }
  const fs::path out_dir = o.out.empty() ? fs::path(".") : fs::path(o.out);
  // Report folders are relative to each share's JSON; make them relative to the output.
  std::error_code ec;
  const fs::path out_abs = fs::weakly_canonical(fs::absolute(out_dir), ec);
  for (std::size_t s = 0; s < shares.size(); ++s)
    for (auto& v : shares[s].variants) {
      if (v.report_dir.empty()) continue;
      const fs::path abs = fs::weakly_canonical(fs::absolute(dirs[s] / v.report_dir), ec);
      v.report_dir = fs::relative(abs, out_abs, ec).generic_string();
      if (ec) v.report_dir.clear();
    }
  auto merged = merge_compare_results(std::move(shares), !o.allow_missing);
  if (!merged) return report_error(merged.error());
  CompareHtmlOptions html;
  html.generated_utc = report_timestamp_utc();
  if (auto st = write_compare_outputs(*merged, out_dir, html); !st) return report_error(st.error());
  print_table(*merged, out_dir, "compare.json, compare.md, compare.html");
  return exit_code_of(*merged, o.require_pass);
}

Result<ComparePlan> build_plan(const CompareOptions& o) {
  ComparePlan plan;
  if (!o.manifest.empty()) {
    if (!o.varies.empty() || !o.sets.empty() || !o.configs.empty() || !o.gcodes.empty() ||
        !o.labels.empty() || !o.slicers.empty())
      return usage_error(
          "--manifest holds the variants; do not give "
          "--vary/--set/--config/--gcode/--label/--slicer too");
    auto text = read_file(o.manifest);
    if (!text) return text.error();
    auto parsed = parse_compare_plan(*text, o.manifest);
    if (!parsed) return parsed.error();
    plan = std::move(*parsed);
    if (!o.mesh.empty()) plan.mesh_path = o.mesh;  // the mesh may live elsewhere on a worker
    // So may the slicer programs: a worker's --slicer-path wins over the manifest's.
    if (!o.slicer_paths.empty()) {
      std::vector<std::string> names;
      for (const auto& v : plan.variants)
        if (v.kind == VariantKind::slicer && v.slicer != "printtwin" &&
            std::find(names.begin(), names.end(), v.slicer) == names.end())
          names.push_back(v.slicer);
      auto paths = parse_slicer_paths(o.slicer_paths, names);
      if (!paths) return paths.error();
      plan.slicer_paths = std::move(*paths);
    }
    return plan;
  }
  if (o.mesh.empty()) return usage_error("compare needs a mesh (or --manifest, or --merge)");
  SweepSpec spec;
  for (const auto& v : o.varies) {
    auto axis = parse_sweep_axis(v);
    if (!axis) return axis.error();
    spec.axes.push_back(std::move(*axis));
  }
  for (const auto& s : o.sets) {
    auto kv = parse_setting_kv(s);
    if (!kv) return usage_error("--set " + kv.error().message);
    spec.common_settings.push_back(std::move(*kv));
  }
  spec.slicers = o.slicers;
  spec.configs = o.configs;
  spec.gcodes = o.gcodes;
  spec.labels = o.labels;
  auto variants = expand_variants(spec);
  if (!variants) return variants.error();
  plan.variants = std::move(*variants);
  plan.mesh_path = o.mesh;
  plan.printer = o.printer;
  plan.verify.gates.tolerance_mm = o.tolerance_mm;
  plan.verify.gates.max_excess_mm = o.max_excess_mm;
  plan.verify.gates.max_deficit_mm = o.max_deficit_mm;
  plan.verify.gates.max_rms_mm = o.max_rms_mm;
  plan.verify.voxel_mm = o.voxel_mm;
  plan.verify.mesh_sample_spacing_mm = o.sample_spacing_mm;
  plan.verify.printer = o.printer;
  if (o.place.size() == 3) plan.verify.place_mm = Vec3(o.place[0], o.place[1], o.place[2]);
  plan.filament_density_g_cm3 = o.filament_density;
  plan.slicer_timeout_s = o.slicer_timeout_s;
  plan.cura_definition = o.cura_definition;
  auto paths = parse_slicer_paths(o.slicer_paths, o.slicers);
  if (!paths) return paths.error();
  plan.slicer_paths = std::move(*paths);
  if (!(o.tolerance_mm > 0)) return usage_error("--tolerance must be > 0 mm");
  if (!(o.voxel_mm > 0)) return usage_error("--voxel must be > 0 mm");
  if (!(o.filament_density > 0)) return usage_error("--filament-density must be > 0 g/cm3");
  auto bytes = read_file(o.mesh);
  if (!bytes) return bytes.error();
  plan.mesh_sha256 = sha256_hex(*bytes);
  return plan;
}

int run_compare_command(const CompareOptions& o) {
  if (auto st = check_output_paths({{o.out, "--out", OutputKind::folder},
                                    {o.write_manifest, "--write-manifest", OutputKind::file}});
      !st)
    return report_error(st.error());
  if (!o.merge.empty()) {
    if (!o.mesh.empty() || !o.manifest.empty())
      return report_error(usage_error("--merge takes only compare JSON files and --out"));
    return run_merge(o);
  }
  if (o.shard_n && !o.shard_k) return report_error(usage_error("--of needs --variant K"));
  if (o.variant_reports != "full" && o.variant_reports != "json" && o.variant_reports != "none")
    return report_error(usage_error("--variant-reports must be full, json or none"));

  auto plan = build_plan(o);
  if (!plan) return report_error(plan.error());
  if (auto st = validate_plan(*plan); !st) return report_error(st.error());
  if (!o.write_manifest.empty()) {
    if (auto st = write_file_atomic(o.write_manifest, compare_plan_json(*plan)); !st)
      return report_error(st.error());
    std::printf("wrote %s: %zu variants, plan %s\n", o.write_manifest.c_str(),
                plan->variants.size(), compare_plan_id(*plan).substr(0, 12).c_str());
    return kPass;
  }

  const int count = static_cast<int>(plan->variants.size());
  std::vector<int> indices;
  std::optional<std::pair<int, int>> shard;
  if (o.shard_k) {
    const int n = o.shard_n.value_or(count);
    auto idx = shard_indices(count, *o.shard_k, n);
    if (!idx) return report_error(idx.error());
    indices = std::move(*idx);
    shard = std::make_pair(*o.shard_k, n);
  }

  auto printer = load_printer_profile(plan->printer);
  if (!printer) return report_error(printer.error());
  const fs::path mesh_path = plan->mesh_path;
  auto part = prepare_shared_part(mesh_path, *printer, plan->verify);
  if (!part) return report_error(part.error());
  if (!plan->mesh_sha256.empty() && part->info.sha256 != plan->mesh_sha256)
    return report_error(bad_input(
        "the mesh differs from the one the manifest was written for (sha256 " +
            part->info.sha256.substr(0, 12) + ", manifest " + plan->mesh_sha256.substr(0, 12) + ")",
        mesh_path.string()));

  const fs::path out_dir =
      o.out.empty() ? fs::path("reports") / (part->info.name + "-compare") : fs::path(o.out);
  CompareRunOptions run;
  run.out_dir = out_dir;
  run.variant_reports = o.variant_reports != "none";
  run.progress = progress_printer();
  const std::string stamp = report_timestamp_utc();
  if (o.variant_reports == "full") {
    // The variants place the same mesh, mostly at the same offset: one writer shares the
    // work that depends only on the placed mesh between them.
    auto writer = std::make_shared<ReportFolderWriter>();
    run.write_variant_report = [stamp, writer](const VerifyReport& rep,
                                               const fs::path& dir) -> Status {
      ReportOptions ro;
      ro.generated_utc = stamp;
      ro.extra_outputs = [&rep](const fs::path& staging) {
        return write_verify_outputs(rep, staging);
      };
      return writer->write(rep, dir, ro);
    };
  }
  // An empty share (more shares than variants) still writes its JSON, so that a merge of
  // every job's output sees all shares.
  auto result = (shard && indices.empty())
                    ? Result<CompareResult>(make_compare_result(*part, *plan))
                    : run_compare(*part, *plan, indices, run);
  if (!result) return report_error(result.error());
  if (shard) {
    result->shard = shard;
    const std::string name = shard_file_name(shard->first, shard->second);
    if (auto st = write_file_atomic(out_dir / name, compare_json(*result)); !st)
      return report_error(st.error());
    print_table(*result, out_dir, name);
  } else {
    CompareHtmlOptions html;
    html.generated_utc = stamp;
    if (auto st = write_compare_outputs(*result, out_dir, html); !st)
      return report_error(st.error());
    print_table(*result, out_dir, "compare.json, compare.md, compare.html");
  }
  return exit_code_of(*result, o.require_pass);
}

}  // namespace

void add_compare_command(CLI::App& app, CommandRunner& runner) {
  auto o = std::make_shared<CompareOptions>();
  auto* cmd = app.add_subcommand(
      "compare",
      "Run variants of a part (slicer settings, configs, other slicers' G-code) side by side");
  cmd->add_option("mesh", o->mesh, "STL, OBJ, PLY, OFF, 3MF or AMF file");
  cmd->add_option("--vary", o->varies,
                  "sweep a slicer setting: key=v1,v2,... (several: cross product)");
  cmd->add_option("--set", o->sets, "a slicer setting for every variant: key=value");
  cmd->add_option(
      "--config", o->configs,
      "the slicer's config: a PrusaSlicer/Slic3r .ini, for Cura a file of key=value lines; "
      "one variant (set) per file");
  cmd->add_option("--gcode", o->gcodes,
                  "an external G-code file of the same part: one variant each");
  add_slicer_options(
      cmd, o->slicers, o->slicer_paths, o->slicer_timeout_s, o->cura_definition,
      "who slices the slicer variants: printtwin (default), prusa-slicer, cura (CuraEngine) or "
      "slic3r; several: one variant set each (a failed slicing run is that variant's row)",
      "the slicer's program (default: found on the PATH); with several --slicer: name=path");
  cmd->add_option("--label", o->labels,
                  "names of the variants, in variant order (one per variant)");
  cmd->add_option(
      "--printer", o->printer,
      "auto (default: each G-code's own printer; ender3 for printtwin's slices), a library printer "
      "(printtwin printers), ender3, ender3-marlin1, ender3-klipper, a profile .json or a "
      "printer.cfg");
  cmd->add_option("--tolerance", o->tolerance_mm, "deviation tolerance, mm (default 0.2)");
  cmd->add_option("--max-excess", o->max_excess_mm,
                  "gate on the largest excess, mm (default: tolerance)");
  cmd->add_option("--max-deficit", o->max_deficit_mm,
                  "gate on the largest deficit, mm (default: tolerance)");
  cmd->add_option("--max-rms", o->max_rms_mm, "gate on the RMS deviation, mm (default: none)");
  cmd->add_option("--voxel", o->voxel_mm, "deposit voxel size, mm (default 0.05)");
  cmd->add_option("--sample-spacing", o->sample_spacing_mm,
                  "mesh sample spacing, mm (default: voxel)");
  cmd->add_option("--place", o->place, "place the mesh at X,Y,Z instead of registering it")
      ->expected(3)
      ->delimiter(',');
  cmd->add_option(
      "--filament-density", o->filament_density,
      "g/cm3 for G-code variants (slicer variants use filament_density; default 1.24, PLA)");
  cmd->add_option("-o,--out", o->out, "output folder (default reports/<part>-compare)");
  cmd->add_option("--variant", o->shard_k,
                  "run only share K (0-based) of --of N; writes compare-K-of-N.json");
  cmd->add_option("--of", o->shard_n, "number of shares (default: the number of variants)");
  cmd->add_option("--write-manifest", o->write_manifest,
                  "write the expanded plan to this JSON file and stop");
  cmd->add_option("--manifest", o->manifest,
                  "read the plan from a manifest instead of the variant flags");
  cmd->add_option("--merge", o->merge, "merge shares' compare JSON files into one comparison");
  cmd->add_flag("--allow-missing", o->allow_missing, "merge even when some variants have no share");
  cmd->add_option("--variant-reports", o->variant_reports,
                  "per-variant verify report folders: full (report.html, junit.xml, report.json, "
                  "...), json (report.json, deviation.ply) or none");
  cmd->add_flag("--require-pass", o->require_pass, "exit 1 when any variant fails its gates");
  cmd->callback([o, &runner] { runner.run = [o]() -> int { return run_compare_command(*o); }; });
}

}  // namespace printtwin::cli

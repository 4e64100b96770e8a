// Running a comparison: the part is loaded, checked and indexed once (SharedPart), then
// every variant runs the verify pipeline on it: slice (or read G-code) -> simulate ->
// deposit -> deviation -> gates -> its report folder.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>


#include "printtwin/printer.hpp"
#include "printtwin/compare.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/mesh_query.hpp"
#include "printtwin/io.hpp"
#include "printtwin/slice.hpp"
#include "printtwin/version.hpp"

namespace printtwin {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A slicer variant's settings: defaults, its config, then its key=value list in order.
Result<SliceSettings> slice_settings_of(const VariantSpec& spec) {
  SliceSettings s;
  if (!spec.config_path.empty()) {
    auto loaded = load_prusa_ini(s, spec.config_path);
    if (!loaded) return loaded.error();
  }
  for (const auto& [key, value] : spec.settings)
    if (auto st = set_slice_setting(s, key, value); !st) return st.error();
  if (auto st = validate_slice_settings(s); !st) return st.error();
  // compare simulates the G-code itself: the slicer's own time estimate (a second planner
  // run over the same text) would be thrown away.
  s.estimate_time = false;
  return s;
}

// Mesh triangle of each sample: the one the deviation stage found (the closest point of a
// deposit sample, the triangle a mesh sample lies on); through the shared BVH for a sample
// that has none. The BVH is in the mesh's own frame, so queries subtract the offset.
std::vector<std::uint32_t> sample_triangles(const MeshQuery& query, const DeviationSamples& samples,
                                            const RigidTransform& placement, double near_mm) {
  std::vector<std::uint32_t> out = samples.triangles;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (out[i] != DeviationSample{}.triangle) continue;
    // Back into the mesh's own frame (the registration may rotate and scale).
    const Vec3 p = placement.rotation.transpose() * (samples.positions_mm[i] - placement.translation_mm) /
                   placement.scale;
    if (auto cp = query.closest_point_within(p, near_mm)) out[i] = cp->triangle;
    else out[i] = query.closest_point(p).triangle;
  }
  return out;
}

std::string slug(const std::string& label) {
  std::string out;
  for (char c : label) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '.' || c == '-';
    if (keep) out += c;
    else if (!out.empty() && out.back() != '_') out += '_';
    if (out.size() >= 48) break;
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out.empty() ? std::string("variant") : out;
}

}  // namespace

Status validate_plan(const ComparePlan& plan) {
  if (plan.variants.empty()) return usage_error("the comparison has no variants");
  for (const auto& v : plan.variants) {
    if (v.kind == VariantKind::slicer) {
      auto s = slice_settings_of(v);
      if (!s) {
        Error e = s.error();
        e.message = "variant " + std::to_string(v.index) + " (" + v.label + "): " + e.message;
        return e;
      }
    } else if (std::error_code ec; !std::filesystem::is_regular_file(v.gcode_path, ec)) {
      return bad_input("variant " + std::to_string(v.index) + " (" + v.label +
                           "): the G-code file does not exist or is not a file",
                       v.gcode_path);
    }
  }
  return Ok{};
}

// ---------------------------------------------------------------- shared part

namespace {

// Slope classes and the BVH of a prepared part.
Result<SharedPart> share(PreparedPart prepared, std::string path, Clock::time_point t0) {
  SharedPart p;
  const Mesh& mesh = prepared.mesh;
  p.info.name = prepared.name;
  p.info.path = std::move(path);
  p.info.sha256 = prepared.mesh_input.sha256;
  p.info.triangles = mesh.triangles.size();
  p.info.volume_mm3 = signed_volume_mm3(mesh);
  p.info.area_mm2 = surface_area_mm2(mesh);
  p.info.bbox_mm = bounding_box(mesh);

  // Sloped triangles: inclination from the horizontal between the two limits.
  const double cos_min = std::cos(kSlopeMinDeg * 3.14159265358979323846 / 180.0);
  const double cos_max = std::cos(kSlopeMaxDeg * 3.14159265358979323846 / 180.0);
  p.sloped.assign(mesh.triangles.size(), 0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Vec3 n = triangle_normal(mesh, t);
    const double len = n.norm();
    if (!(len > 0)) continue;
    const double nz = std::abs(n.z()) / len;  // cos of the inclination from horizontal
    if (nz < cos_min && nz > cos_max) {
      p.sloped[t] = 1;
      p.info.sloped_area_mm2 += 0.5 * len;
    }
  }

  p.prepared = std::move(prepared);
  p.build_time_s = seconds_since(t0);
  return p;
}

}  // namespace

Result<SharedPart> prepare_shared_part(Mesh mesh, std::string name, const PrinterProfile& printer,
                                       const VerifySettings& settings) {
  const auto t0 = Clock::now();
  if (mesh.triangles.empty()) return bad_input("compare: the mesh has no triangles");
  VerifyInput in;
  in.role = "mesh";
  auto prepared = prepare_part(std::move(mesh), std::move(name), std::move(in), printer, settings);
  if (!prepared) return prepared.error();
  return share(std::move(*prepared), {}, t0);
}

Result<SharedPart> prepare_shared_part(const std::filesystem::path& mesh_path, const PrinterProfile& printer,
                                       const VerifySettings& settings) {
  const auto t0 = Clock::now();
  auto prepared = prepare_part(mesh_path, printer, settings);
  if (!prepared) return prepared.error();
  return share(std::move(*prepared), mesh_path.string(), t0);
}

// ---------------------------------------------------------------- one variant

Result<VerifyReport> run_variant_verify(const SharedPart& part, const PrinterProfile& printer,
                                        const ComparePlan& plan, const VariantSpec& spec,
                                        const std::function<void(std::string_view)>& on_stage) {
  if (on_stage) on_stage(spec.kind == VariantKind::slicer ? "slice" : "read");
  Result<GcodeInput> gcode = [&]() -> Result<GcodeInput> {
    if (spec.kind != VariantKind::slicer) return read_gcode_input(spec.gcode_path);
    auto settings = slice_settings_of(spec);
    if (!settings) return settings.error();
    return slice_for_verify(part.prepared, printer, *settings, "printtwin slice (" + spec.label + ")");
  }();
  if (!gcode) return gcode.error();
  VerifySettings settings = plan.verify;
  settings.printer = plan.printer;
  if (spec.kind != VariantKind::slicer && (plan.printer.empty() || plan.printer == "auto")) {
    // --printer auto: each G-code variant runs on the printer its own settings name.
    auto resolved = resolve_printer(plan.printer, spec.gcode_path);
    if (!resolved) return resolved.error();
    return verify_gcode(part.prepared, resolved->profile, settings, std::move(*gcode), false, on_stage);
  }
  // The part's load and check ran once for every variant: not in the variant's timings.
  return verify_gcode(part.prepared, printer, settings, std::move(*gcode), false, on_stage);
}

// ---------------------------------------------------------------- the sweep

CompareResult make_compare_result(const SharedPart& part, const ComparePlan& plan) {
  CompareResult out;
  out.tool_version = kVersion;
  out.part = part.info;
  if (out.part.sha256.empty()) out.part.sha256 = plan.mesh_sha256;
  out.printer = plan.printer;
  out.verify = plan.verify;
  out.plan_id = compare_plan_id(plan);
  out.variant_count = static_cast<int>(plan.variants.size());
  out.shared_time_s = part.build_time_s;
  out.total_time_s = part.build_time_s;
  return out;
}

Result<CompareResult> run_compare(const SharedPart& part, const ComparePlan& plan,
                                  std::span<const int> indices, const CompareRunOptions& options) {
  const auto t0 = Clock::now();
  auto printer = load_printer_profile(plan.printer);
  if (!printer) return printer.error();
  std::vector<int> run;
  if (indices.empty())
    for (int i = 0; i < static_cast<int>(plan.variants.size()); ++i) run.push_back(i);
  else
    run.assign(indices.begin(), indices.end());
  for (int i : run)
    if (i < 0 || i >= static_cast<int>(plan.variants.size()))
      return usage_error("variant " + std::to_string(i) + " is not in the plan (0.." +
                         std::to_string(static_cast<int>(plan.variants.size()) - 1) + ")");

  CompareResult out = make_compare_result(part, plan);

  // The deviation target of the part (built once) holds the BVH and the mesh samples every
  // variant's deviation used; the slope figures look up triangles through them.
  const DeviationTarget& target = *part.prepared.target;
  const double near_mm = std::max(4 * plan.verify.voxel_mm, 2 * plan.verify.gates.tolerance_mm);

  CompareProgress progress;
  progress.total = static_cast<int>(run.size());
  for (int i : run) {
    const VariantSpec& spec = plan.variants[static_cast<std::size_t>(i)];
    const auto tv = Clock::now();
    auto on_stage = [&](std::string_view s) {
      if (!options.progress) return;
      progress.stage = std::string(s) + ": " + spec.label;
      progress.last = nullptr;
      options.progress(progress);
    };
    VariantResult row;
    auto report = run_variant_verify(part, *printer, plan, spec, on_stage);
    if (!report) {
      row.variant = spec;
      row.ran = false;
      row.error = report.error().describe();
    } else {
      // Slope figures: nearest mesh triangle of every sample, through the shared BVH.
      on_stage("slopes");
      const RigidTransform& placement = report->registration.transform;
      const auto dep_tri = sample_triangles(target.query(), report->deviation.deposit_samples, placement, near_mm);
      const auto mesh_tri = sample_triangles(target.query(), report->deviation.mesh_samples, placement, near_mm);
      double density = plan.filament_density_g_cm3;
      if (spec.kind == VariantKind::slicer)
        if (auto s = slice_settings_of(spec)) density = s->filament_density_g_cm3;
      row = summarize_variant(spec, *report, part.sloped, dep_tri, mesh_tri, density);
      if (spec.kind == VariantKind::slicer)
        if (auto s = slice_settings_of(spec)) row.layer_height_mm = s->layer_height_mm;
      if (options.variant_reports && !options.out_dir.empty()) {
        on_stage("report");
        char prefix[16];
        std::snprintf(prefix, sizeof prefix, "%02d-", spec.index);
        const std::string rel = "variants/" + std::string(prefix) + slug(spec.label);
        const auto dir = options.out_dir / rel;
        Status written = options.write_variant_report ? options.write_variant_report(*report, dir)
                                                      : write_verify_outputs(*report, dir);
        if (!written) return written.error();
        row.report_dir = rel;
      }
    }
    row.run_time_s = seconds_since(tv);
    out.variants.push_back(std::move(row));
    ++progress.done;
    if (options.progress) {
      progress.stage.clear();
      progress.last = &out.variants.back();
      options.progress(progress);
    }
  }
  std::stable_sort(out.variants.begin(), out.variants.end(),
                   [](const VariantResult& a, const VariantResult& b) {
                     return a.variant.index < b.variant.index;
                   });
  mark_pareto(out.variants);
  out.total_time_s = seconds_since(t0) + part.build_time_s;
  return out;
}

}  // namespace printtwin

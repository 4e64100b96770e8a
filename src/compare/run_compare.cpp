// Running a comparison: the part is loaded, checked and indexed once (SharedPart), then
// every variant runs the verify pipeline on it: slice (or read G-code) -> simulate ->
// deposit -> deviation -> gates -> its report folder.
#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <thread>

#include "printtwin/compare.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh_query.hpp"
#include "printtwin/printer.hpp"
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
  SettingSources sources;
  if (!spec.config_path.empty()) {
    auto loaded = load_prusa_ini(s, spec.config_path);
    if (!loaded) return loaded.error();
    sources = std::move(loaded->sources);
  }
  for (const auto& [key, value] : spec.settings) {
    if (auto st = set_slice_setting(s, key, value); !st) return st.error();
    sources.erase(key);
  }
  if (auto st = validate_slice_settings(s, sources); !st) return st.error();
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
    const Vec3 p = placement.rotation.transpose() *
                   (samples.positions_mm[i] - placement.translation_mm) / placement.scale;
    if (auto cp = query.closest_point_within(p, near_mm))
      out[i] = cp->triangle;
    else
      out[i] = query.closest_point(p).triangle;
  }
  return out;
}

std::string slug(const std::string& label) {
  std::string out;
  for (char c : label) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '.' || c == '-';
    if (keep)
      out += c;
    else if (!out.empty() && out.back() != '_')
      out += '_';
    if (out.size() >= 48) break;
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out.empty() ? std::string("variant") : out;
}

}  // namespace

Status validate_plan(const ComparePlan& plan) {
  if (plan.variants.empty()) return usage_error("the comparison has no variants");
  if (!(plan.slicer_timeout_s > 0)) return usage_error("--slicer-timeout must be > 0 s");
  for (const auto& v : plan.variants) {
    auto named = [&](Error e) {
      e.message = "variant " + std::to_string(v.index) + " (" + v.label + "): " + e.message;
      return e;
    };
    if (v.kind == VariantKind::slicer && v.slicer != "printtwin") {
      // The external slicer reads its own config; here only that the files are there.
      if (auto st = check_slicer_name(v.slicer); !st) return named(st.error());
      std::error_code ec;
      if (!v.config_path.empty() && !std::filesystem::is_regular_file(v.config_path, ec))
        return named(bad_input("the slicer config does not exist or is not a file", v.config_path));
      if (v.slicer == "cura" && plan.cura_definition.empty())
        return named(usage_error(
            "--slicer cura needs the printer's definition: --cura-definition "
            "/usr/share/cura/resources/definitions/creality_ender3.def.json (package cura)"));
      if (v.slicer == "cura" && !std::filesystem::is_regular_file(plan.cura_definition, ec))
        return named(
            bad_input("the Cura definition does not exist or is not a file", plan.cura_definition));
    } else if (v.kind == VariantKind::slicer) {
      auto s = slice_settings_of(v);
      if (!s) return named(s.error());
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

Result<SharedPart> prepare_shared_part(const std::filesystem::path& mesh_path,
                                       const PrinterProfile& printer,
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
    return slice_for_verify(part.prepared, printer, *settings,
                            "printtwin slice (" + spec.label + ")");
  }();
  if (!gcode) return gcode.error();
  VerifySettings settings = plan.verify;
  settings.printer = plan.printer;
  if (spec.kind != VariantKind::slicer && (plan.printer.empty() || plan.printer == "auto")) {
    // (An external slicer's variant arrives here as the G-code it wrote.)
    // --printer auto: each G-code variant runs on the printer its own settings name.
    auto resolved = resolve_printer(plan.printer, spec.gcode_path);
    if (!resolved) return resolved.error();
    return verify_gcode(part.prepared, resolved->profile, settings, std::move(*gcode), false,
                        on_stage);
  }
  // The part's load and check ran once for every variant: not in the variant's timings.
  return verify_gcode(part.prepared, printer, settings, std::move(*gcode), false, on_stage);
}

// ---------------------------------------------------------------- the sweep

namespace {

// The external slicing runs of a sweep: one job per distinct (slicer, config, effective
// settings), run in order on a worker thread; variants wait for their job's G-code.
class ExternalSlicing {
 public:
  struct Job {
    SlicerProgram program;
    SlicerJob input;
    std::string gcode, command, version;
    /// Cura: the library printer the definition names (its G-code names none), "" if none.
    std::string printer;
    Status status = Ok{};
    bool done = false;
  };

  Status plan(const ComparePlan& plan, const std::vector<int>& run,
              const std::filesystem::path& out_dir, const std::string& mesh_path) {
    std::map<std::string, SlicerProgram> programs;
    std::map<std::string, std::size_t> by_key;
    std::filesystem::path dir = out_dir.empty()
                                    ? std::filesystem::temp_directory_path() /
                                          ("printtwin-compare-" + std::to_string(::getpid()))
                                    : out_dir;
    for (int i : run) {
      const VariantSpec& v = plan.variants[static_cast<std::size_t>(i)];
      if (v.kind != VariantKind::slicer || v.slicer == "printtwin") continue;
      if (!programs.count(v.slicer)) {
        std::string path;
        for (const auto& [name, p] : plan.slicer_paths)
          if (name == v.slicer) path = p;
        auto found = find_slicer_program(v.slicer, path);
        if (!found) return found.error();
        programs.emplace(v.slicer, std::move(*found));
      }
      std::string key = v.slicer + '\n' + v.config_path;
      for (const auto& [k, val] : effective_settings(v.settings)) {
        key += '\n';
        key += k;
        key += '=';
        key += val;
      }
      auto [it, fresh] = by_key.emplace(key, jobs_.size());
      if (fresh) {
        auto job = std::make_unique<Job>();
        job->program = programs.at(v.slicer);
        job->version = job->program.version;
        job->input.mesh_path = mesh_path;
        char prefix[16];
        std::snprintf(prefix, sizeof prefix, "%02d-", v.index);
        auto config =
            slicer_config_file(v.slicer, v.config_path,
                               dir / "gcode" / (std::string(prefix) + slug(v.label) + ".ini"));
        job->input.config_path = config ? *config : v.config_path;
        job->input.settings = v.settings;
        job->input.cura_definition = plan.cura_definition;
        job->gcode = (dir / "gcode" / (std::string(prefix) + slug(v.label) + ".gcode")).string();
        job->input.out_gcode = job->gcode;
        if (v.slicer == "cura") job->printer = cura_definition_printer(plan.cura_definition);
        auto command = config ? slicer_command_line(job->program, job->input)
                              : Result<std::string>(config.error());
        if (!command) {
          job->status = command.error();
          job->done = true;
        } else {
          job->command = std::move(*command);
        }
        jobs_.push_back(std::move(job));
      }
      job_of_[i] = it->second;
    }
    return Ok{};
  }

  void start(double timeout_s) {
    if (jobs_.empty()) return;
    worker_ = std::jthread([this, timeout_s](const std::stop_token& stop) {
      for (auto& job : jobs_) {
        if (stop.stop_requested()) break;
        Status st =
            job->done ? job->status : run_external_slicer(job->program, job->input, timeout_s);
        std::lock_guard lock(mutex_);
        job->status = std::move(st);
        job->done = true;
        cv_.notify_all();
      }
      std::lock_guard lock(mutex_);
      finished_ = true;
      cv_.notify_all();
    });
  }

  [[nodiscard]] const Job* job_of(int variant) const {
    auto it = job_of_.find(variant);
    return it == job_of_.end() ? nullptr : jobs_[it->second].get();
  }

  Status wait(const Job& job) {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [&] { return job.done || finished_; });
    if (!job.done) return bad_input("the slicing run was cancelled");
    return job.status;
  }

 private:
  std::vector<std::unique_ptr<Job>> jobs_;
  std::map<int, std::size_t> job_of_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool finished_ = false;
  std::jthread worker_;  // last: joined (after a stop request) before the jobs go
};

}  // namespace

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

  // External slicers: every distinct job sliced once, in variant order, on a thread of its
  // own, so that the slicer works on the next variant while this one is measured.
  ExternalSlicing slicing;
  if (auto st = slicing.plan(plan, run, options.out_dir,
                             part.info.path.empty() ? plan.mesh_path : part.info.path);
      !st)
    return st.error();
  slicing.start(plan.slicer_timeout_s);

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
    const ExternalSlicing::Job* job = slicing.job_of(i);
    Result<VerifyReport> report = [&]() -> Result<VerifyReport> {
      if (job == nullptr) return run_variant_verify(part, *printer, plan, spec, on_stage);
      on_stage("slice");
      if (auto st = slicing.wait(*job); !st) return st.error();
      VariantSpec as_gcode = spec;  // the twin measures the G-code the slicer wrote
      as_gcode.kind = VariantKind::gcode;
      as_gcode.gcode_path = job->gcode;
      if (!job->printer.empty() && (plan.printer.empty() || plan.printer == "auto")) {
        // A Cura G-code states only its flavour: the printer is the definition's.
        ComparePlan own = plan;
        own.printer = job->printer;
        auto resolved = resolve_printer(job->printer, job->gcode);
        if (!resolved) return resolved.error();
        return run_variant_verify(part, resolved->profile, own, as_gcode, on_stage);
      }
      return run_variant_verify(part, *printer, plan, as_gcode, on_stage);
    }();
    if (!report) {
      row.variant = spec;
      row.ran = false;
      row.error = report.error().describe();
    } else {
      // Slope figures: nearest mesh triangle of every sample, through the shared BVH.
      on_stage("slopes");
      const RigidTransform& placement = report->registration.transform;
      const auto dep_tri =
          sample_triangles(target.query(), report->deviation.deposit_samples, placement, near_mm);
      const auto mesh_tri =
          sample_triangles(target.query(), report->deviation.mesh_samples, placement, near_mm);
      double density = plan.filament_density_g_cm3;
      const bool own_slicer = spec.kind == VariantKind::slicer && job == nullptr;
      if (own_slicer)
        if (auto s = slice_settings_of(spec)) density = s->filament_density_g_cm3;
      row = summarize_variant(spec, *report, part.sloped, dep_tri, mesh_tri, density);
      if (own_slicer)
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
    if (job != nullptr) {
      row.command = job->command;
      if (!job->version.empty()) row.slicer = job->version;
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

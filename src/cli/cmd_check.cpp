// `printtwin check part.stl`: printability of a mesh before slicing.
//   exit 0 printable, 1 errors found, 2 usage, 3 bad input, 4 internal error.
#include <glob.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "cli/manifest.hpp"
#include "printtwin/check.hpp"
#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/verify.hpp"
#include "report/markup.hpp"

namespace printtwin::cli {

namespace {

using detail::md_cell;

struct CheckOptions {
  std::vector<std::string> inputs;
  std::string input;  ///< the part being checked
  std::string summary_out;
  std::string junit_out;
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
  bool orient = false;
  double weld_tolerance_mm = -1;  ///< --weld-tolerance; negative: admesh's default
  std::string manifest;           ///< --manifest FILE
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
  if (comma == std::string::npos)
    return usage_error("--center expects x,y in mm, got '" + text + "'");
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
  std::printf(
      "health     open edges %zu, non-manifold edges %zu / vertices %zu, degenerate %zu, "
      "duplicate %zu, misoriented edges %zu, inverted shells %zu, self-intersections %s\n",
      h.boundary_edges, h.non_manifold_edges, h.non_manifold_vertices, h.degenerate_faces,
      h.duplicate_faces, h.inconsistent_edges, h.inverted_shells,
      h.self_intersections_checked ? std::to_string(h.self_intersections).c_str() : "not checked");
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
  if (r.findings.empty())
    std::printf("findings   none\n");
  else
    std::printf("findings\n");
  for (const auto& f : r.findings)
    std::printf("  %-7s %-24s %s\n", std::string(to_string(f.severity)).c_str(), f.code.c_str(),
                f.message.c_str());
  if (repair != nullptr) {
    std::printf("repair     wrote %s (open seams welded within %s mm)\n", o.repair_out.c_str(),
                format_fixed(repair->weld_tolerance_mm, 4).c_str());
    std::printf("           %s\n", repair_counters_text(repair->counters).c_str());
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

/// One part checked: its report, or the error that stopped it (bad input, internal).
struct PartOutcome {
  std::string file;
  int exit_code = kPass;
  std::optional<Error> error;
  std::optional<CheckReport> report;
  CheckSource source;
  std::optional<RepairResult> repaired;
  std::string repair_file;  ///< where the repaired mesh was written
  double seconds = 0;
};

constexpr const char* kMeshExtensions[] = {".stl", ".obj", ".ply", ".off", ".3mf", ".amf"};

bool has_mesh_extension(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return std::find(std::begin(kMeshExtensions), std::end(kMeshExtensions), ext) !=
         std::end(kMeshExtensions);
}

PartOutcome check_part(const CheckOptions& o, const std::string& file,
                       const PrinterProfile& printer, const CheckSettings& settings,
                       std::optional<double> mm_per_unit, const std::string& repair_out) {
  const auto t0 = std::chrono::steady_clock::now();
  PartOutcome out;
  out.file = file;
  auto fail = [&](Error e) {
    if (e.file.empty()) e.file = file;
    out.exit_code = e.code == ErrorCode::bad_input
                        ? kBadInput
                        : (e.code == ErrorCode::usage ? kUsage : kInternal);
    out.error = std::move(e);
    return out;
  };
  MeshLoadOptions load;
  load.scale = o.scale * mm_per_unit.value_or(1.0);
  // The file is read once: the same bytes are welded and hashed. A name without a mesh
  // extension goes to load_mesh for its error.
  if (!has_mesh_extension(file)) return fail(load_mesh(file, load).error());
  if (auto st = check_mesh_file_header(file); !st) return fail(st.error());
  auto bytes = read_file(file);
  if (!bytes) return fail(bytes.error());
  auto mesh = load_mesh_from_memory(*bytes, file, load);
  if (!mesh) return fail(mesh.error());
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
  std::optional<Finding> oriented;
  if (o.orient) {
    const OrientationAdvice a = advise_orientation(*mesh, settings);
    if (a.better) {
      *mesh = rotated_mesh(*mesh, a.best.rotation_xyz_deg);
      const Vec3& r = a.best.rotation_xyz_deg;
      Finding f;
      f.severity = Severity::info;
      f.code = "oriented";
      f.message = "checked stood on " + a.best.label + " (--orient: rotated " + f2(r.x()) + ", " +
                  f2(r.y()) + ", " + f2(r.z()) +
                  " deg about X, Y, Z): " + format_fixed(a.best.overhang_mm2, 1) +
                  " mm2 of support instead of " + format_fixed(a.current.overhang_mm2, 1) + " mm2";
      oriented = std::move(f);
    }
  }
  auto report = check_printability(*mesh, printer, settings);
  if (!report) return fail(report.error());
  if (oriented) report->findings.push_back(*oriented);
  if (guess)
    report->findings.insert(
        report->findings.begin() + static_cast<std::ptrdiff_t>(first_warning(report->findings)),
        units_guessed_finding(*guess, report->health.bbox_mm.size()));
  if (!repair_out.empty()) {
    RepairSettings repair;
    repair.weld_tolerance_mm = o.weld_tolerance_mm;
    auto rr = repair_mesh(*mesh, repair);
    if (!rr) return fail(rr.error());
    if (auto st = save_stl(rr->mesh, repair_out); !st) return fail(st.error());
    out.repaired = std::move(*rr);
    out.repair_file = repair_out;
  }
  out.source.file = file;
  // The hash goes only into the JSON report.
  if (!o.json_out.empty()) out.source.sha256 = sha256_hex(*bytes);
  out.source.units = units_used;
  out.source.scale = o.scale;
  out.source.printer = printer.name;
  out.exit_code = report->printable ? kPass : kFail;
  out.report = std::move(*report);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

/// Files, folders (every mesh file below them, sorted) and globs -> the parts, in order,
/// each once. A glob that matches nothing and a folder without meshes are usage errors.
Result<std::vector<std::string>> expand_inputs(const std::vector<std::string>& inputs) {
  namespace fs = std::filesystem;
  std::vector<std::string> parts;
  auto add_folder = [&](const fs::path& dir) -> Status {
    std::vector<std::string> found;
    std::error_code ec;
    for (fs::recursive_directory_iterator
             it(dir, fs::directory_options::skip_permission_denied, ec),
         end;
         !ec && it != end; it.increment(ec))
      if (has_mesh_extension(it->path())) found.push_back(it->path().string());
    if (ec) return bad_input(dir.string() + ": cannot list the folder: " + ec.message());
    if (found.empty())
      return usage_error(dir.string() + ": no mesh files (" +
                         ".stl .obj .ply .off .3mf .amf) in the folder");
    std::sort(found.begin(), found.end());
    parts.insert(parts.end(), found.begin(), found.end());
    return Ok{};
  };
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (in.find_first_of("*?[") != std::string::npos && !fs::exists(in, ec)) {
      glob_t g{};
      const int rc = ::glob(in.c_str(), 0, nullptr, &g);
      if (rc == GLOB_NOMATCH || (rc == 0 && g.gl_pathc == 0)) {
        globfree(&g);
        return usage_error("'" + in + "' matches no file");
      }
      for (std::size_t i = 0; rc == 0 && i < g.gl_pathc; ++i) parts.emplace_back(g.gl_pathv[i]);
      globfree(&g);
      if (rc != 0) return usage_error("'" + in + "': cannot expand the pattern");
    } else if (fs::is_directory(in, ec) && !has_mesh_extension(in)) {
      if (auto st = add_folder(in); !st) return st.error();
    } else {
      parts.push_back(in);  // read errors (missing, empty, unreadable) become failed cases
    }
  }
  std::vector<std::string> unique;
  for (auto& p : parts)
    if (std::find(unique.begin(), unique.end(), p) == unique.end()) unique.push_back(std::move(p));
  return unique;
}

std::string verdict(const PartOutcome& p) {
  if (p.error) return p.error->code == ErrorCode::bad_input ? "UNREADABLE" : "ERROR";
  return p.report->printable ? "PRINTABLE" : "NOT PRINTABLE";
}

/// The first error finding (or the first warning), for the summary table.
std::string main_problem(const PartOutcome& p) {
  if (p.error) return p.error->describe();
  for (const auto& f : p.report->findings)
    if (f.severity == Severity::error) return f.code + ": " + f.message;
  for (const auto& f : p.report->findings)
    if (f.severity == Severity::warning) return f.code + ": " + f.message;
  return "";
}

std::array<std::size_t, 3> severity_counts(const PartOutcome& p) {
  std::array<std::size_t, 3> c{0, 0, 0};
  if (p.report)
    for (const auto& f : p.report->findings) ++c[static_cast<int>(f.severity)];
  return c;
}

std::string summary_markdown(const std::vector<PartOutcome>& parts, const std::string& printer) {
  std::size_t ok = 0;
  for (const auto& p : parts) ok += p.exit_code == kPass;
  std::string md = "### printtwin check: " + std::to_string(ok) + " of " +
                   std::to_string(parts.size()) + " parts printable on " + md_cell(printer) +
                   "\n\n";
  const bool repaired = std::any_of(parts.begin(), parts.end(),
                                    [](const PartOutcome& p) { return p.repaired.has_value(); });
  md += std::string(
            "| part | verdict | errors | warnings | triangles | size (mm) | first problem |") +
        (repaired ? " repair |" : "") + "\n";
  md += std::string("|---|---|---:|---:|---:|---|---|") + (repaired ? "---|" : "") + "\n";
  for (const auto& p : parts) {
    const auto c = severity_counts(p);
    std::string tri = "-", size = "-";
    if (p.report) {
      tri = std::to_string(p.report->health.triangles);
      const Vec3 s = p.report->health.bbox_mm.size();
      size = f2(s.x()) + " x " + f2(s.y()) + " x " + f2(s.z());
    }
    std::string problem = main_problem(p);
    if (problem.size() > 200) problem = problem.substr(0, 197) + "...";
    const char* bold = p.exit_code == kPass ? "" : "**";
    for (const std::string& cell : {md_cell(p.file), bold + verdict(p) + bold, std::to_string(c[2]),
                                    std::to_string(c[1]), tri, size, md_cell(problem)}) {
      md += "| ";
      md += cell;
      md += ' ';
    }
    md += '|';
    if (repaired) {
      md += ' ';
      md += p.repaired ? md_cell(repair_counters_text(p.repaired->counters)) : std::string("-");
      md += " |";
    }
    md += '\n';
  }
  return md;
}

std::string check_junit(const std::vector<PartOutcome>& parts) {
  std::vector<CaseOutcome> cases;
  for (const auto& p : parts) {
    CaseOutcome c{p.file,
                  p.seconds,
                  p.exit_code == kPass,
                  p.error ? "unreadable" : "not_printable",
                  verdict(p) + ": " + main_problem(p),
                  ""};
    if (p.report)
      for (const auto& f : p.report->findings)
        c.details += std::string(to_string(f.severity)) + " " + f.code + ": " + f.message + "\n";
    else
      c.details = p.error->describe();
    cases.push_back(std::move(c));
  }
  return junit_xml("printtwin check", "printtwin.check", cases);
}

std::string batch_json(const std::vector<PartOutcome>& parts) {
  nlohmann::ordered_json j;
  j["schema"] = "printtwin.check.batch";
  j["version"] = 1;
  j["parts"] = nlohmann::ordered_json::array();
  for (const auto& p : parts) {
    nlohmann::ordered_json e;
    e["file"] = p.file;
    e["verdict"] = verdict(p);
    e["exit_code"] = p.exit_code;
    if (p.report)
      e["report"] = nlohmann::ordered_json::parse(check_report_to_json(
          *p.report, p.source, p.repaired ? &*p.repaired : nullptr, p.repair_file));
    else
      e["error"] = p.error->describe();
    j["parts"].push_back(std::move(e));
  }
  return j.dump(2) + "\n";
}

/// --repair FOLDER of a batch: FOLDER/<name of the part>.stl, "-2", "-3"... when names repeat;
/// all empty without --repair.
std::vector<std::string> repair_paths(const std::string& folder,
                                      const std::vector<std::string>& files) {
  std::vector<std::string> out(files.size());
  if (folder.empty()) return out;
  std::vector<std::string> used;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string stem = std::filesystem::path(files[i]).stem().string();
    std::string name = stem + ".stl";
    for (int n = 2; std::find(used.begin(), used.end(), name) != used.end(); ++n)
      name = stem + "-" + std::to_string(n) + ".stl";
    used.push_back(name);
    out[i] = (std::filesystem::path(folder) / name).string();
  }
  return out;
}

/// The options of one part resolved into what check_part needs.
struct PartSetup {
  CheckOptions options;
  PrinterProfile printer;
  CheckSettings settings;
  std::optional<double> mm_per_unit;  ///< unset: --units auto
};

Result<PartSetup> resolve_setup(const CheckOptions& o) {
  PartSetup s;
  s.options = o;
  auto printer = load_printer_profile(o.printer);
  if (!printer) return printer.error();
  s.printer = std::move(*printer);
  CheckSettings& settings = s.settings;
  settings.overhang_angle_deg = o.overhang_angle_deg;
  settings.min_thickness_mm = o.min_thickness_mm;
  settings.line_width_mm = o.line_width_mm;
  settings.self_intersections = !o.no_self_intersections;
  if (o.no_center && !o.center.empty())
    return usage_error("--center and --no-center exclude each other");
  settings.center = !o.no_center;
  if (!o.center.empty()) {
    auto c = parse_center(o.center);
    if (!c) return c.error();
    settings.center_x_mm = c->x();
    settings.center_y_mm = c->y();
  }
  // --units: the names and numbers `verify --units` takes, or auto (judged by the size).
  if (o.units != "auto") {
    VerifySettings units;
    if (auto st = parse_units_option(o.units, units); !st) return st.error();
    s.mm_per_unit = units.mesh_scale;
  }
  return s;
}

/// The command line's options with a manifest entry's settings on top.
CheckOptions with_part_settings(CheckOptions o, const PartSettings& p) {
  if (p.printer) o.printer = *p.printer;
  if (p.units) o.units = *p.units;
  if (p.scale) o.scale = *p.scale;
  if (p.orient) o.orient = *p.orient;
  if (p.overhang_angle_deg) o.overhang_angle_deg = *p.overhang_angle_deg;
  if (p.min_thickness_mm) o.min_thickness_mm = *p.min_thickness_mm;
  if (p.line_width_mm) o.line_width_mm = *p.line_width_mm;
  if (p.self_intersections) o.no_self_intersections = !*p.self_intersections;
  if (p.weld_tolerance_mm) o.weld_tolerance_mm = *p.weld_tolerance_mm;
  return o;
}

/// One part of a batch: its file and its setup, or the error that fails it before reading.
struct PartJob {
  std::string file;
  Result<PartSetup> setup;
};

/// The batch's parts with their settings: every file found, then every part a manifest lists
/// that was not found (a listed part that does not exist fails with that message).
std::vector<PartJob> batch_jobs(const CheckOptions& o, std::vector<std::string> files,
                                const std::vector<Manifest>& manifests) {
  for (const auto& m : manifests)
    for (const auto& part : m.parts)
      if (std::none_of(files.begin(), files.end(),
                       [&](const std::string& f) { return same_file(f, part.file); }))
        files.push_back(part.file);
  std::vector<PartJob> jobs;
  for (const auto& file : files) {
    const ManifestPart* listed = find_manifest_part(manifests, file);
    std::error_code ec;
    if (listed != nullptr && !std::filesystem::exists(file, ec)) {
      const auto& in = *std::find_if(manifests.begin(), manifests.end(), [&](const Manifest& m) {
        return std::any_of(m.parts.begin(), m.parts.end(),
                           [&](const ManifestPart& p) { return &p == listed; });
      });
      jobs.push_back({file, bad_input("listed in " + in.path + " but not found", file)});
      continue;
    }
    jobs.push_back({file, resolve_setup(listed ? with_part_settings(o, listed->settings) : o)});
  }
  return jobs;
}

/// "Ender-3" when every part is checked on it, else "their printers (see the JSON)".
std::string printers_label(const std::vector<PartOutcome>& parts, const std::string& fallback) {
  std::string name;
  for (const auto& p : parts) {
    if (p.source.printer.empty()) continue;
    if (!name.empty() && name != p.source.printer) return "the printers the manifest names";
    name = p.source.printer;
  }
  return name.empty() ? fallback : name;
}

int run_batch(const CheckOptions& o, const std::vector<PartJob>& jobs,
              const std::string& printer_name) {
  std::vector<PartOutcome> parts(jobs.size());
  std::vector<std::string> files;
  files.reserve(jobs.size());
  for (const auto& j : jobs) files.push_back(j.file);
  const std::vector<std::string> repair_files = repair_paths(o.repair_out, files);
  if (!o.repair_out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.repair_out, ec);
    if (ec)
      return report_error(
          bad_input(o.repair_out + ": cannot create the --repair folder: " + ec.message()));
  }
  // The largest files first, so that no core waits at the end while one checks a big part
  // (the report keeps the order of the arguments).
  std::vector<std::uintmax_t> bytes(jobs.size(), 0);
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    std::error_code ec;
    const std::uintmax_t size = std::filesystem::file_size(jobs[i].file, ec);
    bytes[i] = ec ? 0 : size;
  }
  std::vector<std::size_t> order(jobs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return bytes[a] > bytes[b]; });
  std::atomic<std::size_t> next{0};
  const std::size_t workers = std::max<std::size_t>(
      1, std::min<std::size_t>(jobs.size(), std::thread::hardware_concurrency()));
  std::vector<std::thread> pool;
  for (std::size_t w = 0; w < workers; ++w)
    pool.emplace_back([&] {
      for (std::size_t k = next++; k < jobs.size(); k = next++) {
        const std::size_t i = order[k];
        const PartJob& job = jobs[i];
        if (!job.setup) {
          parts[i].file = job.file;
          parts[i].error = job.setup.error();
          parts[i].exit_code =
              job.setup.error().code == ErrorCode::internal ? kInternal : kBadInput;
          continue;
        }
        const PartSetup& s = *job.setup;
        parts[i] =
            check_part(s.options, job.file, s.printer, s.settings, s.mm_per_unit, repair_files[i]);
      }
    });
  for (auto& t : pool) t.join();

  const std::string md = summary_markdown(parts, printers_label(parts, printer_name));
  std::fputs(md.c_str(), stdout);
  int worst = kPass;
  for (const auto& p : parts) worst = std::max(worst, p.exit_code);
  for (const auto& [path, text] :
       {std::pair<const std::string&, std::string>{o.summary_out, md},
        {o.junit_out, o.junit_out.empty() ? std::string() : check_junit(parts)},
        {o.json_out, o.json_out.empty() ? std::string() : batch_json(parts)}})
    if (!path.empty())
      if (auto st = write_file_atomic(path, text); !st) return report_error(st.error());
  return worst;
}

int run_check(const CheckOptions& o) {
  if (auto st = check_output_paths({{o.json_out, "--json", OutputKind::file},
                                    {o.summary_out, "--summary", OutputKind::file},
                                    {o.junit_out, "--junit", OutputKind::file}});
      !st)
    return report_error(st.error());
  if (o.inputs.empty() && o.manifest.empty())
    return report_error(usage_error("give the parts (files, folders or globs) or --manifest FILE"));
  auto base = resolve_setup(o);
  if (!base) return report_error(base.error());
  auto manifests = find_manifests(o.inputs, o.manifest);
  if (!manifests) return report_error(manifests.error());

  // Several parts, a folder, a glob or a manifest alone: the batch run (summary table, JUnit,
  // one JSON).
  std::error_code ec;
  const bool batch =
      o.inputs.size() != 1 || !o.summary_out.empty() || !o.junit_out.empty() ||
      (std::filesystem::is_directory(o.inputs[0], ec) && !has_mesh_extension(o.inputs[0])) ||
      (o.inputs[0].find_first_of("*?[") != std::string::npos &&
       !std::filesystem::exists(o.inputs[0], ec));
  if (batch) {
    if (auto st = check_output_path(o.repair_out, "--repair", OutputKind::folder); !st)
      return report_error(st.error());
    std::vector<std::string> files;
    if (!o.inputs.empty()) {
      auto found = expand_inputs(o.inputs);
      if (!found) return report_error(found.error());
      files = std::move(*found);
    }
    return run_batch(o, batch_jobs(o, std::move(files), *manifests), base->printer.name);
  }

  if (auto st = check_output_path(o.repair_out, "--repair", OutputKind::file); !st)
    return report_error(st.error());
  const ManifestPart* listed = find_manifest_part(*manifests, o.inputs[0]);
  auto setup = listed ? resolve_setup(with_part_settings(o, listed->settings)) : std::move(base);
  if (!setup) return report_error(setup.error());
  CheckOptions& one = setup->options;
  one.input = o.inputs[0];
  PartOutcome part =
      check_part(one, one.input, setup->printer, setup->settings, setup->mm_per_unit, o.repair_out);
  if (part.error) return report_error(*part.error);
  print_text(one, setup->printer, *part.report, part.repaired ? &*part.repaired : nullptr);
  if (!o.json_out.empty()) {
    const std::string text = check_report_to_json(
        *part.report, part.source, part.repaired ? &*part.repaired : nullptr, o.repair_out);
    if (auto st = write_file_atomic(o.json_out, text); !st) return report_error(st.error());
  }
  return part.exit_code;
}

}  // namespace

void add_check_command(CLI::App& app, CommandRunner& runner) {
  auto opts = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand(
      "check",
      "Check whether a mesh is printable (no slicing). Exit 0 printable, 1 errors found,\n"
      "2 usage, 3 bad input, 4 internal error. Findings: docs/check.md");
  cmd->add_option("mesh", opts->inputs,
                  "STL, OBJ, PLY, OFF, 3MF or AMF files, folders (every mesh below them) or globs; "
                  "several parts make a batch: a summary table, exit code of the worst part");
  cmd->add_option(
      "--manifest", opts->manifest,
      "per-part settings (JSON, docs/ci.md); default: printtwin.json in each folder given and "
      "beside each file; without parts: check the parts it lists");
  cmd->add_option("--summary", opts->summary_out,
                  "write the batch's Markdown summary table (for $GITHUB_STEP_SUMMARY)");
  cmd->add_option("--junit", opts->junit_out, "write a JUnit XML file with a test case per part");
  cmd->add_option("--printer", opts->printer,
                  "ender3, ender3-marlin1, ender3-klipper, a library printer (printtwin printers), "
                  "a profile FILE.json or a Klipper printer.cfg")
      ->capture_default_str();
  cmd->add_option(
      "--json", opts->json_out,
      "write the report as JSON (schema printtwin.check v1; a batch: printtwin.check.batch "
      "v1, one report per part)");
  cmd->add_option("--repair", opts->repair_out,
                  "write a repaired mesh (binary STL) and count what changed (admesh's counters); "
                  "a batch: a folder, one <part>.stl each");
  cmd->add_option("--weld-tolerance", opts->weld_tolerance_mm,
                  "--repair first joins open seams whose ends lie within this many mm (admesh "
                  "--nearby); 0: no weld; default: admesh's, the shortest edge + 0.01 % of the "
                  "diagonal")
      ->check(CLI::NonNegativeNumber);
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
  cmd->add_flag("--orient", opts->orient,
                "stand the part as the orientation finding advises before checking it (and in "
                "--repair's output)");
  cmd->add_flag("--no-self-intersections", opts->no_self_intersections,
                "skip the self-intersection test");
  cmd->callback([opts, &runner] { runner.run = [opts]() -> int { return run_check(*opts); }; });
}

}  // namespace printtwin::cli

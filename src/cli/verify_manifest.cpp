// `printtwin verify --manifest FILE`: every listed part verified against its G-code, one
// summary table and one JUnit file for the lot (manifest.hpp).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "cli/cli_common.hpp"
#include "cli/manifest.hpp"
#include "printtwin/io.hpp"
#include "printtwin/report.hpp"
#include "printtwin/verify.hpp"
#include "report/report_internal.hpp"

namespace printtwin::cli {

namespace {

namespace fs = std::filesystem;
using detail::md_cell;

/// The command line's settings with a manifest entry's verify keys on top.
Result<VerifySettings> part_settings(VerifySettings s, const PartSettings& p) {
  if (p.printer) s.printer = *p.printer;
  if (p.units) {
    s.mesh_scale.reset();  // auto: the registration searches the scale
    if (*p.units != "auto")
      if (auto st = parse_units_option(*p.units, s); !st) return st.error();
  }
  if (p.scale) s.mesh_scale = s.mesh_scale.value_or(1.0) * *p.scale;
  if (p.tolerance_mm) s.gates.tolerance_mm = *p.tolerance_mm;
  if (p.max_excess_mm) s.gates.max_excess_mm = *p.max_excess_mm;
  if (p.max_deficit_mm) s.gates.max_deficit_mm = *p.max_deficit_mm;
  if (p.max_rms_mm) s.gates.max_rms_mm = *p.max_rms_mm;
  if (p.object) s.object = *p.object;
  return s;
}

struct VerifiedPart {
  std::string file;
  std::string gcode;  ///< "" : sliced by printtwin
  std::string report_dir;
  int exit_code = kPass;
  std::optional<Error> error;
  bool pass = false;
  double excess_mm = 0, deficit_mm = 0, rms_mm = 0;
  std::string problem;  ///< first failed gate or error finding
  std::string details;  ///< every failed gate and error finding
  double seconds = 0;
};

VerifiedPart verify_part(const ManifestPart& part, const VerifySettings& base,
                         const std::string& report_dir, const std::string& manifest_path) {
  const auto t0 = std::chrono::steady_clock::now();
  VerifiedPart out;
  out.file = part.file;
  out.gcode = part.settings.gcode.value_or("");
  out.report_dir = report_dir;
  auto fail = [&](Error e) {
    if (e.file.empty()) e.file = part.file;
    out.exit_code = e.code == ErrorCode::internal
                        ? kInternal
                        : (e.code == ErrorCode::usage ? kUsage : kBadInput);
    out.problem = e.describe();
    out.details = out.problem;
    out.error = std::move(e);
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  };
  std::error_code ec;
  if (!fs::exists(part.file, ec))
    return fail(bad_input("listed in " + manifest_path + " but not found", part.file));
  auto settings = part_settings(base, part.settings);
  if (!settings) return fail(settings.error());
  VerifyOptions options;
  options.mesh_path = part.file;
  options.gcode_path = out.gcode;
  options.settings = *settings;
  auto report = verify(options);
  if (!report) return fail(report.error());
  ReportOptions ro;
  ro.generated_utc = report_timestamp_utc();
  const VerifyReport& finished = *report;
  ro.extra_outputs = [&finished](const fs::path& staging) {
    return write_verify_outputs(finished, staging);
  };
  if (auto st = write_report_folder(*report, report_dir, ro); !st) return fail(st.error());
  out.pass = report->pass;
  out.exit_code = report->pass ? kPass : kFail;
  for (const auto& f : report->findings)
    if (f.severity == Severity::error) {
      if (out.problem.empty()) out.problem = f.code + ": " + f.message;
      out.details += "error " + f.code + ": " + f.message + "\n";
    }
  for (const auto& g : report->gates) {
    if (g.name == "max_excess") out.excess_mm = g.value;
    if (g.name == "max_deficit") out.deficit_mm = g.value;
    if (!g.pass) {
      const std::string line = "gate " + g.name + ": " + format_fixed(g.value, 3) +
                               " over the limit " + format_fixed(g.limit, 3);
      if (out.problem.empty()) out.problem = line;
      out.details += line + "\n";
    }
  }
  out.rms_mm =
      std::max(report->deviation.deposit_to_mesh.rms_mm, report->deviation.mesh_to_deposit.rms_mm);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

std::string summary(const std::vector<VerifiedPart>& parts, const std::string& manifest) {
  std::size_t ok = 0;
  for (const auto& p : parts) ok += p.pass ? 1 : 0;
  std::string md = "### printtwin verify: " + std::to_string(ok) + " of " +
                   std::to_string(parts.size()) + " parts pass (" + md_cell(manifest) + ")\n\n";
  md +=
      "| part | verdict | G-code | max excess (mm) | max deficit (mm) | RMS (mm) | report | first "
      "problem |\n";
  md += "|---|---|---|---:|---:|---:|---|---|\n";
  for (const auto& p : parts) {
    const std::string verdict =
        p.error ? (p.exit_code == kBadInput ? "UNREADABLE" : "ERROR") : (p.pass ? "PASS" : "FAIL");
    const bool measured = !p.error;
    std::string problem = p.problem.size() > 200 ? p.problem.substr(0, 197) + "..." : p.problem;
    md += "| " + md_cell(p.file) + " | " + (p.pass ? verdict : "**" + verdict + "**") + " | " +
          md_cell(p.gcode.empty() ? "(printtwin slice)" : p.gcode) + " | " +
          (measured ? format_fixed(p.excess_mm, 3) : "-") + " | " +
          (measured ? format_fixed(p.deficit_mm, 3) : "-") + " | " +
          (measured ? format_fixed(p.rms_mm, 3) : "-") + " | " +
          (measured ? md_cell(p.report_dir) : "-") + " | " + md_cell(problem) + " |\n";
  }
  return md;
}

}  // namespace

int run_verify_manifest(const VerifyBatchOptions& options, const VerifySettings& base) {
  if (auto st = check_output_paths({{options.out_dir, "--out", OutputKind::folder},
                                    {options.summary_out, "--summary", OutputKind::file},
                                    {options.junit_out, "--junit", OutputKind::file}});
      !st)
    return report_error(st.error());
  auto manifest = load_manifest(options.manifest);
  if (!manifest) return report_error(manifest.error());
  if (manifest->parts.empty()) return report_error(bad_input("lists no parts", manifest->path));
  const fs::path out_root =
      options.out_dir.empty() ? fs::path("reports") : fs::path(options.out_dir);
  std::vector<VerifiedPart> parts;
  std::vector<std::string> used;
  for (const auto& part : manifest->parts) {
    // One report folder per part, named by the part ("-2", "-3"... when names repeat).
    const std::string stem = fs::path(part.file).stem().string();
    std::string name = stem;
    for (int n = 2; std::find(used.begin(), used.end(), name) != used.end(); ++n)
      name = stem + "-" + std::to_string(n);
    used.push_back(name);
    parts.push_back(verify_part(part, base, (out_root / name).string(), manifest->path));
    if (!options.quiet)
      std::fprintf(stderr, "verified %s: %s\n", part.file.c_str(),
                   parts.back().error ? parts.back().problem.c_str()
                                      : (parts.back().pass ? "PASS" : "FAIL"));
  }
  const std::string md = summary(parts, manifest->path);
  if (!options.quiet) std::fputs(md.c_str(), stdout);
  std::vector<CaseOutcome> cases;
  int worst = kPass;
  for (const auto& p : parts) {
    worst = std::max(worst, p.exit_code);
    cases.push_back({p.file, p.seconds, p.pass, p.error ? "unreadable" : "fail",
                     std::string(p.error ? "UNREADABLE: " : "FAIL: ") + p.problem, p.details});
  }
  if (!options.summary_out.empty())
    if (auto st = write_file_atomic(options.summary_out, md); !st) return report_error(st.error());
  if (!options.junit_out.empty())
    if (auto st = write_file_atomic(options.junit_out,
                                    junit_xml("printtwin verify", "printtwin.verify", cases));
        !st)
      return report_error(st.error());
  return worst;
}

}  // namespace printtwin::cli

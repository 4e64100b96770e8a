// summary.md: a short verdict for CI job summaries ($GITHUB_STEP_SUMMARY, GitLab MR notes).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "report/report_internal.hpp"

namespace printtwin {

namespace {

using detail::fixed;
using detail::md_cell;
using detail::signed_fixed;

std::string gate_text(const GateResult& g, double v) {
  return detail::gate_is_count(g.name) ? fixed(v, 0) : fixed(v, 3) + " mm";
}

std::string stats_row(const std::string& name, const DeviationStats& s) {
  return "| " + name + " | " + signed_fixed(s.min_mm, 3) + " | " + signed_fixed(s.max_mm, 3) +
         " | " + fixed(s.rms_mm, 3) + " | " + fixed(s.p95_abs_mm, 3) + " | " +
         fixed(s.within_tolerance_pct, 1) + " % |\n";
}

}  // namespace

std::string report_summary_markdown(const VerifyReport& report, const ReportOptions& options) {
  const auto& dev = report.deviation;
  std::string md;
  md += std::string("### ") + (report.pass ? "✅" : "❌") +
        " printtwin verify: " + md_cell(report.part_name.empty() ? "part" : report.part_name) +
        " — " + (report.pass ? "PASS" : "FAIL") + "\n\n";
  md += detail::verdict_sentence(report) + "\n\n";

  md += "| Gate | Limit | Value | Result |\n|---|---:|---:|:---:|\n";
  for (const auto& g : report.gates)
    md += "| " + md_cell(detail::gate_label(g.name)) + " | " + gate_text(g, g.limit) + " | " +
          gate_text(g, g.value) + " | " + (g.pass ? "pass" : "**FAIL**") + " |\n";
  md += "\n";

  md += "| Deviation (mm) | min | max | RMS | P95 \\|d\\| | within ±" + fixed(dev.tolerance_mm, 2) +
        " |\n|---|---:|---:|---:|---:|---:|\n";
  md += stats_row("deposit → mesh", dev.deposit_to_mesh);
  md += stats_row("mesh → deposit", dev.mesh_to_deposit);
  md += "\n";

  const auto sev = detail::count_severities(report.findings);
  md += "Print time " + detail::duration_text(report.simulation.print_time_s) + " · filament " +
        fixed(report.simulation.filament_mm / 1000.0, 2) + " m · " +
        std::to_string(report.simulation.layers) + " layers · volume mesh " +
        fixed(dev.mesh_volume_mm3, 0) + " mm³ / deposit " + fixed(dev.deposit_volume_mm3, 0) +
        " mm³ · findings: " + std::to_string(sev.errors) + " errors, " +
        std::to_string(sev.warnings) + " warnings\n";

  if (!dev.regions.empty()) {
    std::vector<std::size_t> order(dev.regions.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return std::abs(dev.regions[a].worst_mm) > std::abs(dev.regions[b].worst_mm);
    });
    const std::size_t shown = std::min<std::size_t>(order.size(), 5);
    md +=
        "\n| Region | Kind | Worst | Layers | Where (mm) | G-code lines |\n"
        "|---:|---|---:|---|---|---|\n";
    for (std::size_t k = 0; k < shown; ++k) {
      const auto& r = dev.regions[order[k]];
      md += "| " + std::to_string(order[k] + 1) + " | " +
            std::string(detail::region_kind_name(r.kind)) + " | " + signed_fixed(r.worst_mm, 3) +
            " mm | " + detail::layer_range(r.layer_min, r.layer_max) + " | " +
            fixed(r.worst_position_mm.x(), 1) + ", " + fixed(r.worst_position_mm.y(), 1) + ", " +
            fixed(r.worst_position_mm.z(), 2) + " | " +
            md_cell(detail::line_list(r.gcode_lines, 4)) + " |\n";
    }
    if (order.size() > shown)
      md += "\n" + std::to_string(order.size() - shown) + " more regions in report.html.\n";
  }
  md += "\n<sub>printtwin " + md_cell(report.tool_version) +
        (options.generated_utc.empty() ? "" : " · " + options.generated_utc) +
        " · full report: report.html, junit.xml, report.json</sub>\n";
  return md;
}

}  // namespace printtwin

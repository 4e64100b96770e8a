// compare.md and compare.html: the table of variants and the chart of print time against
// deviation with the Pareto front. compare.html borrows report.html's stylesheet (so the two
// pages look alike) and stays self-contained: inline CSS, SVG and a few lines of JS.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "report/markup.hpp"

namespace printtwin {

namespace {

using detail::html_escape;

std::string fx(double v, int decimals) { return format_fixed(v, decimals); }

std::string settings_text(const VariantSpec& v) {
  if (v.kind == VariantKind::gcode) return v.gcode_path;
  std::string s;
  if (!v.config_path.empty()) s = v.config_path;
  for (const auto& [k, val] : v.settings) {
    if (!s.empty()) s += ' ';
    s.append(k).append("=").append(val);
  }
  return s.empty() ? std::string("defaults") : s;
}

int count_pass(const CompareResult& r) {
  return static_cast<int>(std::count_if(r.variants.begin(), r.variants.end(),
                                        [](const VariantResult& v) { return v.ran && v.pass; }));
}
int count_ran(const CompareResult& r) {
  return static_cast<int>(std::count_if(r.variants.begin(), r.variants.end(),
                                        [](const VariantResult& v) { return v.ran; }));
}

std::string md_cell(std::string_view s) { return detail::md_cell(s); }

std::string verdict_of(const VariantResult& v) {
  if (!v.ran) return "error";
  return v.pass ? "pass" : "fail";
}

// Readable tick step for a range: 1, 2, 2.5 or 5 times a power of ten.
double nice_step(double range, int target_ticks) {
  if (!(range > 0)) return 1;
  const double raw = range / target_ticks;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10 * p;
}

// Fewest decimals that write every multiple of `step` exactly (0.0025 needs 4).
int decimals_for(double step) {
  for (int d = 0; d < 8; ++d) {
    const double scaled = step * std::pow(10.0, d);
    if (std::abs(scaled - std::round(scaled)) < 1e-6 * std::max(1.0, scaled)) return d;
  }
  return 8;
}

struct Axis {
  double lo = 0, hi = 1, step = 1;
};

// Axis over [min, max] of the data: from 0 when the data start near 0 (the usual case for
// deviations), else padded around the data; bounds on whole steps.
Axis make_axis(double min_v, double max_v) {
  Axis a;
  if (!std::isfinite(min_v) || !std::isfinite(max_v)) return a;
  double lo = min_v, hi = max_v;
  if (hi - lo < 1e-12) {
    const double pad = std::max(std::abs(hi) * 0.1, 1e-3);
    lo -= pad;
    hi += pad;
  } else {
    const double pad = 0.08 * (hi - lo);
    lo -= pad;
    hi += pad;
  }
  if (min_v >= 0 && lo < 0.5 * max_v) lo = 0;
  if (lo < 0 && min_v >= 0) lo = 0;
  a.step = nice_step(hi - lo, 5);
  a.lo = std::floor(lo / a.step) * a.step;
  a.hi = std::ceil(hi / a.step) * a.step;
  if (a.hi <= a.lo) a.hi = a.lo + a.step;
  return a;
}

constexpr const char* kCompareCss = R"CSS(
.compare-table{font-size:12.5px}
.compare-table thead th{font-size:11px;text-transform:uppercase;letter-spacing:.35px;color:var(--ink3);
border-bottom:1px solid var(--line);white-space:nowrap;cursor:pointer;user-select:none;vertical-align:bottom}
.compare-table thead th.grp{cursor:default;text-align:center;border-bottom:1px solid var(--line)}
.compare-table thead th[data-sort]:hover{color:var(--accent)}
.compare-table td{border-bottom:1px solid #f0f2f6;white-space:nowrap}
.compare-table td.label{white-space:normal;min-width:160px}
.compare-table tr.pareto td{background:#f4f7ff}
.compare-table tr.pareto td:first-child{box-shadow:inset 3px 0 0 var(--accent)}
.star{color:var(--accent);font-weight:700}
.chart .pt-pass{fill:var(--ok)}.chart .pt-fail{fill:var(--bad)}
.chart .pt{stroke:#fff;stroke-width:1.5}
.chart .ring{fill:none;stroke:var(--accent);stroke-width:2}
.chart .front{fill:none;stroke:var(--accent);stroke-width:1.6;stroke-dasharray:5 3}
.chart .ptlab{font-size:11px;fill:var(--ink2)}
.chart .ptlab-front{fill:var(--accent);font-weight:650}
.chart-key .k-front::before{background:repeating-linear-gradient(90deg,var(--accent) 0 5px,transparent 5px 8px)}
.chart-key .k-pass::before{background:var(--ok);height:10px;width:10px;border-radius:5px}
.chart-key .k-fail::before{background:var(--bad);height:10px;width:10px;border-radius:5px}
details.variant{border:1px solid var(--line);border-radius:8px;margin:0 0 8px;padding:0 12px;background:#fff}
details.variant summary{cursor:pointer;padding:9px 0;font-weight:600;display:flex;gap:10px;align-items:center}
details.variant[open] summary{border-bottom:1px solid var(--line);margin-bottom:8px}
details.variant .kv-grid{margin-bottom:8px}
.err{color:var(--bad)}
)CSS";

constexpr const char* kCompareJs = R"JS(
(function(){
  var t=document.getElementById('variants');if(!t)return;
  var heads=t.querySelectorAll('thead th[data-sort]');
  heads.forEach(function(th){th.addEventListener('click',function(){
    var col=+th.getAttribute('data-col'),asc=th.getAttribute('data-dir')!=='asc';
    heads.forEach(function(h){h.removeAttribute('data-dir');});
    th.setAttribute('data-dir',asc?'asc':'desc');
    var body=t.tBodies[0],rows=Array.prototype.slice.call(body.rows);
    rows.sort(function(a,b){
      var x=a.cells[col].getAttribute('data-v'),y=b.cells[col].getAttribute('data-v');
      var nx=parseFloat(x),ny=parseFloat(y),r;
      if(!isNaN(nx)&&!isNaN(ny))r=nx-ny;else r=String(x).localeCompare(String(y));
      return asc?r:-r;});
    rows.forEach(function(r){body.appendChild(r);});
  });});
})();
)JS";

}  // namespace

// ---------------------------------------------------------------- Markdown

std::string compare_markdown(const CompareResult& r) {
  std::ostringstream md;
  md << "# printtwin compare: " << r.part.name << "\n\n";
  const int ran = count_ran(r), pass = count_pass(r);
  md << "**" << r.variants.size() << " variant" << (r.variants.size() == 1 ? "" : "s") << "**";
  if (r.shard)
    md << " (share " << r.shard->first << " of " << r.shard->second << ", " << r.variant_count
       << " in the sweep)";
  md << ": " << ran << " ran, " << pass << " pass";
  if (ran < static_cast<int>(r.variants.size()))
    md << ", " << (static_cast<int>(r.variants.size()) - ran) << " could not run";
  md << ". Tolerance ±" << fx(r.verify.gates.tolerance_mm, 3) << " mm, voxel "
     << fx(r.verify.voxel_mm, 3) << " mm, printer " << r.printer << ".\n\n";

  std::vector<std::string> front;
  for (const auto& v : r.variants)
    if (v.pareto) front.push_back(v.variant.label);
  if (!front.empty()) {
    md << "Pareto-optimal (print time vs deviation RMS): ";
    for (std::size_t i = 0; i < front.size(); ++i)
      md << (i ? ", " : "") << "**" << md_cell(front[i]) << "**";
    md << ".\n\n";
  }

  md << "| # | Variant | Print time | Filament | RMS | RMS slopes | Dep→mesh RMS / P95 | Max excess"
        " | Mesh→dep RMS / P95 | Max deficit | Regions miss/exc | Findings E/W/I | Result | Pareto "
        "|\n";
  md << "|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|:-:|:-:|\n";
  for (const auto& v : r.variants) {
    md << "| " << v.variant.index << " | " << md_cell(v.variant.label) << " | ";
    if (!v.ran) {
      md << "— | — | — | — | — | — | — | — | — | — | **error** | |\n";
      continue;
    }
    const double max_excess =
        std::max(v.deposit_to_mesh.max_excess_mm, v.mesh_to_deposit.max_excess_mm);
    const double max_deficit =
        std::max(v.deposit_to_mesh.max_deficit_mm, v.mesh_to_deposit.max_deficit_mm);
    md << format_duration(v.print_time_s) << " | " << fx(v.filament_m, 2) << " m / "
       << fx(v.filament_g, 1) << " g | " << fx(v.rms_mm, 3) << " | " << fx(v.slope_rms_mm, 3)
       << " | " << fx(v.deposit_to_mesh.rms_mm, 3) << " / " << fx(v.deposit_to_mesh.p95_mm, 3)
       << " | +" << fx(max_excess, 3) << " | " << fx(v.mesh_to_deposit.rms_mm, 3) << " / "
       << fx(v.mesh_to_deposit.p95_mm, 3) << " | −" << fx(max_deficit, 3) << " | "
       << v.missing_regions << " / " << v.excess_regions << " | " << v.error_findings << " / "
       << v.warning_findings << " / " << v.info_findings << " | " << (v.pass ? "pass" : "**fail**")
       << " | " << (v.pareto ? "★" : "") << " |\n";
  }
  md << "\nDeviations in mm; RMS = sqrt((RMS deposit→mesh² + RMS mesh→deposit²) / 2); "
        "\"slopes\": samples on surfaces between "
     << fx(kSlopeMinDeg, 0) << "° and " << fx(kSlopeMaxDeg, 0) << "° from horizontal.\n";
  bool any_error = false;
  for (const auto& v : r.variants) {
    if (v.ran) continue;
    if (!any_error) md << "\n**Variants that could not run**\n\n";
    any_error = true;
    md << "- " << v.variant.index << " " << md_cell(v.variant.label) << ": " << md_cell(v.error)
       << "\n";
  }
  // External slicers: how to make each variant's G-code again by hand.
  bool any_command = false;
  for (const auto& v : r.variants) {
    if (v.command.empty()) continue;
    if (!any_command) md << "\n**Slicer commands** (re-run a variant's G-code by hand)\n\n";
    any_command = true;
    md << "- " << v.variant.index << " " << md_cell(v.variant.label) << " (" << md_cell(v.slicer)
       << "): `" << v.command << "`\n";
  }
  return md.str();
}

// ---------------------------------------------------------------- chart

std::string compare_chart_svg(const CompareResult& r) {
  constexpr double kW = 760, kH = 380, kL = 70, kR = 24, kT = 18, kB = 48;
  std::vector<const VariantResult*> pts;
  for (const auto& v : r.variants)
    if (v.ran && std::isfinite(v.print_time_s) && std::isfinite(v.rms_mm)) pts.push_back(&v);
  std::ostringstream s;
  s << "<svg class=\"chart\" id=\"tradeoff\" viewBox=\"0 0 " << kW << " " << kH
    << "\" role=\"img\" aria-label=\"Print time against deviation RMS\">";
  if (pts.empty()) {
    s << "<text class=\"note\" x=\"" << kW / 2 << "\" y=\"" << kH / 2
      << "\" text-anchor=\"middle\">No variant ran.</text></svg>";
    return s.str();
  }
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto* v : pts) {
    x0 = std::min(x0, v->print_time_s / 60);
    x1 = std::max(x1, v->print_time_s / 60);
    y0 = std::min(y0, v->rms_mm);
    y1 = std::max(y1, v->rms_mm);
  }
  const Axis ax = make_axis(x0, x1), ay = make_axis(y0, y1);
  auto X = [&](double minutes) {
    return kL + (minutes - ax.lo) / (ax.hi - ax.lo) * (kW - kL - kR);
  };
  auto Y = [&](double mm) { return kT + (ay.hi - mm) / (ay.hi - ay.lo) * (kH - kT - kB); };
  const int xd = decimals_for(ax.step), yd = decimals_for(ay.step);
  // Grid and tick labels.
  for (double t = ay.lo; t <= ay.hi + ay.step * 1e-6; t += ay.step) {
    s << "<line class=\"grid\" x1=\"" << fx(kL, 1) << "\" x2=\"" << fx(kW - kR, 1) << "\" y1=\""
      << fx(Y(t), 1) << "\" y2=\"" << fx(Y(t), 1) << "\"/><text class=\"ylab\" x=\""
      << fx(kL - 6, 1) << "\" y=\"" << fx(Y(t) + 4, 1) << "\">" << fx(t, yd) << "</text>";
  }
  for (double t = ax.lo; t <= ax.hi + ax.step * 1e-6; t += ax.step) {
    s << "<line class=\"grid\" y1=\"" << fx(kT, 1) << "\" y2=\"" << fx(kH - kB, 1) << "\" x1=\""
      << fx(X(t), 1) << "\" x2=\"" << fx(X(t), 1) << "\"/><text class=\"xlab\" y=\""
      << fx(kH - kB + 16, 1) << "\" x=\"" << fx(X(t), 1) << "\">" << fx(t, xd) << "</text>";
  }
  s << "<line class=\"axis\" x1=\"" << kL << "\" x2=\"" << kL << "\" y1=\"" << kT << "\" y2=\""
    << kH - kB << "\"/><line class=\"axis\" x1=\"" << kL << "\" x2=\"" << kW - kR << "\" y1=\""
    << kH - kB << "\" y2=\"" << kH - kB << "\"/>";
  s << "<text class=\"xlab\" x=\"" << fx(kL + (kW - kL - kR) / 2, 1) << "\" y=\"" << kH - 8
    << "\">print time (min) →</text>";
  s << "<text class=\"ylab\" transform=\"translate(16," << fx(kT + (kH - kT - kB) / 2, 1)
    << ") rotate(-90)\" text-anchor=\"middle\" style=\"text-anchor:middle\">deviation RMS (mm) "
       "→</text>";
  // The front: Pareto points by increasing time, drawn as a staircase (the region it bounds
  // is what no variant reaches).
  std::vector<const VariantResult*> front;
  for (const auto* v : pts)
    if (v->pareto) front.push_back(v);
  std::stable_sort(front.begin(), front.end(), [](const VariantResult* a, const VariantResult* b) {
    return a->print_time_s < b->print_time_s;
  });
  if (front.size() > 1) {
    s << "<polyline class=\"front\" points=\"";
    for (std::size_t i = 0; i < front.size(); ++i) {
      const double x = X(front[i]->print_time_s / 60), y = Y(front[i]->rms_mm);
      if (i > 0) s << fx(x, 1) << "," << fx(Y(front[i - 1]->rms_mm), 1) << " ";
      s << fx(x, 1) << "," << fx(y, 1) << " ";
    }
    s << "\"/>";
  }
  // Points, rings on the front, labels.
  for (const auto* v : pts) {
    const double x = X(v->print_time_s / 60), y = Y(v->rms_mm);
    s << "<g><title>" << html_escape(v->variant.label) << "\n"
      << format_duration(v->print_time_s) << ", RMS " << fx(v->rms_mm, 3) << " mm"
      << (v->pass ? "" : ", fails its gates") << (v->pareto ? ", Pareto-optimal" : "")
      << "</title>";
    if (v->pareto)
      s << "<circle class=\"ring\" cx=\"" << fx(x, 1) << "\" cy=\"" << fx(y, 1) << "\" r=\"9\"/>";
    s << "<circle class=\"pt " << (v->pass ? "pt-pass" : "pt-fail") << "\" cx=\"" << fx(x, 1)
      << "\" cy=\"" << fx(y, 1) << "\" r=\"5.5\"/>";
    std::string label = "#" + std::to_string(v->variant.index);
    if (pts.size() <= 12 || v->pareto) {
      std::string l = v->variant.label;
      if (l.size() > 34) l = l.substr(0, 33) + "…";
      label += " " + l;
    }
    const bool left = x > kW - 230;
    s << "<text class=\"ptlab" << (v->pareto ? " ptlab-front" : "") << "\" x=\""
      << fx(left ? x - 12 : x + 12, 1) << "\" y=\"" << fx(y - 8, 1) << "\""
      << (left ? " text-anchor=\"end\"" : "") << ">" << html_escape(label) << "</text></g>";
  }
  s << "</svg>";
  return s.str();
}

// ---------------------------------------------------------------- HTML

std::string compare_html(const CompareResult& r, const CompareHtmlOptions& options) {
  std::ostringstream h;
  const int ran = count_ran(r), pass = count_pass(r);
  const bool all_pass = ran == static_cast<int>(r.variants.size()) && pass == ran && ran > 0;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
       "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
       "<title>printtwin compare · "
    << html_escape(r.part.name) << "</title><style>" << detail::report_css() << kCompareCss
    << "</style></head><body>";
  h << "<header class=\"top\"><div class=\"wrap\"><div class=\"brand\">"
       "<svg class=\"logo\" viewBox=\"0 0 20 20\"><path d=\"M10 1.5 18 6v8l-8 4.5L2 14V6z\"/></svg>"
       "printtwin <span>compare</span></div><div class=\"top-meta\"><span>"
    << html_escape(r.part.name) << "</span><span>" << r.variants.size() << " variants</span><span>"
    << html_escape(r.printer) << "</span>";
  if (!options.generated_utc.empty())
    h << "<span>" << html_escape(options.generated_utc) << "</span>";
  h << "</div></div></header><main class=\"wrap\">";

  // Verdict strip.
  std::vector<const VariantResult*> front;
  for (const auto& v : r.variants)
    if (v.pareto) front.push_back(&v);
  h << "<section class=\"verdict" << (all_pass ? "" : " is-fail") << "\"><div class=\"badge\">"
    << pass << " / " << r.variants.size() << "</div><div class=\"verdict-text\"><h1>"
    << html_escape(r.part.name) << ": " << r.variants.size() << " variant"
    << (r.variants.size() == 1 ? "" : "s") << " side by side</h1><p>" << ran << " ran, " << pass
    << " pass their gates (tolerance ±" << fx(r.verify.gates.tolerance_mm, 3) << " mm, voxel "
    << fx(r.verify.voxel_mm, 3) << " mm).";
  if (r.shard)
    h << " This is share " << r.shard->first << " of " << r.shard->second << " of a "
      << r.variant_count << "-variant sweep.";
  h << "</p><p>Pareto-optimal on print time and deviation RMS: ";
  if (front.empty()) h << "none";
  for (std::size_t i = 0; i < front.size(); ++i)
    h << (i ? ", " : "") << "<b>#" << front[i]->variant.index << " "
      << html_escape(front[i]->variant.label) << "</b>";
  h << ".</p></div><table class=\"kv\"><tbody><tr><th>Part</th><td class=\"mono\">"
    << html_escape(r.part.path) << "</td></tr><tr><th>SHA-256</th><td class=\"mono hash\">"
    << html_escape(r.part.sha256) << "</td></tr><tr><th>Size</th><td>";
  if (!r.part.bbox_mm.empty()) {
    const Vec3 sz = r.part.bbox_mm.size();
    h << fx(sz.x(), 1) << " × " << fx(sz.y(), 1) << " × " << fx(sz.z(), 1) << " mm, ";
  }
  h << r.part.triangles << " triangles</td></tr><tr><th>Sloped area</th><td>"
    << fx(r.part.sloped_area_mm2, 0) << " of " << fx(r.part.area_mm2, 0)
    << " mm²</td></tr></tbody></table></section>";

  // Chart.
  h << "<section class=\"panel\"><div class=\"panel-head\"><h2>Print time against deviation</h2>"
       "<p>Each point is a variant; lower and further left is better. Ringed points joined by the "
       "dashed staircase are Pareto-optimal: no other variant is both faster and closer to the "
       "design. Hover a point for its numbers.</p></div>"
    << compare_chart_svg(r)
    << "<div class=\"chart-key\"><span class=\"k-pass\">passes its gates</span><span "
       "class=\"k-fail\">fails</span><span class=\"k-front\">Pareto front</span></div></section>";

  // Table.
  h << "<section class=\"panel\"><div class=\"panel-head\"><h2>Variants</h2><p>Click a column to "
       "sort. Deviations in mm; RMS combines both directions as sqrt((RMS<sub>d→m</sub>² + "
       "RMS<sub>m→d</sub>²)/2); “slopes” counts only samples on surfaces between "
    << fx(kSlopeMinDeg, 0) << "° and " << fx(kSlopeMaxDeg, 0)
    << "° from horizontal, where layer steps show.</p></div><div class=\"scroll\">"
       "<table class=\"compare-table\" id=\"variants\"><thead><tr>";
  const char* heads[] = {"#",           "Variant",    "Time",       "Filament m",
                         "Filament g",  "RMS",        "RMS slopes", "D→M RMS",
                         "D→M P95",     "Max excess", "M→D RMS",    "M→D P95",
                         "Max deficit", "Regions",    "Findings",   "Result"};
  for (int c = 0; c < static_cast<int>(std::size(heads)); ++c)
    h << "<th data-sort data-col=\"" << c << "\"" << (c >= 2 && c <= 14 ? " class=\"num\"" : "")
      << ">" << heads[c] << "</th>";
  h << "</tr></thead><tbody>";
  for (const auto& v : r.variants) {
    h << "<tr" << (v.pareto ? " class=\"pareto\"" : "") << "><td data-v=\"" << v.variant.index
      << "\">" << v.variant.index
      << (v.pareto ? " <span class=\"star\" title=\"Pareto-optimal\">★</span>" : "")
      << "</td><td class=\"label\" data-v=\"" << html_escape(v.variant.label) << "\"><a href=\"#v"
      << v.variant.index << "\">" << html_escape(v.variant.label) << "</a></td>";
    if (!v.ran) {
      for (int c = 2; c < 15; ++c) h << "<td class=\"num\" data-v=\"\">—</td>";
      h << "<td data-v=\"error\"><span class=\"chip chip-error\">error</span></td></tr>";
      continue;
    }
    const double max_excess =
        std::max(v.deposit_to_mesh.max_excess_mm, v.mesh_to_deposit.max_excess_mm);
    const double max_deficit =
        std::max(v.deposit_to_mesh.max_deficit_mm, v.mesh_to_deposit.max_deficit_mm);
    auto num = [&](double value, const std::string& text) {
      h << "<td class=\"num\" data-v=\"" << format_number(value) << "\">" << text << "</td>";
    };
    num(v.print_time_s, format_duration(v.print_time_s));
    num(v.filament_m, fx(v.filament_m, 2));
    num(v.filament_g, fx(v.filament_g, 1));
    num(v.rms_mm, "<b>" + fx(v.rms_mm, 3) + "</b>");
    num(v.slope_rms_mm, fx(v.slope_rms_mm, 3));
    num(v.deposit_to_mesh.rms_mm, fx(v.deposit_to_mesh.rms_mm, 3));
    num(v.deposit_to_mesh.p95_mm, fx(v.deposit_to_mesh.p95_mm, 3));
    num(max_excess, "+" + fx(max_excess, 3));
    num(v.mesh_to_deposit.rms_mm, fx(v.mesh_to_deposit.rms_mm, 3));
    num(v.mesh_to_deposit.p95_mm, fx(v.mesh_to_deposit.p95_mm, 3));
    num(max_deficit, "−" + fx(max_deficit, 3));
    num(v.missing_regions + v.excess_regions,
        std::to_string(v.missing_regions) + " miss / " + std::to_string(v.excess_regions) + " exc");
    num(v.error_findings * 1e6 + v.warning_findings * 1e3 + v.info_findings,
        std::to_string(v.error_findings) + " / " + std::to_string(v.warning_findings) + " / " +
            std::to_string(v.info_findings));
    h << "<td data-v=\"" << (v.pass ? "pass" : "fail") << "\"><span class=\"chip "
      << (v.pass ? "chip-ok" : "chip-bad") << "\">" << (v.pass ? "pass" : "fail")
      << "</span></td></tr>";
  }
  h << "</tbody></table></div><p class=\"fine\">Regions: clusters of out-of-tolerance samples "
       "(missing / excess). Findings: error / warning / info of every stage.</p></section>";

  // One summary per variant.
  h << "<section class=\"panel\"><div class=\"panel-head\"><h2>Each variant</h2><p>The settings "
       "it ran with, its gates and largest regions; the full verify report (heatmaps, layer "
       "viewer) is linked where it was written.</p></div>";
  for (const auto& v : r.variants) {
    h << "<details class=\"variant\" id=\"v" << v.variant.index << "\"><summary><span class=\"rnum "
      << (v.ran && v.pass ? "\" style=\"background:var(--ok)" : "\" style=\"background:var(--bad)")
      << "\">" << v.variant.index << "</span>" << html_escape(v.variant.label)
      << " <span class=\"chip " << (v.ran ? (v.pass ? "chip-ok" : "chip-bad") : "chip-error")
      << "\">" << verdict_of(v) << "</span>"
      << (v.pareto ? "<span class=\"star\">★ Pareto</span>" : "") << "</summary>";
    h << "<div class=\"kv-grid\"><table class=\"kv\"><tbody><tr><th>Source</th><td>"
      << (v.variant.kind == VariantKind::gcode ? std::string("G-code file")
          : v.variant.slicer == "printtwin"    ? std::string("printtwin slice")
                                               : v.variant.slicer + " slice")
      << "</td></tr><tr><th>Settings</th><td class=\"mono\">"
      << html_escape(settings_text(v.variant)) << "</td></tr>";
    if (!v.command.empty())
      h << "<tr><th>Command</th><td class=\"mono\">" << html_escape(v.command) << "</td></tr>";
    if (v.ran) {
      h << "<tr><th>Slicer</th><td>" << html_escape(v.slicer) << "</td></tr><tr><th>Layers</th><td>"
        << v.layers << " (" << fx(v.layer_height_mm, 3)
        << " mm)</td></tr><tr><th>Print time</th><td>" << format_duration(v.print_time_s)
        << "</td></tr><tr><th>Filament</th><td>" << fx(v.filament_m, 2) << " m, "
        << fx(v.filament_g, 1) << " g at " << fx(v.filament_density_g_cm3, 2) << " g/cm³</td></tr>";
    }
    if (!v.report_dir.empty())
      h << "<tr><th>Report</th><td><a href=\"" << html_escape(v.report_dir) << "/report.html\">"
        << html_escape(v.report_dir) << "/report.html</a></td></tr>";
    h << "</tbody></table>";
    if (!v.ran) {
      h << "<p class=\"err\">Could not run: " << html_escape(v.error) << "</p></div></details>";
      continue;
    }
    h << "<table class=\"gates\"><thead><tr><th>Gate</th><th class=\"num\">Limit</th><th "
         "class=\"num\">Value</th><th></th></tr></thead><tbody>";
    for (const auto& g : v.gates) {
      const bool count = detail::gate_is_count(g.name);
      h << "<tr" << (g.pass ? "" : " class=\"bad\"") << "><td>"
        << html_escape(detail::gate_label(g.name)) << "</td><td class=\"num\">"
        << (count ? fx(g.limit, 0) : fx(g.limit, 3) + " mm") << "</td><td class=\"num\">"
        << (count ? fx(g.value, 0) : fx(g.value, 3) + " mm") << "</td><td><span class=\"chip "
        << (g.pass ? "chip-ok" : "chip-bad") << "\">" << (g.pass ? "pass" : "fail")
        << "</span></td></tr>";
    }
    h << "</tbody></table></div>";
    h << "<table class=\"stats\"><thead><tr><th>Direction</th><th>RMS</th><th>P95</th><th>Max "
         "excess</th><th>Max deficit</th><th>Within tol.</th><th>RMS slopes</th><th>Samples</th>"
         "</tr></thead><tbody>";
    auto dir_row = [&](const char* name, const DirectionFigures& d) {
      h << "<tr><th>" << name << "</th><td>" << fx(d.rms_mm, 3) << "</td><td>" << fx(d.p95_mm, 3)
        << "</td><td>+" << fx(d.max_excess_mm, 3) << "</td><td>−" << fx(d.max_deficit_mm, 3)
        << "</td><td>" << fx(d.within_tolerance_pct, 1) << " %</td><td>" << fx(d.slope_rms_mm, 3)
        << "</td><td>" << d.samples << "</td></tr>";
    };
    dir_row("Deposit → mesh", v.deposit_to_mesh);
    dir_row("Mesh → deposit", v.mesh_to_deposit);
    h << "</tbody></table>";
    if (!v.top_regions.empty()) {
      h << "<h3>Largest regions <small>" << v.missing_regions << " missing, " << v.excess_regions
        << " excess</small></h3><table class=\"list\"><thead><tr><th>Kind</th><th "
           "class=\"num\">Worst</th><th class=\"num\">Area</th><th>Layers</th><th>At (mm)</th>"
           "</tr></thead><tbody>";
      for (const auto& b : v.top_regions) {
        h << "<tr><td><span class=\"chip chip-" << html_escape(b.kind) << "\">"
          << html_escape(b.kind) << "</span></td><td class=\"num\">"
          << detail::signed_fixed(b.worst_mm, 3) << " mm</td><td class=\"num\">"
          << fx(b.area_mm2, 2) << " mm²</td><td>" << detail::layer_range(b.layer_min, b.layer_max)
          << "</td><td class=\"mono\">" << fx(b.worst_position_mm.x(), 1) << ", "
          << fx(b.worst_position_mm.y(), 1) << ", " << fx(b.worst_position_mm.z(), 1)
          << "</td></tr>";
      }
      h << "</tbody></table>";
    }
    h << "</details>";
  }
  h << "</section></main><footer class=\"wrap\">printtwin " << html_escape(r.tool_version)
    << " · compare.json schema " << r.schema_version << " · plan "
    << html_escape(r.plan_id.substr(0, 12));
  if (!options.generated_utc.empty()) h << " · generated " << html_escape(options.generated_utc);
  h << "</footer><script>" << kCompareJs << "</script></body></html>\n";
  return h.str();
}

Status write_compare_outputs(const CompareResult& result, const std::filesystem::path& out_dir,
                             const CompareHtmlOptions& options) {
  if (auto s = write_file_atomic(out_dir / "compare.json", compare_json(result)); !s) return s;
  if (auto s = write_file_atomic(out_dir / "compare.md", compare_markdown(result)); !s) return s;
  return write_file_atomic(out_dir / "compare.html", compare_html(result, options));
}

}  // namespace printtwin

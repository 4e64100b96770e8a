// report.html: one self-contained page (inline CSS, JS, SVG charts and PNG images as data:
// URIs). No external URL is referenced, so it opens offline, from a CI artifact, with no
// server. Layout and behaviour: docs/reports.md.
#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "report/report_internal.hpp"

namespace printtwin {

namespace {

using detail::fixed;
using detail::html_escape;
using detail::signed_fixed;

std::string rgb_css(const std::array<std::uint8_t, 3>& c) {
  return "rgb(" + std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]) +
         ")";
}

// CSS gradient of the colour scale over [-range, +range], hard edges at +-tolerance.
std::string scale_gradient(const DeviationColorScale& s) {
  const double r = s.range_mm, t = s.tolerance_mm;
  std::string g = "linear-gradient(90deg";
  auto stop = [&](double d, double at) {
    g += "," + rgb_css(s.color(d)) + " " + fixed(100.0 * (at + r) / (2 * r), 2) + "%";
  };
  const int n = 12;
  for (int i = 0; i <= n; ++i)
    stop(-r + (r - t) * i / n, -r + (r - t) * i / n - (i == n ? 1e-9 : 0));
  for (int i = 0; i <= n; ++i) {
    const double d = -t + 2 * t * i / n;
    stop(std::clamp(d, -t, t), d);
  }
  for (int i = 0; i <= n; ++i) {
    const double d = t + (r - t) * i / n;
    stop(i == 0 ? d + 1e-9 : d, d);
  }
  return g + ")";
}

std::string legend_html(const DeviationColorScale& s) {
  const double r = s.range_mm, t = s.tolerance_mm;
  auto pos = [&](double d) { return fixed(100.0 * (d + r) / (2 * r), 2); };
  auto lab = [](double v) {
    std::string x = signed_fixed(v, 2);
    return x == "0.00" ? std::string("0") : x;
  };
  std::string h =
      "<div class=\"legend\"><div class=\"legend-bar\" style=\"background:" + scale_gradient(s) +
      "\"></div><div class=\"legend-ticks\">";
  h += "<span style=\"left:0%\">≤ " + lab(-r) + "</span>";
  h += "<span style=\"left:" + pos(-t) + "%\">" + lab(-t) + "</span>";
  h += "<span style=\"left:50%\">0</span>";
  h += "<span style=\"left:" + pos(t) + "%\">" + lab(t) + "</span>";
  h += "<span style=\"left:100%\">≥ " + lab(r) + " mm</span>";
  h += "</div><div class=\"legend-names\"><span>deficit (material missing)</span><span>within ±" +
       fixed(t, 2) + " mm</span><span>excess (extra material)</span></div></div>";
  return h;
}

struct Card {
  std::string label, value, unit, sub, cls;
};

std::string card_html(const Card& c) {
  return "<div class=\"card " + c.cls + "\"><div class=\"card-label\">" + c.label +
         "</div><div class=\"card-value\">" + c.value + "<span class=\"unit\">" + c.unit +
         "</span></div><div class=\"card-sub\">" + c.sub + "</div></div>";
}

std::string stat_cells(const DeviationStats& s) {
  std::string h;
  for (const std::string& v :
       {signed_fixed(s.min_mm, 3), signed_fixed(s.max_mm, 3), signed_fixed(s.mean_mm, 3),
        fixed(s.rms_mm, 3), fixed(s.std_mm, 3), fixed(s.p50_abs_mm, 3), fixed(s.p95_abs_mm, 3),
        fixed(s.p99_abs_mm, 3), fixed(s.hausdorff_mm, 3), fixed(s.within_tolerance_pct, 2) + " %",
        std::to_string(s.samples)})
    h += "<td>" + v + "</td>";
  return h;
}

std::string kv_row(const std::string& k, const std::string& v);

/// Every value of the printer the run used, with its source (file setting, library
/// profile, config file or default): the same list as report.json's "printer".
std::string printer_values_html(const PrinterProfile& printer) {
  const auto doc = nlohmann::json::parse(printer_provenance_json(printer));
  std::string h = "<div><h3>Printer</h3><p>" + html_escape(doc.value("summary", std::string())) +
                  "</p><details><summary>every value and its source</summary><table class=\"kv\">";
  for (const auto& [key, v] : doc.at("values").items()) {
    std::string source = v.value("source", std::string());
    if (v.contains("key"))
      source += ": " + v.at("key").get<std::string>();
    else if (v.contains("profile"))
      source += ": " + v.at("profile").get<std::string>();
    else if (v.contains("file"))
      source += ": " + v.at("file").get<std::string>();
    h += kv_row(key, html_escape(v.at("value").dump()) + " · " + html_escape(source));
  }
  return h + "</table></details></div>";
}

std::string kv_row(const std::string& k, const std::string& v) {
  return "<tr><th>" + html_escape(k) + "</th><td>" + v + "</td></tr>";
}

std::string box_text(const Box3& b, int decimals) {
  if (b.empty()) return "—";
  return "(" + fixed(b.min.x(), decimals) + ", " + fixed(b.min.y(), decimals) + ", " +
         fixed(b.min.z(), decimals) + ") – (" + fixed(b.max.x(), decimals) + ", " +
         fixed(b.max.y(), decimals) + ", " + fixed(b.max.z(), decimals) + ")";
}

std::string vec_text(const Vec3& v, int decimals) {
  return fixed(v.x(), decimals) + ", " + fixed(v.y(), decimals) + ", " + fixed(v.z(), decimals);
}

std::string gate_value_text(const GateResult& g, double v) {
  return detail::gate_is_count(g.name) ? fixed(v, 0) : fixed(v, 3) + " mm";
}

std::string size_text(std::uint64_t bytes) {
  if (bytes < 1024) return std::to_string(bytes) + " B";
  if (bytes < 1024 * 1024) return fixed(static_cast<double>(bytes) / 1024.0, 1) + " KiB";
  return fixed(static_cast<double>(bytes) / (1024.0 * 1024.0), 2) + " MiB";
}

std::string views_html(const VerifyReport& report, const ReportAssets& assets) {
  std::string h = "<div class=\"views\">";
  for (std::size_t v = 0; v < assets.views.size(); ++v) {
    const HeatmapView& hv = assets.views[v];
    const int w = hv.image.width, ht = hv.image.height;
    h += "<figure class=\"view" + std::string(v == 0 ? " view-main" : "") +
         "\"><div class=\"view-img\">";
    h += "<img alt=\"" + html_escape(hv.view.label) + " heatmap\" width=\"" + std::to_string(w) +
         "\" height=\"" + std::to_string(ht) + "\" src=\"data:image/png;base64," +
         detail::base64(assets.view_png[v]) + "\">";
    h +=
        "<svg class=\"pins\" viewBox=\"0 0 " + std::to_string(w) + " " + std::to_string(ht) + "\">";
    const double pin_r = v == 0 ? 9 : 7.5;
    // Pins for the largest regions that this side shows (regions come largest first); the
    // table lists them all.
    constexpr std::size_t kMaxPins = 12;
    for (std::size_t r = std::min(hv.markers.size(), kMaxPins); r-- > 0;) {  // region 1 on top
      const RegionMarker& m = hv.markers[r];
      if (!m.visible) continue;
      const DeviationRegion& reg = report.deviation.regions[r];
      const std::string cls = reg.kind == RegionKind::missing ? "pin-missing" : "pin-excess";
      const double bx = std::clamp(m.bbox_min_px.x(), 0.0, static_cast<double>(w)),
                   by = std::clamp(m.bbox_min_px.y(), 0.0, static_cast<double>(ht));
      const double bw = std::clamp(m.bbox_max_px.x(), 0.0, static_cast<double>(w)) - bx,
                   bh = std::clamp(m.bbox_max_px.y(), 0.0, static_cast<double>(ht)) - by;
      const double px = std::clamp(m.worst_px.x(), pin_r, w - pin_r),
                   py = std::clamp(m.worst_px.y(), pin_r, ht - pin_r);
      h += "<g class=\"pin " + cls + "\" data-region=\"" + std::to_string(r + 1) +
           "\"><title>Region " + std::to_string(r + 1) + ": " +
           std::string(detail::region_kind_name(reg.kind)) + ", worst " +
           signed_fixed(reg.worst_mm, 3) + " mm, layers " +
           detail::layer_range(reg.layer_min, reg.layer_max) + "</title>";
      if (bw > 2 * pin_r || bh > 2 * pin_r)
        h += "<rect x=\"" + fixed(bx, 1) + "\" y=\"" + fixed(by, 1) + "\" width=\"" + fixed(bw, 1) +
             "\" height=\"" + fixed(bh, 1) + "\" rx=\"3\"/>";
      h += "<circle cx=\"" + fixed(px, 1) + "\" cy=\"" + fixed(py, 1) + "\" r=\"" +
           fixed(pin_r, 1) + "\"/><text x=\"" + fixed(px, 1) + "\" y=\"" +
           fixed(py + pin_r * 0.42, 1) + "\">" + std::to_string(r + 1) + "</text></g>";
    }
    h += "</svg></div><figcaption>" + html_escape(hv.view.label) + "</figcaption></figure>";
  }
  return h + "</div>";
}

}  // namespace

namespace {
/// The verdict, its sentence and the gate table.
void append_verdict_html(std::string& h, const VerifyReport& report) {
  const std::string part = report.part_name.empty() ? "part" : report.part_name;
  const std::string verdict = report.pass ? "PASS" : "FAIL";
  // Verdict and gates.
  h += "<section class=\"verdict " + std::string(report.pass ? "is-pass" : "is-fail") +
       "\" id=\"verdict\">";
  h += "<div class=\"badge\">" + verdict + "</div><div class=\"verdict-text\"><h1>" +
       html_escape(part) + "</h1><p>" + html_escape(detail::verdict_sentence(report)) +
       "</p></div>";
  h += "<table "
       "class=\"gates\"><thead><tr><th>Gate</th><th>Value</th><th>Limit</th><th></th></tr></"
       "thead><tbody>";
  for (const auto& g : report.gates) {
    const double frac =
        g.limit > 0 ? std::clamp(g.value / g.limit, 0.0, 1.5) / 1.5 : (g.value > 0 ? 1.0 : 0.0);
    h += "<tr class=\"" + std::string(g.pass ? "ok" : "bad") + "\"><td>" +
         html_escape(detail::gate_label(g.name)) + "</td><td class=\"num\">" +
         gate_value_text(g, g.value) + "</td><td class=\"num\">" + gate_value_text(g, g.limit) +
         "</td><td><span class=\"gate-bar\"><span style=\"width:" + fixed(100 * frac, 1) +
         "%\"></span><i></i></span><span class=\"chip " +
         std::string(g.pass ? "chip-ok\">pass" : "chip-bad\">fail") + "</span></td></tr>";
  }
  h += "</tbody></table></section>\n";
}

/// The cards of key numbers: the gate figures, within tolerance, print time, filament, volume.
void append_key_numbers_html(std::string& h, const VerifyReport& report) {
  const auto& dev = report.deviation;
  const auto& sim = report.simulation;
  // Key numbers.
  // The gate figures (voxel-noise clusters excluded); the raw extremes are in the statistics.
  const double raw_excess = std::max({dev.deposit_to_mesh.max_mm, dev.mesh_to_deposit.max_mm, 0.0});
  const double raw_deficit =
      -std::min({dev.deposit_to_mesh.min_mm, dev.mesh_to_deposit.min_mm, 0.0});
  const double dvol =
      dev.mesh_volume_mm3 > 0
          ? 100.0 * (dev.deposit_volume_mm3 - dev.mesh_volume_mm3) / dev.mesh_volume_mm3
          : 0.0;
  const double tol = dev.tolerance_mm;
  const std::string noise =
      dev.noise_regions > 0 ? " · " + std::to_string(dev.noise_regions) + " noise clusters ignored"
                            : "";
  h += "<section class=\"cards\">";
  h += card_html({"Max excess", signed_fixed(dev.max_excess_mm, 3), " mm",
                  "raw max " + signed_fixed(raw_excess, 3) + " mm · RMS " +
                      fixed(dev.deposit_to_mesh.rms_mm, 3) + " (deposit → mesh)" + noise,
                  dev.max_excess_mm > tol ? "warn-excess" : ""});
  h += card_html({"Max deficit", signed_fixed(-dev.max_deficit_mm, 3), " mm",
                  "raw min " + signed_fixed(-raw_deficit, 3) + " mm · RMS " +
                      fixed(dev.mesh_to_deposit.rms_mm, 3) + " (mesh → deposit)",
                  dev.max_deficit_mm > tol ? "warn-deficit" : ""});
  h += card_html({"Within ±" + fixed(tol, 2) + " mm",
                  fixed(dev.deposit_to_mesh.within_tolerance_pct, 1), " %",
                  "of the deposit surface · " + fixed(dev.mesh_to_deposit.within_tolerance_pct, 1) +
                      " % of the mesh surface",
                  ""});
  if (dev.wall_area_mm2 > 0)
    h += card_html({"Layer lines", fixed(dev.wall_rq_mm, 3), " mm Rq",
                    "roughness of the walls away from sharp edges (RMS about each layer's "
                    "mean) · " +
                        fixed(dev.wall_rms_mm, 3) + " mm RMS from the design · " +
                        fixed(dev.wall_mesh_rms_mm, 3) + " mm RMS from the design to the print",
                    ""});
  h += card_html({"Print time", html_escape(detail::duration_text(sim.print_time_s)), "",
                  std::to_string(sim.layers) + " layers · " + std::to_string(sim.gcode_lines) +
                      " G-code lines",
                  ""});
  h += card_html({"Filament", fixed(sim.filament_mm / 1000.0, 2), " m",
                  fixed(sim.extruded_volume_mm3 / 1000.0, 2) + " cm³ extruded", ""});
  h += card_html({"Volume", fixed(dev.deposit_volume_mm3 / 1000.0, 2), " cm³",
                  "deposit vs mesh " + fixed(dev.mesh_volume_mm3 / 1000.0, 2) + " cm³ (" +
                      signed_fixed(dvol, 1) + " %)",
                  ""});
  h += "</section>\n";
}

/// Histograms of both directions, the per-layer chart and the statistics table.
void append_distribution_html(std::string& h, const VerifyReport& report,
                              const ReportAssets& assets, const ReportOptions& options) {
  const auto& dev = report.deviation;
  const DeviationColorScale& scale = assets.scale;
  const double tol = report.deviation.tolerance_mm;
  // Distribution and per layer.
  h += "<section class=\"two\"><div class=\"panel\" id=\"histogram\"><div "
       "class=\"panel-head\"><h2>Distribution"
       "</h2><p>Samples per signed distance (logarithmic count); the green band is the "
       "tolerance.</p></div>";
  h += "<h3>Deposit surface → mesh <small>" + std::to_string(dev.deposit_samples.size()) +
       " samples</small></h3>";
  h += detail::histogram_svg(dev.deposit_samples.distances_mm, scale, options.histogram_bins,
                             "Deposit to mesh histogram");
  h += "<h3>Mesh surface → deposit <small>" + std::to_string(dev.mesh_samples.size()) +
       " samples</small></h3>";
  h += detail::histogram_svg(dev.mesh_samples.distances_mm, scale, options.histogram_bins,
                             "Mesh to deposit histogram");
  h += "</div><div class=\"panel\" id=\"per-layer\"><div class=\"panel-head\"><h2>Deviation per "
       "layer</h2><p>"
       "Worst excess, worst deficit and RMS of both directions per layer. Click a layer to open it "
       "in the "
       "layer viewer.</p></div>";
  const std::string chart = detail::layer_chart_svg(dev, scale);
  h += chart.empty() ? "<p class=\"empty\">No per-layer data.</p>" : chart;
  h += "<div class=\"chart-key\"><span class=\"k-excess\">max excess</span><span "
       "class=\"k-deficit\">max deficit"
       "</span><span class=\"k-rms\">RMS</span><span class=\"k-tol\">±" +
       fixed(tol, 2) + " mm</span></div>";
  h += "<div class=\"scroll\"><table "
       "class=\"stats\"><thead><tr><th></th><th>min</th><th>max</th><th>mean</th><th>RMS</"
       "th><th>std</th>"
       "<th>P50 |d|</th><th>P95 |d|</th><th>P99 "
       "|d|</th><th>Hausdorff</th><th>within</th><th>samples</th></tr>"
       "</thead><tbody>";
  h += "<tr><th>deposit → mesh</th>" + stat_cells(dev.deposit_to_mesh) + "</tr>";
  h += "<tr><th>mesh → deposit</th>" + stat_cells(dev.mesh_to_deposit) + "</tr>";
  h += "</tbody></table></div><p class=\"fine\">mm; positive = material outside the designed part "
       "(excess), negative = "
       "inside it / missing (deficit).</p></div></section>\n";
}

/// The table of out-of-tolerance regions.
void append_regions_html(std::string& h, const VerifyReport& report) {
  const auto& dev = report.deviation;
  const double tol = report.deviation.tolerance_mm;
  // Regions.
  h += "<section class=\"panel\" id=\"regions\"><div class=\"panel-head\"><h2>Regions out of "
       "tolerance <small>" +
       std::to_string(dev.regions.size()) + "</small></h2><p>Clusters of samples beyond ±" +
       fixed(tol, 2) + " mm. Click a row to show it in the layer viewer.</p></div>";
  if (dev.regions.empty()) {
    h += "<p class=\"empty\">None: every sample is within tolerance.</p>";
  } else {
    h +=
        "<div class=\"scroll\"><table class=\"list\"><thead><tr><th>#</th><th>kind</th><th "
        "class=\"num\">worst</th>"
        "<th>worst at (x, y, z) mm</th><th>size (mm)</th><th>layers</th><th class=\"num\">area</th>"
        "<th>G-code lines</th></tr></thead><tbody>";
    for (std::size_t i = 0; i < dev.regions.size(); ++i) {
      const auto& r = dev.regions[i];
      const Vec3 sz = r.bbox_mm.size();
      h += "<tr data-region=\"" + std::to_string(i + 1) + "\" data-layer=\"" +
           std::to_string(r.layer_min) + "\"><td class=\"num\"><span class=\"rnum rnum-" +
           std::string(detail::region_kind_name(r.kind)) + "\">" + std::to_string(i + 1) +
           "</span></td><td><span class=\"chip chip-" +
           std::string(detail::region_kind_name(r.kind)) + "\">" +
           std::string(detail::region_kind_name(r.kind)) + "</span></td><td class=\"num\">" +
           signed_fixed(r.worst_mm, 3) + " mm</td><td class=\"mono\">" +
           vec_text(r.worst_position_mm, 2) + "</td><td class=\"mono\">" + fixed(sz.x(), 1) +
           " × " + fixed(sz.y(), 1) + " × " + fixed(sz.z(), 1) + "</td><td>" +
           detail::layer_range(r.layer_min, r.layer_max) + "</td><td class=\"num\">" +
           fixed(r.area_mm2, 2) + " mm²</td><td class=\"mono\">" +
           html_escape(detail::line_list(r.gcode_lines, 6)) + "</td></tr>";
    }
    h += "</tbody></table></div>";
  }
  h += "</section>\n";
}

/// The printability findings, errors first (at most 400 rows).
void append_findings_html(std::string& h, const VerifyReport& report) {
  const auto sev = detail::count_severities(report.findings);
  // Findings.
  h += "<section class=\"panel\" id=\"findings\"><div class=\"panel-head\"><h2>Printability "
       "findings <small>" +
       std::to_string(sev.errors) + " errors · " + std::to_string(sev.warnings) + " warnings · " +
       std::to_string(sev.infos) +
       " notes</small></h2><p>From the mesh check, the simulated run and the "
       "deposit.</p></div>";
  if (report.findings.empty()) {
    h += "<p class=\"empty\">No findings.</p>";
  } else {
    constexpr std::size_t kMaxRows = 400;
    h += "<div class=\"scroll\"><table "
         "class=\"list\"><thead><tr><th>severity</th><th>code</th><th>message</th>"
         "<th>where</th></tr></thead><tbody>";
    std::vector<std::size_t> order;  // errors first, then warnings, then notes; stable
    for (Severity s : {Severity::error, Severity::warning, Severity::info})
      for (std::size_t i = 0; i < report.findings.size(); ++i)
        if (report.findings[i].severity == s) order.push_back(i);
    for (std::size_t k = 0; k < order.size() && k < kMaxRows; ++k) {
      const Finding& f = report.findings[order[k]];
      std::string where;
      auto add = [&where](const std::string& s) { where += (where.empty() ? "" : " · ") + s; };
      if (f.layer) add("layer " + std::to_string(*f.layer));
      if (f.line) add("line " + std::to_string(*f.line));
      if (f.position_mm) add(vec_text(*f.position_mm, 2));
      if (f.count > 1) add("×" + std::to_string(f.count));
      h += "<tr><td><span class=\"chip chip-" + std::string(to_string(f.severity)) + "\">" +
           std::string(to_string(f.severity)) + "</span></td><td class=\"mono\">" +
           html_escape(f.code) + "</td><td>" + html_escape(f.message) + "</td><td class=\"mono\">" +
           html_escape(where) + "</td></tr>";
    }
    h += "</tbody></table></div>";
    if (order.size() > kMaxRows)
      h += "<p class=\"fine\">" + std::to_string(order.size() - kMaxRows) +
           " more findings in report.json.</p>";
  }
  h += "</section>\n";
}

/// Inputs with their hashes, settings, the part and print, the printer's values, the run.
void append_provenance_html(std::string& h, const VerifyReport& report,
                            const ReportOptions& options) {
  const auto& dev = report.deviation;
  const auto& sim = report.simulation;
  // Provenance.
  const auto& st = report.settings;
  h += "<section class=\"panel\" id=\"provenance\"><div class=\"panel-head\"><h2>Inputs, settings "
       "and run</h2><p>"
       "Everything that produced this report.</p></div>";
  h += "<h3>Inputs</h3><div class=\"scroll\"><table "
       "class=\"list\"><thead><tr><th>role</th><th>path</th>"
       "<th class=\"num\">size</th><th>SHA-256</th></tr></thead><tbody>";
  for (const auto& in : report.inputs)
    h += "<tr><td>" + html_escape(in.role) + "</td><td class=\"mono\">" + html_escape(in.path) +
         "</td><td class=\"num\">" +
         (in.sha256.empty() ? std::string("built-in") : size_text(in.size_bytes)) +
         "</td><td class=\"mono hash\">" +
         (in.sha256.empty() ? std::string("—") : html_escape(in.sha256)) + "</td></tr>";
  h += "</tbody></table></div><div class=\"kv-grid\">";
  h += "<div><h3>Settings</h3><table class=\"kv\">";
  h += kv_row("tolerance", "±" + fixed(st.gates.tolerance_mm, 3) + " mm");
  h += kv_row("max excess",
              st.gates.max_excess_mm ? fixed(*st.gates.max_excess_mm, 3) + " mm" : "= tolerance");
  h += kv_row("max deficit",
              st.gates.max_deficit_mm ? fixed(*st.gates.max_deficit_mm, 3) + " mm" : "= tolerance");
  h += kv_row("max RMS",
              st.gates.max_rms_mm ? fixed(*st.gates.max_rms_mm, 3) + " mm" : "not checked");
  h += kv_row("voxel", fixed(st.voxel_mm, 3) + " mm");
  h += kv_row("mesh sample spacing", st.mesh_sample_spacing_mm > 0
                                         ? fixed(st.mesh_sample_spacing_mm, 3) + " mm"
                                         : "= voxel");
  h += kv_row("printer", html_escape(printer_provenance_summary(report.printer)));
  h += kv_row("G-code source", html_escape(st.gcode_source));
  h += kv_row(
      "registration",
      html_escape(dev.registration_method.empty() ? std::string("auto") : dev.registration_method) +
          ", offset " + vec_text(dev.registration_offset_mm, 3) + " mm");
  {
    const Registration& reg = report.registration;
    if (!reg.transform.rotation.isIdentity(0))
      h += kv_row("rotation",
                  vec_text(xyz_deg_of(reg.transform.rotation), 2) + " deg about X, Y, Z");
    if (reg.transform.scale != 1.0)
      h += kv_row("mesh scale", fixed(reg.transform.scale, 4) + " mm per unit");
    if (reg.object_id >= 0) h += kv_row("object", html_escape(reg.object));
    if (reg.wall_points > 0)
      h += kv_row("registration fit",
                  "walls " + fixed(reg.residual_rms_mm, 3) + " mm RMS from the mesh, " +
                      fixed(reg.coverage_pct, 1) + " % of the mesh covered" +
                      (reg.matches ? std::string() : " — " + html_escape(reg.mismatch)));
  }
  h += kv_row("sampling seed", std::to_string(st.seed));
  h += kv_row("max regions", std::to_string(st.max_regions));
  h += "</table></div>";
  h += "<div><h3>Part and print</h3><table class=\"kv\">";
  const auto& ck = report.check;
  h += kv_row("mesh", std::to_string(ck.triangles) + " triangles · " + std::to_string(ck.vertices) +
                          " vertices · " + (ck.watertight ? "watertight" : "not watertight"));
  h += kv_row("mesh volume / area",
              fixed(ck.volume_mm3, 1) + " mm³ · " + fixed(ck.area_mm2, 1) + " mm²");
  h += kv_row("mesh box (own frame)", box_text(ck.bbox_mm, 2));
  h += kv_row("G-code",
              html_escape(sim.slicer.empty() ? std::string("unknown slicer") : sim.slicer) + " · " +
                  std::to_string(sim.moves) + " moves · " + std::to_string(sim.extrusion_moves) +
                  " extrusions");
  h += kv_row("extrusion box", box_text(sim.extrusion_bbox_mm, 2));
  h += kv_row("deposit", std::to_string(report.deposit.voxels) + " voxels (" +
                             std::to_string(report.deposit.surface_voxels) + " on the surface) · " +
                             size_text(report.deposit.memory_bytes));
  h += kv_row("deposit part box", box_text(report.deposit.part_bbox_mm, 2));
  if (!options.deposit_mesh_href.empty())
    h += kv_row("as-printed mesh", "<a href=\"" + html_escape(options.deposit_mesh_href) + "\">" +
                                       html_escape(options.deposit_mesh_href) + "</a> · " +
                                       html_escape(options.deposit_mesh_text));
  h += "</table></div>";
  h += printer_values_html(report.printer);
  h += "<div><h3>Run</h3><table class=\"kv\">";
  for (const auto& t : report.timings) h += kv_row(t.stage, fixed(t.seconds, 3) + " s");
  if (!report.timings.empty()) h += kv_row("total", fixed(total_time_s(report), 3) + " s");
  h += kv_row("printtwin", html_escape(report.tool_version));
  h += kv_row("report schema", std::to_string(report.schema_version));
  if (!options.generated_utc.empty()) h += kv_row("generated", html_escape(options.generated_utc));
  h += "</table></div></div></section>\n</main>\n";
}

}  // namespace

std::string report_html(const VerifyReport& report, const ReportAssets& assets,
                        const ReportOptions& options) {
  const auto& sim = report.simulation;
  const DeviationColorScale& scale = assets.scale;
  const std::string part = report.part_name.empty() ? "part" : report.part_name;
  const std::string verdict = report.pass ? "PASS" : "FAIL";

  std::string h;
  h.reserve(1 << 20);
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
       "<meta name=\"generator\" content=\"printtwin " +
       html_escape(report.tool_version) + "\">\n";
  h += "<title>" + verdict + " · " + html_escape(part) + " — printtwin verify</title>\n<style>";
  h += detail::report_css();
  h += "</style>\n</head>\n<body>\n";

  // Header.
  h += "<header class=\"top\"><div class=\"wrap\"><div class=\"brand\"><svg viewBox=\"0 0 24 24\" "
       "class=\"logo\" aria-hidden=\"true\"><path d=\"M12 2 21 7v10l-9 5-9-5V7z\"/><path d=\"M3 "
       "7l9 5 9-5M12 "
       "12v10\"/></svg>printtwin <span>verify</span></div><div class=\"top-meta\">";
  h += "<span>" + html_escape(part) + "</span>";
  if (!sim.slicer.empty()) h += "<span>G-code: " + html_escape(sim.slicer) + "</span>";
  h += "<span>printer: " + html_escape(report.printer.name) + "</span>";
  if (!options.generated_utc.empty())
    h += "<span>" + html_escape(options.generated_utc) + "</span>";
  h += "<span>v" + html_escape(report.tool_version) +
       "</span></div></div></header>\n<main class=\"wrap\">\n";

  append_verdict_html(h, report);
  append_key_numbers_html(h, report);
  // Heatmaps.
  h += "<section class=\"panel\" id=\"heatmaps\"><div class=\"panel-head\"><h2>Deviation on the "
       "part</h2><p>"
       "Mesh surface coloured by the signed distance to the simulated deposit (machine frame, "
       "orthographic views). Numbered pins mark the largest out-of-tolerance regions listed below, "
       "on "
       "the views that show them.</p></div>";
  h += legend_html(scale);
  h += views_html(report, assets);
  h += "</section>\n";

  append_distribution_html(h, report, assets, options);
  // Layer viewer.
  h += "<section class=\"panel\" id=\"layers\"><div class=\"panel-head\"><h2>Layer "
       "viewer</h2><p>The mesh's cross-"
       "section (outline) against the deposit's outer surface in that layer (dots coloured by "
       "deviation). "
       "Ringed dots are mesh points out of tolerance. Use the slider, ← →, or click the "
       "chart.</p></div>";
  h += "<div class=\"viewer\"><div class=\"viewer-stage\"><canvas id=\"layer-canvas\" "
       "width=\"800\" height=\"600\">"
       "</canvas><div id=\"layer-tip\" class=\"tip\" hidden></div></div><div class=\"viewer-side\">"
       "<div class=\"viewer-title\" id=\"layer-title\">—</div><div class=\"viewer-controls\">"
       "<button type=\"button\" id=\"layer-prev\" aria-label=\"previous layer\">‹</button>"
       "<input type=\"range\" id=\"layer-slider\" min=\"0\" max=\"0\" value=\"0\" "
       "aria-label=\"layer\">"
       "<button type=\"button\" id=\"layer-next\" aria-label=\"next layer\">›</button></div>"
       "<dl class=\"layer-stats\" id=\"layer-stats\"></dl><button type=\"button\" class=\"link\" "
       "id=\"layer-worst\">"
       "Go to the worst layer</button><div class=\"viewer-key\"><span class=\"k-outline\">mesh "
       "cross-section</span>"
       "<span class=\"k-dots\">deposit surface</span><span class=\"k-ring\">mesh point out of "
       "tolerance</span>"
       "<span class=\"k-box\">region</span></div></div></div></section>\n";

  append_regions_html(h, report);
  append_findings_html(h, report);
  append_provenance_html(h, report, options);
  h += "<footer class=\"wrap\">printtwin " + html_escape(report.tool_version) +
       " · the same folder holds report.json, junit.xml, summary.md and the PNG views</footer>\n";

  // Viewer data (JSON; "</" escaped so that it cannot end the script element).
  const std::string data =
      assets.viewer_data.empty() ? detail::viewer_json(report, scale, options) : assets.viewer_data;
  std::string safe;
  safe.reserve(data.size());
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (data[i] == '<' && i + 1 < data.size() && data[i + 1] == '/') {
      safe += "<\\/";
      ++i;
    } else {
      safe += data[i];
    }
  }
  h += "<script type=\"application/json\" id=\"viewer-data\">" + safe + "</script>\n<script>";
  h += detail::report_js();
  h += "</script>\n</body>\n</html>\n";
  return h;
}

}  // namespace printtwin

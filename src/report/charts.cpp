// Inline SVG charts of report.html: histogram of signed deviation and deviation per layer.
// Drawn in C++ so that the page works without a charting library and the charts are
// deterministic text.
#include <algorithm>
#include <cmath>

#include "report/report_internal.hpp"

namespace printtwin::detail {

namespace {

std::string num(double v) { return fixed(v, 1); }

std::string rgb_hex(const std::array<std::uint8_t, 3>& c) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string s = "#";
  for (auto v : c) {
    s += kHex[v >> 4];
    s += kHex[v & 15];
  }
  return s;
}

double nice_step(double span, int target_ticks) {
  const double raw = span / std::max(target_ticks, 1);
  const double e = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * e >= raw) return m * e;
  return 10 * e;
}

// Trims "0.50" -> "0.5", "1.00" -> "1" for axis labels.
std::string tick_label(double v) {
  std::string s = fixed(v, 3);
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
}

}  // namespace

std::string histogram_svg(std::span<const double> distances_mm, const DeviationColorScale& scale,
                          int bins, std::string_view title) {
  bins = std::clamp(bins, 4, 400);
  const double range = scale.range_mm, tol = scale.tolerance_mm;
  std::vector<std::size_t> counts(static_cast<std::size_t>(bins), 0);
  std::size_t total = 0, below = 0, above = 0;
  for (const double d : distances_mm) {
    if (!std::isfinite(d)) continue;
    ++total;
    if (d < -range) ++below;
    if (d > range) ++above;
    const int b =
        std::clamp(static_cast<int>(std::floor((d + range) / (2 * range) * bins)), 0, bins - 1);
    ++counts[static_cast<std::size_t>(b)];
  }
  const double W = 560, H = 210, ml = 44, mr = 10, mt = 14, mb = 34;
  const double pw = W - ml - mr, ph = H - mt - mb;
  // Logarithmic count axis: the tails (the defects) stay visible next to the in-tolerance peak.
  std::size_t peak = 1;
  for (auto c : counts) peak = std::max(peak, c);
  const int decades =
      std::max(1, static_cast<int>(std::ceil(std::log10(static_cast<double>(peak)) - 1e-9)));
  const double ymax = static_cast<double>(decades);
  auto xpos = [&](double d) { return ml + (d + range) / (2 * range) * pw; };
  auto ypos = [&](double count) { return mt + ph - std::log10(std::max(count, 1.0)) / ymax * ph; };

  std::string svg = "<svg class=\"chart\" viewBox=\"0 0 " + num(W) + " " + num(H) +
                    "\" role=\"img\" aria-label=\"" + html_escape(title) + "\">";
  // Tolerance band.
  svg += "<rect class=\"tolband\" x=\"" + num(xpos(-tol)) + "\" y=\"" + num(mt) + "\" width=\"" +
         num(xpos(tol) - xpos(-tol)) + "\" height=\"" + num(ph) + "\"/>";
  // Grid and y labels: 1, 10, 100, ...
  const int label_every = decades > 5 ? 2 : 1;
  for (int e = 0; e <= decades; ++e) {
    const double c = std::pow(10.0, e);
    svg += "<line class=\"grid\" x1=\"" + num(ml) + "\" x2=\"" + num(ml + pw) + "\" y1=\"" +
           num(ypos(c)) + "\" y2=\"" + num(ypos(c)) + "\"/>";
    if (e % label_every == 0) {
      static constexpr const char* kLabels[] = {"1",    "10", "100", "1k",   "10k",
                                                "100k", "1M", "10M", "100M", "1G"};
      svg += "<text class=\"ylab\" x=\"" + num(ml - 6) + "\" y=\"" + num(ypos(c) + 4) + "\">" +
             kLabels[std::min(e, 9)] + "</text>";
    }
  }
  // Bars.
  const double bw = pw / bins;
  for (int b = 0; b < bins; ++b) {
    const std::size_t c = counts[static_cast<std::size_t>(b)];
    if (c == 0) continue;
    const double lo = -range + 2 * range * b / bins, hi = lo + 2 * range / bins;
    const double pct = 100.0 * static_cast<double>(c) / static_cast<double>(total);
    // A single sample still gets a visible bar (log10(1) = 0).
    const double y = std::min(ypos(static_cast<double>(c)), mt + ph - 2.0);
    svg += "<rect fill=\"" + rgb_hex(scale.color(0.5 * (lo + hi))) + "\" x=\"" +
           num(ml + b * bw + 0.5) + "\" y=\"" + num(y) + "\" width=\"" +
           num(std::max(bw - 1.0, 0.8)) + "\" height=\"" + num(std::max(mt + ph - y, 0.8)) +
           "\"><title>" + (b == 0 ? "≤ " : "") + fixed(lo, 3) + " … " + fixed(hi, 3) +
           (b == bins - 1 ? " ≤" : "") + " mm: " + std::to_string(c) + " samples (" +
           fixed(pct, 2) + " %)</title></rect>";
  }
  // X axis with ticks at the scale's marks.
  svg += "<line class=\"axis\" x1=\"" + num(ml) + "\" x2=\"" + num(ml + pw) + "\" y1=\"" +
         num(mt + ph) + "\" y2=\"" + num(mt + ph) + "\"/>";
  for (double v : {-range, -tol, 0.0, tol, range}) {
    const double x = xpos(v);
    svg += "<line class=\"axis\" x1=\"" + num(x) + "\" x2=\"" + num(x) + "\" y1=\"" + num(mt + ph) +
           "\" y2=\"" + num(mt + ph + 4) + "\"/>";
    svg += "<text class=\"xlab\" x=\"" + num(x) + "\" y=\"" + num(mt + ph + 16) + "\">" +
           tick_label(v) + "</text>";
  }
  svg += "<text class=\"xunit\" x=\"" + num(ml + pw) + "\" y=\"" + num(H - 3) + "\">mm</text>";
  if (below > 0 || above > 0)
    svg += "<text class=\"note\" x=\"" + num(ml) + "\" y=\"" + num(H - 3) + "\">" +
           std::to_string(below) + " below / " + std::to_string(above) +
           " beyond the axis (in the end bins)</text>";
  svg += "</svg>";
  return svg;
}

std::string layer_chart_svg(const DeviationResult& deviation, const DeviationColorScale& scale) {
  const auto& layers = deviation.per_layer;
  if (layers.empty()) return {};
  struct Row {
    int layer;
    double excess, deficit, rms;
  };
  std::vector<Row> rows;
  double extreme = scale.tolerance_mm * 1.5;
  for (const auto& l : layers) {
    Row r{l.layer, 0.0, 0.0, 0.0};
    double ss = 0;
    std::size_t n = 0;
    for (const DeviationStats* s : {&l.deposit_to_mesh, &l.mesh_to_deposit}) {
      if (s->samples == 0) continue;
      r.excess = std::max(r.excess, s->max_mm);
      r.deficit = std::min(r.deficit, s->min_mm);
      ss += s->rms_mm * s->rms_mm * static_cast<double>(s->samples);
      n += s->samples;
    }
    r.rms = n > 0 ? std::sqrt(ss / static_cast<double>(n)) : 0.0;
    extreme = std::max({extreme, r.excess, -r.deficit});
    rows.push_back(r);
  }
  const double ystep = nice_step(2 * extreme, 6);
  const double ymax = ystep * std::ceil(extreme / ystep);
  const double W = 720, H = 236, ml = 48, mr = 10, mt = 22, mb = 30;
  const double pw = W - ml - mr, ph = H - mt - mb;
  const std::size_t n = rows.size();
  const double colw = pw / static_cast<double>(n);
  auto xpos = [&](std::size_t i) { return ml + (static_cast<double>(i) + 0.5) * colw; };
  auto ypos = [&](double v) { return mt + (ymax - std::clamp(v, -ymax, ymax)) / (2 * ymax) * ph; };

  std::string svg = "<svg class=\"chart\" id=\"layer-chart\" viewBox=\"0 0 " + num(W) + " " +
                    num(H) + "\" role=\"img\" aria-label=\"Deviation per layer\">";
  svg += "<rect class=\"tolband\" x=\"" + num(ml) + "\" y=\"" + num(ypos(scale.tolerance_mm)) +
         "\" width=\"" + num(pw) + "\" height=\"" +
         num(ypos(-scale.tolerance_mm) - ypos(scale.tolerance_mm)) + "\"/>";
  for (double v = -ymax; v <= ymax + 1e-9; v += ystep) {
    svg += "<line class=\"" + std::string(std::abs(v) < 1e-12 ? "axis" : "grid") + "\" x1=\"" +
           num(ml) + "\" x2=\"" + num(ml + pw) + "\" y1=\"" + num(ypos(v)) + "\" y2=\"" +
           num(ypos(v)) + "\"/>";
    svg += "<text class=\"ylab\" x=\"" + num(ml - 6) + "\" y=\"" + num(ypos(v) + 4) + "\">" +
           tick_label(v) + "</text>";
  }
  // Envelope between the worst deficit and the worst excess, then the three lines.
  std::string env = "M";
  for (std::size_t i = 0; i < n; ++i) env += num(xpos(i)) + "," + num(ypos(rows[i].excess)) + " ";
  for (std::size_t i = n; i-- > 0;) env += num(xpos(i)) + "," + num(ypos(rows[i].deficit)) + " ";
  svg += "<path class=\"envelope\" d=\"" + env + "Z\"/>";
  auto polyline = [&](const char* cls, auto value) {
    std::string pts;
    for (std::size_t i = 0; i < n; ++i) pts += num(xpos(i)) + "," + num(ypos(value(rows[i]))) + " ";
    svg += "<polyline class=\"" + std::string(cls) + "\" points=\"" + pts + "\"/>";
  };
  polyline("line-excess", [](const Row& r) { return r.excess; });
  polyline("line-deficit", [](const Row& r) { return r.deficit; });
  polyline("line-rms", [](const Row& r) { return r.rms; });
  // X ticks: layer numbers.
  const double xstep = std::max(1.0, nice_step(static_cast<double>(n), 8));
  for (std::size_t i = 0; i < n; i += static_cast<std::size_t>(xstep)) {
    svg += "<text class=\"xlab\" x=\"" + num(xpos(i)) + "\" y=\"" + num(mt + ph + 16) + "\">" +
           std::to_string(rows[i].layer) + "</text>";
  }
  svg += "<text class=\"xunit\" x=\"" + num(ml + pw) + "\" y=\"" + num(H - 3) + "\">layer</text>";
  svg += "<text class=\"yunit\" x=\"" + num(ml - 6) + "\" y=\"" + num(mt - 10) + "\">mm</text>";
  // Cursor (moved by the layer viewer) and one hit column per layer.
  svg += "<line id=\"layer-cursor\" x1=\"" + num(xpos(0)) + "\" x2=\"" + num(xpos(0)) + "\" y1=\"" +
         num(mt) + "\" y2=\"" + num(mt + ph) + "\"/>";
  svg += "<g class=\"cols\">";
  for (std::size_t i = 0; i < n; ++i) {
    svg += "<rect data-layer=\"" + std::to_string(rows[i].layer) + "\" x=\"" + num(ml + colw * i) +
           "\" y=\"" + num(mt) + "\" width=\"" + num(colw) + "\" height=\"" + num(ph) +
           "\"><title>layer " + std::to_string(rows[i].layer) + ": excess " +
           signed_fixed(rows[i].excess, 3) + ", deficit " + signed_fixed(rows[i].deficit, 3) +
           ", RMS " + fixed(rows[i].rms, 3) + " mm</title></rect>";
  }
  svg += "</g></svg>";
  return svg;
}

}  // namespace printtwin::detail

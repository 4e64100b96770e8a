// The comparison table: one row per variant from its VerifyReport, the Pareto front over
// (print time, deviation RMS), and the merge of shares run apart.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "printtwin/compare.hpp"

namespace printtwin {

namespace {

DirectionFigures direction_figures(const DeviationStats& s) {
  DirectionFigures f;
  f.samples = s.samples;
  f.rms_mm = s.rms_mm;
  f.p95_mm = s.p95_abs_mm;
  f.max_excess_mm = s.samples > 0 ? std::max(0.0, s.max_mm) : 0.0;
  f.max_deficit_mm = s.samples > 0 ? std::max(0.0, -s.min_mm) : 0.0;
  f.within_tolerance_pct = s.within_tolerance_pct;
  return f;
}

// RMS over the samples whose nearest mesh triangle is sloped.
void slope_figures(DirectionFigures& f, std::span<const double> distances_mm,
                   std::span<const std::uint32_t> triangle, std::span<const std::uint8_t> sloped) {
  if (sloped.empty() || triangle.size() != distances_mm.size()) return;
  double sum_sq = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < distances_mm.size(); ++i) {
    const std::uint32_t t = triangle[i];
    if (t >= sloped.size() || sloped[t] == 0) continue;
    sum_sq += distances_mm[i] * distances_mm[i];
    ++n;
  }
  f.slope_samples = n;
  f.slope_rms_mm = n > 0 ? std::sqrt(sum_sq / static_cast<double>(n)) : 0.0;
}

}  // namespace

double combined_rms_mm(double rms_a_mm, double rms_b_mm) {
  return std::sqrt(0.5 * (rms_a_mm * rms_a_mm + rms_b_mm * rms_b_mm));
}

std::vector<bool> pareto_front(std::span<const std::pair<double, double>> points) {
  const std::size_t n = points.size();
  std::vector<bool> front(n, false);
  // Sort by x then y; sweep keeping the best y seen. A point is dominated when an earlier
  // point (x' <= x) has y' < y, or has y' == y with x' < x. Equal points are all kept.
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < n; ++i)
    if (std::isfinite(points[i].first) && std::isfinite(points[i].second)) order.push_back(i);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (points[a].first != points[b].first) return points[a].first < points[b].first;
    return points[a].second < points[b].second;
  });
  double best_y = std::numeric_limits<double>::infinity();
  std::pair<double, double> best_point{std::numeric_limits<double>::infinity(), best_y};
  for (std::size_t i : order) {
    const auto& p = points[i];
    if (p.second < best_y) {
      front[i] = true;
      best_y = p.second;
      best_point = p;
    } else if (p == best_point) {
      front[i] = true;  // a duplicate of a front point is not dominated by it
    }
  }
  return front;
}

void mark_pareto(std::vector<VariantResult>& variants) {
  std::vector<std::pair<double, double>> pts;
  pts.reserve(variants.size());
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  // On the values compare.json holds (1e-6), so that a merged table marks the same front as
  // the run that wrote the shares.
  auto r6 = [](double x) { return std::round(x * 1e6) / 1e6; };
  for (const auto& v : variants)
    pts.emplace_back(v.ran ? r6(v.print_time_s) : kNaN, v.ran ? r6(v.rms_mm) : kNaN);
  const auto front = pareto_front(pts);
  for (std::size_t i = 0; i < variants.size(); ++i) variants[i].pareto = front[i];
}

VariantResult summarize_variant(const VariantSpec& spec, const VerifyReport& report,
                                std::span<const std::uint8_t> slope_of_triangle,
                                std::span<const std::uint32_t> deposit_triangle,
                                std::span<const std::uint32_t> mesh_triangle,
                                double filament_density_g_cm3) {
  VariantResult r;
  r.variant = spec;
  r.ran = true;
  const auto& sim = report.simulation;
  r.slicer = sim.slicer;
  r.layers = sim.layers;
  if (sim.layers > 0 && !sim.extrusion_bbox_mm.empty())
    r.layer_height_mm = sim.extrusion_bbox_mm.max.z() / sim.layers;  // mean, first layer included
  r.print_time_s = sim.print_time_s;
  r.filament_m = sim.filament_mm / 1000.0;
  r.filament_density_g_cm3 = filament_density_g_cm3;
  r.filament_g = sim.extruded_volume_mm3 / 1000.0 * filament_density_g_cm3;

  const auto& dev = report.deviation;
  r.deposit_to_mesh = direction_figures(dev.deposit_to_mesh);
  r.mesh_to_deposit = direction_figures(dev.mesh_to_deposit);
  slope_figures(r.deposit_to_mesh, dev.deposit_samples.distances_mm, deposit_triangle,
                slope_of_triangle);
  slope_figures(r.mesh_to_deposit, dev.mesh_samples.distances_mm, mesh_triangle, slope_of_triangle);
  r.rms_mm = combined_rms_mm(r.deposit_to_mesh.rms_mm, r.mesh_to_deposit.rms_mm);
  r.slope_rms_mm = combined_rms_mm(r.deposit_to_mesh.slope_rms_mm, r.mesh_to_deposit.slope_rms_mm);

  for (const auto& reg : dev.regions) {
    (reg.kind == RegionKind::missing ? r.missing_regions : r.excess_regions) += 1;
    if (r.top_regions.size() < 5) {
      RegionBrief b;
      b.kind = reg.kind == RegionKind::missing ? "missing" : "excess";
      b.worst_mm = reg.worst_mm;
      b.area_mm2 = reg.area_mm2;
      b.layer_min = reg.layer_min;
      b.layer_max = reg.layer_max;
      b.worst_position_mm = reg.worst_position_mm;
      r.top_regions.push_back(b);
    }
  }
  for (const auto& f : report.findings) {
    switch (f.severity) {
      case Severity::error:
        ++r.error_findings;
        break;
      case Severity::warning:
        ++r.warning_findings;
        break;
      case Severity::info:
        ++r.info_findings;
        break;
    }
  }
  r.gates = report.gates;
  r.pass = report.pass;
  return r;
}

Result<CompareResult> merge_compare_results(std::vector<CompareResult> shares,
                                            bool require_complete) {
  if (shares.empty()) return usage_error("--merge: no compare JSON files were given");
  CompareResult out = shares.front();
  out.shard.reset();
  out.variants.clear();
  out.shared_time_s = 0;
  out.total_time_s = 0;
  std::map<int, VariantResult> rows;
  for (std::size_t s = 0; s < shares.size(); ++s) {
    auto& share = shares[s];
    const std::string which = "share " + std::to_string(s + 1);
    if (share.plan_id != out.plan_id)
      return bad_input("--merge: " + which + " comes from another sweep (plan id " +
                       share.plan_id.substr(0, 12) + ", expected " + out.plan_id.substr(0, 12) +
                       "); merge only the shares of one --write-manifest / command line");
    if (share.part.sha256 != out.part.sha256)
      return bad_input("--merge: " + which + " was run on another mesh (sha256 " +
                       share.part.sha256.substr(0, 12) + ", expected " +
                       out.part.sha256.substr(0, 12) + ")");
    if (share.variant_count != out.variant_count)
      return bad_input("--merge: " + which + " has " + std::to_string(share.variant_count) +
                       " variants in its plan, expected " + std::to_string(out.variant_count));
    out.shared_time_s += share.shared_time_s;
    out.total_time_s += share.total_time_s;
    for (auto& v : share.variants) {
      const int i = v.variant.index;
      if (i < 0 || i >= out.variant_count)
        return bad_input("--merge: " + which + " holds variant " + std::to_string(i) +
                         " outside the plan's 0.." + std::to_string(out.variant_count - 1));
      auto [it, inserted] = rows.try_emplace(i, v);
      if (!inserted && it->second.variant.label != v.variant.label)
        return bad_input("--merge: variant " + std::to_string(i) + " is '" +
                         it->second.variant.label + "' in one share and '" + v.variant.label +
                         "' in another");
      // A repeated index with the same label is a re-run (e.g. a retried CI job): keep the
      // one that ran, else the first.
      if (!inserted && !it->second.ran && v.ran) it->second = std::move(v);
    }
  }
  if (require_complete && static_cast<int>(rows.size()) != out.variant_count) {
    std::string missing;
    int listed = 0, count = 0;
    for (int i = 0; i < out.variant_count; ++i) {
      if (rows.count(i) != 0) continue;
      ++count;
      if (listed < 20) {
        missing += (listed ? ", " : "") + std::to_string(i);
        ++listed;
      }
    }
    if (count > listed) missing += ", ...";
    return bad_input("--merge: " + std::to_string(count) + " of " +
                     std::to_string(out.variant_count) + " variants are missing (indices " +
                     missing + "); run their shares or pass --allow-missing");
  }
  for (auto& [i, v] : rows) out.variants.push_back(std::move(v));
  mark_pareto(out.variants);
  return out;
}

std::string shard_file_name(int k, int n) {
  return "compare-" + std::to_string(k) + "-of-" + std::to_string(n) + ".json";
}

}  // namespace printtwin

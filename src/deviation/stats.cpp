// Statistics of signed distances.
#include <algorithm>
#include <cmath>

#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {
/// Percentile q in [0, 1] of values, linear interpolation between order statistics
/// (Hyndman & Fan type 7, the default of R and NumPy), from a table of order statistics.
double percentile(const std::vector<std::pair<std::size_t, double>>& order, std::size_t n, double q) {
  const double h = q * static_cast<double>(n - 1);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, n - 1);
  double vlo = 0, vhi = 0;
  for (const auto& [k, v] : order) {
    if (k == lo) vlo = v;
    if (k == hi) vhi = v;
  }
  return vlo + (h - static_cast<double>(lo)) * (vhi - vlo);
}
}  // namespace

DeviationStats deviation_stats(std::span<const double> d, double tolerance_mm) {
  DeviationStats s;
  s.samples = d.size();
  if (d.empty()) return s;
  s.min_mm = d[0];
  s.max_mm = d[0];
  // Kahan-free but ordered sums in long double: deterministic and accurate enough for
  // millions of sub-millimetre values.
  long double sum = 0, sum2 = 0, sum_abs = 0;
  std::size_t within = 0;
  std::vector<double> abs_d(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double v = d[i];
    s.min_mm = std::min(s.min_mm, v);
    s.max_mm = std::max(s.max_mm, v);
    sum += v;
    sum2 += static_cast<long double>(v) * v;
    abs_d[i] = std::abs(v);
    sum_abs += abs_d[i];
    if (abs_d[i] <= tolerance_mm) ++within;
  }
  const auto n = static_cast<long double>(d.size());
  s.mean_mm = static_cast<double>(sum / n);
  s.mean_abs_mm = static_cast<double>(sum_abs / n);
  s.rms_mm = static_cast<double>(std::sqrt(sum2 / n));
  const long double var = std::max<long double>(0, sum2 / n - (sum / n) * (sum / n));
  s.std_mm = static_cast<double>(std::sqrt(var));
  // The order statistics the percentiles need, by selection instead of a full sort: from
  // the lowest rank up, each selection only partitions the part above the previous one
  // (half of the values for the median, a twentieth for P95 and so on); the rank right after
  // a selected one is the least of the part above it.
  const std::size_t n_all = abs_d.size();
  std::vector<std::size_t> ranks;
  for (const double q : {0.50, 0.95, 0.99}) {
    const auto lo = static_cast<std::size_t>(std::floor(q * static_cast<double>(n_all - 1)));
    ranks.push_back(lo);
    ranks.push_back(std::min(lo + 1, n_all - 1));
  }
  ranks.push_back(n_all - 1);
  std::sort(ranks.begin(), ranks.end());
  ranks.erase(std::unique(ranks.begin(), ranks.end()), ranks.end());
  std::vector<std::pair<std::size_t, double>> order;
  std::size_t begin = 0;
  const auto first = abs_d.begin();
  for (const std::size_t k : ranks) {
    const auto at = first + static_cast<std::ptrdiff_t>(k);
    if (k == begin) {  // the least of [begin, n): move it to k
      std::iter_swap(std::min_element(at, abs_d.end()), at);
    } else {
      std::nth_element(first + static_cast<std::ptrdiff_t>(begin), at, abs_d.end());
    }
    order.emplace_back(k, abs_d[k]);
    begin = k + 1;
  }
  s.p50_abs_mm = percentile(order, n_all, 0.50);
  s.p95_abs_mm = percentile(order, n_all, 0.95);
  s.p99_abs_mm = percentile(order, n_all, 0.99);
  s.hausdorff_mm = order.back().second;
  s.within_tolerance_pct = 100.0 * static_cast<double>(within) / static_cast<double>(d.size());
  return s;
}

}  // namespace printtwin

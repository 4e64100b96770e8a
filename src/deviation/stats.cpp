// Statistics of signed distances.
#include <algorithm>
#include <cmath>

#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {
/// Percentile q in [0, 1] of sorted values, linear interpolation between order statistics
/// (Hyndman & Fan type 7, the default of R and NumPy).
double percentile_sorted(const std::vector<double>& v, double q) {
  if (v.empty()) return 0;
  const double h = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (h - static_cast<double>(lo)) * (v[hi] - v[lo]);
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
  std::sort(abs_d.begin(), abs_d.end());
  s.p50_abs_mm = percentile_sorted(abs_d, 0.50);
  s.p95_abs_mm = percentile_sorted(abs_d, 0.95);
  s.p99_abs_mm = percentile_sorted(abs_d, 0.99);
  s.hausdorff_mm = abs_d.back();
  s.within_tolerance_pct = 100.0 * static_cast<double>(within) / static_cast<double>(d.size());
  return s;
}

}  // namespace printtwin

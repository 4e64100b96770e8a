// Statistics of signed distances.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {
/// Percentile q in [0, 1] of values, linear interpolation between order statistics
/// (Hyndman & Fan type 7, the default of R and NumPy), from a table of order statistics.
double percentile(const std::vector<std::pair<std::size_t, double>>& order, std::size_t n,
                  double q) {
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
/// |d| as an unsigned integer with the same order (IEEE 754: for non-negative doubles, the
/// bit pattern orders like the value; NaN sorts last).
inline std::uint64_t abs_bits(double x) { return std::bit_cast<std::uint64_t>(std::abs(x)); }

/// The order statistics of |d| at `ranks` (ascending), by selection: from the lowest rank
/// up, each selection only partitions the part above the previous one; the rank right after
/// a selected one is the least of the part above it.
std::vector<std::pair<std::size_t, double>> order_statistics_by_selection(
    std::span<const double> d, const std::vector<std::size_t>& ranks) {
  std::vector<double> abs_d(d.size());
  for (std::size_t i = 0; i < d.size(); ++i) abs_d[i] = std::abs(d[i]);
  std::vector<std::pair<std::size_t, double>> order;
  std::size_t begin = 0;
  const auto first = abs_d.begin();
  for (const std::size_t k : ranks) {
    const auto at = first + static_cast<std::ptrdiff_t>(k);
    if (k == begin) {
      std::iter_swap(std::min_element(at, abs_d.end()), at);
    } else {
      std::nth_element(first + static_cast<std::ptrdiff_t>(begin), at, abs_d.end());
    }
    order.emplace_back(k, abs_d[k]);
    begin = k + 1;
  }
  return order;
}

/// From this many values on, the order statistics come from a histogram instead.
constexpr std::size_t kHistogramMin = 512;

/// The same by a histogram of |d|'s bit patterns over their range (for non-negative doubles
/// the pattern orders like the value, and equal-width bins of it are about equally fine in
/// every octave): one pass counts, the bins holding the ranks are found from the counts, a
/// pass gathers those bins' values (a table names each bin's list, so a value costs one
/// lookup), and a selection within them gives the exact order statistics. Up to 2^16 bins
/// (fewer for fewer values, so the counts stay in cache): streaming passes instead of
/// repeated partitions of a copy. `lo_key` and `hi_key`: the least and greatest |d| bit
/// patterns (the caller's pass finds them); the top rank, n - 1, is the greatest, without a
/// bin.
std::vector<std::pair<std::size_t, double>> order_statistics_by_histogram(
    std::span<const double> d, const std::vector<std::size_t>& ranks, std::uint64_t lo_key,
    std::uint64_t hi_key) {
  const int bin_bits = std::clamp(static_cast<int>(std::bit_width(d.size())) - 2, 8, 16);
  const int span_bits = static_cast<int>(std::bit_width(hi_key - lo_key));
  const int shift = std::max(0, span_bits - bin_bits);
  const auto bin = [&](double v) {
    return static_cast<std::size_t>((abs_bits(v) - lo_key) >> shift);
  };
  std::vector<std::uint32_t> count(((hi_key - lo_key) >> shift) + 1, 0);
  for (const double v : d) ++count[bin(v)];
  // The ranks below the top: the bin of each, and the rank's place within its bin.
  std::vector<std::size_t> binned;
  for (const std::size_t r : ranks)
    if (r + 1 < d.size()) binned.push_back(r);
  std::vector<std::size_t> bin_of(binned.size()), before(binned.size());
  {
    std::size_t acc = 0, r = 0;
    for (std::size_t b = 0; b < count.size() && r < binned.size(); ++b) {
      while (r < binned.size() && binned[r] < acc + count[b]) {
        bin_of[r] = b;
        before[r] = acc;
        ++r;
      }
      acc += count[b];
    }
  }
  std::vector<std::size_t> bins(bin_of);
  bins.erase(std::unique(bins.begin(), bins.end()), bins.end());
  std::vector<std::vector<double>> values(bins.size());
  std::vector<std::int16_t> list_of(count.size(), -1);  // bins.size() <= 7
  for (std::size_t k = 0; k < bins.size(); ++k) {
    values[k].reserve(count[bins[k]]);
    list_of[bins[k]] = static_cast<std::int16_t>(k);
  }
  if (!bins.empty())
    for (const double v : d)
      if (const int k = list_of[bin(v)]; k >= 0)
        values[static_cast<std::size_t>(k)].push_back(std::abs(v));
  std::vector<std::pair<std::size_t, double>> order;
  for (std::size_t r = 0; r < binned.size(); ++r) {
    auto& vals = values[static_cast<std::size_t>(list_of[bin_of[r]])];
    const auto at = vals.begin() + static_cast<std::ptrdiff_t>(binned[r] - before[r]);
    std::nth_element(vals.begin(), at, vals.end());
    order.emplace_back(binned[r], *at);
  }
  if (binned.size() < ranks.size()) order.emplace_back(d.size() - 1, std::bit_cast<double>(hi_key));
  return order;
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
  std::uint64_t lo_key = ~std::uint64_t{0}, hi_key = 0;  // least and greatest |d| bit patterns
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double v = d[i];
    s.min_mm = std::min(s.min_mm, v);
    s.max_mm = std::max(s.max_mm, v);
    sum += v;
    sum2 += static_cast<long double>(v) * v;
    const double a = std::abs(v);
    sum_abs += a;
    if (a <= tolerance_mm) ++within;
    const std::uint64_t k = abs_bits(v);
    lo_key = std::min(lo_key, k);
    hi_key = std::max(hi_key, k);
  }
  const auto n = static_cast<long double>(d.size());
  s.mean_mm = static_cast<double>(sum / n);
  s.mean_abs_mm = static_cast<double>(sum_abs / n);
  s.rms_mm = static_cast<double>(std::sqrt(sum2 / n));
  const long double var = std::max<long double>(0, sum2 / n - (sum / n) * (sum / n));
  s.std_mm = static_cast<double>(std::sqrt(var));
  const std::size_t n_all = d.size();
  std::vector<std::size_t> ranks;
  for (const double q : {0.50, 0.95, 0.99}) {
    const auto lo = static_cast<std::size_t>(std::floor(q * static_cast<double>(n_all - 1)));
    ranks.push_back(lo);
    ranks.push_back(std::min(lo + 1, n_all - 1));
  }
  ranks.push_back(n_all - 1);
  std::sort(ranks.begin(), ranks.end());
  ranks.erase(std::unique(ranks.begin(), ranks.end()), ranks.end());
  const std::vector<std::pair<std::size_t, double>> order =
      n_all >= kHistogramMin ? order_statistics_by_histogram(d, ranks, lo_key, hi_key)
                             : order_statistics_by_selection(d, ranks);
  s.p50_abs_mm = percentile(order, n_all, 0.50);
  s.p95_abs_mm = percentile(order, n_all, 0.95);
  s.p99_abs_mm = percentile(order, n_all, 0.99);
  s.hausdorff_mm = order.back().second;
  s.within_tolerance_pct = 100.0 * static_cast<double>(within) / static_cast<double>(d.size());
  return s;
}

namespace {
/// Weighted percentiles of |d| (the least |d| whose cumulative weight reaches q of the whole)
/// for ascending q: a histogram of |d|'s bit patterns sums the weights per bin, the bins
/// holding the q's are found from the sums, and only their values are sorted.
std::vector<double> weighted_percentiles(std::span<const double> d, std::span<const double> w,
                                         const std::vector<double>& qs, long double total,
                                         std::uint64_t lo_key, std::uint64_t hi_key) {
  const int bin_bits = std::clamp(static_cast<int>(std::bit_width(d.size())) - 2, 8, 16);
  const int span_bits = static_cast<int>(std::bit_width(hi_key - lo_key));
  const int shift = std::max(0, span_bits - bin_bits);
  const auto bin = [&](double v) {
    return static_cast<std::size_t>((abs_bits(v) - lo_key) >> shift);
  };
  std::vector<long double> sum(((hi_key - lo_key) >> shift) + 1, 0);
  for (std::size_t i = 0; i < d.size(); ++i) sum[bin(d[i])] += w[i];
  // The bin of each q and the weight before it, then one pass gathers those bins' values.
  std::vector<std::size_t> bin_of;
  std::vector<long double> before_of;
  {
    std::size_t b = 0;
    long double before = 0;
    for (const double q : qs) {
      while (b + 1 < sum.size() && before + sum[b] < q * total) before += sum[b++];
      bin_of.push_back(b);
      before_of.push_back(before);
    }
  }
  std::vector<std::pair<double, double>> in_bins;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const std::size_t k = bin(d[i]);
    if (std::find(bin_of.begin(), bin_of.end(), k) != bin_of.end())
      in_bins.emplace_back(std::abs(d[i]), w[i]);
  }
  std::sort(in_bins.begin(), in_bins.end());
  std::vector<double> out;
  for (std::size_t j = 0; j < qs.size(); ++j) {
    const long double target = qs[j] * total;
    long double acc = before_of[j];
    double value = std::bit_cast<double>(hi_key);
    for (const auto& [v, wt] : in_bins) {
      if (bin(v) != bin_of[j]) continue;
      acc += wt;
      if (acc >= target) {
        value = v;
        break;
      }
    }
    out.push_back(value);
  }
  return out;
}
}  // namespace

DeviationStats deviation_stats(std::span<const double> d, std::span<const double> area_mm2,
                               double tolerance_mm) {
  if (area_mm2.empty()) return deviation_stats(d, tolerance_mm);
  DeviationStats s;
  s.samples = d.size();
  if (d.empty()) return s;
  s.min_mm = d[0];
  s.max_mm = d[0];
  long double wsum = 0, sum = 0, sum2 = 0, sum_abs = 0, within = 0;
  std::uint64_t lo_key = ~std::uint64_t{0}, hi_key = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double v = d[i];
    const long double wt = area_mm2[i];
    s.min_mm = std::min(s.min_mm, v);
    s.max_mm = std::max(s.max_mm, v);
    wsum += wt;
    sum += wt * v;
    sum2 += wt * v * v;
    const double a = std::abs(v);
    sum_abs += wt * a;
    if (a <= tolerance_mm) within += wt;
    const std::uint64_t k = abs_bits(v);
    lo_key = std::min(lo_key, k);
    hi_key = std::max(hi_key, k);
  }
  if (!(wsum > 0)) return deviation_stats(d, tolerance_mm);
  s.mean_mm = static_cast<double>(sum / wsum);
  s.mean_abs_mm = static_cast<double>(sum_abs / wsum);
  s.rms_mm = static_cast<double>(std::sqrt(sum2 / wsum));
  const long double var = std::max<long double>(0, sum2 / wsum - (sum / wsum) * (sum / wsum));
  s.std_mm = static_cast<double>(std::sqrt(var));
  const std::vector<double> p =
      weighted_percentiles(d, area_mm2, {0.50, 0.95, 0.99}, wsum, lo_key, hi_key);
  s.p50_abs_mm = p[0];
  s.p95_abs_mm = p[1];
  s.p99_abs_mm = p[2];
  s.hausdorff_mm = std::bit_cast<double>(hi_key);
  s.within_tolerance_pct = static_cast<double>(100.0L * within / wsum);
  return s;
}

}  // namespace printtwin

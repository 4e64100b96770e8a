// Query points grouped by small cells (see point_groups.hpp).
#include "deviation/point_groups.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <tuple>

namespace printtwin::detail {

void group_by_cell(std::span<const Vec3> points, double cell_mm, std::vector<std::uint32_t>& order,
                   std::vector<std::uint32_t>& group) {
  const std::size_t n = points.size();
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  for (const Vec3& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // At most 1000 cells per axis (10 bits): a larger extent gets larger cells, never a
  // catch-all last cell.
  const double cell = n == 0 ? cell_mm : std::max(cell_mm, (hi - lo).maxCoeff() / 1000.0);
  std::vector<std::uint32_t> code(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t c[3];
    for (int a = 0; a < 3; ++a)
      c[a] = static_cast<std::uint32_t>(
          std::clamp(std::floor((points[i][a] - lo[a]) / cell), 0.0, 1023.0));
    code[i] = (c[1] << 20) | (c[0] << 10) | c[2];
  }
  // A stable sort by code: by y cell first (a counting sort, skipped when the points come
  // sorted that way, as a deposit's face centres do), then each y strip by its (x, z) code
  // in two 10-bit passes whose counters stay in L1.
  constexpr int kBits = 10;
  constexpr std::uint32_t kMask = (1U << kBits) - 1;
  order.resize(n);
  std::vector<std::uint32_t> tmp(n);
  std::array<std::uint32_t, kMask + 2> count{};
  const auto digit = [&](std::uint32_t i, int shift) { return (code[i] >> shift) & kMask; };
  bool y_sorted = true;
  for (std::size_t i = 1; i < n && y_sorted; ++i) y_sorted = (code[i] >> 20) >= (code[i - 1] >> 20);
  if (y_sorted) {
    for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
  } else {
    for (std::size_t i = 0; i < n; ++i) ++count[digit(static_cast<std::uint32_t>(i), 20) + 1];
    for (std::size_t k = 0; k <= kMask; ++k) count[k + 1] += count[k];
    for (std::size_t i = 0; i < n; ++i)
      order[count[digit(static_cast<std::uint32_t>(i), 20)]++] = static_cast<std::uint32_t>(i);
  }
  for (std::size_t lo_j = 0; lo_j < n;) {
    std::size_t hi_j = lo_j + 1;
    while (hi_j < n && (code[order[hi_j]] >> 20) == (code[order[lo_j]] >> 20)) ++hi_j;
    // order[lo_j, hi_j) -> tmp by z, then back by x (stable: ties keep their order).
    for (const auto& [from, to, shift] :
         {std::tuple{order.data(), tmp.data(), 0}, std::tuple{tmp.data(), order.data(), kBits}}) {
      count.fill(0);
      for (std::size_t j = lo_j; j < hi_j; ++j) ++count[digit(from[j], shift) + 1];
      for (std::size_t k = 0; k <= kMask; ++k) count[k + 1] += count[k];
      for (std::size_t j = lo_j; j < hi_j; ++j) to[lo_j + count[digit(from[j], shift)]++] = from[j];
    }
    lo_j = hi_j;
  }
  group.clear();
  for (std::size_t j = 0; j < n; ++j)
    if (j == 0 || code[order[j]] != code[order[j - 1]])
      group.push_back(static_cast<std::uint32_t>(j));
  group.push_back(static_cast<std::uint32_t>(n));
}

}  // namespace printtwin::detail

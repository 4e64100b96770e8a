// Query points grouped by small cells (see point_groups.hpp).
#include "deviation/point_groups.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
      c[a] = static_cast<std::uint32_t>(std::clamp(std::floor((points[i][a] - lo[a]) / cell), 0.0, 1023.0));
    code[i] = (c[1] << 20) | (c[0] << 10) | c[2];
  }
  constexpr int kBits = 15;
  constexpr std::uint32_t kMask = (1U << kBits) - 1;
  std::vector<std::uint32_t> tmp(n), count(kMask + 2);
  order.resize(n);
  for (int pass = 0; pass < 2; ++pass) {
    const int shift = pass * kBits;
    std::fill(count.begin(), count.end(), 0);
    for (std::size_t i = 0; i < n; ++i) ++count[((code[i] >> shift) & kMask) + 1];
    for (std::size_t k = 0; k <= kMask; ++k) count[k + 1] += count[k];
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t i = pass == 0 ? static_cast<std::uint32_t>(j) : tmp[j];
      (pass == 0 ? tmp : order)[count[(code[i] >> shift) & kMask]++] = i;
    }
  }
  group.clear();
  for (std::size_t j = 0; j < n; ++j)
    if (j == 0 || code[order[j]] != code[order[j - 1]]) group.push_back(static_cast<std::uint32_t>(j));
  group.push_back(static_cast<std::uint32_t>(n));
}

}  // namespace printtwin::detail

// Clusters of out-of-tolerance samples: union-find over a hash grid whose cell is the link
// radius, so only the 27 neighbouring cells are searched for each sample.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "deviation/disjoint_sets.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

using detail::DisjointSets;

std::uint64_t cell_key(std::int64_t x, std::int64_t y, std::int64_t z) {
  // 21 bits per axis (offset so negative cells map too): unique for |cell| < 2^20.
  constexpr std::int64_t kOff = std::int64_t{1} << 20;
  return (static_cast<std::uint64_t>(x + kOff) << 42) |
         (static_cast<std::uint64_t>(y + kOff) << 21) | static_cast<std::uint64_t>(z + kOff);
}

}  // namespace

std::vector<DeviationRegion> cluster_regions(std::span<const DeviationSample> samples,
                                             double tolerance_mm, double radius_mm,
                                             double area_per_sample_mm2, RegionKind kind,
                                             std::size_t max_lines,
                                             std::vector<std::int32_t>* sample_region,
                                             std::span<const double> sample_area_mm2) {
  if (sample_region != nullptr) sample_region->assign(samples.size(), -1);
  std::vector<std::uint32_t> picked;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double d = samples[i].distance_mm;
    if ((kind == RegionKind::missing && d < -tolerance_mm) ||
        (kind == RegionKind::excess && d > tolerance_mm))
      picked.push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<DeviationRegion> regions;
  if (picked.empty() || !(radius_mm > 0)) return regions;

  const auto cell = [&](const Vec3& p) {
    return Eigen::Matrix<std::int64_t, 3, 1>(
        static_cast<std::int64_t>(std::floor(p.x() / radius_mm)),
        static_cast<std::int64_t>(std::floor(p.y() / radius_mm)),
        static_cast<std::int64_t>(std::floor(p.z() / radius_mm)));
  };
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid;
  grid.reserve(picked.size());
  for (std::uint32_t k = 0; k < picked.size(); ++k) {
    const auto c = cell(samples[picked[k]].position_mm);
    grid[cell_key(c.x(), c.y(), c.z())].push_back(k);
  }
  DisjointSets sets(picked.size());
  const double r2 = radius_mm * radius_mm;
  for (std::uint32_t k = 0; k < picked.size(); ++k) {
    const Vec3& p = samples[picked[k]].position_mm;
    const auto c = cell(p);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const auto it = grid.find(cell_key(c.x() + dx, c.y() + dy, c.z() + dz));
          if (it == grid.end()) continue;
          for (const std::uint32_t o : it->second)
            if (o > k && (samples[picked[o]].position_mm - p).squaredNorm() <= r2) sets.unite(k, o);
        }
  }
  // Collect members per root, in sample order (deterministic).
  std::vector<std::uint32_t> region_of(picked.size(), 0);
  std::unordered_map<std::uint32_t, std::uint32_t> root_region;
  std::vector<std::vector<std::uint32_t>> members;
  for (std::uint32_t k = 0; k < picked.size(); ++k) {
    const std::uint32_t root = sets.find(k);
    auto [it, inserted] = root_region.try_emplace(root, static_cast<std::uint32_t>(members.size()));
    if (inserted) members.emplace_back();
    members[it->second].push_back(picked[k]);
  }
  regions.reserve(members.size());
  for (const auto& m : members) {
    DeviationRegion r;
    r.kind = kind;
    r.samples = m.size();
    if (sample_area_mm2.size() == samples.size()) {
      for (const std::uint32_t i : m) r.area_mm2 += sample_area_mm2[i];
    } else {
      r.area_mm2 = static_cast<double>(m.size()) * area_per_sample_mm2;
    }
    std::vector<std::uint32_t> by_worst(m.begin(), m.end());
    std::stable_sort(by_worst.begin(), by_worst.end(), [&](std::uint32_t a, std::uint32_t b) {
      return std::abs(samples[a].distance_mm) > std::abs(samples[b].distance_mm);
    });
    r.worst_mm = samples[by_worst.front()].distance_mm;
    r.worst_position_mm = samples[by_worst.front()].position_mm;
    for (const std::uint32_t i : m) {
      const DeviationSample& s = samples[i];
      r.bbox_mm.extend(s.position_mm);
      if (s.layer >= 0) {
        r.layer_min = r.layer_min < 0 ? s.layer : std::min(r.layer_min, static_cast<int>(s.layer));
        r.layer_max = std::max(r.layer_max, static_cast<int>(s.layer));
      }
    }
    // The G-code lines that laid the deposit nearest to the worst samples first.
    for (const std::uint32_t i : by_worst) {
      if (r.gcode_lines.size() >= max_lines) break;
      const long line = samples[i].line;
      if (line > 0 &&
          std::find(r.gcode_lines.begin(), r.gcode_lines.end(), line) == r.gcode_lines.end())
        r.gcode_lines.push_back(line);
    }
    std::sort(r.gcode_lines.begin(), r.gcode_lines.end());
    regions.push_back(std::move(r));
  }
  // Largest first; ties by worst deviation, then first sample (deterministic).
  std::vector<std::uint32_t> order(regions.size());
  std::iota(order.begin(), order.end(), 0U);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    if (regions[a].area_mm2 != regions[b].area_mm2)
      return regions[a].area_mm2 > regions[b].area_mm2;
    return std::abs(regions[a].worst_mm) > std::abs(regions[b].worst_mm);
  });
  std::vector<DeviationRegion> sorted;
  sorted.reserve(regions.size());
  for (std::size_t rank = 0; rank < order.size(); ++rank) {
    sorted.push_back(std::move(regions[order[rank]]));
    if (sample_region != nullptr)
      for (const std::uint32_t i : members[order[rank]])
        (*sample_region)[i] = static_cast<std::int32_t>(rank);
  }
  regions = std::move(sorted);
  return regions;
}

}  // namespace printtwin

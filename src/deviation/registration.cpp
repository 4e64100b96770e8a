// Registration of the mesh in the G-code frame: find the part among the extrusions, then
// centre the mesh on it the way slicers place parts.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "deviation/disjoint_sets.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

using detail::DisjointSets;

}  // namespace

PartExtent find_part_extent(std::span<const Move> moves) {
  PartExtent part;
  // Extrusions that may belong to the part.
  std::vector<const Move*> candidates;
  bool tagged = false;
  for (const Move& m : moves) {
    if (m.kind != MoveKind::extrude || m.xy_length_mm() <= 0) continue;
    if (m.feature != Feature::unknown) tagged = true;
    if (is_auxiliary_feature(m.feature)) continue;
    candidates.push_back(&m);
  }
  if (candidates.empty()) return part;
  part.method = tagged ? "tags" : "connectivity";

  // XY footprint on a raster of kCell mm; cells 8-connected. Skirts lie a few mm away from
  // the part and purge lines at the bed's edge, so they form separate components.
  constexpr double kCell = 0.5;
  Box3 all;
  for (const Move* m : candidates) {
    all.extend(m->start_mm);
    all.extend(m->end_mm);
  }
  const int nx = static_cast<int>(std::floor(all.size().x() / kCell)) + 1;
  const int ny = static_cast<int>(std::floor(all.size().y() / kCell)) + 1;
  const auto cell_of = [&](const Vec3& p) {
    const int x = std::clamp(static_cast<int>(std::floor((p.x() - all.min.x()) / kCell)), 0, nx - 1);
    const int y = std::clamp(static_cast<int>(std::floor((p.y() - all.min.y()) / kCell)), 0, ny - 1);
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(x);
  };
  std::vector<double> weight(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny), 0.0);
  std::vector<std::uint32_t> move_cell(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Move& m = *candidates[i];
    const double len = m.xy_length_mm();
    const int steps = std::max(1, static_cast<int>(std::ceil(len / (0.5 * kCell))));
    for (int s = 0; s <= steps; ++s) {
      const Vec3 p = m.start_mm + (m.end_mm - m.start_mm) * (static_cast<double>(s) / steps);
      weight[cell_of(p)] += len / (steps + 1);
    }
    move_cell[i] = static_cast<std::uint32_t>(cell_of(m.start_mm));
  }
  DisjointSets sets(weight.size());
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      const std::size_t c = static_cast<std::size_t>(y) * nx + x;
      if (weight[c] == 0) continue;
      for (int dy = 0; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          if (dy == 0 && dx <= 0) continue;
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || xx >= nx || yy >= ny) continue;
          const std::size_t n = static_cast<std::size_t>(yy) * nx + xx;
          if (weight[n] > 0) sets.unite(static_cast<std::uint32_t>(c), static_cast<std::uint32_t>(n));
        }
    }
  std::vector<double> component_weight(weight.size(), 0.0);
  for (std::size_t c = 0; c < weight.size(); ++c)
    if (weight[c] > 0) component_weight[sets.find(static_cast<std::uint32_t>(c))] += weight[c];
  const auto best = static_cast<std::uint32_t>(
      std::max_element(component_weight.begin(), component_weight.end()) - component_weight.begin());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (sets.find(move_cell[i]) != best) continue;
    part.bbox_mm.extend(candidates[i]->start_mm);
    part.bbox_mm.extend(candidates[i]->end_mm);
    ++part.moves;
  }
  return part;
}

Vec3 registration_offset(const Mesh& mesh, const PartExtent& part) {
  const Box3 mb = bounding_box(mesh);
  if (mb.empty()) return Vec3::Zero();
  if (part.bbox_mm.empty()) return Vec3(0, 0, -mb.min.z());
  const Vec3 pc = part.bbox_mm.center();
  const Vec3 mc = mb.center();
  return Vec3(pc.x() - mc.x(), pc.y() - mc.y(), -mb.min.z());
}

}  // namespace printtwin

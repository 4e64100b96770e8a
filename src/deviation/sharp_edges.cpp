// The design's sharp edges (see sharp_edges.hpp).
#include "deviation/sharp_edges.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace printtwin::detail {

SharpEdges::SharpEdges(const Mesh& mesh, double min_angle_deg, double margin_mm)
    : margin_(margin_mm), cell_(2 * margin_mm) {
  if (!(margin_mm > 0)) return;
  // Each edge's uses, sorted by the undirected edge: (low vertex, high vertex, triangle).
  std::vector<std::array<std::uint32_t, 3>> uses;
  uses.reserve(3 * mesh.triangles.size());
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t u = mesh.triangles[t][static_cast<std::size_t>(k)],
                          w = mesh.triangles[t][static_cast<std::size_t>((k + 1) % 3)];
      uses.push_back({std::min(u, w), std::max(u, w), t});
    }
  std::sort(uses.begin(), uses.end());
  const double cos_min = std::cos(min_angle_deg * std::numbers::pi / 180.0);
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i + 1;
    while (j < uses.size() && uses[j][0] == uses[i][0] && uses[j][1] == uses[i][1]) ++j;
    bool sharp = j - i != 2;  // open or non-manifold
    if (!sharp) {
      const Vec3 n0 = triangle_normal(mesh, uses[i][2]), n1 = triangle_normal(mesh, uses[i + 1][2]);
      const double l = n0.norm() * n1.norm();
      sharp = l > 0 && n0.dot(n1) < cos_min * l;
    }
    if (sharp) {
      a_.push_back(mesh.vertices_mm[uses[i][0]]);
      b_.push_back(mesh.vertices_mm[uses[i][1]]);
    }
    i = j;
  }
  // Each edge in the cells round points along it, half a cell apart: a point within the
  // margin of the edge is within 3/4 of a cell of one of them, so in one of those cells.
  for (std::uint32_t e = 0; e < a_.size(); ++e) {
    const Vec3 d = b_[e] - a_[e];
    const int steps = 1 + static_cast<int>(std::ceil(d.norm() / (0.5 * cell_)));
    std::vector<std::uint64_t> keys;
    for (int s = 0; s <= steps; ++s) {
      const Vec3 p = a_[e] + (static_cast<double>(s) / steps) * d;
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) keys.push_back(key(p + cell_ * Vec3(dx, dy, dz)));
    }
    std::sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    for (const std::uint64_t k : keys) cells_[k].push_back(e);
  }
}

std::uint64_t SharpEdges::key(const Vec3& p) const {
  std::uint64_t k = 0;
  for (int a = 0; a < 3; ++a)  // 21 bits per axis, wrapped: a collision only costs a test
    k = (k << 21) |
        (static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(p[a] / cell_))) &
         0x1FFFFFu);
  return k;
}

bool SharpEdges::near(const Vec3& p) const {
  if (cells_.empty()) return false;
  const auto it = cells_.find(key(p));
  if (it == cells_.end()) return false;
  for (const std::uint32_t e : it->second) {
    const Vec3 d = b_[e] - a_[e];
    const double len2 = d.squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - a_[e]).dot(d) / len2, 0.0, 1.0) : 0.0;
    if ((a_[e] + t * d - p).squaredNorm() <= margin_ * margin_) return true;
  }
  return false;
}

}  // namespace printtwin::detail

// Horizontal cross-sections of a mesh for the layer viewer: every triangle is visited once
// and cut by the planes it spans; cut segments are chained into polylines through the mesh
// edges they share and simplified with Douglas-Peucker.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "printtwin/report.hpp"

namespace printtwin {

namespace {

struct CutSegment {
  std::uint64_t key_a, key_b;  // mesh edges the segment ends on
  Vec2 a, b;
};

std::uint64_t edge_key(std::uint32_t u, std::uint32_t v) {
  if (u > v) std::swap(u, v);
  return (static_cast<std::uint64_t>(u) << 32) | v;
}

// Where edge (u, v) crosses z; computed from the lower-index end so that the two triangles
// sharing the edge get bit-identical points.
Vec2 edge_point(const Mesh& mesh, std::uint32_t u, std::uint32_t v, double z) {
  if (u > v) std::swap(u, v);
  const Vec3& p = mesh.vertices_mm[u];
  const Vec3& q = mesh.vertices_mm[v];
  const double dz = q.z() - p.z();
  const double t = dz != 0 ? std::clamp((z - p.z()) / dz, 0.0, 1.0) : 0.5;
  return Vec2(p.x() + t * (q.x() - p.x()), p.y() + t * (q.y() - p.y()));
}

void douglas_peucker(const std::vector<Vec2>& pts, std::size_t first, std::size_t last, double eps2,
                     std::vector<char>& keep) {
  // Iterative with an explicit stack (long loops would recurse deeply).
  std::vector<std::pair<std::size_t, std::size_t>> stack{{first, last}};
  while (!stack.empty()) {
    const auto [i0, i1] = stack.back();
    stack.pop_back();
    if (i1 <= i0 + 1) continue;
    const Vec2& a = pts[i0];
    const Vec2 ab = pts[i1] - pts[i0];
    const double len2 = ab.squaredNorm();
    double worst = -1;
    std::size_t worst_i = i0;
    for (std::size_t i = i0 + 1; i < i1; ++i) {
      const Vec2 ap = pts[i] - a;
      double d2;
      if (len2 > 0) {
        const double t = std::clamp(ap.dot(ab) / len2, 0.0, 1.0);
        d2 = (ap - t * ab).squaredNorm();
      } else {
        d2 = ap.squaredNorm();
      }
      if (d2 > worst) worst = d2, worst_i = i;
    }
    if (worst > eps2) {
      keep[worst_i] = 1;
      stack.push_back({i0, worst_i});
      stack.push_back({worst_i, i1});
    }
  }
}

std::vector<Vec2> simplify(const std::vector<Vec2>& pts, double eps) {
  if (pts.size() <= 3 || !(eps > 0)) return pts;
  std::vector<char> keep(pts.size(), 0);
  keep.front() = keep.back() = 1;
  // A closed loop (first == last) is split at its farthest point so both halves keep shape.
  std::size_t far = pts.size() - 1;
  if ((pts.front() - pts.back()).squaredNorm() == 0) {
    double best = -1;
    for (std::size_t i = 1; i + 1 < pts.size(); ++i) {
      const double d2 = (pts[i] - pts.front()).squaredNorm();
      if (d2 > best) best = d2, far = i;
    }
    keep[far] = 1;
  }
  douglas_peucker(pts, 0, far, eps * eps, keep);
  douglas_peucker(pts, far, pts.size() - 1, eps * eps, keep);
  std::vector<Vec2> out;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (keep[i]) out.push_back(pts[i]);
  // The chain started wherever the first cut segment was: drop that start point of a closed
  // loop when it lies on the line of its neighbours.
  if (far != pts.size() - 1 && out.size() >= 5) {
    const Vec2 a = out[out.size() - 2], b = out[1], p = out[0];
    const Vec2 ab = b - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    if ((p - a - t * ab).squaredNorm() <= eps * eps) {
      out.pop_back();
      out.erase(out.begin());
      out.push_back(out.front());
    }
  }
  return out;
}

std::vector<std::vector<Vec2>> chain(const std::vector<CutSegment>& segs, double simplify_mm) {
  std::unordered_map<std::uint64_t, std::array<std::uint32_t, 2>> at_edge;
  at_edge.reserve(segs.size() * 2);
  constexpr std::uint32_t kFree = std::numeric_limits<std::uint32_t>::max();
  auto add = [&](std::uint64_t key, std::uint32_t s) {
    auto [it, inserted] = at_edge.try_emplace(key, std::array<std::uint32_t, 2>{kFree, kFree});
    auto& slots = it->second;
    if (slots[0] == kFree)
      slots[0] = s;
    else if (slots[1] == kFree)
      slots[1] = s;  // non-manifold extras start their own chain
  };
  for (std::uint32_t s = 0; s < segs.size(); ++s) {
    add(segs[s].key_a, s);
    add(segs[s].key_b, s);
  }
  std::vector<char> used(segs.size(), 0);
  // Next unused segment at `key`, and the key at its far end.
  auto next = [&](std::uint64_t key, std::uint32_t& seg, std::uint64_t& far_key, Vec2& far_pt) {
    const auto it = at_edge.find(key);
    if (it == at_edge.end()) return false;
    for (std::uint32_t s : it->second) {
      if (s == kFree || used[s]) continue;
      used[s] = 1;
      seg = s;
      const bool forward = segs[s].key_a == key;
      far_key = forward ? segs[s].key_b : segs[s].key_a;
      far_pt = forward ? segs[s].b : segs[s].a;
      return true;
    }
    return false;
  };
  std::vector<std::vector<Vec2>> loops;
  for (std::uint32_t s0 = 0; s0 < segs.size(); ++s0) {
    if (used[s0]) continue;
    used[s0] = 1;
    std::vector<Vec2> fwd{segs[s0].a, segs[s0].b};
    std::uint64_t key = segs[s0].key_b;
    std::uint32_t s;
    std::uint64_t far_key;
    Vec2 pt;
    while (next(key, s, far_key, pt)) fwd.push_back(pt), key = far_key;
    std::vector<Vec2> back;
    key = segs[s0].key_a;
    while (next(key, s, far_key, pt)) back.push_back(pt), key = far_key;
    std::vector<Vec2> poly(back.rbegin(), back.rend());
    poly.insert(poly.end(), fwd.begin(), fwd.end());
    loops.push_back(simplify(poly, simplify_mm));
  }
  return loops;
}

}  // namespace

std::vector<std::vector<std::vector<Vec2>>> cut_mesh(const Mesh& mesh, std::span<const double> z_mm,
                                                     double simplify_mm) {
  std::vector<std::size_t> order(z_mm.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return z_mm[a] < z_mm[b]; });
  std::vector<double> sorted_z(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted_z[i] = z_mm[order[i]];

  std::vector<std::vector<CutSegment>> segs(z_mm.size());
  for (const auto& t : mesh.triangles) {
    const double z0 = mesh.vertices_mm[t[0]].z(), z1 = mesh.vertices_mm[t[1]].z(),
                 z2 = mesh.vertices_mm[t[2]].z();
    const double lo = std::min({z0, z1, z2}), hi = std::max({z0, z1, z2});
    // Planes with lo < z <= hi: some vertex below (z_v < z), some at or above.
    auto it = std::upper_bound(sorted_z.begin(), sorted_z.end(), lo);
    for (; it != sorted_z.end() && *it <= hi; ++it) {
      const double z = *it;
      std::array<std::uint64_t, 2> keys{};
      std::array<Vec2, 2> pts;
      int n = 0;
      for (int e = 0; e < 3 && n < 2; ++e) {
        const std::uint32_t u = t[e], v = t[(e + 1) % 3];
        const bool below_u = mesh.vertices_mm[u].z() < z, below_v = mesh.vertices_mm[v].z() < z;
        if (below_u == below_v) continue;
        keys[n] = edge_key(u, v);
        pts[n] = edge_point(mesh, u, v, z);
        ++n;
      }
      if (n == 2)
        segs[order[static_cast<std::size_t>(it - sorted_z.begin())]].push_back(
            {keys[0], keys[1], pts[0], pts[1]});
    }
  }
  std::vector<std::vector<std::vector<Vec2>>> out(z_mm.size());
  for (std::size_t i = 0; i < z_mm.size(); ++i) out[i] = chain(segs[i], simplify_mm);
  return out;
}

}  // namespace printtwin

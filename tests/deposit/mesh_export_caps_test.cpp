// The caps' planar walk (src/deposit/mesh_export_caps.cpp) on rings built here: crossing
// rings, rings crossing at shallow angles all along, coincident stretches, rings a few
// micrometres apart, holes and islands. Each cap must close with its rings (every edge once
// each way), face up where only the lower region is and down where only the upper one is,
// and cover the exclusive-or of the two regions.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <vector>

#include "deposit/mesh_export_caps.hpp"
#include "deposit/mesh_export_internal.hpp"

namespace printtwin {
namespace {

using P2 = Eigen::Vector2d;
using Ring = std::vector<P2>;

double ring_area(const Ring& r) {
  double a = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    const P2& p = r[i];
    const P2& q = r[(i + 1) % r.size()];
    a += p.x() * q.y() - p.y() * q.x();
  }
  return 0.5 * a;
}

Ring rect(double x0, double y0, double x1, double y1) {
  return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
}

Ring reversed(Ring r) {
  std::reverse(r.begin(), r.end());
  return r;
}

/// A closed curve of n points at radius r(theta) around c, counter-clockwise.
template <class Radius>
Ring curve(const P2& c, int n, Radius radius, double phase = 0) {
  Ring r;
  for (int i = 0; i < n; ++i) {
    const double t = phase + 2 * std::numbers::pi * i / n;
    r.push_back(c + radius(t) * P2(std::cos(t), std::sin(t)));
  }
  return r;
}

struct Areas {
  double up = 0, down = 0;  // facing up (lower region only), facing down (upper only)
  int flat = 0;             // triangles of no area
};

Areas cap_areas(const detail::Boundary& b) {
  Areas a;
  for (const auto& t : b.tris) {
    const P2 u = b.verts[t[1]] - b.verts[t[0]], v = b.verts[t[2]] - b.verts[t[0]];
    const double s = 0.5 * (u.x() * v.y() - u.y() * v.x());
    (s > 0 ? a.up : a.down) += std::abs(s);
    a.flat += s == 0 ? 1 : 0;
  }
  return a;
}

/// The cap with the rings' own edges (a lower ring's sub-edge a -> b taken as b -> a, an
/// upper one's as a -> b, as the slabs' sides take them): every directed edge once, and its
/// reverse once.
bool closes_with_rings(const detail::Boundary& b, std::size_t n_rings, std::size_t n_below) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
  for (const auto& t : b.tris)
    for (int k = 0; k < 3; ++k) ++uses[{t[k], t[(k + 1) % 3]}];
  for (std::size_t r = 0; r < n_rings; ++r) {
    const std::uint32_t first = b.pos[b.pos_base[r]];
    const std::size_t n =
        r + 1 < n_rings ? b.pos_base[r + 1] - b.pos_base[r] - 1 : b.pos.size() - b.pos_base[r] - 1;
    const std::uint32_t last = b.pos[b.pos_base[r] + n];
    for (std::uint32_t i = first; i < last; ++i) {
      const std::uint32_t p = b.seq[i], q = b.seq[i + 1];
      if (p == q) continue;
      ++uses[r < n_below ? std::pair{q, p} : std::pair{p, q}];
    }
  }
  for (const auto& [e, n] : uses) {
    if (n != 1) return false;
    const auto back = uses.find({e.second, e.first});
    if (back == uses.end() || back->second != 1) return false;
  }
  return true;
}

/// The cap by the walk, checked closed; `ok` false when the walk gave up.
detail::Boundary walk(const std::vector<Ring>& lower, const std::vector<Ring>& upper, bool& ok,
                      const detail::CapExtras& extras = {}) {
  std::vector<detail::CapRing> rings(lower.begin(), lower.end());
  rings.insert(rings.end(), upper.begin(), upper.end());
  detail::Boundary b;
  ok = detail::cap_by_walk(rings, lower.size(), extras, b);
  if (ok) {
    EXPECT_TRUE(closes_with_rings(b, rings.size(), lower.size()));
    EXPECT_EQ(cap_areas(b).flat, 0);
  }
  return b;
}

/// The exclusive-or's areas by CGAL's exact triangulation of all rings (the reference).
Areas reference(const std::vector<Ring>& lower, const std::vector<Ring>& upper) {
  const detail::LayerCap cap = detail::layer_cap(lower, upper, 0.0, true);
  EXPECT_TRUE(cap.ok);
  detail::Boundary b;
  b.verts = cap.vertices;
  b.tris = cap.triangles;
  return cap_areas(b);
}

TEST(CapWalk, TwoOffsetSquares) {
  bool ok = false;
  const auto b = walk({rect(0, 0, 10, 10)}, {rect(1, -1, 11, 9)}, ok);
  ASSERT_TRUE(ok);
  const Areas a = cap_areas(b);
  EXPECT_NEAR(a.up, 19.0, 1e-9);  // 100 - 81
  EXPECT_NEAR(a.down, 19.0, 1e-9);
}

TEST(CapWalk, ShallowCrossingsAllAlong) {
  // Two outlines of one wall, their vertices in different places, crossing about 40 times.
  const Ring lower = curve(P2(3, 4), 211, [](double t) { return 5.0 + 0.002 * std::sin(20 * t); });
  const Ring upper = curve(
      P2(3, 4), 157, [](double t) { return 5.0 + 0.0021 * std::cos(20 * t + 0.3); }, 0.01);
  bool ok = false;
  const auto b = walk({lower}, {upper}, ok);
  ASSERT_TRUE(ok);
  const Areas a = cap_areas(b), ref = reference({lower}, {upper});
  EXPECT_GT(a.up, 0.0);
  EXPECT_NEAR(a.up, ref.up, 1e-9);
  EXPECT_NEAR(a.down, ref.down, 1e-9);
  EXPECT_NEAR(a.up - a.down, ring_area(lower) - ring_area(upper), 1e-9);
  // The same input, the same cap.
  bool again = false;
  const auto b2 = walk({lower}, {upper}, again);
  EXPECT_EQ(b2.tris, b.tris);
  EXPECT_EQ(b2.seq, b.seq);
}

TEST(CapWalk, CoincidentStretches) {
  // Three sides shared exactly, the fourth pushed out above: the cap is the step only.
  const Ring lower = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
  const Ring upper = {{0, 0}, {10, 0}, {12, 5}, {10, 10}, {0, 10}};
  bool ok = false;
  const auto b = walk({lower}, {upper}, ok);
  ASSERT_TRUE(ok);
  const Areas a = cap_areas(b);
  EXPECT_NEAR(a.up, 0.0, 1e-12);
  EXPECT_NEAR(a.down, 10.0, 1e-9);
  // Shared in part: the upper ring's points on the lower ring's edges, put on them as split
  // points (as the snapping does), and a notch between two of them.
  const Ring split = {{0, 0}, {5, 0}, {10, 0}, {10, 4}, {9, 6}, {10, 8}, {10, 10}, {0, 10}};
  detail::Boundary plain;
  EXPECT_FALSE(detail::cap_by_walk({lower, split}, 1, {}, plain));  // overlapping edges
  const detail::CapExtras extras{{{0, 0.5, P2(5, 0)}, {1, 0.4, P2(10, 4)}, {1, 0.8, P2(10, 8)}},
                                 {}};
  const auto c = walk({lower}, {split}, ok, extras);
  ASSERT_TRUE(ok);
  EXPECT_NEAR(cap_areas(c).up, 2.0, 1e-9);
}

TEST(CapWalk, RingsAFewMicrometresApart) {
  // The upper ring's vertices 2-3 um to either side of the lower ring's edges.
  Ring lower, upper;
  for (int i = 0; i < 40; ++i) lower.emplace_back(0.25 * i, 0.0);
  for (int i = 0; i < 20; ++i) lower.emplace_back(10.0, 0.5 * i);
  for (int i = 40; i > 0; --i) lower.emplace_back(0.25 * i, 10.0);
  for (int i = 20; i > 0; --i) lower.emplace_back(0.0, 0.5 * i);
  for (std::size_t i = 0; i < lower.size(); ++i) {
    const P2 mid = 0.5 * (lower[i] + lower[(i + 1) % lower.size()]);
    const P2 in = P2(5, 5) - mid;
    upper.push_back(mid + (i % 3 == 0 ? 0.003 : -0.002) * in.normalized());
  }
  bool ok = false;
  const auto b = walk({lower}, {upper}, ok);
  ASSERT_TRUE(ok);
  const Areas a = cap_areas(b), ref = reference({lower}, {upper});
  EXPECT_NEAR(a.up, ref.up, 1e-9);
  EXPECT_NEAR(a.down, ref.down, 1e-9);
  // Through the snapping of the slabs' caps: the walk's cap covers the same area.
  const detail::LayerCap snapped = detail::layer_cap({lower}, {upper}, 0.005);
  const detail::LayerCap exact = detail::layer_cap({lower}, {upper}, 0.005, true);
  ASSERT_TRUE(snapped.ok);
  ASSERT_TRUE(exact.ok);
  double s = 0, e = 0;
  for (const auto* c : {&snapped, &exact})
    for (const auto& t : c->triangles) {
      const P2 u = c->vertices[t[1]] - c->vertices[t[0]], v = c->vertices[t[2]] - c->vertices[t[0]];
      (c == &snapped ? s : e) += std::abs(u.x() * v.y() - u.y() * v.x());
    }
  EXPECT_NEAR(s, e, 1e-9);
}

TEST(CapWalk, HolesAndIslands) {
  const Ring outer = rect(0, 0, 10, 10), hole = reversed(rect(3, 3, 7, 7));
  bool ok = false;
  // The bottom of a part with a hole: one face with a hole, facing down.
  auto b = walk({}, {outer, hole}, ok);
  ASSERT_TRUE(ok);
  EXPECT_NEAR(cap_areas(b).down, 84.0, 1e-9);
  EXPECT_NEAR(cap_areas(b).up, 0.0, 1e-12);
  // Its top, with an island above inside the hole (a face with a hole, and one without).
  const Ring island = rect(4, 4, 6, 6);
  b = walk({outer, hole}, {island}, ok);
  ASSERT_TRUE(ok);
  EXPECT_NEAR(cap_areas(b).up, 84.0, 1e-9);
  EXPECT_NEAR(cap_areas(b).down, 4.0, 1e-9);
  // An island above on the solid part: a hole in the lower region's face.
  b = walk({outer, hole}, {rect(0.5, 0.5, 2.5, 2.5)}, ok);
  ASSERT_TRUE(ok);
  EXPECT_NEAR(cap_areas(b).up, 80.0, 1e-9);
  EXPECT_NEAR(cap_areas(b).down, 0.0, 1e-12);
  // A hole that grows, crossing the one below.
  const Ring hole2 = reversed(curve(P2(5, 5), 37, [](double) { return 2.4; }));
  b = walk({outer, hole}, {outer, hole2}, ok);
  ASSERT_TRUE(ok);
  const Areas ref = reference({outer, hole}, {outer, hole2});
  EXPECT_NEAR(cap_areas(b).up, ref.up, 1e-9);
  EXPECT_NEAR(cap_areas(b).down, ref.down, 1e-9);
}

TEST(CapWalk, LargeFacesAndManyPieces) {
  // A round top (one face of many points) and a row of small islands below it.
  std::vector<Ring> lower{curve(P2(0, 0), 500, [](double) { return 20.0; })};
  std::vector<Ring> upper;
  for (int i = 0; i < 10; ++i) upper.push_back(rect(-10 + 2 * i, -1, -9 + 2 * i, 1));
  bool ok = false;
  const auto b = walk(lower, upper, ok);
  ASSERT_TRUE(ok);
  EXPECT_NEAR(cap_areas(b).up, ring_area(lower[0]) - 20.0, 1e-9);
}

TEST(CapWalk, ListsRingsCrossingTheirSetAndGivesUpOnTouches) {
  // The two lower rings cross: both listed, as the triangulation finds them.
  std::vector<detail::CapRing> rings{rect(0, 0, 4, 4), rect(2, 2, 6, 6), rect(1, 1, 5, 5)};
  detail::Boundary b;
  ASSERT_TRUE(detail::cap_by_walk(rings, 2, {}, b));
  EXPECT_EQ(b.crossed, (std::vector<std::array<std::size_t, 2>>{{0, 0}, {0, 1}}));
  EXPECT_TRUE(b.tris.empty());
  EXPECT_FALSE(detail::layer_cap({rings[0], rings[1]}, {rings[2]}, 0.0).ok);
  // An upper ring folding over itself (a figure eight).
  rings = {rect(0, 0, 4, 4), {{1, 1}, {3, 3}, {3, 1}, {1, 3}}};
  ASSERT_TRUE(detail::cap_by_walk(rings, 1, {}, b));
  EXPECT_EQ(b.crossed, (std::vector<std::array<std::size_t, 2>>{{1, 0}}));
  // A ring touching the other set without sharing the point: the triangulation's case.
  rings = {rect(0, 0, 4, 4), {{4, 1}, {6, 1}, {6, 3}}};
  EXPECT_FALSE(detail::cap_by_walk(rings, 1, {}, b));
  EXPECT_TRUE(detail::layer_cap({rings[0]}, {rings[1]}, 0.0).ok);
}

}  // namespace
}  // namespace printtwin

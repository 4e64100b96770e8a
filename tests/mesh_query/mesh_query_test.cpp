#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>
#include <vector>

#include "mesh/mesh_query_ball.hpp"
#include "mesh/mesh_query_rays.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

// Brute force over all triangles: the reference for the BVH query.
ClosestPoint brute_force(const Mesh& m, const Vec3& p) {
  ClosestPoint best{Vec3::Zero(), 1e300, 0};
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    const Vec3 q = closest_point_on_triangle(p, m.vertices_mm[tri[0]], m.vertices_mm[tri[1]],
                                             m.vertices_mm[tri[2]]);
    const double d = (q - p).norm();
    if (d < best.distance_mm) best = {q, d, t};
  }
  return best;
}

// n points in a box 10 mm around the 20 mm test cube at (100, 100, 0).
std::vector<Vec3> points_near_cube(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(90, 130);
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i) {
    const double x = u(rng), y = u(rng), z = u(rng) - 100;
    pts.emplace_back(x, y, z);
  }
  return pts;
}

TEST(MeshQuery, ClosestPointMatchesBruteForce) {
  const Mesh cube = test::make_cube_mm(20.0, Vec3(100, 100, 0));
  auto q = MeshQuery::build(cube);
  ASSERT_TRUE(q.ok());
  std::mt19937 rng(7);
  const std::vector<Vec3> pts = points_near_cube(rng, 500);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Vec3& p = pts[i];
    const auto got = q->closest_point(p);
    const auto want = brute_force(cube, p);
    EXPECT_NEAR(got.distance_mm, want.distance_mm, 1e-9 * (1 + want.distance_mm))
        << "seed 7, i " << i;
  }
}

TEST(MeshQuery, HintsNeverChangeTheClosestPoints) {
  // Hinted batches (the right triangle, a neighbour's, a random one, an invalid index) give
  // closest_points' answers bit for bit, ties on the cube's edges and corners included.
  const Mesh cube = test::make_cube_mm(20.0, Vec3(100, 100, 0));
  auto q = MeshQuery::build(cube);
  ASSERT_TRUE(q.ok());
  std::mt19937 rng(11);
  std::vector<Vec3> pts = points_near_cube(rng, 2000);
  pts.emplace_back(110, 110, 25);  // above the top face's diagonal (a tie)
  pts.emplace_back(125, 125, 25);  // beyond a corner (ties of three faces)
  pts.emplace_back(100, 100, 0);   // on a corner
  std::vector<ClosestPoint> want;
  q->closest_points(pts, want);
  std::uniform_int_distribution<std::uint32_t> tri(0, 11);
  for (int variant = 0; variant < 4; ++variant) {
    std::vector<std::uint32_t> hints(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i)
      hints[i] = variant == 0   ? want[i].triangle
                 : variant == 1 ? want[(i + 1) % pts.size()].triangle
                 : variant == 2 ? tri(rng)
                                : 1000;  // out of range: ignored
    std::vector<ClosestPoint> got;
    q->closest_points(pts, got, hints);
    ASSERT_EQ(got.size(), pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      EXPECT_EQ(got[i].triangle, want[i].triangle) << variant << " " << i;
      EXPECT_EQ(got[i].distance_mm, want[i].distance_mm) << variant << " " << i;
      EXPECT_EQ(got[i].point_mm, want[i].point_mm) << variant << " " << i;
    }
  }
}

TEST(MeshQuery, BallQueryGivesClosestPointsBitForBitOrNothing) {
  // A wavy height field of 2 x 40 x 40 triangles (10 x 10 mm): groups of nearby points around
  // random centres, one ball query per group. Every answer it vouches for is exactly
  // closest_point's (same point, distance and triangle); points the ball cannot vouch for
  // (the group's far ones) get nothing.
  Mesh m;
  constexpr int kN = 40;
  for (int j = 0; j <= kN; ++j)
    for (int i = 0; i <= kN; ++i) {
      const double x = 10.0 * i / kN, y = 10.0 * j / kN;
      m.vertices_mm.emplace_back(x, y, 0.5 * std::sin(x) * std::cos(0.7 * y));
    }
  const auto vid = [](int i, int j) { return static_cast<std::uint32_t>(j * (kN + 1) + i); };
  for (int j = 0; j < kN; ++j)
    for (int i = 0; i < kN; ++i) {
      m.triangles.push_back({vid(i, j), vid(i + 1, j), vid(i + 1, j + 1)});
      m.triangles.push_back({vid(i, j), vid(i + 1, j + 1), vid(i, j + 1)});
    }
  auto q = MeshQuery::build(m);
  ASSERT_TRUE(q.ok());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(1, 9), jitter(-0.1, 0.1), far(-2.0, 2.0);
  int vouched = 0, empty = 0;
  detail::BallScratch scratch;
  for (int g = 0; g < 200; ++g) {
    const Vec3 c(u(rng), u(rng), jitter(rng));
    std::vector<Vec3> pts;
    for (int k = 0; k < 12; ++k) pts.push_back(c + Vec3(jitter(rng), jitter(rng), jitter(rng)));
    pts.push_back(c + Vec3(0, 0, far(rng)));  // often beyond the ball
    std::vector<std::optional<ClosestPoint>> out;
    detail::closest_points_in_ball(*q, c, 0.3, pts, out, scratch);
    ASSERT_EQ(out.size(), pts.size());
    for (std::size_t k = 0; k < pts.size(); ++k) {
      const ClosestPoint want = q->closest_point(pts[k]);
      if (!out[k]) {
        ++empty;
        // Nothing only when the point's ball of its distance is not inside the query ball.
        EXPECT_GT((pts[k] - c).norm() + want.distance_mm, 0.3 * (1 - 1e-6)) << g << " " << k;
        continue;
      }
      ++vouched;
      EXPECT_EQ(out[k]->triangle, want.triangle) << g << " " << k;
      EXPECT_EQ(out[k]->distance_mm, want.distance_mm) << g << " " << k;
      EXPECT_EQ(out[k]->point_mm, want.point_mm) << g << " " << k;
    }
  }
  EXPECT_GT(vouched, 1000);
  EXPECT_GT(empty, 20);
}

TEST(MeshQuery, BallQueryOnATriangleSoupMatchesClosestPointInEveryRegion) {
  // Small random triangles (every Voronoi region of a triangle gets points: corners, edges,
  // interior) plus degenerate ones (a repeated vertex, three collinear vertices, a sliver),
  // queried by balls: the ball query's candidates go through the 4-wide exact test where the
  // CPU has AVX2, so its answers must be closest_point's (scalar) bit for bit, and both the
  // brute force's.
  Mesh m;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> pos(0, 4), edge(-0.4, 0.4);
  const auto add = [&](const Vec3& a, const Vec3& b, const Vec3& c) {
    const auto i = static_cast<std::uint32_t>(m.vertices_mm.size());
    m.vertices_mm.push_back(a);
    m.vertices_mm.push_back(b);
    m.vertices_mm.push_back(c);
    m.triangles.push_back({i, i + 1, i + 2});
  };
  for (int t = 0; t < 600; ++t) {
    const Vec3 a(pos(rng), pos(rng), pos(rng));
    const Vec3 b = a + Vec3(edge(rng), edge(rng), edge(rng));
    switch (t % 10) {
      case 0:
        add(a, a, b);
        break;  // repeated vertex
      case 1:
        add(a, b, a + 2.0 * (b - a));
        break;  // collinear
      case 2:
        add(a, b, b + Vec3(1e-12, 0, 0));
        break;  // sliver
      default:
        add(a, b, a + Vec3(edge(rng), edge(rng), edge(rng)));
    }
  }
  auto q = MeshQuery::build(m);
  ASSERT_TRUE(q.ok());
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  detail::BallScratch scratch;
  int vouched = 0;
  for (int g = 0; g < 300; ++g) {
    const Vec3 c(pos(rng), pos(rng), pos(rng));
    std::vector<Vec3> pts;
    for (int k = 0; k < 16; ++k) pts.push_back(c + Vec3(jitter(rng), jitter(rng), jitter(rng)));
    std::vector<std::optional<ClosestPoint>> out;
    detail::closest_points_in_ball(*q, c, 0.8, pts, out, scratch);
    for (std::size_t k = 0; k < pts.size(); ++k) {
      if (!out[k]) continue;
      ++vouched;
      const ClosestPoint want = q->closest_point(pts[k]);
      EXPECT_EQ(out[k]->triangle, want.triangle) << g << " " << k;
      EXPECT_EQ(out[k]->distance_mm, want.distance_mm) << g << " " << k;
      EXPECT_EQ(out[k]->point_mm, want.point_mm) << g << " " << k;
      // And both are the brute force's (slivers included: their plane is no bound).
      const ClosestPoint bf = brute_force(m, pts[k]);
      EXPECT_EQ(want.triangle, bf.triangle) << g << " " << k;
      EXPECT_EQ(want.distance_mm, bf.distance_mm) << g << " " << k;
    }
  }
  EXPECT_GT(vouched, 1000);
}

TEST(MeshQuery, KnownDistancesAndSigns) {
  const Mesh cube = test::make_cube_mm(10.0);
  auto q = MeshQuery::build(cube);
  ASSERT_TRUE(q.ok());
  EXPECT_NEAR(q->signed_distance(Vec3(5, 5, 5)), -5.0, 1e-12);
  EXPECT_NEAR(q->signed_distance(Vec3(5, 5, 10.1)), 0.1, 1e-12);
  EXPECT_NEAR(q->signed_distance(Vec3(5, 5, 9.9)), -0.1, 1e-12);
  EXPECT_NEAR(q->signed_distance(Vec3(13, 14, 5)), 5.0, 1e-12);
  EXPECT_TRUE(q->inside(Vec3(0.001, 0.001, 0.001)));
  EXPECT_FALSE(q->inside(Vec3(-0.001, 5, 5)));
}

TEST(MeshQuery, RaysHitTheNearFaceAndCountCrossings) {
  const Mesh cube = test::make_cube_mm(10.0);
  auto q = MeshQuery::build(cube);
  ASSERT_TRUE(q.ok());
  auto hit = q->first_hit(Vec3(5, 5, 5), Vec3(0, 0, 1));
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->t_mm, 5.0, 1e-5);
  EXPECT_NEAR(hit->normal.z(), 1.0, 1e-12);
  EXPECT_EQ(q->crossings(Vec3(-5, 3.3, 4.4), Vec3(1, 0.01, 0.02)), 2);
  EXPECT_FALSE(q->first_hit(Vec3(5, 5, 5), Vec3(0, 0, 1), 0.0, 4.0).has_value());
  // Through a shared edge (diagonal of the top face): still one crossing.
  EXPECT_EQ(q->crossings(Vec3(5, 5, 20), Vec3(0, 0, -1)), 2);
}

/// A cube with every face repeated the other way round (coincident faces, as in a mesh with
/// duplicate facets).
Mesh doubled_cube() {
  Mesh cube = test::make_cube_mm(10.0);
  const std::size_t n = cube.triangles.size();
  for (std::size_t t = 0; t < n; ++t) {
    const auto tri = cube.triangles[t];
    cube.triangles.push_back({tri[0], tri[2], tri[1]});
  }
  return cube;
}

TEST(MeshQuery, RayOnlyBuildGivesTheSameHitsAndBreaksTiesByLowestTriangle) {
  // Every ray hits two triangles at the same distance.
  const Mesh cube = doubled_cube();
  const std::size_t n = cube.triangles.size() / 2;
  auto full = MeshQuery::build(cube);
  auto rays = MeshQuery::build_for_rays(cube);
  ASSERT_TRUE(full.ok());
  ASSERT_TRUE(rays.ok());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 500; ++i) {
    const Vec3 origin(5 + 4 * u(rng), 5 + 4 * u(rng), 5 + 4 * u(rng));
    const Vec3 dir(u(rng), u(rng), u(rng));
    const auto a = full->first_hit(origin, dir);
    const auto b = rays->first_hit(origin, dir);
    ASSERT_TRUE(a.has_value());
    ASSERT_TRUE(b.has_value());
    EXPECT_EQ(a->t_mm, b->t_mm);
    EXPECT_EQ(a->triangle, b->triangle);
    EXPECT_LT(a->triangle, n);  // of two coincident faces, the first
    EXPECT_EQ(a->normal, b->normal);
  }
  EXPECT_EQ(rays->crossings(Vec3(5, 5, 20), Vec3(0, 0, -1)), 2);
}

TEST(MeshQuery, RayStreamGivesTheHitsOfSingleRays) {
  // Coincident faces (ties at every hit), rays from inside and outside, bounded and
  // unbounded, some missing everything, and one without a direction.
  const Mesh cube = doubled_cube();
  const std::size_t n = cube.triangles.size() / 2;
  auto q = MeshQuery::build_for_rays(cube);
  ASSERT_TRUE(q.ok());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<detail::RayRequest> rays;
  for (int i = 0; i < 300; ++i)
    rays.push_back({Vec3(5 + 8 * u(rng), 5 + 8 * u(rng), 5 + 8 * u(rng)),
                    Vec3(u(rng), u(rng), u(rng)), 1e-4, i % 3 == 0 ? 3.0 : 1e30});
  rays.push_back({Vec3(5, 5, 5), Vec3::Zero(), 0, 1e30});
  std::vector<std::optional<RayHit>> hits(rays.size());
  detail::first_hits(*q, rays, hits);
  int hit_count = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const auto one = q->first_hit(rays[i].origin, rays[i].dir, rays[i].t_min, rays[i].t_max);
    ASSERT_EQ(one.has_value(), hits[i].has_value()) << "ray " << i;
    if (!one) continue;
    ++hit_count;
    EXPECT_EQ(one->t_mm, hits[i]->t_mm);
    EXPECT_EQ(one->triangle, hits[i]->triangle);
    EXPECT_LT(hits[i]->triangle, n);  // of two coincident faces, the first
    EXPECT_EQ(one->normal, hits[i]->normal);
  }
  EXPECT_GT(hit_count, 100);
  EXPECT_LT(hit_count, 300);
  EXPECT_FALSE(hits.back().has_value());
}

TEST(MeshQuery, EmptyMeshIsAnError) {
  auto q = MeshQuery::build(Mesh{});
  EXPECT_FALSE(q.ok());
}

}  // namespace
}  // namespace printtwin

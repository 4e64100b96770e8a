#include <gtest/gtest.h>

#include <random>

#include "printtwin/mesh_query.hpp"
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

TEST(MeshQuery, ClosestPointMatchesBruteForce) {
  const Mesh cube = test::make_cube_mm(20.0, Vec3(100, 100, 0));
  auto q = MeshQuery::build(cube);
  ASSERT_TRUE(q.ok());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(90, 130);
  for (int i = 0; i < 500; ++i) {
    const Vec3 p(u(rng), u(rng), u(rng) - 100);
    const auto got = q->closest_point(p);
    const auto want = brute_force(cube, p);
    EXPECT_NEAR(got.distance_mm, want.distance_mm, 1e-9 * (1 + want.distance_mm)) << "seed 7, i " << i;
  }
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

TEST(MeshQuery, EmptyMeshIsAnError) {
  auto q = MeshQuery::build(Mesh{});
  EXPECT_FALSE(q.ok());
}

}  // namespace
}  // namespace printtwin

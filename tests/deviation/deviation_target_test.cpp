// DeviationTarget: the design side prepared once and reused for several deposits and
// placements gives what compute_deviation on the placed mesh gives.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

#include "deviation/deposit_surface_internal.hpp"
#include "deviation/outer_surface.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/mesh_query.hpp"

namespace printtwin {
namespace {

/// A closed UV sphere of radius r (outward CCW) centred at c.
Mesh sphere_mesh(double r, int stacks, int slices, const Vec3& c) {
  Mesh m;
  m.vertices_mm.push_back(c + Vec3(0, 0, -r));
  for (int i = 1; i < stacks; ++i) {
    const double phi = std::numbers::pi * i / stacks - std::numbers::pi / 2;
    for (int j = 0; j < slices; ++j) {
      const double th = 2 * std::numbers::pi * j / slices;
      m.vertices_mm.push_back(
          c + r * Vec3(std::cos(phi) * std::cos(th), std::cos(phi) * std::sin(th), std::sin(phi)));
    }
  }
  m.vertices_mm.push_back(c + Vec3(0, 0, r));
  const auto ring = [&](int i, int j) {
    return static_cast<std::uint32_t>(1 + (i - 1) * slices + (j % slices));
  };
  const auto top = static_cast<std::uint32_t>(m.vertices_mm.size() - 1);
  for (int j = 0; j < slices; ++j) m.triangles.push_back({0, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i < stacks - 1; ++i)
    for (int j = 0; j < slices; ++j) {
      m.triangles.push_back({ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)});
    }
  for (int j = 0; j < slices; ++j)
    m.triangles.push_back({ring(stacks - 1, j), ring(stacks - 1, j + 1), top});
  return m;
}

/// Grid of `voxel_mm` around `box` (+1 mm, unaligned origin), filled where inside(centre);
/// layer = z / 0.2, line = 1000 + layer.
VoxelGrid voxelise(double voxel_mm, const Box3& box,
                   const std::function<bool(const Vec3&)>& inside) {
  const Vec3 origin = box.min - Vec3(1.0123, 1.0061, 1.0037);
  const Eigen::Vector3i dims = ((box.max - origin + Vec3::Constant(1.0)) / voxel_mm).cast<int>();
  VoxelGrid grid(voxel_mm, origin, dims);
  for (int z = 0; z < dims.z(); ++z)
    for (int y = 0; y < dims.y(); ++y)
      for (int x = 0; x < dims.x(); ++x) {
        const VoxelKey k{x, y, z};
        const Vec3 c = grid.center_mm(k);
        if (!inside(c)) continue;
        const int layer = static_cast<int>(std::floor(c.z() / 0.2));
        grid.set(
            k, VoxelTag{static_cast<std::uint32_t>(1000 + layer), layer, Feature::outer_perimeter});
      }
  return grid;
}

void expect_stats_near(const DeviationStats& a, const DeviationStats& b, double tol) {
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_NEAR(a.min_mm, b.min_mm, tol);
  EXPECT_NEAR(a.max_mm, b.max_mm, tol);
  EXPECT_NEAR(a.mean_mm, b.mean_mm, tol);
  EXPECT_NEAR(a.rms_mm, b.rms_mm, tol);
  EXPECT_NEAR(a.std_mm, b.std_mm, tol);
  EXPECT_NEAR(a.p50_abs_mm, b.p50_abs_mm, tol);
  EXPECT_NEAR(a.p95_abs_mm, b.p95_abs_mm, tol);
  EXPECT_NEAR(a.p99_abs_mm, b.p99_abs_mm, tol);
  EXPECT_NEAR(a.hausdorff_mm, b.hausdorff_mm, tol);
  EXPECT_EQ(a.within_tolerance_pct, b.within_tolerance_pct);
}

/// Same result up to `tol` on every distance (0: bit-identical).
void expect_same(const DeviationResult& a, const DeviationResult& b, double tol) {
  expect_stats_near(a.deposit_to_mesh, b.deposit_to_mesh, tol);
  expect_stats_near(a.mesh_to_deposit, b.mesh_to_deposit, tol);
  ASSERT_EQ(a.deposit_samples.size(), b.deposit_samples.size());
  for (std::size_t i = 0; i < a.deposit_samples.size(); ++i) {
    ASSERT_EQ(a.deposit_samples[i].position_mm, b.deposit_samples[i].position_mm) << i;
    ASSERT_NEAR(a.deposit_samples[i].distance_mm, b.deposit_samples[i].distance_mm, tol) << i;
    ASSERT_EQ(a.deposit_samples[i].line, b.deposit_samples[i].line) << i;
  }
  ASSERT_EQ(a.mesh_samples.size(), b.mesh_samples.size());
  for (std::size_t i = 0; i < a.mesh_samples.size(); ++i) {
    ASSERT_LE((a.mesh_samples[i].position_mm - b.mesh_samples[i].position_mm).norm(), tol) << i;
    ASSERT_NEAR(a.mesh_samples[i].distance_mm, b.mesh_samples[i].distance_mm, tol) << i;
    ASSERT_EQ(a.mesh_samples[i].layer, b.mesh_samples[i].layer) << i;
  }
  ASSERT_EQ(a.vertex_deviation_mm.size(), b.vertex_deviation_mm.size());
  for (std::size_t i = 0; i < a.vertex_deviation_mm.size(); ++i)
    ASSERT_NEAR(a.vertex_deviation_mm[i], b.vertex_deviation_mm[i], tol) << i;
  ASSERT_EQ(a.per_layer.size(), b.per_layer.size());
  for (std::size_t i = 0; i < a.per_layer.size(); ++i) {
    EXPECT_EQ(a.per_layer[i].layer, b.per_layer[i].layer);
    expect_stats_near(a.per_layer[i].deposit_to_mesh, b.per_layer[i].deposit_to_mesh, tol);
    expect_stats_near(a.per_layer[i].mesh_to_deposit, b.per_layer[i].mesh_to_deposit, tol);
  }
  ASSERT_EQ(a.regions.size(), b.regions.size());
  for (std::size_t i = 0; i < a.regions.size(); ++i) {
    EXPECT_EQ(a.regions[i].kind, b.regions[i].kind);
    EXPECT_EQ(a.regions[i].samples, b.regions[i].samples);
    EXPECT_NEAR(a.regions[i].worst_mm, b.regions[i].worst_mm, tol);
    EXPECT_EQ(a.regions[i].gcode_lines, b.regions[i].gcode_lines);
  }
  EXPECT_NEAR(a.max_excess_mm, b.max_excess_mm, tol);
  EXPECT_NEAR(a.max_deficit_mm, b.max_deficit_mm, tol);
  EXPECT_EQ(a.surface_faces, b.surface_faces);
  EXPECT_EQ(a.surface_voxels, b.surface_voxels);
  EXPECT_NEAR(a.mesh_volume_mm3, b.mesh_volume_mm3, 1e-9 * std::abs(a.mesh_volume_mm3));
  EXPECT_EQ(a.deposit_volume_mm3, b.deposit_volume_mm3);
}

class DeviationTargetReuse : public ::testing::Test {
 protected:
  // The design in its own frame: a sphere of radius 3 around the origin.
  const Mesh mesh = sphere_mesh(3.0, 20, 40, Vec3::Zero());
  static constexpr double kVoxel = 0.1;
  DeviationSettings settings = [] {
    DeviationSettings s;
    s.tolerance_mm = 0.15;
    s.min_region_area_mm2 = 0.05;
    return s;
  }();

  /// A deposit of the sphere placed at `at`, 0.05 mm too large, with a 0.6 mm bump
  /// (excess region) and a flattened bottom cap (missing region).
  static VoxelGrid deposit_at(const Vec3& at) {
    const Box3 box{at - Vec3::Constant(3.5), at + Vec3::Constant(3.5)};
    return voxelise(kVoxel, box, [&](const Vec3& c) {
      const Vec3 q = c - at;
      if (q.z() < -2.6) return false;
      return q.norm() <= 3.05 || (q - Vec3(3.2, 0, 0)).norm() <= 0.6;
    });
  }
};

TEST_F(DeviationTargetReuse, MeshOverloadEqualsTargetWithZeroOffsetBitForBit) {
  const Vec3 at(40.25, 30.5, 3.0);
  const Mesh placed = translated(mesh, at);
  const VoxelGrid grid = deposit_at(at);
  const auto direct = compute_deviation(placed, grid, settings);
  ASSERT_TRUE(direct.ok()) << direct.error().describe();
  auto target = DeviationTarget::build(placed, settings, kVoxel);
  ASSERT_TRUE(target.ok()) << target.error().describe();
  EXPECT_EQ(target->sample_spacing_mm(), 2 * kVoxel);
  EXPECT_FALSE(target->samples().empty());
  const auto via_target = compute_deviation(*target, Vec3::Zero(), grid, settings);
  ASSERT_TRUE(via_target.ok());
  expect_same(*direct, *via_target, 0.0);
  // The deposit is the design grown by 0.05 mm, with a bump and a flat bottom: both kinds
  // of regions are found.
  EXPECT_NEAR(direct->mesh_to_deposit.p50_abs_mm, 0.05, 0.03);
  bool excess = false, missing = false;
  for (const auto& r : direct->regions) (r.kind == RegionKind::excess ? excess : missing) = true;
  EXPECT_TRUE(excess);
  EXPECT_TRUE(missing);
}

TEST_F(DeviationTargetReuse, SamplesNameTheirMeshTriangle) {
  // Deposit samples carry the triangle of their closest point, mesh samples the triangle
  // they lie on: compare's slope figures read them instead of querying the BVH again.
  const Vec3 at(40.25, 30.5, 3.0);
  const Mesh placed = translated(mesh, at);
  const auto dev = compute_deviation(placed, deposit_at(at), settings);
  ASSERT_TRUE(dev.ok()) << dev.error().describe();
  auto query = MeshQuery::build(placed);
  ASSERT_TRUE(query.ok());
  ASSERT_GT(dev->deposit_samples.size(), 1000u);
  ASSERT_GT(dev->mesh_samples.size(), 1000u);
  for (std::size_t i = 0; i < dev->deposit_samples.size(); i += 97) {
    const DeviationSample& s = dev->deposit_samples[i];
    ASSERT_LT(s.triangle, placed.triangles.size());
    // The named triangle holds a closest point: its distance is the sample's |d|.
    const ClosestPoint cp = query->closest_point(s.position_mm);
    const Vec3 on = closest_point_on_triangle(s.position_mm,
                                              placed.vertices_mm[placed.triangles[s.triangle][0]],
                                              placed.vertices_mm[placed.triangles[s.triangle][1]],
                                              placed.vertices_mm[placed.triangles[s.triangle][2]]);
    EXPECT_NEAR((on - s.position_mm).norm(), cp.distance_mm, 1e-9);
    EXPECT_NEAR(std::abs(s.distance_mm), cp.distance_mm, 1e-9);
  }
  for (std::size_t i = 0; i < dev->mesh_samples.size(); i += 97) {
    const DeviationSample& s = dev->mesh_samples[i];
    ASSERT_LT(s.triangle, placed.triangles.size());
    EXPECT_LT(query->closest_point(s.position_mm).distance_mm, 1e-9);
    const auto& t = placed.triangles[s.triangle];
    const Vec3 on = closest_point_on_triangle(s.position_mm, placed.vertices_mm[t[0]],
                                              placed.vertices_mm[t[1]], placed.vertices_mm[t[2]]);
    EXPECT_LT((on - s.position_mm).norm(), 1e-9);
  }
}

TEST_F(DeviationTargetReuse, OneTargetReusedForTwoPlacementsEqualsFreshRuns) {
  // Built without a voxel: the samples are drawn per call (same rule, same seed).
  auto lazy = DeviationTarget::build(mesh, settings);
  ASSERT_TRUE(lazy.ok());
  EXPECT_TRUE(lazy->samples().empty());
  auto target = DeviationTarget::build(mesh, settings, kVoxel);
  ASSERT_TRUE(target.ok());
  EXPECT_NEAR(target->volume_mm3(), signed_volume_mm3(mesh), 1e-12);
  for (const Vec3& at : {Vec3(117.3, 95.2, 3.0), Vec3(20.1, 180.7, 3.0)}) {
    const VoxelGrid grid = deposit_at(at);
    const auto fresh = compute_deviation(translated(mesh, at), grid, settings);
    ASSERT_TRUE(fresh.ok());
    const auto reused = compute_deviation(*target, at, grid, settings);
    ASSERT_TRUE(reused.ok());
    // Only the rounding of the translation differs (points moved vs mesh moved).
    expect_same(*fresh, *reused, 1e-9);
    const auto reused_lazy = compute_deviation(*lazy, at, grid, settings);
    ASSERT_TRUE(reused_lazy.ok());
    expect_same(*reused, *reused_lazy, 0.0);
    EXPECT_FALSE(fresh->regions.empty());
  }
}

TEST_F(DeviationTargetReuse, SignedDistancesWithOffsetMatchThePlacedMesh) {
  auto target = DeviationTarget::build(mesh, settings);
  ASSERT_TRUE(target.ok());
  const Vec3 at(10.5, -4.25, 7.0);
  std::vector<Vec3> points;
  for (int i = 0; i < 200; ++i) {
    const double t = 0.1 * i;
    points.push_back(at + (1.0 + 0.02 * i) *
                              Vec3(std::cos(t), std::sin(t), 0.3 * std::cos(3 * t)).normalized());
  }
  std::vector<double> d;
  target->signed_distances(at, points, 0.2, d);
  ASSERT_EQ(d.size(), points.size());
  const auto ref = reference_distances_cgal(translated(mesh, at), points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(std::abs(d[i]), ref[i], 1e-9) << i;
    const double r = (points[i] - at).norm();
    if (r < 2.9) {
      EXPECT_LT(d[i], 0) << i;
    }
    if (r > 3.01) {
      EXPECT_GT(d[i], 0) << i;
    }
  }
}

TEST_F(DeviationTargetReuse, SurfaceCellGroupsGiveTheSameDistancesAsAnyGrouping) {
  // The deposit surface's faces come cell by cell; signed_distances given those cells as
  // groups, grouping the points itself, or taking them in input order (no near_mm) finds the
  // same closest points, bit for bit.
  auto target = DeviationTarget::build(mesh, settings);
  ASSERT_TRUE(target.ok());
  const Vec3 at(10.5, -4.25, 7.0);
  const VoxelGrid grid = deposit_at(at);
  const DepositSurface surface =
      extract_outer_surface(grid, Box3{at - Vec3::Constant(4.0), at + Vec3::Constant(4.0)});
  ASSERT_GT(surface.faces.size(), 1000U);
  const std::vector<std::uint32_t> cells = detail::face_cell_groups(surface);
  ASSERT_GE(cells.size(), 2U);
  EXPECT_EQ(cells.front(), 0U);
  EXPECT_EQ(cells.back(), surface.faces.size());
  for (std::size_t g = 0; g + 1 < cells.size(); ++g) {  // each group: one cell of 4^3 voxels
    ASSERT_LT(cells[g], cells[g + 1]);
    const VoxelKey& first = surface.faces[cells[g]].voxel;
    for (std::uint32_t f = cells[g]; f < cells[g + 1]; ++f) {
      const VoxelKey& k = surface.faces[f].voxel;
      ASSERT_TRUE((k.x >> 2) == (first.x >> 2) && (k.y >> 2) == (first.y >> 2) &&
                  (k.z >> 2) == (first.z >> 2))
          << f;
    }
  }
  std::vector<double> by_cells, self_grouped, in_order;
  std::vector<std::uint32_t> t_cells, t_self, t_order;
  const std::vector<Vec3> centres = surface.face_centers_mm();
  target->signed_distances(at, centres, 4 * kVoxel, by_cells, &t_cells, cells);
  target->signed_distances(at, centres, 4 * kVoxel, self_grouped, &t_self);
  target->signed_distances(at, centres, 0.0, in_order, &t_order);
  ASSERT_EQ(by_cells.size(), surface.faces.size());
  for (std::size_t i = 0; i < by_cells.size(); ++i) {
    ASSERT_EQ(by_cells[i], self_grouped[i]) << i;
    ASSERT_EQ(by_cells[i], in_order[i]) << i;
    ASSERT_EQ(t_cells[i], t_self[i]) << i;
    ASSERT_EQ(t_cells[i], t_order[i]) << i;
  }
}

TEST(DeviationTargetBuild, RejectsEmptyMeshAndNegativeSpacing) {
  EXPECT_FALSE(DeviationTarget::build(Mesh{}, DeviationSettings{}).ok());
  DeviationSettings bad;
  bad.mesh_sample_spacing_mm = -1;
  EXPECT_FALSE(DeviationTarget::build(make_box_mesh(Vec3::Zero(), Vec3::Ones()), bad).ok());
}

}  // namespace
}  // namespace printtwin

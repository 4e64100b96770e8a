// Sub-voxel smoothing of the as-printed mesh: vertices on the true bead surfaces (round beads,
// layer grooves), the mesh still closed, oriented, without self-intersections, with the
// deposit's volume.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>

#include "deposit/deposit_test_support.hpp"
#include "deposit/mesh_export.hpp"
#include "deposit/mesh_export_internal.hpp"
#include "deposit/mesh_test_support.hpp"
#include "deviation/surface_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {
namespace {

/// These tests are about the voxel surface's smoothing (the default surface is layers).
DepositMeshOptions voxel_surface() {
  DepositMeshOptions o;
  o.surface = DepositMeshSurface::voxel;
  return o;
}

/// `layers` square loops of stadium beads (w x h) around [20, 30]^2,
/// deposited at 0.05 mm.
struct Printed {
  std::vector<Move> moves;
  DepositResult deposit;
};

/// The moves and their deposit at 0.05 mm voxels.
Printed deposited(const std::vector<Move>& moves, const PrinterProfile& profile) {
  Printed p;
  p.moves = moves;
  p.deposit = test::deposit_at(p.moves, profile);
  return p;
}
Printed lay_loops(double h, double w, int layers) {
  const PrinterProfile profile = ender3_marlin2();
  test::BeadWriter bw(profile);
  bw.feature = Feature::outer_perimeter;
  const double a = 20.0 + 0.5 * w, b = 30.0 - 0.5 * w;
  const std::array<Vec2, 4> corners = {Vec2(b, a), Vec2(b, b), Vec2(a, b), Vec2(a, a)};
  for (bw.layer = 0; bw.layer < layers; ++bw.layer) {
    const double z = h * (bw.layer + 1);
    bw.travel({a, a, z});
    for (const Vec2& c : corners) {
      bw.extrude({c.x(), c.y(), z}, w, h);
      bw.moves.back().height_hint_mm = static_cast<float>(h);  // the slicer's ;HEIGHT:
    }
  }
  return deposited(bw.moves, profile);
}

using test::expect_closed_oriented;

/// Mean |distance| from the vertices to the surface of the nearest bead of any line.
double mean_bead_distance(const Mesh& m, std::span<const SurfaceBead> beads) {
  double sum = 0;
  for (const Vec3& p : m.vertices_mm) {
    double best = 1e9;
    for (const SurfaceBead& b : beads) {
      Vec3 c;
      best = std::min(best, std::abs(detail::bead_closest(b, p, c)));
    }
    sum += best;
  }
  return sum / static_cast<double>(m.vertices_mm.size());
}

TEST(DepositMeshSmooth, VerticesGoOntoTheBeadsAndTheMeshStaysClosed) {
  const Printed p = lay_loops(0.2, 0.45, 6);
  const auto beads = surface_beads(p.moves, ender3_marlin2());
  ASSERT_FALSE(beads.empty());
  DepositMeshOptions o;
  o.surface = DepositMeshSurface::voxel;
  o.smooth = false;
  auto stair = build_deposit_mesh(p.deposit.grid, o, beads);
  o.smooth = true;
  auto smooth = build_deposit_mesh(p.deposit.grid, o, beads);
  ASSERT_TRUE(stair.ok() && smooth.ok());
  EXPECT_EQ(stair->smoothed_vertices, 0u);
  // A good share of the vertices lie on the beads (not where lines meet).
  EXPECT_GT(smooth->smoothed_vertices, smooth->mesh.vertices_mm.size() / 3);
  EXPECT_EQ(smooth->mesh.triangles, stair->mesh.triangles);  // positions only
  expect_closed_oriented(smooth->mesh);
  // Within a voxel of the filled volume, and much closer to the beads than the staircase.
  EXPECT_NEAR(smooth->volume_mm3 / smooth->filled_volume_mm3, 1.0, 0.01);
  const double d_stair = mean_bead_distance(stair->mesh, beads);
  const double d_smooth = mean_bead_distance(smooth->mesh, beads);
  EXPECT_LT(d_smooth, 0.8 * d_stair) << d_smooth << " vs " << d_stair;
  // The bound is the largest move, or the staircase's own bound where that is larger; the
  // layer grooves' vertices go deeper than half a voxel.
  double largest = 0;
  for (std::size_t i = 0; i < smooth->mesh.vertices_mm.size(); ++i)
    largest = std::max(largest, (smooth->mesh.vertices_mm[i] - stair->mesh.vertices_mm[i]).norm());
  EXPECT_DOUBLE_EQ(smooth->error_bound_mm, std::max(largest, stair->error_bound_mm));
  EXPECT_GT(largest, 0.5 * 0.05);
  EXPECT_LE(largest, 0.5 * 0.2 + 0.05 + 1e-9);  // half a bead height plus a voxel
}

TEST(DepositMeshSmooth, GroovesBetweenLayersShowOnTheOuterWall) {
  // On the -x wall (x = 20), the bead sides bulge out at mid-layer and recede at the layer
  // boundaries: the smoothed vertices' x spans part of the groove depth R (1 - cos 45) ... R.
  const Printed p = lay_loops(0.2, 0.45, 6);
  const auto beads = surface_beads(p.moves, ender3_marlin2());
  auto m = build_deposit_mesh(p.deposit.grid, voxel_surface(), beads);
  ASSERT_TRUE(m.ok());
  double xmin_mid = 1e9, xmax_groove = -1e9;
  for (const Vec3& v : m->mesh.vertices_mm) {
    if (v.x() > 20.2 || v.y() < 22 || v.y() > 28 || v.z() < 0.3 || v.z() > 1.0) continue;
    const double f = std::fmod(v.z(), 0.2) / 0.2;  // 0 at a layer boundary, 0.5 mid-layer
    if (std::abs(f - 0.5) < 0.15) xmin_mid = std::min(xmin_mid, v.x());
    if (f < 0.15 || f > 0.85) xmax_groove = std::max(xmax_groove, v.x());
  }
  EXPECT_LT(xmin_mid, 20.03);  // the bead's outer edge (x = 20)
  // The groove between stacked round beads, R = 0.1 deep: the crease vertices reach it
  // (the voxels alone show at most a voxel of it).
  EXPECT_GT(xmax_groove, 20.08);
}

TEST(DepositMeshSmooth, NoBeadsOrDecimationKeepTheVoxelFaces) {
  const Printed p = lay_loops(0.2, 0.45, 3);
  const auto beads = surface_beads(p.moves, ender3_marlin2());
  auto plain = build_deposit_mesh(p.deposit.grid, {});
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->smoothed_vertices, 0u);
  DepositMeshOptions o;
  o.surface = DepositMeshSurface::voxel;
  o.max_triangles = plain->mesh.triangles.size() / 4;
  auto coarse = build_deposit_mesh(p.deposit.grid, o, beads);
  ASSERT_TRUE(coarse.ok());
  EXPECT_GT(coarse->cell_voxels, 1);
  EXPECT_EQ(coarse->smoothed_vertices, 0u);
}

// Above smooth_max_triangles the mesh stays on the voxel faces and says so; 0 lifts the limit.
TEST(DepositMeshSmooth, TheTriangleLimitSkipsSmoothingAndZeroLiftsIt) {
  const Printed p = lay_loops(0.2, 0.45, 2);
  const auto beads = surface_beads(p.moves, ender3_marlin2());
  DepositMeshOptions o;
  o.surface = DepositMeshSurface::voxel;
  auto full = build_deposit_mesh(p.deposit.grid, o, beads);
  ASSERT_TRUE(full.ok());
  ASSERT_GT(full->smoothed_vertices, 0u);
  EXPECT_FALSE(full->smoothing_skipped);
  o.smooth_max_triangles = full->mesh.triangles.size() - 1;
  auto limited = build_deposit_mesh(p.deposit.grid, o, beads);
  ASSERT_TRUE(limited.ok());
  EXPECT_TRUE(limited->smoothing_skipped);
  EXPECT_EQ(limited->smoothed_vertices, 0u);
  EXPECT_NE(deposit_mesh_summary(*limited, "x.stl").find("--deposit-mesh-smooth-max-triangles"),
            std::string::npos);
  o.smooth_max_triangles = 0;
  auto unlimited = build_deposit_mesh(p.deposit.grid, o, beads);
  ASSERT_TRUE(unlimited.ok());
  EXPECT_FALSE(unlimited->smoothing_skipped);
  EXPECT_EQ(unlimited->mesh.vertices_mm, full->mesh.vertices_mm);
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

/// Beads laid by `path` (one layer per entry of `zs`), deposited at 0.05 mm.
Printed lay_path(const std::vector<Vec2>& path, const std::vector<double>& zs, double w, double h) {
  const PrinterProfile profile = ender3_marlin2();
  test::BeadWriter bw(profile);
  bw.feature = Feature::outer_perimeter;
  for (std::size_t l = 0; l < zs.size(); ++l) {
    bw.layer = static_cast<int>(l);
    bw.travel({path[0].x(), path[0].y(), zs[l]});
    for (std::size_t i = 1; i < path.size(); ++i) {
      bw.extrude({path[i].x(), path[i].y(), zs[l]}, w, h);
      bw.moves.back().height_hint_mm = static_cast<float>(h);
    }
  }
  return deposited(bw.moves, profile);
}

// One bead, and a zig-zag of beads at odd angles over three layers (creases where lines
// meet, corners, staircases in every direction): the local crossing check leaves what the
// check stage's exact test over the whole mesh finds free of self-intersections.
TEST(DepositMeshSmooth, SingleBeadAndZigZagStayFreeOfSelfIntersections) {
  const std::vector<std::pair<std::vector<Vec2>, std::vector<double>>> cases = {
      {{Vec2(20, 20), Vec2(26, 23.3)}, {0.2}},
      {{Vec2(20, 20), Vec2(24, 21.7), Vec2(21.5, 24.1), Vec2(25.3, 26.9)}, {0.2, 0.4, 0.6}},
  };
  for (const auto& [path, zs] : cases) {
    const Printed p = lay_path(path, zs, 0.45, 0.2);
    const auto beads = surface_beads(p.moves, ender3_marlin2());
    DepositMeshOptions o;
    o.surface = DepositMeshSurface::voxel;
    auto m = build_deposit_mesh(p.deposit.grid, o, beads);
    ASSERT_TRUE(m.ok());
    SCOPED_TRACE(path.size());
    EXPECT_GT(m->smoothed_vertices, m->mesh.vertices_mm.size() / 4);
    expect_closed_oriented(m->mesh);
    // A bead four voxels tall: the voxel count misses a few % of its round sides.
    EXPECT_NEAR(m->volume_mm3 / m->filled_volume_mm3, 1.0, 0.06);
  }
}

}  // namespace
}  // namespace printtwin

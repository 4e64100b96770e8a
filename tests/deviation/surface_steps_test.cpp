// The steps of the outer surface (src/deviation/surface_steps.hpp), each on a grid built in
// code: the region, the part blocks, the flood, the filled volume and the faces. The groove
// reopening and the bead placement are tested in surface_test.cpp.
#include <gtest/gtest.h>

#include <cmath>

#include "deviation/outer_surface.hpp"
#include "deviation/surface_steps.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::surface_blocks {
namespace {

/// A hollow box: a 0.4 mm shell around a closed 1.2 x 1.2 x 0.2 mm cavity, voxel 0.05 mm,
/// plus a skirt voxel row (auxiliary) beside it.
VoxelGrid hollow_box() {
  VoxelGrid grid(0.05, Vec3(-1, -1, -1), Eigen::Vector3i(80, 80, 60));
  const Box3 outer{Vec3(0, 0, 0), Vec3(2, 2, 1)};
  const Box3 cavity{Vec3(0.4, 0.4, 0.4), Vec3(1.6, 1.6, 0.6)};
  for (int z = 0; z < 60; ++z)
    for (int y = 0; y < 80; ++y)
      for (int x = 0; x < 80; ++x) {
        const Vec3 c = grid.center_mm({x, y, z});
        if (outer.contains(c) && !cavity.contains(c))
          grid.set({x, y, z}, VoxelTag{1, 7, Feature::outer_perimeter});
      }
  for (int x = 0; x < 40; ++x) grid.set({x, 5, 20}, VoxelTag{0, 3, Feature::skirt});
  return grid;
}

const Box3 kRegion{Vec3(-0.5, -0.8, -0.5), Vec3(2.5, 2.5, 1.5)};

/// The hollow box through steps 1 and 2 (seal radius 2 voxels).
struct Flooded {
  VoxelGrid grid = hollow_box();
  DepositSurface s;
  SurfaceRegion r = SurfaceRegion::of(grid, kRegion, s);
  PartBlocks part = part_blocks(grid, r);
  OutsideFlood flood = flood_outside(r, part, 2);
};

TEST(SurfaceSteps, RegionIsPaddedByOneVoxel) {
  const VoxelGrid grid = hollow_box();
  DepositSurface s;
  const SurfaceRegion r = SurfaceRegion::of(grid, kRegion, s);
  const VoxelKey lo = grid.key_of(kRegion.min), hi = grid.key_of(kRegion.max);
  EXPECT_EQ(r.rlo.x, lo.x - 1);
  EXPECT_EQ(r.rhi.z, hi.z + 1);
  EXPECT_EQ(r.ilo.y, lo.y);
  EXPECT_EQ(s.dims, Eigen::Vector3i(hi.x - lo.x + 3, hi.y - lo.y + 3, hi.z - lo.z + 3));
  std::size_t region = 0, interior = 0;
  for (std::size_t i = 0; i < r.box.size(); ++i) {
    const Eigen::Vector3i b = r.box.coords(i);
    region += static_cast<std::size_t>(count(r.region_cube_of(i)));
    interior += static_cast<std::size_t>(count(r.interior_cube(b.x(), b.y(), b.z())));
    EXPECT_EQ(r.region_voxels_of(i), static_cast<std::size_t>(count(r.region_cube_of(i))));
  }
  const auto n = s.dims.cast<std::size_t>();
  EXPECT_EQ(region, n.x() * n.y() * n.z());
  EXPECT_EQ(interior, (n.x() - 2) * (n.y() - 2) * (n.z() - 2));
}

TEST(SurfaceSteps, PartBlocksDropAuxiliaryVoxels) {
  const VoxelGrid grid = hollow_box();
  DepositSurface s;
  const SurfaceRegion r = SurfaceRegion::of(grid, kRegion, s);
  const PartBlocks part = part_blocks(grid, r);
  std::size_t shell = 0;
  for (int z = 0; z < 60; ++z)
    for (int y = 0; y < 80; ++y)
      for (int x = 0; x < 80; ++x)
        if (grid.occupied({x, y, z}) && grid.tag({x, y, z})->feature != Feature::skirt) ++shell;
  EXPECT_EQ(part.occupied, shell);
  std::size_t counted = 0;
  for (std::size_t i = 0; i < r.box.size(); ++i)
    if (part.of[i] != nullptr) counted += static_cast<std::size_t>(count(*part.of[i]));
  EXPECT_EQ(counted, shell);
}

TEST(SurfaceSteps, FloodReachesAroundButNotIntoTheCavity) {
  Flooded f;
  const VoxelGrid& grid = f.grid;
  const SurfaceRegion& r = f.r;
  const OutsideFlood& flood = f.flood;
  // The outside voxel holding p (false when p's block was never reached).
  const auto outside = [&](const Vec3& p) {
    const VoxelKey k = grid.key_of(p);
    const std::size_t i = r.box.index(k.x >> 3, k.y >> 3, k.z >> 3);
    if (flood.kind[i] == OutsideFlood::kWhole) return true;
    if (flood.kind[i] != OutsideFlood::kPartial) return false;
    const int slot = (k.y & 7) * 8 + (k.x & 7);
    return ((flood.outside[flood.slot[i]][static_cast<std::size_t>(k.z & 7)] >> slot) & 1U) != 0;
  };
  EXPECT_TRUE(outside(Vec3(-0.3, 1, 0.5)));
  EXPECT_TRUE(outside(Vec3(1, 1, 1.3)));
  EXPECT_FALSE(outside(Vec3(1, 1, 0.5)));    // the cavity
  EXPECT_FALSE(outside(Vec3(1, 0.2, 0.5)));  // the shell
}

TEST(SurfaceSteps, FilledVolumeHoldsTheShellAndTheCavity) {
  Flooded f;
  DepositSurface& s = f.s;
  fill_volume(s, f.r, f.part, f.flood, 2, 5);
  EXPECT_TRUE(s.filled(Vec3(1, 1, 0.5)));
  EXPECT_TRUE(s.filled(Vec3(1, 0.2, 0.5)));
  EXPECT_FALSE(s.filled(Vec3(-0.3, 1, 0.5)));
  EXPECT_FALSE(s.filled(Vec3(0.5, -0.725, 0.025)));  // the skirt row is not part
  // Shell and cavity: the 2 x 2 x 1 mm box in 0.05 mm voxels.
  EXPECT_EQ(s.filled_voxels, 40U * 40U * 20U);
}

TEST(SurfaceSteps, FacesOfABoxAreItsSixSides) {
  VoxelGrid grid(0.05, Vec3(0, 0, 0), Eigen::Vector3i(40, 40, 40));
  for (int z = 10; z < 13; ++z)
    for (int y = 10; y < 14; ++y)
      for (int x = 10; x < 15; ++x) grid.set({x, y, z}, VoxelTag{5, 1, Feature::outer_perimeter});
  const Box3 region{Vec3(0.2, 0.2, 0.2), Vec3(1.5, 1.5, 1.5)};
  DepositSurface s;
  const SurfaceRegion r = SurfaceRegion::of(grid, region, s);
  const PartBlocks part = part_blocks(grid, r);
  fill_volume(s, r, part, flood_outside(r, part, 0), 0, 0);
  extract_faces(s, grid, r, part);
  // 5 x 4 x 3 voxels: 2 (20 + 15 + 12) faces.
  ASSERT_EQ(s.faces.size(), 94U);
  ASSERT_EQ(s.face_cell_begin.back(), 94U);
  for (std::size_t i = 0; i < s.faces.size(); ++i) {
    const SurfaceFace& f = s.faces[i];
    const Vec3 c = s.face_center(i);
    const double lo = 0.5, hi = f.axis == 0 ? 0.75 : f.axis == 1 ? 0.7 : 0.65;
    EXPECT_NEAR(c[f.axis], f.side > 0 ? hi : lo, 1e-12);
    EXPECT_EQ(s.face_tags[i].line, 5U);
  }
  // The same faces as the whole routine gives.
  const DepositSurface whole = extract_outer_surface(grid, region, 0, 0);
  EXPECT_EQ(whole.face_centers_mm(), s.face_centers_mm());
}

}  // namespace
}  // namespace printtwin::surface_blocks

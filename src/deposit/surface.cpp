// The deposit's outer surface as voxels (the PLY export): the one outer-surface routine of
// the deviation stage (extract_outer_surface: flood, seal, groove reopening, faces) over the
// whole grid, its faces gathered per voxel.
#include <vector>

#include "deposit/voxel_blocks.hpp"
#include "deviation/outer_surface.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

std::vector<SurfaceVoxel> outer_surface(const VoxelGrid& grid) {
  std::vector<SurfaceVoxel> out;
  const Eigen::Vector3i& dims = grid.dims();
  if (dims.minCoeff() <= 0) return out;
  const double v = grid.voxel_mm();
  const Box3 region{grid.origin_mm() + Vec3::Constant(0.5 * v),
                    grid.origin_mm() + v * (dims.cast<double>() - Vec3::Constant(0.5))};
  const DeviationSettings defaults;
  const DepositSurface s =
      extract_outer_surface(grid, region, defaults.seal_gap_mm, defaults.groove_depth_mm);
  // A voxel's faces are consecutive (-x +x -y +y -z +z).
  for (const SurfaceFace& f : s.faces) {
    if (out.empty() || !(out.back().key == f.voxel)) out.push_back({f.voxel, 0});
    out.back().exposed_faces |=
        static_cast<std::uint8_t>(1U << (2 * f.axis + (f.side > 0 ? 1 : 0)));
  }
  return out;
}

}  // namespace printtwin

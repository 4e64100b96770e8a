#pragma once
// The sweep: one bead (tip path, section, end cuts) to voxels, 64 at a time.
//
// A voxel is occupied when its fixed sample point (bead_raster.hpp) lies inside the bead.
// The bead's footprint at its widest over its voxel layers gives, once per bead, the block
// rows it reaches, the blocks of each row and the rows of each block; each such 8 x 8 tile
// of a block's z-slice is tested layer by layer (bead_raster.cpp) and written as one
// occupancy word per layer through the GridWriter, and the height map is raised under it.
#include <cstdint>
#include <vector>

#include "deposit/bead_raster.hpp"
#include "deposit/grid_writer.hpp"
#include "deposit/height_map.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

/// One bead as the sweep lays it (mm, machine frame).
struct SweptBead {
  Vec3 a_mm, b_mm;       ///< tip path
  Vec2 d, n;             ///< unit direction (xy) and lateral normal
  Vec2 m0, m1;           ///< start and end cut normals (unit, xy)
  double h_mm = 0, w_mm = 0;
  std::int32_t layer = 0;
};

class BeadSweep {
 public:
  /// Sweeps into a grid of `grid`'s frame. `exhaustive`: test every tile of each bead's box
  /// (DepositSettings::exhaustive_tiles).
  BeadSweep(const VoxelGrid& grid, bool exhaustive);

  /// Lays `bead`: its tiles go to `writer`, the height map is raised under them.
  void lay(const SweptBead& bead, GridWriter& writer, HeightMap& map);

 private:
  /// The frame of the sample-point tests, and the layers the section reaches (reached_) with
  /// its widest half-width over them (voxel units); false when it reaches none.
  bool set_up(const SweptBead& bead, BeadFrame& f, Vec2& a2, Vec2& b2, double& hw);

  Vec3 origin_;
  double inv_voxel_;
  int nx_, ny_, nz_;
  Eigen::Vector3i block_dims_;
  bool exhaustive_;
  std::vector<std::int32_t> reached_;  // scratch: the voxel layers a bead reaches
  std::vector<std::uint64_t> masks_;   // scratch: a tile's occupancy word per reached layer
};

}  // namespace printtwin::detail

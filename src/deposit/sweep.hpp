#pragma once
// The sweep: one bead (tip path, section, end cuts) to voxels, 64 at a time.
//
// A voxel is occupied when its fixed sample point (kernels.hpp) lies inside the bead.
// The bead's footprint at its widest over its voxel layers gives, once per bead, the block
// rows it reaches, the blocks of each row and the rows of each block; each such 8 x 8 tile
// of a block's z-slice is tested layer by layer (kernels.cpp) and written as one
// occupancy word per layer into the grid, and the height map is raised under it. Material
// that falls on occupied voxels squeezes into the free voxels nearest the section.
#include <cstdint>
#include <vector>

#include "deposit/height_map.hpp"
#include "deposit/kernels.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

/// One bead as the sweep lays it (mm, machine frame).
struct SweptBead {
  Vec3 a_mm, b_mm;  ///< tip path
  Vec2 d, n;        ///< unit direction (xy) and lateral normal
  Vec2 m0, m1;      ///< start and end cut normals (unit, xy)
  double h_mm = 0, w_mm = 0;
  std::int32_t layer = 0;
  /// How far (mm) the material that falls on occupied voxels may squeeze out of the section
  /// into free voxels (0: it is lost).
  double squeeze_mm = 0;
};

class BeadSweep {
 public:
  /// Sweeps into a grid of `grid`'s frame. `exhaustive`: test every tile of each bead's box
  /// (DepositSettings::exhaustive_tiles).
  BeadSweep(const VoxelGrid& grid, bool exhaustive);

  struct Laid {
    std::size_t overlap = 0;   ///< voxels of the bead that were occupied already
    std::size_t squeezed = 0;  ///< free voxels nearby that took that material instead
  };
  /// Lays `bead` into `grid` with tag `tag` and raises the height map under it.
  Laid lay(const SweptBead& bead, VoxelGrid& grid, std::uint32_t tag, HeightMap& map);

 private:
  /// The frame of the sample-point tests, and the layers the section reaches (reached_) with
  /// its widest half-width over them (voxel units); false when it reaches none.
  bool set_up(const SweptBead& bead, BeadFrame& f, Vec2& a2, Vec2& b2, double& hw);
  /// Calls fn(bx, by, row_lo, row_hi, lanes) for each tile the footprint of half-width hw
  /// (voxel units) reaches.
  template <class Fn>
  void for_each_tile(const SweptBead& bead, const Vec2& a2, const Vec2& b2, double hw,
                     Fn&& fn) const;
  /// Places up to `lost` voxels of material in the free voxels nearest the bead; returns how
  /// many it placed.
  std::size_t squeeze(const SweptBead& bead, const BeadFrame& f, const Vec2& a2, const Vec2& b2,
                      std::size_t lost, VoxelGrid& grid, std::uint32_t tag, HeightMap& map);

  struct Candidate {
    float d;             // distance beyond the section (voxel units)
    std::uint32_t hash;  // tie-break
    std::int32_t i, j, k;
  };

  Vec3 origin_;
  double inv_voxel_;
  int nx_, ny_, nz_;
  Eigen::Vector3i block_dims_;
  bool exhaustive_;
  std::vector<std::int32_t> reached_;  // scratch: the voxel layers a bead reaches
  std::vector<std::uint64_t> masks_;   // scratch: a tile's occupancy word per reached layer
  std::vector<std::int32_t> layers_;   // scratch: the layers of the squeeze
  std::vector<Candidate> candidates_;  // scratch: free voxels of the squeeze
};

}  // namespace printtwin::detail

#pragma once
// The steps of extract_outer_surface (private to src/deviation/ and its tests), one file each:
//   1. surface_part.cpp    the part voxels per block (auxiliary features and the padding cut)
//   2. surface_flood.cpp   the flood from outside, on the part dilated by the seal radius
//   3. surface_seal.cpp    the filled volume: the outside dilated back, the grooves reopened
//                          (surface_reopen.cpp), the filled voxels counted
//   4. surface_faces.cpp   the exposed faces in the fixed cell order
// then, for the deviation stage, surface_beads.cpp places the faces on the beads and
// surface_samples.cpp lays the deposit -> mesh points on the beads' exposed outlines.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/zeroed_array.hpp"
#include "deviation/outer_surface.hpp"
#include "deviation/surface_blocks.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::surface_blocks {

/// The analysed region R (region_mm in whole voxels, padded by one voxel) and its interior I
/// (R without the padding), as key boxes (inclusive) and as the grid blocks covering R.
struct SurfaceRegion {
  VoxelKey rlo, rhi, ilo, ihi;
  BlockBox box;

  /// The region of `region_mm` in `grid`; fills the surface's frame (voxel, origin, dims,
  /// block box). Empty box (size 0) when region_mm is empty.
  static SurfaceRegion of(const VoxelGrid& grid, const Box3& region_mm, DepositSurface& s);
  /// Whether block (bx, by, bz) lies wholly inside the key box [lo, hi].
  static bool block_inside(int bx, int by, int bz, const VoxelKey& lo, const VoxelKey& hi);
  /// R's voxels in a block, and I's.
  [[nodiscard]] Cube region_cube(int bx, int by, int bz) const;
  [[nodiscard]] Cube region_cube_of(std::size_t i) const;
  [[nodiscard]] Cube interior_cube(int bx, int by, int bz) const;
  /// Voxels of R in the blocks of `kind` "whole" (see OutsideFlood), counted.
  [[nodiscard]] std::size_t region_voxels_of(std::size_t i) const;
};

/// A cube of all ones.
inline Cube full_cube() {
  Cube c;
  c.fill(~std::uint64_t{0});
  return c;
}

/// Step 1: the part voxels (occupied, not auxiliary, in I) per block of the box: a pointer to
/// the grid's occupancy, or to a filtered copy where auxiliary voxels or I's border cut it.
struct PartBlocks {
  ZeroedArray<const Cube*> of;  ///< per box index; null = no part voxel
  CubePool filtered;            ///< the filtered copies
  std::size_t occupied = 0;     ///< part voxels
  [[nodiscard]] const Cube* at(const BlockBox& box, int bx, int by, int bz) const {
    return box.contains(bx, by, bz) ? of[box.index(bx, by, bz)] : nullptr;
  }
};
PartBlocks part_blocks(const VoxelGrid& grid, const SurfaceRegion& region);

/// Step 2: the outside, the component of the empty region voxels (after the part is dilated
/// by `seal_r` voxels) that holds the padding, per block: untouched (the outside never came
/// in), whole (open all through: wholly outside) or partial (its outside voxels in
/// outside[slot]).
struct OutsideFlood {
  enum : std::uint8_t { kUntouched = 0, kWhole = 1, kPartial = 2 };
  std::vector<std::uint8_t> kind;
  std::vector<std::uint32_t> slot;
  CubePool outside;
};
OutsideFlood flood_outside(const SurfaceRegion& region, const PartBlocks& part, int seal_r);

/// Step 3: the filled volume of the surface (filled_block_code, filled_masks,
/// filled_voxels): R minus the outside dilated back by `seal_r` (where not part), then what
/// the seal closed reopened to `reopen` steps (surface_reopen.cpp).
void fill_volume(DepositSurface& s, const SurfaceRegion& region, const PartBlocks& part,
                 const OutsideFlood& flood, int seal_r, int reopen);

/// Step 3b, the groove reopening (surface_reopen.cpp): what the seal closed opens again to
/// `steps` 6-connected steps through empty region voxels from the outside found (a geodesic
/// dilation of the not-filled voxels of the mixed blocks within their free voxels, region
/// minus part). The mixed set (box indices, the blocks with filled masks, in mask order) must
/// cover every block within `steps` voxels of an outside voxel; other blocks stay as they are.
void reopen_grooves(DepositSurface& s, const SurfaceRegion& region, const PartBlocks& part,
                    const std::vector<std::uint32_t>& mixed, int steps);

/// Step 4: the faces between a filled part voxel and a voxel that is not filled, with their
/// tags, in the fixed cell order (faces, face_tags, face_blocks, face_cell_begin).
void extract_faces(DepositSurface& s, const VoxelGrid& grid, const SurfaceRegion& region,
                   const PartBlocks& part);

}  // namespace printtwin::surface_blocks

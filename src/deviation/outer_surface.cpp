// The deposit's outer surface: a flood fill from outside over the grid's 8^3 blocks, where
// only the blocks the outside reaches (and their neighbours) are ever looked at voxel by
// voxel. The inside of a part (sparse infill, enclosed by its walls and solid layers) is
// never visited: it stays "filled" by default. The steps, one file each, are listed in
// surface_steps.hpp; this file holds the region and the routine that runs them.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "deviation/outer_surface.hpp"
#include "deviation/surface_steps.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

bool is_auxiliary_feature(Feature f) {
  switch (f) {
    case Feature::skirt:
    case Feature::support:
    case Feature::support_interface:
    case Feature::wipe_tower:
    case Feature::custom:
      return true;
    default:
      return false;
  }
}

namespace {
/// The region voxel holding p: its grid key, or false when p is outside the region.
bool region_key(const DepositSurface& s, const Vec3& p_mm, VoxelKey& key) {
  if (s.voxel_mm <= 0) return false;
  const Vec3 q = (p_mm - s.origin_mm) / s.voxel_mm;
  const auto x = static_cast<long>(std::floor(q.x()));
  const auto y = static_cast<long>(std::floor(q.y()));
  const auto z = static_cast<long>(std::floor(q.z()));
  if (x < 0 || y < 0 || z < 0 || x >= s.dims.x() || y >= s.dims.y() || z >= s.dims.z())
    return false;
  key = VoxelKey{s.origin_key.x + static_cast<int>(x), s.origin_key.y + static_cast<int>(y),
                 s.origin_key.z + static_cast<int>(z)};
  return true;
}
}  // namespace

const std::uint32_t* DepositSurface::filled_code_of(const Vec3& p_mm, int& slot) const {
  VoxelKey k;
  if (!region_key(*this, p_mm, k)) return nullptr;
  const int bx = k.x >> 3, by = k.y >> 3, bz = k.z >> 3;
  slot = (k.z & 7) * 64 + (k.y & 7) * 8 + (k.x & 7);
  const std::size_t i =
      (static_cast<std::size_t>(by - filled_blocks_lo.y()) * filled_blocks_dims.x() +
       static_cast<std::size_t>(bx - filled_blocks_lo.x())) *
          filled_blocks_dims.z() +
      static_cast<std::size_t>(bz - filled_blocks_lo.z());
  return filled_block_code.data() + i;
}

std::vector<Vec3> DepositSurface::face_centers_mm() const {
  std::vector<Vec3> c(faces.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, faces.size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) c[i] = face_center(i);
                    });
  return c;
}

bool DepositSurface::filled(const Vec3& p_mm) const {
  int slot = 0;
  const std::uint32_t* code = filled_code_of(p_mm, slot);
  if (code == nullptr) return false;
  if (*code == kAllFilled) return true;
  if (*code == kNoneFilled) return false;
  return ((filled_masks[*code - kFirstMask][static_cast<std::size_t>(slot >> 6)] >> (slot & 63)) &
          1U) != 0;
}

namespace surface_blocks {

namespace {
VoxelKey base_of(int bx, int by, int bz) { return VoxelKey{bx * kE, by * kE, bz * kE}; }
}  // namespace

SurfaceRegion SurfaceRegion::of(const VoxelGrid& grid, const Box3& region_mm, DepositSurface& s) {
  SurfaceRegion r;
  s.voxel_mm = grid.voxel_mm();
  if (region_mm.empty()) return r;
  // R in grid keys, padded by one voxel: the padding (R minus its interior I) is forced
  // empty, so the outside is connected all around the part.
  const VoxelKey kmin0 = grid.key_of(region_mm.min);
  const VoxelKey kmax0 = grid.key_of(region_mm.max);
  const VoxelKey kmin{kmin0.x - 1, kmin0.y - 1, kmin0.z - 1};
  const int nx = kmax0.x - kmin0.x + 3, ny = kmax0.y - kmin0.y + 3, nz = kmax0.z - kmin0.z + 3;
  s.dims = Eigen::Vector3i(nx, ny, nz);
  s.origin_mm = grid.origin_mm() + s.voxel_mm * Vec3(kmin.x, kmin.y, kmin.z);
  s.origin_key = kmin;
  r.rlo = kmin;
  r.rhi = VoxelKey{kmin.x + nx - 1, kmin.y + ny - 1, kmin.z + nz - 1};
  r.ilo = VoxelKey{r.rlo.x + 1, r.rlo.y + 1, r.rlo.z + 1};
  r.ihi = VoxelKey{r.rhi.x - 1, r.rhi.y - 1, r.rhi.z - 1};
  // Keys may be negative: >> 3 is the floor.
  r.box.lo = Eigen::Vector3i(r.rlo.x >> 3, r.rlo.y >> 3, r.rlo.z >> 3);
  r.box.n = Eigen::Vector3i((r.rhi.x >> 3) - r.box.lo.x() + 1, (r.rhi.y >> 3) - r.box.lo.y() + 1,
                            (r.rhi.z >> 3) - r.box.lo.z() + 1);
  s.filled_blocks_lo = r.box.lo;
  s.filled_blocks_dims = r.box.n;
  return r;
}

bool SurfaceRegion::block_inside(int bx, int by, int bz, const VoxelKey& lo, const VoxelKey& hi) {
  const VoxelKey b = base_of(bx, by, bz);
  return b.x >= lo.x && b.y >= lo.y && b.z >= lo.z && b.x + kE - 1 <= hi.x &&
         b.y + kE - 1 <= hi.y && b.z + kE - 1 <= hi.z;
}

Cube SurfaceRegion::region_cube(int bx, int by, int bz) const {
  return block_inside(bx, by, bz, rlo, rhi) ? full_cube() : box_cube(base_of(bx, by, bz), rlo, rhi);
}

Cube SurfaceRegion::region_cube_of(std::size_t i) const {
  const Eigen::Vector3i b = box.coords(i);
  return region_cube(b.x(), b.y(), b.z());
}

Cube SurfaceRegion::interior_cube(int bx, int by, int bz) const {
  return block_inside(bx, by, bz, ilo, ihi) ? full_cube() : box_cube(base_of(bx, by, bz), ilo, ihi);
}

std::size_t SurfaceRegion::region_voxels_of(std::size_t i) const {
  const Eigen::Vector3i b = box.coords(i);
  return block_inside(b.x(), b.y(), b.z(), rlo, rhi)
             ? std::size_t{512}
             : static_cast<std::size_t>(count(region_cube(b.x(), b.y(), b.z())));
}

}  // namespace surface_blocks

namespace {

/// The steps of extract_outer_surface; `faces` false stops after the filled volume.
DepositSurface outer_surface(const VoxelGrid& grid, const Box3& region_mm, double seal_gap_mm,
                             double groove_depth_mm, bool faces) {
  using namespace surface_blocks;  // NOLINT(google-build-using-namespace): the steps
  DepositSurface s;
  const SurfaceRegion region = SurfaceRegion::of(grid, region_mm, s);
  if (region_mm.empty()) return s;
  // Gaps narrower than seal_gap_mm must not let the outside in (pinholes between beads are
  // voxelisation artefacts): the flood runs on the part dilated by r voxels, and the outside
  // it reaches is dilated back by r (a morphological opening of the empty space).
  const int seal_r =
      seal_gap_mm > 0 ? static_cast<int>(std::floor(seal_gap_mm / (2 * s.voxel_mm) + 1e-9)) : 0;
  // What the seal closed is opened again to `reopen` voxels (6-connected steps through empty
  // voxels) from the sealed outside: grooves between layers and beads are surface again, a
  // pinhole lets the outside in no further than that.
  const int reopen =
      groove_depth_mm > 0 ? static_cast<int>(std::floor(groove_depth_mm / s.voxel_mm + 1e-9)) : 0;
  const PartBlocks part = part_blocks(grid, region);
  s.occupied_voxels = part.occupied;
  {
    const OutsideFlood flood = flood_outside(region, part, seal_r);
    fill_volume(s, region, part, flood, seal_r, reopen);
  }
  if (faces) extract_faces(s, grid, region, part);
  return s;
}

}  // namespace

DepositSurface extract_outer_surface(const VoxelGrid& grid, const Box3& region_mm,
                                     double seal_gap_mm, double groove_depth_mm) {
  return outer_surface(grid, region_mm, seal_gap_mm, groove_depth_mm, true);
}

DepositSurface extract_filled_volume(const VoxelGrid& grid, const Box3& region_mm,
                                     double seal_gap_mm, double groove_depth_mm) {
  return outer_surface(grid, region_mm, seal_gap_mm, groove_depth_mm, false);
}

}  // namespace printtwin

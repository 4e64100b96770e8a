// Step 3b of the outer surface: the groove reopening. The seal (a closing of the empty space
// by a cube of 2r + 1 voxels) keeps pinholes between beads from exposing the infill, but it
// also closes every groove narrower than the seal: the lines between layers, the valleys
// between outer beads. What it closed opens again here, to a fixed number of 6-connected
// steps through empty voxels from the sealed outside, so a groove (h / 2 deep) is surface
// again while a pinhole lets the outside in no deeper than that.
#include <tbb/parallel_for.h>

#include <algorithm>

#include "deviation/surface_steps.hpp"

namespace printtwin::surface_blocks {

void reopen_grooves(DepositSurface& s, const SurfaceRegion& region, const PartBlocks& part,
                    const std::vector<std::uint32_t>& mixed, int steps) {
  const BlockBox& box = region.box;
  std::vector<Cube> free(mixed.size());  // region voxels that are not part
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Cube r = region.region_cube_of(mixed[m]);
    const Cube& p = or_empty(part.of[mixed[m]]);
    for (std::size_t z = 0; z < kE; ++z) free[m][z] = r[z] & ~p[z];
  });
  // Not filled, per mixed block (the state of the step before).
  std::vector<Cube> open(mixed.size()), next(mixed.size());
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Cube r = region.region_cube_of(mixed[m]);
    for (std::size_t z = 0; z < kE; ++z) open[m][z] = r[z] & ~s.filled_masks[m][z];
  });
  Cube all;
  all.fill(~std::uint64_t{0});
  std::vector<std::uint8_t> active(mixed.size(), 1), changed(mixed.size(), 0);
  for (int step = 0; step < steps; ++step) {
    const auto open_of = [&](int bx, int by, int bz) -> const Cube& {
      if (!box.contains(bx, by, bz)) return kNoCube;
      const std::uint32_t code = s.filled_block_code[box.index(bx, by, bz)];
      if (code == DepositSurface::kAllFilled) return kNoCube;
      if (code == DepositSurface::kNoneFilled)
        return all;  // no part voxel: what of it is in R is outside
      return open[code - DepositSurface::kFirstMask];
    };
    tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
      changed[m] = 0;
      next[m] = open[m];
      if (active[m] == 0) return;
      const Eigen::Vector3i b = box.coords(mixed[m]);
      const int bx = b.x(), by = b.y(), bz = b.z();
      const Cube& o = open[m];
      const Cube &l = open_of(bx - 1, by, bz), &r = open_of(bx + 1, by, bz),
                 &d = open_of(bx, by - 1, bz), &u = open_of(bx, by + 1, bz),
                 &lo = open_of(bx, by, bz - 1), &hi = open_of(bx, by, bz + 1);
      for (std::size_t z = 0; z < kE; ++z) {
        std::uint64_t g = o[z] | ((o[z] << 1) & ~kX0) | ((l[z] & kX7) >> 7) | ((o[z] >> 1) & ~kX7) |
                          ((r[z] & kX0) << 7) | (o[z] << 8) | ((d[z] & kY7) >> 56) | (o[z] >> 8) |
                          ((u[z] & kY0) << 56);
        g |= z > 0 ? o[z - 1] : lo[kE - 1];
        g |= z + 1 < kE ? o[z + 1] : hi[0];
        g = o[z] | (g & free[m][z]);
        changed[m] |= g != o[z] ? 1 : 0;
        next[m][z] = g;
      }
    });
    open.swap(next);
    // The next step looks only at blocks that changed and their neighbours.
    std::fill(active.begin(), active.end(), 0);
    for (std::size_t m = 0; m < mixed.size(); ++m) {
      if (changed[m] == 0) continue;
      active[m] = 1;
      const Eigen::Vector3i b = box.coords(mixed[m]);
      for (const auto& dir : kDirs) {
        const int x = b.x() + dir[0], y = b.y() + dir[1], z = b.z() + dir[2];
        if (!box.contains(x, y, z)) continue;
        const std::uint32_t code = s.filled_block_code[box.index(x, y, z)];
        if (code >= DepositSurface::kFirstMask) active[code - DepositSurface::kFirstMask] = 1;
      }
    }
  }
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    for (std::size_t z = 0; z < kE; ++z) s.filled_masks[m][z] &= ~open[m][z];
  });
}

}  // namespace printtwin::surface_blocks

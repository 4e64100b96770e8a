// Step 3b of the outer surface: the groove reopening. The seal (a closing of the empty space
// by a cube of 2r + 1 voxels) keeps pinholes between beads from exposing the infill, but it
// also closes every groove narrower than the seal: the lines between layers, the valleys
// between outer beads. What it closed opens again here, to a fixed number of 6-connected
// steps through empty voxels from the sealed outside, so a groove (h / 2 deep) is surface
// again while a pinhole lets the outside in no deeper than that.
//
// Each step reads the state of the step before (the same result on any thread count). Only
// blocks with free voxels not yet open can change, and after the first step only those that
// changed or touch one that did; a block's six neighbours are looked up once.
#include <tbb/parallel_for.h>

#include <array>
#include <cstdint>
#include <vector>

#include "deviation/surface_steps.hpp"

namespace printtwin::surface_blocks {

namespace {

/// A mixed block's neighbour (kDirs order): a mixed block's index, or one of these.
constexpr std::int32_t kClosed = -1;  ///< all filled, or beyond the box: nothing open
constexpr std::int32_t kOpen = -2;    ///< none filled: every voxel (of R) open

/// The six neighbours of every mixed block.
std::vector<std::array<std::int32_t, 6>> neighbours_of(const DepositSurface& s, const BlockBox& box,
                                                       const std::vector<std::uint32_t>& mixed) {
  std::vector<std::array<std::int32_t, 6>> nb(mixed.size());
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Eigen::Vector3i b = box.coords(mixed[m]);
    for (std::size_t d = 0; d < 6; ++d) {
      const int x = b.x() + kDirs[d][0], y = b.y() + kDirs[d][1], z = b.z() + kDirs[d][2];
      std::int32_t v = kClosed;
      if (box.contains(x, y, z)) {
        const std::uint32_t code = s.filled_block_code[box.index(x, y, z)];
        if (code == DepositSurface::kNoneFilled)
          v = kOpen;
        else if (code >= DepositSurface::kFirstMask)
          v = static_cast<std::int32_t>(code - DepositSurface::kFirstMask);
      }
      nb[m][d] = v;
    }
  });
  return nb;
}

/// One step of block m: its open voxels grown by one 6-connected step within its free voxels.
Cube grow_step(const std::vector<Cube>& open, const Cube& free,
               const std::array<std::int32_t, 6>& nb, std::size_t m) {
  static const Cube all = full_cube();
  const auto at = [&](std::int32_t v) -> const Cube& {
    return v >= 0 ? open[static_cast<std::size_t>(v)] : v == kOpen ? all : kNoCube;
  };
  const Cube& o = open[m];
  const Cube &l = at(nb[0]), &r = at(nb[1]), &d = at(nb[2]), &u = at(nb[3]), &lo = at(nb[4]),
             &hi = at(nb[5]);
  Cube next;
  for (std::size_t z = 0; z < kE; ++z) {
    std::uint64_t g = ((o[z] << 1) & ~kX0) | ((l[z] & kX7) >> 7) | ((o[z] >> 1) & ~kX7) |
                      ((r[z] & kX0) << 7) | (o[z] << 8) | ((d[z] & kY7) >> 56) | (o[z] >> 8) |
                      ((u[z] & kY0) << 56);
    g |= z > 0 ? o[z - 1] : lo[kE - 1];
    g |= z + 1 < kE ? o[z + 1] : hi[0];
    next[z] = o[z] | (g & free[z]);
  }
  return next;
}

}  // namespace

void reopen_grooves(DepositSurface& s, const SurfaceRegion& region, const PartBlocks& part,
                    const std::vector<std::uint32_t>& mixed, int steps) {
  const BlockBox& box = region.box;
  // Per mixed block: not filled (the state of the step before), and the free voxels (region
  // voxels that are not part) not yet open: a block without them never changes.
  std::vector<Cube> open(mixed.size()), free(mixed.size());
  std::vector<std::uint8_t> can(mixed.size(), 0);
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Cube r = region.region_cube_of(mixed[m]);
    const Cube& p = or_empty(part.of[mixed[m]]);
    std::uint64_t closed = 0;
    for (std::size_t z = 0; z < kE; ++z) {
      open[m][z] = r[z] & ~s.filled_masks[m][z];
      free[m][z] = r[z] & ~p[z];
      closed |= free[m][z] & ~open[m][z];
    }
    can[m] = closed != 0 ? 1 : 0;
  });
  const std::vector<std::array<std::int32_t, 6>> nb = neighbours_of(s, box, mixed);
  std::vector<std::uint32_t> active;
  for (std::size_t m = 0; m < mixed.size(); ++m)
    if (can[m] != 0) active.push_back(static_cast<std::uint32_t>(m));
  std::vector<Cube> grown;
  std::vector<std::uint8_t> changed, listed(mixed.size(), 0);
  for (int step = 0; step < steps && !active.empty(); ++step) {
    grown.resize(active.size());
    changed.assign(active.size(), 0);
    tbb::parallel_for(std::size_t{0}, active.size(), [&](std::size_t k) {
      const std::size_t m = active[k];
      grown[k] = grow_step(open, free[m], nb[m], m);
      changed[k] = grown[k] != open[m] ? 1 : 0;
    });
    // The step's results, then the blocks the next step looks at: those that changed and
    // their mixed neighbours that can still change.
    std::vector<std::uint32_t> next;
    for (std::size_t k = 0; k < active.size(); ++k) {
      if (changed[k] == 0) continue;
      const std::uint32_t m = active[k];
      open[m] = grown[k];
      if (listed[m] == 0) {
        listed[m] = 1;
        next.push_back(m);
      }
      for (const std::int32_t v : nb[m])
        if (v >= 0 && can[static_cast<std::size_t>(v)] != 0 &&
            listed[static_cast<std::size_t>(v)] == 0) {
          listed[static_cast<std::size_t>(v)] = 1;
          next.push_back(static_cast<std::uint32_t>(v));
        }
    }
    for (const std::uint32_t m : next) listed[m] = 0;
    active.swap(next);
  }
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    for (std::size_t z = 0; z < kE; ++z) s.filled_masks[m][z] &= ~open[m][z];
  });
}

}  // namespace printtwin::surface_blocks

// Step 3 of the outer surface: the filled volume. Filled = R minus (the outside dilated back
// by the seal radius r, where not part): a morphological opening of the empty space, so gaps
// narrower than the seal (pinholes between beads) do not let the outside in. What the seal
// closed then opens again to the groove depth (surface_reopen.cpp).
#include <tbb/parallel_for.h>

#include <cstdint>
#include <vector>

#include "deviation/surface_steps.hpp"

namespace printtwin::surface_blocks {

namespace {

/// Region voxels that are not filled in the wholly outside blocks.
std::size_t outside_voxels(const SurfaceRegion& region, const OutsideFlood& flood) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < flood.kind.size(); ++i)
    if (flood.kind[i] == OutsideFlood::kWhole) n += region.region_voxels_of(i);
  return n;
}

/// The mixed blocks whose mask came out all filled or none filled take those codes, the
/// others keep a mask (renumbered, in the same order); returns the region voxels the masks
/// leave not filled.
std::size_t settle_masks(DepositSurface& s, const SurfaceRegion& region,
                         const std::vector<std::uint32_t>& mixed) {
  enum : std::uint8_t { kMixed = 0, kAll = 1, kNone = 2 };
  std::vector<std::uint8_t> state(mixed.size());
  std::vector<std::uint32_t> open_voxels(mixed.size());
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Cube r = region.region_cube_of(mixed[m]);
    std::uint64_t filled = 0, open = 0;
    int n = 0;
    for (std::size_t z = 0; z < kE; ++z) {
      const std::uint64_t f = s.filled_masks[m][z] & r[z];
      filled |= f;
      open |= r[z] & ~f;
      n += popcount64(r[z] & ~f);
    }
    open_voxels[m] = static_cast<std::uint32_t>(n);
    state[m] = open == 0 ? kAll : filled == 0 ? kNone : kMixed;
  });
  std::size_t not_filled = 0, kept = 0;
  for (std::size_t m = 0; m < mixed.size(); ++m) {
    not_filled += open_voxels[m];
    std::uint32_t& code = s.filled_block_code[mixed[m]];
    if (state[m] == kAll) {
      code = DepositSurface::kAllFilled;
    } else if (state[m] == kNone) {
      code = DepositSurface::kNoneFilled;
    } else {
      if (kept != m) s.filled_masks[kept] = s.filled_masks[m];
      code = DepositSurface::kFirstMask + static_cast<std::uint32_t>(kept++);
    }
  }
  s.filled_masks.resize(kept);
  s.filled_masks.shrink_to_fit();
  return not_filled;
}

}  // namespace

void fill_volume(DepositSurface& s, const SurfaceRegion& region, const PartBlocks& part,
                 const OutsideFlood& flood, int seal_r, int reopen) {
  const BlockBox& box = region.box;
  const std::size_t n_blocks = box.size();
  const auto& kind = flood.kind;
  // Only blocks within reach of a block the outside entered can differ from "all filled"
  // (untouched) or "none filled" (wholly outside, which holds no part voxel): a voxel the
  // outside takes back lies within seal_r (Chebyshev) of a voxel the flood found, and one the
  // reopening opens within `reopen` 6-connected steps of such a voxel, so within
  // seal_r + reopen of the flood's outside.
  const int reach = (seal_r + (seal_r > 0 ? reopen : 0) + kE - 1) / kE;
  std::vector<std::uint8_t> near_outside(n_blocks, 0);
  for (std::size_t i = 0; i < n_blocks; ++i)
    near_outside[i] = kind[i] == OutsideFlood::kWhole || (kind[i] == OutsideFlood::kPartial &&
                                                          any(flood.outside[flood.slot[i]]))
                          ? 1
                          : 0;
  dilate_flags(near_outside, box, reach);
  s.filled_block_code.assign(n_blocks, DepositSurface::kAllFilled);
  std::vector<std::uint32_t> mixed;
  for (std::size_t i = 0; i < n_blocks; ++i) {
    if (kind[i] == OutsideFlood::kWhole)
      s.filled_block_code[i] = DepositSurface::kNoneFilled;
    else if (near_outside[i] != 0)
      mixed.push_back(static_cast<std::uint32_t>(i));
  }
  const Cube full = full_cube();
  const auto outside_cube = [&](int bx, int by, int bz) -> const Cube* {
    const std::size_t i = box.index(bx, by, bz);
    if (kind[i] == OutsideFlood::kWhole) return &full;  // R's part of it: the field clips to R
    if (kind[i] == OutsideFlood::kPartial) return &flood.outside[flood.slot[i]];
    return nullptr;
  };
  const auto region_cube = [&](int bx, int by, int bz) { return region.region_cube(bx, by, bz); };
  DilatedField outside_back(box, seal_r, outside_cube, region_cube);
  outside_back.prepare(mixed);
  s.filled_masks.resize(mixed.size());
  tbb::parallel_for(std::size_t{0}, mixed.size(), [&](std::size_t m) {
    const Eigen::Vector3i b = box.coords(mixed[m]);
    Cube o{};
    const bool some = outside_back.top_of(b.x(), b.y(), b.z(), o);
    const Cube r = region.region_cube(b.x(), b.y(), b.z());
    Cube& f = s.filled_masks[m];
    if (!some) {
      f = r;
      return;
    }
    const Cube& p = or_empty(part.of[mixed[m]]);
    for (std::size_t z = 0; z < kE; ++z) f[z] = r[z] & ~(o[z] & ~p[z]);
  });
  for (std::size_t m = 0; m < mixed.size(); ++m)
    s.filled_block_code[mixed[m]] = DepositSurface::kFirstMask + static_cast<std::uint32_t>(m);
  if (seal_r > 0 && reopen > 0) reopen_grooves(s, region, part, mixed, reopen);
  const std::size_t not_filled = settle_masks(s, region, mixed) + outside_voxels(region, flood);
  const auto n = s.dims.cast<std::size_t>();
  s.filled_voxels = n.x() * n.y() * n.z() - not_filled;
}

}  // namespace printtwin::surface_blocks

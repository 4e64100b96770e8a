// Step 1 of the outer surface: the part voxels per block. Voxels of auxiliary features (skirt,
// support, wipe tower, purge) are not part of the deposit, nor is anything in the padding.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "deviation/surface_steps.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin::surface_blocks {

using detail::VoxelBlocks;

namespace {

/// Bit i set when voxel i of z-slice z of block b has an auxiliary tag (`auxiliary[t]` is 1
/// for an auxiliary tag index t; indices clamped to `last`; tags of empty voxels mean nothing).
std::uint64_t aux_mask(const VoxelBlocks::BlockView& b, int z, const std::uint8_t* auxiliary,
                       std::uint32_t last) {
  std::uint64_t m = 0;
  if (b.wide != nullptr) {
    for (int i = 0; i < 64; ++i)
      m |= static_cast<std::uint64_t>(auxiliary[std::min(b.wide[z * 64 + i], last)] & 1U) << i;
    return m;
  }
  unsigned on = 0;  // bit e: palette entry e is auxiliary
  for (int e = 0; e < b.palette_size; ++e)
    on |= (auxiliary[std::min(b.palette[e], last)] & 1U) << e;
  const std::uint8_t* nib = b.nibbles + z * 32;
  for (int i = 0; i < 64; i += 2) {
    const unsigned v = nib[i >> 1];
    m |= static_cast<std::uint64_t>((on >> (v & 0xFU)) & 1U) << i;
    m |= static_cast<std::uint64_t>((on >> (v >> 4)) & 1U) << (i + 1);
  }
  return m;
}

}  // namespace

PartBlocks part_blocks(const VoxelGrid& grid, const SurfaceRegion& region) {
  // The allocated blocks are read in the order they were allocated (their memory order).
  const BlockBox& box = region.box;
  const auto& table = VoxelBlocks::tag_table(grid);
  std::vector<std::uint8_t> auxiliary(table.size());
  for (std::size_t i = 0; i < table.size(); ++i)
    auxiliary[i] = is_auxiliary_feature(table[i].feature) ? 1 : 0;
  const auto last_tag = static_cast<std::uint32_t>(auxiliary.empty() ? 0 : auxiliary.size() - 1);
  PartBlocks part;
  part.of = ZeroedArray<const Cube*>(box.size());
  VoxelBlocks::visit_blocks_as_allocated(grid, [&](const VoxelBlocks::BlockView& b) {
    const int bx = b.base.x >> 3, by = b.base.y >> 3, bz = b.base.z >> 3;
    if (!box.contains(bx, by, bz)) return;
    Cube c;
    std::copy(b.occupancy, b.occupancy + kE, c.begin());
    bool cut = false;
    // A block none of whose palette entries is auxiliary needs no per-voxel test.
    bool aux = b.wide != nullptr;
    for (int e = 0; e < b.palette_size && !aux; ++e)
      aux = auxiliary[std::min(b.palette[e], last_tag)] != 0;
    if (aux) {
      for (int z = 0; z < kE; ++z)
        if (c[static_cast<std::size_t>(z)] != 0)
          c[static_cast<std::size_t>(z)] &= ~aux_mask(b, z, auxiliary.data(), last_tag);
      cut = true;
    }
    if (!SurfaceRegion::block_inside(bx, by, bz, region.ilo, region.ihi)) {
      const Cube in = box_cube(b.base, region.ilo, region.ihi);
      for (std::size_t z = 0; z < kE; ++z) c[z] &= in[z];
      cut = true;
    }
    const int n = count(c);
    if (n == 0) return;
    part.occupied += static_cast<std::size_t>(n);
    const std::size_t i = box.index(bx, by, bz);
    if (cut) {
      part.of[i] = &part.filtered[part.filtered.push(c)];
    } else {
      static_assert(sizeof(Cube) == kE * sizeof(std::uint64_t));
      part.of[i] = reinterpret_cast<const Cube*>(b.occupancy);
    }
  });
  return part;
}

}  // namespace printtwin::surface_blocks

#pragma once
// Private to src/ (the deposit and deviation stages, their tests and benchmarks): the block
// layout of VoxelGrid and the writes and reads that work on it block by block.
//
// The grid is a dense directory of 8x8x8-voxel blocks, a block allocated on its first write.
// A block holds 512 occupancy bits (one 64-bit word per z-slice, bit y * 8 + x), a palette of
// up to kPaletteSize tag indices (into the grid's table of distinct tags) and a 4-bit palette
// index per voxel; a block that needs more distinct tags becomes "wide" (a 32-bit tag index
// per voxel).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

struct VoxelBlocks {
  /// Edge of a block in voxels.
  static constexpr int kBlockEdge = 8;
  /// Distinct tags a block stores as 4-bit palette indices.
  static constexpr int kPaletteSize = 16;
  /// Bytes of one allocated block: 512 occupancy bits, a 4-bit palette index per voxel, the
  /// palette (16 tag indices), its length and the block's coordinates.
  static constexpr std::size_t kBlockBytes = 8 * sizeof(std::uint64_t) + 512 / 2 +
                                             kPaletteSize * sizeof(std::uint32_t) + 1 +
                                             3 * sizeof(std::int32_t);

  /// One allocated block: voxel (base.x + x, base.y + y, base.z + z) for x, y, z in 0..7 is
  /// occupied when bit (y * 8 + x) of occupancy[z] is set; its tag index is
  /// tag_index(z * 64 + y * 8 + x) (meaningful for occupied voxels only).
  struct BlockView {
    VoxelKey base;
    const std::uint64_t* occupancy = nullptr;
    /// 4-bit palette index per voxel slot: slot s in byte s / 2, low nibble for even s.
    const std::uint8_t* nibbles = nullptr;
    /// The block's distinct tag indices (palette_size of them); unused when `wide`.
    const std::uint32_t* palette = nullptr;
    int palette_size = 0;
    /// Non-null for a wide block: the tag index of every slot.
    const std::uint32_t* wide = nullptr;
    std::uint32_t block = 0;
    /// Index into tag_table() of the voxel in `slot` (meaningful when it is occupied).
    [[nodiscard]] std::uint32_t tag_index(int slot) const {
      if (wide != nullptr) return wide[slot];
      return palette[(nibbles[slot >> 1] >> ((slot & 1) * 4)) & 15U];
    }
  };

  // --- Tag table and fast writes (tags are shared per move) ------------------------------

  /// Appends `tag` to the tag table (or reuses the last entry when equal); returns its index.
  static std::uint32_t add_tag(VoxelGrid& grid, const VoxelTag& tag);
  /// Every distinct tag recorded so far; voxels store an index into this table.
  [[nodiscard]] static const std::vector<VoxelTag>& tag_table(const VoxelGrid& grid);
  /// Index into tag_table() of an occupied voxel.
  [[nodiscard]] static std::optional<std::uint32_t> tag_index(const VoxelGrid& grid,
                                                              const VoxelKey& k);
  /// Like VoxelGrid::set(), with a tag already in the table. Returns true if the voxel was
  /// empty before.
  static bool set_index(VoxelGrid& grid, const VoxelKey& k, std::uint32_t tag_index);
  /// Marks voxels x0..x1-1 of the row (y, z) occupied with `tag_index` (clipped to the grid).
  /// Returns how many of them were empty before.
  static std::size_t fill_row(VoxelGrid& grid, std::int32_t y, std::int32_t z, std::int32_t x0,
                              std::int32_t x1, std::uint32_t tag_index);
  /// ORs `mask` into z-slice z of block (bx, by, z / 8), allocating the block: bit y * 8 + x
  /// stands for voxel (8 bx + x, 8 by + y, z). The voxels of the mask get `tag_index`. The
  /// block must be inside block_dims() and z inside dims(). Returns how many of the voxels
  /// were empty before.
  static std::size_t write_tile(VoxelGrid& grid, int bx, int by, std::int32_t z, std::uint64_t mask,
                                std::uint32_t tag_index);
  /// write_tile returning the z-slice's occupancy word before the write.
  static std::uint64_t write_tile_before(VoxelGrid& grid, int bx, int by, std::int32_t z,
                                         std::uint64_t mask, std::uint32_t tag_index);
  /// Asks the kernel to back the whole 2 MiB pages of [p, p + bytes), memory that is filled
  /// densely from its start, with transparent huge pages (one page fault instead of 512);
  /// a special path (core/plain_path.hpp): PRINTTWIN_PLAIN=deposit_huge_pages leaves 4 KiB
  /// pages. Nothing changes where the kernel has no transparent huge pages.
  static void advise_huge_pages(void* p, std::size_t bytes);
  /// Pre-allocates room for `blocks` blocks (no effect on count()).
  static void reserve_blocks(VoxelGrid& grid, std::size_t blocks);

  // --- Reads block by block --------------------------------------------------------------

  /// Allocated blocks.
  [[nodiscard]] static std::size_t block_count(const VoxelGrid& grid);
  /// Allocated blocks that hold more than kPaletteSize distinct tags (wide blocks).
  [[nodiscard]] static std::size_t wide_block_count(const VoxelGrid& grid);
  /// Size of the block directory (blocks per axis, covering dims()).
  [[nodiscard]] static Eigen::Vector3i block_dims(const VoxelGrid& grid);
  /// Occupancy words (8, one per z-slice) of block (bx, by, bz); nullptr when the block is
  /// unallocated or out of range.
  [[nodiscard]] static const std::uint64_t* block_occupancy(const VoxelGrid& grid, int bx, int by,
                                                            int bz);
  /// Block (bx, by, bz) when it is allocated (and inside block_dims()).
  [[nodiscard]] static std::optional<BlockView> block_view(const VoxelGrid& grid, int bx, int by,
                                                           int bz);
  /// Calls fn for every allocated block, in the fixed order of VoxelGrid::for_each (z, then
  /// y, then x).
  static void visit_blocks(const VoxelGrid& grid, const std::function<void(const BlockView&)>& fn);
  /// Calls fn for every allocated block in the order they were allocated (deterministic for
  /// the same writes); touches the allocated blocks only, not the whole directory.
  static void visit_blocks_as_allocated(const VoxelGrid& grid,
                                        const std::function<void(const BlockView&)>& fn);

 private:
  /// The view of allocated block `b` at block coordinates (bx, by, bz).
  [[nodiscard]] static BlockView view_of_block(const VoxelGrid& grid, std::size_t b, int bx, int by,
                                               int bz);
};

}  // namespace printtwin::detail

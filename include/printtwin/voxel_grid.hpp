#pragma once
// VoxelGrid: the in-memory deposit. A blocked grid (8x8x8-voxel blocks allocated on first
// write inside a dense block directory over the grid's extent), after OctoMap's split of
// discrete keys and metric coordinates. Each occupied voxel remembers which move laid it
// (its G-code line, layer and feature), so a defect found later names its G-code lines.
#include <bit>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "printtwin/geometry.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin {

/// Integer voxel address; voxel (i, j, k) covers
/// [origin + i*voxel, origin + (i+1)*voxel) on each axis.
struct VoxelKey {
  std::int32_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelKey&) const = default;
};

/// What laid a voxel (the last move that wrote it).
struct VoxelTag {
  std::uint32_t line = 0;      ///< G-code line
  std::int32_t layer = -1;     ///< layer index
  Feature feature = Feature::unknown;
  bool operator==(const VoxelTag&) const = default;
};

class VoxelGrid {
 public:
  /// Empty grid of `dims` voxels of edge `voxel_mm`, corner at `origin_mm`.
  /// Memory grows with the occupied blocks only (plus 4 bytes per block of the extent).
  VoxelGrid(double voxel_mm, const Vec3& origin_mm, const Eigen::Vector3i& dims);
  VoxelGrid(VoxelGrid&&) noexcept;
  VoxelGrid& operator=(VoxelGrid&&) noexcept;
  VoxelGrid(const VoxelGrid&);
  VoxelGrid& operator=(const VoxelGrid&);
  ~VoxelGrid();

  [[nodiscard]] double voxel_mm() const;
  [[nodiscard]] const Vec3& origin_mm() const;
  [[nodiscard]] const Eigen::Vector3i& dims() const;

  [[nodiscard]] bool in_range(const VoxelKey& k) const;
  /// Key of the voxel containing p (not range-checked).
  [[nodiscard]] VoxelKey key_of(const Vec3& p_mm) const;
  [[nodiscard]] Vec3 center_mm(const VoxelKey& k) const;

  /// Out-of-range keys read as empty.
  [[nodiscard]] bool occupied(const VoxelKey& k) const;
  [[nodiscard]] std::optional<VoxelTag> tag(const VoxelKey& k) const;
  /// Marks a voxel occupied; returns true if it was empty before. Out of range: ignored (false).
  bool set(const VoxelKey& k, const VoxelTag& tag);
  void clear(const VoxelKey& k);

  /// Occupied voxels.
  [[nodiscard]] std::size_t count() const;
  /// Bytes of the blocks in use, the directory and the tag table (chunks of blocks are
  /// reserved as address space; their pages become resident as blocks are used).
  [[nodiscard]] std::size_t memory_bytes() const;
  /// Bytes a grid of `dims` needs for its directory plus `occupied_voxels` spread over blocks
  /// (an estimate, used for the --max-memory check before allocation).
  [[nodiscard]] static std::size_t estimate_bytes(const Eigen::Vector3i& dims,
                                                  std::size_t occupied_voxels);

  // --- Tag table and fast writes (used by the deposit; tags are shared per move) ---------

  /// Edge of a block in voxels.
  static constexpr int kBlockEdge = 8;
  /// Distinct tags a block stores as 4-bit palette indices; a block that needs more becomes
  /// "wide" (a 32-bit tag index per voxel, kept beside the chunks).
  static constexpr int kPaletteSize = 16;
  /// Bytes of one allocated block: 512 occupancy bits, a 4-bit palette index per voxel, the
  /// palette (16 tag indices), its length and the block's coordinates.
  static constexpr std::size_t kBlockBytes =
      8 * sizeof(std::uint64_t) + 512 / 2 + kPaletteSize * sizeof(std::uint32_t) + 1 + 3 * sizeof(std::int32_t);

  /// Appends `tag` to the tag table (or reuses the last entry when equal); returns its index.
  std::uint32_t add_tag(const VoxelTag& tag);
  /// Every distinct tag recorded so far; voxels store an index into this table.
  [[nodiscard]] const std::vector<VoxelTag>& tag_table() const;
  /// Index into tag_table() of an occupied voxel.
  [[nodiscard]] std::optional<std::uint32_t> tag_index(const VoxelKey& k) const;
  /// Like set(), with a tag already in the table. Returns true if the voxel was empty before.
  bool set_index(const VoxelKey& k, std::uint32_t tag_index);
  /// Marks voxels x0..x1-1 of the row (y, z) occupied with `tag_index` (clipped to the grid).
  /// Returns how many of them were empty before.
  std::size_t fill_row(std::int32_t y, std::int32_t z, std::int32_t x0, std::int32_t x1,
                       std::uint32_t tag_index);
  /// ORs `mask` into z-slice z of block (bx, by, z / 8), allocating the block: bit y * 8 + x
  /// stands for voxel (8 bx + x, 8 by + y, z). The voxels of the mask get `tag_index`. The
  /// block must be inside block_dims() and z inside dims(). Returns how many of the voxels
  /// were empty before.
  std::size_t write_tile(int bx, int by, std::int32_t z, std::uint64_t mask, std::uint32_t tag_index);
  /// Pre-allocates room for `blocks` blocks (no effect on count()).
  void reserve_blocks(std::size_t blocks);
  /// Allocated blocks.
  [[nodiscard]] std::size_t block_count() const;
  /// Allocated blocks that hold more than kPaletteSize distinct tags (wide blocks).
  [[nodiscard]] std::size_t wide_block_count() const;

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
  /// Size of the block directory (blocks per axis, covering dims()).
  [[nodiscard]] Eigen::Vector3i block_dims() const;
  /// Occupancy words (8, one per z-slice) of block (bx, by, bz); nullptr when the block is
  /// unallocated or out of range.
  [[nodiscard]] const std::uint64_t* block_occupancy(int bx, int by, int bz) const;
  /// Block (bx, by, bz) when it is allocated (and inside block_dims()).
  [[nodiscard]] std::optional<BlockView> block_view(int bx, int by, int bz) const;
  /// Calls fn for every allocated block, in the fixed order of for_each (z, then y, then x).
  void visit_blocks(const std::function<void(const BlockView&)>& fn) const;
  /// Calls fn for every allocated block in the order they were allocated (deterministic for
  /// the same writes); touches the allocated blocks only, not the whole directory.
  void visit_blocks_as_allocated(const std::function<void(const BlockView&)>& fn) const;

  /// Calls fn(const VoxelKey&, const VoxelTag&) for every occupied voxel, in a fixed order
  /// (block by block, z-major), so results are deterministic.
  template <class Fn>
  void for_each(Fn&& fn) const {
    const auto& table = tag_table();
    visit_blocks([&](const BlockView& b) {
      for (int z = 0; z < kBlockEdge; ++z) {
        std::uint64_t bits = b.occupancy[z];
        while (bits != 0) {
          const int bit = std::countr_zero(bits);
          bits &= bits - 1;
          const VoxelKey k{b.base.x + (bit & 7), b.base.y + (bit >> 3), b.base.z + z};
          fn(k, table[b.tag_index(z * 64 + bit)]);
        }
      }
    });
  }
  /// All occupied keys in the fixed order of for_each.
  [[nodiscard]] std::vector<VoxelKey> occupied_keys() const;

 private:
  struct Impl;
  /// The view of allocated block `b` at block coordinates (bx, by, bz).
  [[nodiscard]] BlockView view_of_block(std::size_t b, int bx, int by, int bz) const;
  std::unique_ptr<Impl> impl_;
};

}  // namespace printtwin

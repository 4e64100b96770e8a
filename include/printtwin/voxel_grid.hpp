#pragma once
// VoxelGrid: the in-memory deposit, after OctoMap's split of discrete keys and metric
// coordinates. Memory grows with the occupied part of the extent only. Each occupied voxel
// remembers which move laid it (its G-code line, layer and feature), so a defect found later
// names its G-code lines.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "printtwin/geometry.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin {

namespace detail {
struct VoxelBlocks;
}  // namespace detail

/// Integer voxel address; voxel (i, j, k) covers
/// [origin + i*voxel, origin + (i+1)*voxel) on each axis.
struct VoxelKey {
  std::int32_t x = 0, y = 0, z = 0;
  bool operator==(const VoxelKey&) const = default;
};

/// What laid a voxel (the last move that wrote it).
struct VoxelTag {
  std::uint32_t line = 0;   ///< G-code line
  std::int32_t layer = -1;  ///< layer index
  Feature feature = Feature::unknown;
  bool operator==(const VoxelTag&) const = default;
};

class VoxelGrid {
 public:
  /// Empty grid of `dims` voxels of edge `voxel_mm`, corner at `origin_mm`.
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
  /// Bytes in use (the occupied part of the grid, its index and the tags).
  [[nodiscard]] std::size_t memory_bytes() const;
  /// Bytes a grid of `dims` with `occupied_voxels` occupied voxels needs (an estimate, used
  /// for the --max-memory check before allocation).
  [[nodiscard]] static std::size_t estimate_bytes(const Eigen::Vector3i& dims,
                                                  std::size_t occupied_voxels);

  /// Calls fn for every occupied voxel with its tag, in a fixed order (block by block,
  /// z-major), so results are deterministic.
  void for_each(const std::function<void(const VoxelKey&, const VoxelTag&)>& fn) const;
  /// All occupied keys in the fixed order of for_each.
  [[nodiscard]] std::vector<VoxelKey> occupied_keys() const;

 private:
  friend struct detail::VoxelBlocks;  // block-level access of the deposit and deviation stages
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace printtwin

#pragma once
// The deposit's height map: per XY column, the rows of voxels occupied up to (0 = bed or
// empty), the layer of the move that last wrote the column's top voxel, and the rows the
// column held before that layer first reached its top (what the earlier layers left, which
// the droop model reads under this layer's beads), and whether that top voxel is support
// (the droop model rests beads on support tops across the support's Z gap). The bead model
// reads it for each bead's height and support; the sweep raises it as it lays the bead. It
// never reads the grid, whose writes may still be under way on the writer thread.
//
// Stored in 8 x 8 tiles in the blocks' order (HeightMapView::index), so a tile of the sweep
// and the samples across a bead touch a cache line or two instead of one page per row.
#include <cstddef>
#include <cstdint>
#include <optional>

#include "core/zeroed_array.hpp"
#include "deposit/kernels.hpp"
#include "printtwin/geometry.hpp"

namespace printtwin::detail {

/// floor(v) for finite v in int range (std::floor is a library call on baseline x86-64).
inline int floor_int(double v) {
  const int i = static_cast<int>(v);
  return i - (v < static_cast<double>(i) ? 1 : 0);
}

class HeightMap {
 public:
  /// Rows of the map at most (signed 16-bit maximum, see raise_tops).
  static constexpr std::size_t kMaxRows = 32767;

  /// A map over nx x ny columns (tiles_x tiles per row, tiles_y rows of tiles) of edge
  /// `voxel_mm` with its corner at `origin_mm`.
  HeightMap(double voxel_mm, const Vec3& origin_mm, int nx, int ny, std::size_t tiles_x,
            std::size_t tiles_y);

  [[nodiscard]] HeightMapView view() const { return {top_.data(), tiles_x_, nx_, ny_}; }
  /// Index of column (i, j) (in the map) in the tile layout.
  [[nodiscard]] std::size_t index(int i, int j) const { return view().index(i, j); }
  /// Map coordinates (voxel units from the corner) of x and y (mm).
  [[nodiscard]] double u(double x_mm) const { return (x_mm - ox_) * inv_voxel_; }
  [[nodiscard]] double v(double y_mm) const { return (y_mm - oy_) * inv_voxel_; }
  /// Deposit rows in the column under (x, y) (mm), 0 outside the map.
  [[nodiscard]] int rows(double x_mm, double y_mm) const {
    return view().rows_at(u(x_mm), v(y_mm));
  }
  /// Height (mm, machine frame) of the deposit top in the column under (x, y), or the grid
  /// bottom (the bed) outside the map.
  [[nodiscard]] double top_mm(double x_mm, double y_mm) const {
    return oz_ + rows(x_mm, y_mm) * voxel_;
  }
  /// The value raise_tile stores per column for a bead of `layer`: the layer and whether the
  /// bead is support (its lowest bit).
  [[nodiscard]] static constexpr std::int32_t layer_code(std::int32_t layer, bool support) {
    return layer * 2 + (support ? 1 : 0);
  }
  /// Layer of the move that last wrote the top voxel of the column under (x, y) (mm);
  /// nullopt when the column is empty or outside the map.
  [[nodiscard]] std::optional<std::int32_t> top_layer_at(double x_mm, double y_mm) const;
  /// Whether the top voxel of the column under (x, y) (mm) is support (false when empty).
  [[nodiscard]] bool top_is_support(double x_mm, double y_mm) const;
  /// Rows the column under (x, y) (mm) held before the layer of its top voxel first wrote its
  /// top (the earlier layers' material under that layer's beads); 0 outside the map.
  [[nodiscard]] int rows_before_top_layer(double x_mm, double y_mm) const;
  /// Smallest row count r with oz + r * voxel >= z_mm (the same comparison top_mm makes).
  [[nodiscard]] int rows_reaching(double z_mm) const;

  /// Raises the 64 columns of the tile whose first column has index `at` to at least `rows`
  /// where `mask` (bit y * 8 + x) is set; where the write reaches a column's top (rows >= its
  /// height), the column's top voxel is now `layer`'s (a layer_code); where that changes the
  /// column's top layer, the rows it held before are kept (rows_before_top_layer).
  void raise_tile(std::size_t at, std::uint64_t mask, std::uint16_t rows, std::int32_t layer) {
    raise_tops(top_.data() + at, top_layer_.data() + at, before_.data() + at, mask, &rows, false,
               layer);
  }
  /// raise_tile with rows per column: column s (bit s of `mask`) to at least rows[s]. One call
  /// for a tile's voxel layers instead of one per layer (each column raised by its highest).
  void raise_tile_columns(std::size_t at, std::uint64_t mask, const std::uint16_t* rows,
                          std::int32_t layer) {
    raise_tops(top_.data() + at, top_layer_.data() + at, before_.data() + at, mask, rows, true,
               layer);
  }
  /// Sets rows[s] = value for the bits s of `mask` (the per-column rows of raise_tile_columns).
  static void set_columns(std::uint16_t* rows, std::uint64_t mask, std::uint16_t value);

  /// The columns (bit y * 8 + x) of the tile whose first column has index `at` that hold
  /// exactly `rows` rows. The top voxel of a column is always occupied (every write raises
  /// the map), so these are the columns whose voxel in row rows - 1 is occupied and is their
  /// top.
  [[nodiscard]] std::uint64_t tops_equal(std::size_t at, std::uint16_t rows) const;

  /// Bytes per column of the map (for the memory estimate).
  static constexpr std::size_t kColumnBytes = 2 * sizeof(std::uint16_t) + sizeof(std::int32_t);
  [[nodiscard]] std::size_t memory_bytes() const { return top_.size() * kColumnBytes; }
  /// Frees the map.
  void release() {
    top_ = {};
    top_layer_ = {};
    before_ = {};
  }

 private:
  /// `rows`: one value for every column, or (per_column) 64 values.
  static void raise_tops(std::uint16_t* tile, std::int32_t* layers, std::uint16_t* before,
                         std::uint64_t mask, const std::uint16_t* rows, bool per_column,
                         std::int32_t layer);

  double voxel_, inv_voxel_;
  double ox_, oy_, oz_;
  int nx_, ny_;
  std::size_t tiles_x_;
  ZeroedArray<std::uint16_t> top_;       // rows per column
  ZeroedArray<std::int32_t> top_layer_;  // layer_code of each column's top voxel
  ZeroedArray<std::uint16_t> before_;    // rows before that layer first wrote the top
};

}  // namespace printtwin::detail

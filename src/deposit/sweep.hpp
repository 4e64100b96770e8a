#pragma once
// The sweep: one bead (tip path, section, end cuts) to voxels, 64 at a time.
//
// A voxel is occupied when its fixed sample point (kernels.hpp) lies inside the bead.
// The bead's footprint at its widest over its voxel layers gives, once per bead, the block
// rows it reaches, the blocks of each row and the rows of each block; each such 8 x 8 tile
// of a block's z-slice is tested layer by layer (kernels.cpp) and written as one
// occupancy word per layer into the grid, and the height map is raised under it. Material
// that falls on occupied voxels squeezes into the free voxels nearest the section.
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/zeroed_array.hpp"
#include "deposit/grid_writer.hpp"
#include "deposit/height_map.hpp"
#include "deposit/kernels.hpp"
#include "deposit/voxel_blocks.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin::detail {

/// Sixteen 64-bit words per 8 x 8 x 8 block of a grid: the occupancy as the sweep wrote it
/// (words 0-7, one per z-slice, bit y * 8 + x, as the grid's), then the voxels holding
/// squeezed material (words 8-15). A block's words are allocated (zero) on their first write
/// and never move.
///
/// The directory has two levels, so that its memory grows with the blocks written, not with
/// the extent: a coarse directory (4 bytes per 8 x 8 blocks of a z-slab of blocks) points to
/// the directories of 8 x 8 blocks that hold words, which, like the words, are taken in
/// order from arenas of large chunks. Every page of those is written before it is read, so
/// the kernel backs them with huge pages where it can; a dense directory of the extent, read
/// before it is written, took a 4 KiB page fault per page touched.
class BlockWords {
 public:
  static constexpr int kWords = 16;    ///< words per block
  static constexpr int kSqueezed = 8;  ///< the first word of the squeezed voxels
  explicit BlockWords(const Eigen::Vector3i& block_dims);
  /// The words of block (bx, by, bz); nullptr when it has none or lies outside the grid.
  [[nodiscard]] const std::uint64_t* find(int bx, int by, int bz) const {
    if (bx == last_.x() && by == last_.y() && bz == last_.z()) return last_words_;
    if (bx < 0 || by < 0 || bz < 0 || bx >= dims_.x() || by >= dims_.y() || bz >= dims_.z())
      return nullptr;
    const std::uint32_t group = top_.empty() ? 0 : top_[top_index(bx, by, bz)];
    if (group == 0) return nullptr;
    const std::uint32_t block = groups_.at(group - 1)[group_slot(bx, by)];
    if (block == 0) return nullptr;
    last_ = Eigen::Vector3i(bx, by, bz), last_words_ = words_.at(block - 1);
    return last_words_;
  }
  [[nodiscard]] std::uint64_t* find(int bx, int by, int bz) {
    return const_cast<std::uint64_t*>(std::as_const(*this).find(bx, by, bz));
  }
  /// The words of block (bx, by, bz), allocated when it had none; nullptr outside the grid.
  std::uint64_t* make(int bx, int by, int bz);

 private:
  /// Items of T taken in order from chunks of 2 MiB (kernel-zeroed mappings), `per` at a
  /// time; item i starts at at(i).
  template <class T, std::size_t kPer>
  class Arena {
   public:
    static constexpr std::size_t kChunkItems = (std::size_t{2} << 20) / (kPer * sizeof(T));
    [[nodiscard]] T* at(std::uint32_t i) const {
      return bases_[i / kChunkItems] + (i % kChunkItems) * kPer;
    }
    /// A new zero item: its index + 1.
    std::uint32_t add() {
      if (count_ % kChunkItems == 0) {
        chunks_.emplace_back(kChunkItems * kPer);
        bases_.push_back(chunks_.back().data());
        VoxelBlocks::advise_huge_pages(bases_.back(), kChunkItems * kPer * sizeof(T));
      }
      return static_cast<std::uint32_t>(++count_);
    }

   private:
    std::vector<ZeroedArray<T>> chunks_;
    std::vector<T*> bases_;  // chunks_[c].data()
    std::size_t count_ = 0;
  };
  [[nodiscard]] std::size_t top_index(int bx, int by, int bz) const {
    return (static_cast<std::size_t>(bz) * static_cast<std::size_t>(top_y_) +
            static_cast<std::size_t>(by >> 3)) *
               static_cast<std::size_t>(top_x_) +
           static_cast<std::size_t>(bx >> 3);
  }
  static std::size_t group_slot(int bx, int by) {
    return static_cast<std::size_t>(((by & 7) << 3) | (bx & 7));
  }
  Eigen::Vector3i dims_;
  int top_x_, top_y_;
  ZeroedArray<std::uint32_t> top_;      // 8 x 8 blocks -> 1 + their group (0: none)
  Arena<std::uint32_t, 64> groups_;     // per group: block -> 1 + its words (0: none)
  Arena<std::uint64_t, kWords> words_;  // per block with words
  // The block found or made last (the sweep writes a tile's layers in turn) and its words.
  mutable Eigen::Vector3i last_{-1, -1, -1};
  mutable std::uint64_t* last_words_ = nullptr;
};

/// One bead as the sweep lays it (mm, machine frame).
struct SweptBead {
  Vec3 a_mm, b_mm;  ///< tip path
  Vec2 d, n;        ///< unit direction (xy) and lateral normal
  Vec2 m0, m1;      ///< start and end cut normals (unit, xy)
  double h_mm = 0, w_mm = 0;
  std::int32_t layer = 0;  ///< HeightMap::layer_code of the bead's layer
  /// How far (mm) the material that falls on occupied voxels may squeeze out of the section
  /// into free voxels (0: it is lost).
  double squeeze_mm = 0;
  /// A round join at a_mm with the bead before it (both cut square there): a section of
  /// height join_h_mm and width join_w_mm (the wider bead's), revolved about the vertical
  /// through a_mm, fills what neither bead covers. join_w_mm 0: no join.
  double join_h_mm = 0, join_w_mm = 0;
  Vec2 join_d = Vec2::UnitX();  ///< the bead before's direction (unit, xy)
  /// Round end caps: the section revolved half a turn about the vertical through a_mm (behind
  /// the start) and b_mm (past the end), the disc a nozzle leaves where a path starts or
  /// stops. The ends must be cut square (m0 = m1 = d).
  bool cap_start = false, cap_end = false;
  /// The bead may form the part's side surface (an outer or overhang perimeter, or a bead of
  /// unknown feature): its squeezed material stays off an open side beyond the bead's flat
  /// part, so the grooves between layers stay open. Other beads (inner perimeters, infill,
  /// gap fill, support, skirt, start code) lie inside the part or outside it: their material
  /// may go past an open side.
  bool keeps_sides = true;
  /// Material (mm3 per mm of the path) the section leaves out: a bead flattened over earlier
  /// plastic spreads no further than squeeze_mm beyond its nominal edges (bound_flattened);
  /// the rest is overflow like the bead's overlap, and the squeeze places it.
  double overflow_mm2 = 0;
  /// How many voxel layers the squeezed material may rise above the tip, last (an over-full
  /// solid layer rises); -1: up to squeeze_mm. 0 for a bead that keeps its sides (a raised top
  /// narrows the next layer's gap, which then lays its bead thinner and wider), 1 for top
  /// solid infill (the part's top surface rises by a voxel at most).
  int rise_voxels = 0;
};

class BeadSweep {
 public:
  /// Sweeps into a grid of `grid`'s frame. `exhaustive`: test every tile of each bead's box
  /// (DepositSettings::exhaustive_tiles).
  BeadSweep(const VoxelGrid& grid, bool exhaustive);

  struct Laid {
    std::size_t overlap = 0;   ///< voxels of the bead that were occupied already
    std::size_t squeezed = 0;  ///< free voxels nearby that took that material instead
  };
  /// Lays `bead` into `grid` with tag `tag` and raises the height map under it.
  Laid lay(const SweptBead& bead, VoxelGrid& grid, std::uint32_t tag, HeightMap& map);
  /// Sends the grid's writes to `writer` (nullptr: writes them at once), which then counts
  /// the overlap (lay returns zeros). Only for beads without a squeeze, which reads the grid.
  void defer_writes(GridWriter* writer) { writer_ = writer; }
  /// With the squeeze: sends the grid's writes to `writer`, which only writes them, and keeps
  /// a copy of the grid's occupancy that the sweep reads instead of the grid's, so that the
  /// writes may run on a writer thread behind the sweep (the counts stay the sweep's).
  void mirror_writes(GridWriter* writer) { mirror_to_ = writer; }

 private:
  /// The frame of the sample-point tests, and the layers the section reaches (reached_) with
  /// its widest half-width over them (voxel units); false when it reaches none.
  bool set_up(const SweptBead& bead, BeadFrame& f, Vec2& a2, Vec2& b2, double& hw);
  /// Calls fn(bx, by, row_lo, row_hi, lanes) for each tile the footprint reaches whose
  /// lateral offsets (voxel units, along +n from the centre line) lie in [lo, hi], row of
  /// tiles by row (by ascending), each row in x order; an fn that returns bool stops the walk
  /// by returning false.
  template <class Fn>
  void for_each_tile(const SweptBead& bead, const Vec2& a2, const Vec2& b2, double lo, double hi,
                     Fn&& fn) const;
  /// A section (height h_mm, width w_mm) revolved about the vertical through centre_mm, in
  /// the wedge where m0 . q >= 0 and m1 . q < 0 (q from the centre, xy): a round join or an
  /// end cap.
  struct Disc {
    Vec3 centre_mm;
    double h_mm, w_mm;
    Vec2 m0, m1;
    std::int32_t layer;  ///< HeightMap::layer_code
  };
  /// Lays `disc` with tag `tag` and raises the height map under it. `overlap` nullptr (a
  /// join): fills only the free voxels; otherwise writes them all and adds those that were
  /// occupied already to *overlap. Returns how many free voxels it filled.
  std::size_t lay_disc(const Disc& disc, VoxelGrid& grid, std::uint32_t tag, HeightMap& map,
                       std::size_t* overlap);
  /// The voxels of material `bead` leaves out of its section (SweptBead::overflow_mm2).
  std::size_t overflow_voxels(const SweptBead& bead) const;
  /// Where a bead's squeezed material may go sideways: voxel centres whose offset from the
  /// centre line (voxel units, along +n) lies in [-neg, pos]. A side against earlier plastic
  /// is open (infinite); a side open to air ends at the bead's own flat part, so the grooves
  /// between layers on the outside of a wall stay.
  struct Sides {
    Vec2 a2 = Vec2::Zero(), n = Vec2::UnitY();
    double pos = 0, neg = 0;
    Vec2 b2 = Vec2::Zero(), m0 = Vec2::UnitX(), m1 = Vec2::UnitX();  ///< the bead's end cuts
    [[nodiscard]] bool open() const { return std::isinf(pos) && std::isinf(neg); }
    /// The tile's voxels (bit y * 8 + x) that lie between the limits.
    [[nodiscard]] std::uint64_t tile_mask(int i0, int j0) const;
    /// The tile's voxels between the bead's start cut (m0 . (q - a2) >= 0) and end cut
    /// (m1 . (q - b2) <= 0): the local ring stays on the bead's own stretch of the path.
    [[nodiscard]] std::uint64_t cut_mask(int i0, int j0) const;
  };
  /// The sides of `bead` (frame f, start a2, end b2): which side holds earlier plastic, probed
  /// just beyond its edges at its centre height.
  Sides sides_of(const BeadFrame& f, const SweptBead& bead, const Vec2& a2, const Vec2& b2,
                 const VoxelGrid& grid) const;
  /// Places up to `lost` voxels of material in the free voxels near the bead: within the
  /// bead's squeeze_mm beside and below it (within `sides` first, then on both sides), then
  /// above the tip a voxel layer at a time. Returns how many it placed.
  std::size_t squeeze(const SweptBead& bead, const BeadFrame& f, const Vec2& a2, const Vec2& b2,
                      const Sides& sides, std::size_t lost, VoxelGrid& grid, std::uint32_t tag,
                      HeightMap& map);
  /// Where a squeeze places material: a grown section, over some layers of a tile's rows.
  struct Ring {
    const BeadFrame* grown;      ///< the section grown by the ring's reach, or nullptr:
    const std::uint64_t* masks;  ///< per layer, the bead's voxels; the ring: up to `steps`
                                 ///< voxels from them (x, y or z steps, within the tile)
    const std::int32_t* layers;  ///< the voxel layers, lowest first
    int count;                   ///< how many
    const std::uint64_t* hits;   ///< per layer, voxels next to which material goes first
    std::int32_t bead_layer;     ///< the layer the placed voxels belong to
    const Sides* sides;          ///< where it may go sideways (nullptr: anywhere)
    int steps;                   ///< the local ring's reach (voxels)
    bool past_sides;             ///< what finds no room within `sides` may go past them
    /// The grown section's masks of this tile, per layer, kept across two passes over the
    /// same tiles and layers (nullptr: none); *known: bit n set when cache[n] is filled in.
    std::uint64_t* cache = nullptr;
    std::uint64_t* known = nullptr;
    /// The bead's lowest voxel layer: below it, only voxels on earlier plastic (or the bed)
    /// take material.
    std::int32_t bottom = 0;
  };
  /// Into free_: per layer of `ring`, the free voxels of tile (bx, by) that may take material
  /// (below ring.bottom, only those resting on plastic or the bed). Returns their union.
  std::uint64_t free_voxels(const Ring& ring, const VoxelGrid& grid, int bx, int by);
  /// Into ring_: the grown section's voxels of tile (bx, by) on each layer of `ring` that has
  /// free voxels in `within` (free_), 0 on the others.
  void grown_masks(const Ring& ring, int bx, int by, int row_lo, int row_hi, unsigned lanes,
                   std::uint64_t within);
  /// Places up to `need` voxels in the free voxels of tile (bx, by) inside the ring (rows
  /// row_lo..row_hi-1, x lanes `lanes`, within ring.sides): nearest first; of equal distance,
  /// those next to ring.hits first (when given; beside, above and below), then the rest,
  /// lower layers first. Returns how many it placed.
  std::size_t squeeze_tile(const Ring& ring, int bx, int by, int row_lo, int row_hi, unsigned lanes,
                           std::size_t need, VoxelGrid& grid, std::uint32_t tag, HeightMap& map);

  /// The occupancy words of block (bx, by, bz) as the sweep has written them (the grid's, or
  /// its copy with mirror_writes); nullptr when the block holds nothing.
  [[nodiscard]] const std::uint64_t* occupancy(const VoxelGrid& grid, int bx, int by, int bz) const;
  /// Writes `mask` into z-slice k of block (bx, by) with tag `tag` (into the grid, or into the
  /// copy and to the writer with mirror_writes); returns the slice's occupancy before.
  std::uint64_t write_slice(VoxelGrid& grid, int bx, int by, int k, std::uint64_t mask,
                            std::uint32_t tag);

  GridWriter* writer_ = nullptr;     // where the writes go (nullptr: into the grid at once)
  GridWriter* mirror_to_ = nullptr;  // with the squeeze: where the writes go (nullptr: the grid)
  bool joined_ = false;              // the bead laid last had a round join with writes
  Vec3 origin_;
  double inv_voxel_;
  int nx_, ny_, nz_;
  Eigen::Vector3i block_dims_;
  bool exhaustive_;
  std::vector<std::int32_t> reached_;       // scratch: the voxel layers a bead reaches
  std::vector<std::uint64_t> masks_;        // scratch: a tile's occupancy word per reached layer
  std::vector<std::int32_t> layers_;        // scratch: the layers of the squeeze
  std::vector<std::int32_t> local_layers_;  // scratch: the layers of the local ring
  std::vector<std::uint64_t> hits_;         // scratch: the bead's voxels that were occupied already
  std::vector<std::uint64_t> ring_;         // scratch: a tile's free voxels in a squeeze ring
  std::vector<std::uint64_t> reach_;        // scratch: the local ring's reach per step and layer
  std::vector<std::uint64_t> put_;          // scratch: a tile's voxels a squeeze fills, per layer
  std::vector<std::uint64_t> hit_near_;     // scratch: a tile's voxels next to the hits, per layer
  std::vector<std::uint64_t> free_;         // scratch: a tile's free voxels per ring layer
  std::vector<std::uint64_t> tile_masks_;   // scratch: grown masks per tile of a first pass
  std::vector<std::uint64_t> tile_known_;   // scratch: which of them are filled in, per tile
  using TileKey = std::array<int, 4>;       // a tile of a walk: by, bx, its rows lo and hi
  std::vector<TileKey> tile_keys_;          // scratch: the tiles of a first pass, in order
  std::vector<std::int32_t> test_layers_;   // scratch: the ring layers a tile test covers
  std::vector<std::int32_t> test_ks_;       // scratch: their voxel layers
  std::vector<std::uint64_t> test_out_;     // scratch: their masks
  // Per written block: with mirror_writes, the grid's occupancy as the sweep wrote it; and
  // the voxels that hold squeezed material: a later bead that falls on them displaces that
  // material again as its own overflow, but it is not counted as overlap a second time.
  BlockWords words_;
};

}  // namespace printtwin::detail

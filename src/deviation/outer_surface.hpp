#pragma once
// Private to the deviation stage (and its tests and benchmark): the deposit's outer surface
// as compute_deviation measures it: its exposed voxel faces in a fixed cell order, the
// filled volume block by block, and the exact distance search to the faces.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "printtwin/deviation.hpp"
#include "printtwin/voxel_grid.hpp"

namespace printtwin {

/// One exposed face of the deposit's outer surface.
struct SurfaceFace {
  VoxelKey voxel;         ///< the filled voxel the face belongs to
  std::uint8_t axis = 0;  ///< 0 x, 1 y, 2 z: the face's normal axis
  std::int8_t side = 1;   ///< +1: face on the voxel's max side, -1: min side
};

/// The outer surface of the deposit inside `region_mm`, plus the filled volume.
struct DepositSurface {
  double voxel_mm = 0;
  Vec3 origin_mm = Vec3::Zero();  ///< min corner of the analysed region (voxel aligned)
  VoxelKey origin_key{};          ///< grid key of the region's min-corner voxel
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< analysed voxels per axis
  /// Fixed order, by 4^3-voxel cell: the grid's 8^3 blocks in the order of
  /// filled_block_code (y, then x, then z), each block's 8 cells by their y, x and z halves,
  /// in a cell its voxel rows by y then x, voxels by z, a voxel's faces consecutive (-x +x -y
  /// +y -z +z). Both distance searches visit the faces cell by cell in this order.
  std::vector<SurfaceFace> faces;
  std::vector<VoxelTag> face_tags;  ///< tag of each face's voxel
  /// After place_on_beads, the deposit -> mesh points: where a bead owns the surface, points
  /// laid on its exposed outline (sample_bead_outlines); elsewhere each face's point (its
  /// centre, or moved onto a bead). Empty: the face centres stand for themselves.
  std::vector<Vec3> points_mm;
  std::vector<double> point_area_mm2;  ///< true surface each point stands for
  std::vector<VoxelTag> point_tags;    ///< layer, line and feature of each point
  /// Runs of nearby points for the closest-point search: run g is
  /// [point_groups[g], point_groups[g + 1]).
  std::vector<std::uint32_t> point_groups;
  /// Per face: the bead its point was placed on, or whose outline covers the voxel pit the
  /// face lies in (kNoBead where the face centre stays).
  std::vector<std::uint32_t> face_bead;
  /// Per bead (CSR, beads + 1 entries; empty lists for beads laid no points): the beads whose
  /// outline may touch it, for the distance to the beads' union near it.
  std::vector<std::uint32_t> bead_touch_begin, bead_touch;
  /// The blocks holding faces, as indices into filled_block_code, ascending.
  std::vector<std::uint32_t> face_blocks;
  /// First face of cell c (0..7: y half * 4 + x half * 2 + z half) of face block k:
  /// face_cell_begin[8 k + c]; a cell ends where the next begins (one entry past the last).
  std::vector<std::uint32_t> face_cell_begin;
  /// Filled (not outside-reachable) voxels, by 8^3 block of the grid: word z of a block is its
  /// z-slice z, bit y * 8 + x its voxel (x, y).
  using BlockBits = std::array<std::uint64_t, 8>;
  /// Per block code: every region voxel of the block filled, none, or filled_masks[code - 2].
  static constexpr std::uint32_t kAllFilled = 0, kNoneFilled = 1, kFirstMask = 2;
  Eigen::Vector3i filled_blocks_lo = Eigen::Vector3i::Zero();  ///< first block (grid block coords)
  Eigen::Vector3i filled_blocks_dims =
      Eigen::Vector3i::Zero();  ///< blocks per axis, covering the region
  /// Codes of the blocks, y then x then z (z fastest).
  std::vector<std::uint32_t> filled_block_code;
  std::vector<BlockBits> filled_masks;
  std::size_t occupied_voxels = 0;  ///< occupied part voxels in the region
  std::size_t filled_voxels = 0;    ///< occupied + enclosed voids

  /// The centre of face f (a deposit->mesh point before the placement on the beads): a
  /// function of the face, computed where it is read rather than stored (24 bytes a face).
  [[nodiscard]] Vec3 face_center(const SurfaceFace& f) const {
    Vec3 c =
        origin_mm + voxel_mm * Vec3(f.voxel.x - origin_key.x + 0.5, f.voxel.y - origin_key.y + 0.5,
                                    f.voxel.z - origin_key.z + 0.5);
    c[f.axis] += 0.5 * voxel_mm * f.side;
    return c;
  }
  [[nodiscard]] Vec3 face_center(std::size_t i) const { return face_center(faces[i]); }
  /// Every face's centre, in face order (in parallel).
  [[nodiscard]] std::vector<Vec3> face_centers_mm() const;
  /// True when p lies in a filled voxel of the region (false outside the region).
  [[nodiscard]] bool filled(const Vec3& p_mm) const;
  /// The code of p's block and p's bit in it (slot z * 64 + y * 8 + x); nullptr when p is
  /// outside the region.
  [[nodiscard]] const std::uint32_t* filled_code_of(const Vec3& p_mm, int& slot) const;
};

/// Extracts the outer surface of `grid` within `region_mm` (expanded to whole voxels and
/// padded by one voxel so the border is outside). Voxels of auxiliary features are empty.
/// `seal_gap_mm` > 0: gaps up to about that width (2r voxels, r = floor(seal / (2 voxel)))
/// do not let the outside in: the flood fill runs on the occupancy dilated by r voxels and
/// the outside found is dilated back by r (a morphological opening of the empty space), so
/// pinholes between beads do not expose the infill. `groove_depth_mm` > 0 (with a seal): what
/// the seal closed opens again to that depth (6-connected voxel steps through empty voxels)
/// from the sealed outside, so the grooves between layers and between outer beads stay
/// surface while a pinhole lets the outside in no deeper than that. Faces belong to occupied
/// voxels only.
[[nodiscard]] DepositSurface extract_outer_surface(const VoxelGrid& grid, const Box3& region_mm,
                                                   double seal_gap_mm = 0,
                                                   double groove_depth_mm = 0);

/// The filled volume of extract_outer_surface alone (the same filled_block_code,
/// filled_masks, occupied and filled counts; no faces): what the as-printed mesh reads.
[[nodiscard]] DepositSurface extract_filled_volume(const VoxelGrid& grid, const Box3& region_mm,
                                                   double seal_gap_mm = 0,
                                                   double groove_depth_mm = 0);

/// Sub-voxel placement: each face's point moves from the face centre onto the surface of the
/// nearest bead among those of its voxel's G-code line and their neighbours along the path,
/// when that surface lies within `max_shift_mm` of the centre and faces the same way; its
/// area becomes voxel^2 / (|n_x| + |n_y| + |n_z|) for the bead surface's normal n (the true
/// area a staircase face stands for). Fills face_bead, then sample_bead_outlines fills the
/// deposit -> mesh points.
void place_on_beads(DepositSurface& surface, std::span<const SurfaceBead> beads,
                    double max_shift_mm);

/// The deposit -> mesh points from the placed faces (surface_samples.cpp). A face placed on
/// the side of a bead (not beyond its ends) gives way to points laid on that bead's outline:
/// its stadium section at a fixed arc-length and along-line spacing, area = arc x along
/// length. A bead's outline is exposed where its faces lie, extended along the section (up to
/// a quarter circle plus a voxel) to where another bead covers it: the cusp between two
/// stacked beads, narrower than a voxel, is reached. Other faces keep their point. Fills
/// points_mm, point_area_mm2, point_tags, point_groups and the bead_touch lists.
/// `placed`: per face, whether place_on_beads moved its point onto its bead (face_bead).
void sample_bead_outlines(DepositSurface& surface, std::span<const SurfaceBead> beads,
                          std::span<const std::uint8_t> placed);

/// Where the deposit -> mesh search stops (mm): a point farther than this from every face
/// reads this distance (at least), so a mesh placed far from its print is measured quickly.
inline constexpr double kDepositFarMm = 10.0;

/// Exact distances from points to the union of the surface's face squares (up to
/// kDepositFarMm), signed positive when the point is in the filled volume. Nearest face index per
/// point in `nearest_face` (may be null). Parallel (TBB).
void distances_to_deposit(const DepositSurface& surface, std::span<const Vec3> points,
                          std::vector<double>& signed_mm, std::vector<std::uint32_t>* nearest_face);

}  // namespace printtwin

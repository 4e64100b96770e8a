// Exact distances from points to the deposit's outer surface (a bucket grid of face squares).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <span>
#include <utility>

#include "core/zeroed_array.hpp"
#include "deposit/voxel_blocks.hpp"
#include "deviation/deposit_surface_internal.hpp"
#include "deviation/kernels.hpp"
#include "deviation/outer_surface.hpp"
#include "deviation/point_groups.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

using detail::VoxelBlocks;

// ---------------------------------------------------------------- distances to the faces

namespace {

/// The surface's faces by cell of kCell^3 voxels. The surface lists its faces cell by cell,
/// the cells of a grid block (8^3 voxels, 2 x 2 x 2 cells: a "pair block") together, so a
/// face's index is its place and the search reads the surface's own face centres; a
/// directory over the surface's blocks names those holding faces (the surface is thin: most
/// of the region has none), and the surface's cell starts are the ranges.
struct FaceBuckets {
  static constexpr int kCell = 4;
  Eigen::Vector3i cells = Eigen::Vector3i::Zero();
  Eigen::Vector3i pairs = Eigen::Vector3i::Zero();  ///< pair blocks (the surface's blocks) per axis
  /// Per pair block (y, then x, then z): 0 = no face, k + 1 = face block k of the surface.
  ZeroedArray<std::uint32_t> slot;
  const std::uint32_t* ranges = nullptr;  ///< the surface's face_cell_begin
  std::vector<Eigen::Vector3i> held;      ///< the pair blocks holding faces, in slot order
  std::size_t n = 0;                      ///< faces
  /// Per face, its centre as indices into its cell's coordinates and its axis (FaceCell).
  std::unique_ptr<std::uint16_t[]> code;
  /// Per axis, three coordinates (centre, min side, max side) per voxel row of the cells.
  std::array<std::vector<double>, 3> coord;
  double cell_mm = 0;
  Vec3 origin_mm = Vec3::Zero();  ///< corner of cell (0, 0, 0): the surface's first block

  explicit FaceBuckets(const DepositSurface& s) {
    static_assert(2 * kCell == VoxelBlocks::kBlockEdge);
    cell_mm = s.voxel_mm * kCell;
    pairs = s.filled_blocks_dims;
    cells = 2 * pairs;
    const Eigen::Vector3i first_key = VoxelBlocks::kBlockEdge * s.filled_blocks_lo;
    origin_mm = s.origin_mm + s.voxel_mm * Vec3(first_key.x() - s.origin_key.x,
                                                first_key.y() - s.origin_key.y,
                                                first_key.z() - s.origin_key.z);
    slot = ZeroedArray<std::uint32_t>(static_cast<std::size_t>(pairs.x()) * pairs.y() * pairs.z());
    held.resize(s.face_blocks.size());
    const auto nz = static_cast<std::size_t>(pairs.z()), nx = static_cast<std::size_t>(pairs.x());
    for (std::size_t k = 0; k < s.face_blocks.size(); ++k) {
      const std::size_t i = s.face_blocks[k];
      slot[i] = static_cast<std::uint32_t>(k + 1);
      held[k] = Eigen::Vector3i(static_cast<int>((i / nz) % nx), static_cast<int>(i / (nz * nx)),
                                static_cast<int>(i % nz));
    }
    ranges = s.face_cell_begin.data();
    n = s.faces.size();
    // A voxel row's coordinates as DepositSurface::face_center computes them (the same bits).
    const std::array<int, 3> origin_key{s.origin_key.x, s.origin_key.y, s.origin_key.z};
    for (int a = 0; a < 3; ++a) {
      auto& c = coord[static_cast<std::size_t>(a)];
      c.resize(3 * static_cast<std::size_t>(kCell) * static_cast<std::size_t>(cells[a]));
      for (std::size_t j = 0; j < c.size() / 3; ++j) {
        const int l = first_key[a] - origin_key[static_cast<std::size_t>(a)] + static_cast<int>(j);
        const double centre = s.origin_mm[a] + s.voxel_mm * (l + 0.5);
        c[3 * j] = centre;
        for (const int side : {-1, 1})
          c[3 * j + (side > 0 ? 2 : 1)] = centre + 0.5 * s.voxel_mm * side;
      }
    }
    // Written once each, in parallel: no initial values.
    code = std::make_unique_for_overwrite<std::uint16_t[]>(n);
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, 1 << 16),
        [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t k = r.begin(); k != r.end(); ++k) {
            const SurfaceFace& f = s.faces[k];
            const std::array<int, 3> key{f.voxel.x, f.voxel.y, f.voxel.z};
            unsigned x = static_cast<unsigned>(f.axis) << 12;
            for (int a = 0; a < 3; ++a) {
              // The voxel's row in its cell (cells start at multiples of kCell).
              const auto l = static_cast<unsigned>(key[static_cast<std::size_t>(a)] & (kCell - 1));
              const unsigned kind = a != f.axis ? 0U : f.side > 0 ? 2U : 1U;
              x |= (3 * l + kind) << (4 * a);
            }
            code[k] = static_cast<std::uint16_t>(x);
          }
        });
  }
  /// The coordinates of the cells at cell coordinate `c` along axis a (3 per voxel row).
  [[nodiscard]] const double* coords(int a, int c) const {
    return coord[static_cast<std::size_t>(a)].data() + 3 * static_cast<std::size_t>(kCell) * c;
  }
  [[nodiscard]] std::size_t pair_index(int x, int y, int z) const {
    return (static_cast<std::size_t>(y) * pairs.x() + static_cast<std::size_t>(x)) * pairs.z() +
           static_cast<std::size_t>(z);
  }
  static int local_of(const Eigen::Vector3i& c) {
    return ((c.y() & 1) << 2) | ((c.x() & 1) << 1) | (c.z() & 1);
  }
  /// The faces of cell c (inside the grid of cells): [lo, hi), empty when lo == hi.
  void cell_range(const Eigen::Vector3i& c, std::uint32_t& lo, std::uint32_t& hi) const {
    const std::uint32_t k = slot[pair_index(c.x() >> 1, c.y() >> 1, c.z() >> 1)];
    if (k == 0) {
      lo = hi = 0;
      return;
    }
    const std::uint32_t* r = ranges + 8 * static_cast<std::size_t>(k - 1) + local_of(c);
    lo = r[0];
    hi = r[1];
  }
  [[nodiscard]] Eigen::Vector3i cell_coord(const Vec3& p) const {
    Eigen::Vector3i c;
    for (int a = 0; a < 3; ++a)
      c[a] = std::clamp(static_cast<int>(std::floor((p[a] - origin_mm[a]) / cell_mm)), 0,
                        cells[a] - 1);
    return c;
  }
};

}  // namespace

namespace detail {

DepositQueryGroups group_deposit_queries(std::span<const Vec3> points, double voxel_mm) {
  DepositQueryGroups g;
  group_by_cell(points, voxel_mm * FaceBuckets::kCell, g.order, g.group);
  return g;
}

std::vector<std::uint32_t> face_cell_groups(const DepositSurface& surface) {
  std::vector<std::uint32_t> cells;
  cells.reserve(surface.face_cell_begin.size());
  for (const std::uint32_t b : surface.face_cell_begin)
    if (cells.empty() || b != cells.back()) cells.push_back(b);
  return cells;
}

namespace {

constexpr double kFarMm = kDepositFarMm;

/// A point's terms against the cells a search reads (detail::AxisTerms), by axis and cell
/// coordinate, each made when first needed: the cells round a point share their coordinates
/// along each axis (2 per axis cover the cells within a bound), so each axis keeps a few.
class PointTerms {
 public:
  PointTerms(const FaceBuckets& b, const Vec3& p, const std::array<double, 12>& reach)
      : b_(b), p_(p), reach_(reach) {}
  /// The terms along axis a for the cells at coordinate c along it.
  const double* axis(int a, int c) {
    Slots& s = slots_[static_cast<std::size_t>(a)];
    for (std::size_t i = 0; i < kSlots; ++i)
      if (s.key[i] == c) return s.terms[i].t.data();
    const std::size_t i = s.next;
    s.next = (i + 1) % kSlots;
    s.key[i] = c;
    s.terms[i].fill(b_.coords(a, c), reach_, p_[a]);
    return s.terms[i].t.data();
  }

 private:
  static constexpr std::size_t kSlots = 3;
  struct Slots {
    std::array<int, kSlots> key{-1, -1, -1};  ///< no cell has a negative coordinate
    std::array<detail::AxisTerms, kSlots> terms;
    std::size_t next = 0;
  };
  const FaceBuckets& b_;
  const Vec3& p_;
  const std::array<double, 12>& reach_;
  std::array<Slots, 3> slots_;
};

/// The exact nearest face of a point: p's own cell, then the cells a bound reaches, then
/// rings of cells and rings of groups of cells (a coarse level flags where faces are, so
/// points far from the deposit, say a missing wall, skip empty space quickly).
class FaceSearch {
 public:
  explicit FaceSearch(const DepositSurface& s)
      : buckets_(s),
        half_(0.5 * s.voxel_mm),
        reach_(detail::AxisTerms::reaches(half_)),
        scan_faces_(face_scan_kernel()) {
    groups_ = (buckets_.cells.array() + kGroup - 1) / kGroup;
    group_has_.assign(static_cast<std::size_t>(groups_.x()) * groups_.y() * groups_.z(), 0);
    static_assert(kGroup % 2 == 0);
    for (const Eigen::Vector3i& b : buckets_.held)  // a group is kGroup / 2 pair blocks across
      group_has_[group_index(b / (kGroup / 2))] = 1;
    group_mm_ = buckets_.cell_mm * kGroup;
    // Far points: the search goes no further than kFarMm past the faces' box (in parallel:
    // a minimum and a maximum do not depend on the order).
    if (!s.faces.empty()) {
      using Bounds = std::pair<Vec3, Vec3>;
      const Vec3 c0 = s.face_center(0);
      const Bounds b = tbb::parallel_reduce(
          tbb::blocked_range<std::size_t>(0, s.faces.size(), 1 << 16), Bounds(c0, c0),
          [&](const tbb::blocked_range<std::size_t>& r, Bounds x) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) {
              const Vec3 c = s.face_center(i);
              x.first = x.first.cwiseMin(c);
              x.second = x.second.cwiseMax(c);
            }
            return x;
          },
          [](const Bounds& x, const Bounds& y) {
            return Bounds(x.first.cwiseMin(y.first), x.second.cwiseMax(y.second));
          });
      lo_ = b.first;
      hi_ = b.second;
    }
    max_group_ring_ =
        std::min(groups_.maxCoeff(), static_cast<int>(std::ceil((kFarMm + half_) / group_mm_)) + 1);
  }

  /// The nearest face of p; `bound` (may be infinite) is a distance within which a face is
  /// known to lie (it only prunes).
  [[nodiscard]] NearestFace nearest(const Vec3& p, double bound) const {
    NearestFace best;
    // Farther than kFarMm from every face: that distance, and the first face.
    const Vec3 out = (lo_ - p).cwiseMax(p - hi_).cwiseMax(Vec3::Zero());
    if (out.squaredNorm() > (kFarMm + half_) * (kFarMm + half_)) return far();
    // p's own cell first; then the bound (the caller's, or the best face of p's cell) limits
    // the search to the cells its ball touches (at most 2 per axis): all faces within the
    // bound are in them, so the minimum over them is the global one.
    const Eigen::Vector3i c0 = buckets_.cell_coord(p);
    PointTerms terms(buckets_, p, reach_);
    scan_cell(p, c0, best, terms);
    bound = std::min(bound, std::sqrt(best.d2) * (1 + 1e-9) + 1e-9);
    bool done = bound < buckets_.cell_mm && scan_within(p, c0, bound, best, terms);
    for (int ring = 0; ring <= kFineRings && !done; ++ring)
      done = scan_fine_ring(p, c0, ring, best, terms);
    const Eigen::Vector3i g0 = c0 / kGroup;
    for (int ring = 0; ring <= max_group_ring_ && !done; ++ring)
      done = scan_group_ring(p, g0, ring, best, terms);
    return done || best.d2 <= kFarMm * kFarMm ? best : far();
  }

 private:
  static constexpr int kGroup = 8;
  static NearestFace far() {
    NearestFace f;
    f.d2 = kFarMm * kFarMm;
    f.face = 0;
    return f;
  }
  static constexpr int kFineRings = 2;

  [[nodiscard]] std::size_t group_index(const Eigen::Vector3i& g) const {
    return (static_cast<std::size_t>(g.z()) * groups_.y() + g.y()) * groups_.x() + g.x();
  }
  /// Squared distance from p to a box of `size` at `lo`, widened by half a voxel (a face
  /// centred in a cell reaches half a voxel beyond it).
  [[nodiscard]] double box_dist2(const Vec3& p, const Vec3& lo, double size) const {
    double b2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double l = lo[a] - half_, h = lo[a] + size + half_;
      const double e = p[a] < l ? l - p[a] : (p[a] > h ? p[a] - h : 0.0);
      b2 += e * e;
    }
    return b2;
  }
  /// Every face as close as the best so far is visited (strict pruning), and ties go to the
  /// lowest face index: the result does not depend on the order cells are scanned.
  void scan_cell(const Vec3& p, const Eigen::Vector3i& c, NearestFace& best,
                 PointTerms& terms) const {
    if ((c.array() < 0).any() || (c.array() >= buckets_.cells.array()).any()) return;
    std::uint32_t lo = 0, hi = 0;
    buckets_.cell_range(c, lo, hi);
    if (lo == hi) return;
    if (box_dist2(p, buckets_.origin_mm + buckets_.cell_mm * c.cast<double>(), buckets_.cell_mm) >
        best.d2)
      return;
    scan_faces_(buckets_.code.get(), lo, hi, terms.axis(0, c.x()), terms.axis(1, c.y()),
                terms.axis(2, c.z()), best);
  }
  /// The cells the ball of radius `bound` about p touches; true when the best is within it.
  bool scan_within(const Vec3& p, const Eigen::Vector3i& c0, double bound, NearestFace& best,
                   PointTerms& terms) const {
    const double reach_mm = bound + half_;
    Eigen::Vector3i lo, hi;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max(0, static_cast<int>(std::floor((p[a] - reach_mm - buckets_.origin_mm[a]) /
                                                      buckets_.cell_mm)));
      hi[a] = std::min(buckets_.cells[a] - 1,
                       static_cast<int>(std::floor((p[a] + reach_mm - buckets_.origin_mm[a]) /
                                                   buckets_.cell_mm)));
    }
    for (int z = lo.z(); z <= hi.z(); ++z)
      for (int y = lo.y(); y <= hi.y(); ++y)
        for (int x = lo.x(); x <= hi.x(); ++x) {
          const Eigen::Vector3i c(x, y, z);
          if (c != c0) scan_cell(p, c, best, terms);
        }
    return best.d2 <= bound * bound;
  }
  /// Ring `ring` of cells around p's cell; every cell of ring + 1 is at least
  /// ring * cell - half away: true when the best is closer.
  bool scan_fine_ring(const Vec3& p, const Eigen::Vector3i& c0, int ring, NearestFace& best,
                      PointTerms& terms) const {
    for (int dz = -ring; dz <= ring; ++dz)
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx)
          if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) == ring)
            scan_cell(p, c0 + Eigen::Vector3i(dx, dy, dz), best, terms);
    const double reach = ring * buckets_.cell_mm - half_;
    return reach > 0 && best.d2 < reach * reach;
  }
  /// Far points: a ring of groups, descending only into groups that hold faces and may beat
  /// the best so far (cells already scanned are simply scanned again).
  bool scan_group_ring(const Vec3& p, const Eigen::Vector3i& g0, int ring, NearestFace& best,
                       PointTerms& terms) const {
    for (int dz = -ring; dz <= ring; ++dz)
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx) {
          if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != ring) continue;
          const Eigen::Vector3i g = g0 + Eigen::Vector3i(dx, dy, dz);
          if ((g.array() < 0).any() || (g.array() >= groups_.array()).any()) continue;
          if (group_has_[group_index(g)] == 0) continue;
          if (box_dist2(p, buckets_.origin_mm + group_mm_ * g.cast<double>(), group_mm_) > best.d2)
            continue;
          for (int z = 0; z < kGroup; ++z)
            for (int y = 0; y < kGroup; ++y)
              for (int x = 0; x < kGroup; ++x)
                scan_cell(p, g * kGroup + Eigen::Vector3i(x, y, z), best, terms);
        }
    const double reach = ring * group_mm_ - half_;
    return reach > 0 && best.d2 < reach * reach;
  }

  FaceBuckets buckets_;
  double half_;
  std::array<double, 12> reach_;  ///< per coordinate index (AxisTerms::reaches)
  FaceScan scan_faces_;
  Eigen::Vector3i groups_ = Eigen::Vector3i::Zero();
  std::vector<std::uint8_t> group_has_;
  Vec3 lo_ = Vec3::Zero(), hi_ = Vec3::Zero();  ///< the face centres' box
  double group_mm_ = 0;
  int max_group_ring_ = 0;
};

}  // namespace

void distances_to_deposit_with(const DepositSurface& s, std::span<const Vec3> points,
                               std::vector<double>& signed_mm,
                               std::vector<std::uint32_t>* nearest_face,
                               const DepositQueryGroups* pregrouped) {
  signed_mm.assign(points.size(), 0.0);
  if (nearest_face != nullptr) nearest_face->assign(points.size(), 0);
  if (s.faces.empty()) {
    // No deposit at all: everything designed is missing; distance to the region's far side.
    const double far = (s.dims.cast<double>() * s.voxel_mm).norm();
    std::fill(signed_mm.begin(), signed_mm.end(), -far);
    return;
  }
  const FaceSearch search(s);
  // Queries in cells of the buckets' size, column by column: neighbouring queries read the
  // same cells and filled bits (the input, say mesh samples in triangle order, may jump).
  DepositQueryGroups own;
  if (pregrouped == nullptr) {
    own = group_deposit_queries(points, s.voxel_mm);
    pregrouped = &own;
  }
  const std::vector<std::uint32_t>& order = pregrouped->order;
  const bool in_order = order.empty();  // the points come in visiting order
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 2048),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      // The previous point of this chunk and its distance: by the triangle
                      // inequality the nearest face of p is at most prev_d + |p - prev_p| away.
                      Vec3 prev_p = Vec3::Zero();
                      double prev_d = std::numeric_limits<double>::infinity();
                      for (std::size_t j = range.begin(); j != range.end(); ++j) {
                        const std::size_t i = in_order ? j : order[j];
                        const Vec3& p = points[i];
                        const NearestFace best =
                            search.nearest(p, (prev_d + (p - prev_p).norm()) * (1 + 1e-9) + 1e-9);
                        const double d = std::sqrt(best.d2);
                        prev_p = p;
                        prev_d = d;
                        signed_mm[i] = s.filled(p) ? d : -d;
                        if (nearest_face != nullptr) (*nearest_face)[i] = best.face;
                      }
                    });
}

}  // namespace detail

void distances_to_deposit(const DepositSurface& surface, std::span<const Vec3> points,
                          std::vector<double>& signed_mm,
                          std::vector<std::uint32_t>* nearest_face) {
  detail::distances_to_deposit_with(surface, points, signed_mm, nearest_face);
}

}  // namespace printtwin

// The sweep (see sweep.hpp).
#include "deposit/sweep.hpp"
#include "core/bits.hpp"
#include "deposit/voxel_blocks.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <type_traits>

namespace printtwin::detail {

namespace {

/// A constraint lo <= p*x + q*y + c <= hi on the (major x, minor y) plane.
struct Linear {
  double p = 0, q = 0, c = 0, inv_p = 0, inv_q = 0, lo = 0, hi = 0;
  bool flat = true;    // p == 0: independent of x
  bool flat_y = true;  // q == 0: independent of y
  void init(double p_, double q_, double c_, double lo_, double hi_) {
    p = p_, q = q_, c = c_, lo = lo_, hi = hi_;
    flat = std::abs(p) < 1e-12;
    inv_p = flat ? 0.0 : 1.0 / p;
    flat_y = std::abs(q) < 1e-12;
    inv_q = flat_y ? 0.0 : 1.0 / q;
  }
  /// Narrows [yl, yh] to the y where the constraint holds on the line x; false if empty.
  bool clip_y(double x, double& yl, double& yh) const {
    return narrow(p * x + c, inv_q, flat_y, yl, yh);
  }
  /// Narrows [xl, xh] to the x where the constraint holds on the line y; false if empty.
  bool clip(double y, double& xl, double& xh) const {
    return narrow(q * y + c, inv_p, flat, xl, xh);
  }

 private:
  /// lo <= k * t + rest <= hi narrows [tl, th] (inv_k = 1 / k; `flat`: k == 0).
  bool narrow(double rest, double inv_k, bool flat_k, double& tl, double& th) const {
    if (flat_k) return rest >= lo && rest <= hi;
    double t0 = (lo - rest) * inv_k;
    double t1 = (hi - rest) * inv_k;
    if (t0 > t1) std::swap(t0, t1);
    tl = std::max(tl, t0);
    th = std::min(th, t1);
    return tl <= th;
  }
};

/// The bead's footprint between two lateral offsets, in the (major, minor) plane of the sweep:
/// the strip lo <= n.(q-a) <= hi between the start cut (m0.(q-a) >= 0) and the end cut
/// (m1.(q-b) < 0).
struct Footprint {
  Linear side, start, end;
  // Every corner of the footprint is among these: the side lines' crossings with the cuts,
  // and the crossing of the two cuts when it lies between the sides (a short bead between
  // two sharp mitres is a triangle). Corners outside the footprint only widen the ranges.
  std::array<Vec2, 5> vertices;

  void init(const Vec2& a, const Vec2& b, const Vec2& d, const Vec2& n, const Vec2& m0,
            const Vec2& m1, double lo, double hi) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    side.init(n.x(), n.y(), -n.dot(a), lo, hi);
    start.init(m0.x(), m0.y(), -m0.dot(a), 0.0, kInf);
    end.init(m1.x(), m1.y(), -m1.dot(b), -kInf, 0.0);
    // Intersections of the side lines s = lo, hi with the two cut lines.
    const double k0 = m0.dot(n) / m0.dot(d);
    const double k1 = m1.dot(n) / m1.dot(d);
    vertices = {a + (-hi * k0) * d + hi * n, a + (-lo * k0) * d + lo * n,
                b + (-hi * k1) * d + hi * n, b + (-lo * k1) * d + lo * n, a};
    const double det = m0.x() * m1.y() - m0.y() * m1.x();
    if (std::abs(det) > 1e-12) {
      const double c0 = m0.dot(a), c1 = m1.dot(b);
      const Vec2 cross((c0 * m1.y() - m0.y() * c1) / det, (m0.x() * c1 - c0 * m1.x()) / det);
      const double s = n.dot(cross - a);
      if (s >= lo && s <= hi) vertices[4] = cross;
    }
  }
  /// Interval of the major coordinate on the line minor = y.
  bool interval(double y, double& xl, double& xh) const {
    xl = -std::numeric_limits<double>::infinity();
    xh = std::numeric_limits<double>::infinity();
    return side.clip(y, xl, xh) && start.clip(y, xl, xh) && end.clip(y, xl, xh);
  }
  /// Interval of the minor coordinate on the line major = x.
  bool interval_y(double x, double& yl, double& yh) const {
    yl = -std::numeric_limits<double>::infinity();
    yh = std::numeric_limits<double>::infinity();
    return side.clip_y(x, yl, yh) && start.clip_y(x, yl, yh) && end.clip_y(x, yl, yh);
  }
  /// Range of coordinate `axis` (0 major, 1 minor) over the band of lines where the other
  /// coordinate lies in [t0, t1]; false if empty.
  bool range_over(int axis, double t0, double t1, double& lo, double& hi) const {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (const double t : {t0, t1}) {
      double a, b;
      if (axis == 0 ? interval(t, a, b) : interval_y(t, a, b))
        lo = std::min(lo, a), hi = std::max(hi, b);
    }
    for (const auto& v : vertices)
      if (v[1 - axis] >= t0 && v[1 - axis] <= t1)
        lo = std::min(lo, v[axis]), hi = std::max(hi, v[axis]);
    return lo <= hi;
  }
  void minor_range(double& lo, double& hi) const {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (const auto& v : vertices) {
      lo = std::min(lo, v.y());
      hi = std::max(hi, v.y());
    }
  }
};

/// Values that are whole up to rounding (Z 0.4 / 0.05 = 7.9999999) snapped to them.
double snap_whole(double v) {
  const double r = std::round(v);
  return std::abs(v - r) < 1e-6 ? r : v;
}

// Widening of the footprint bounds, so that they never cut a cell the single-precision test
// would take.
constexpr double kBoundSlack = 1e-3;

}  // namespace

BeadSweep::BeadSweep(const VoxelGrid& grid, bool exhaustive)
    : origin_(grid.origin_mm()),
      inv_voxel_(1.0 / grid.voxel_mm()),
      nx_(grid.dims().x()),
      ny_(grid.dims().y()),
      nz_(grid.dims().z()),
      block_dims_(detail::VoxelBlocks::block_dims(grid)),
      exhaustive_(exhaustive),
      words_(block_dims_) {}

const std::uint64_t* BeadSweep::occupancy(const VoxelGrid& grid, int bx, int by, int bz) const {
  if (mirror_to_ != nullptr) return words_.find(bx, by, bz);
  return detail::VoxelBlocks::block_occupancy(grid, bx, by, bz);
}

std::uint64_t BeadSweep::write_slice(VoxelGrid& grid, int bx, int by, int k, std::uint64_t mask,
                                     std::uint32_t tag) {
  if (mirror_to_ == nullptr)
    return detail::VoxelBlocks::write_tile_before(grid, bx, by, k, mask, tag);
  std::uint64_t& word = words_.make(bx, by, k >> 3)[k & 7];
  const std::uint64_t before = word;
  word |= mask;
  mirror_to_->put(bx, by, k, mask, tag);
  return before;
}

bool BeadSweep::set_up(const SweptBead& bead, BeadFrame& f, Vec2& a2, Vec2& b2, double& hw) {
  // Heights that are whole voxels up to rounding (Z 0.4 / 0.05 = 7.9999999) are snapped, so
  // layer boundaries stay on voxel boundaries.
  const auto snap = snap_whole;
  Vec3 a = (bead.a_mm - origin_) * inv_voxel_;
  Vec3 b = (bead.b_mm - origin_) * inv_voxel_;
  a.z() = snap(a.z());
  b.z() = snap(b.z());
  const double len = (b - a).head<2>().norm();
  const double hh = snap(bead.h_mm * inv_voxel_);
  const double r = 0.5 * hh;
  const double r2 = r * r;
  const double flat = 0.5 * (bead.w_mm - bead.h_mm) * inv_voxel_;
  const double slope = (b.z() - a.z()) / len;
  const double zt_lo = std::min(a.z(), b.z());
  const double zt_hi = std::max(a.z(), b.z());
  const double zc_lo = zt_lo - r;
  const double zc_hi = zt_hi - r;
  a2 = a.head<2>(), b2 = b.head<2>();

  // The frame of the sample-point tests: relative to the voxel holding the start.
  f.ia = floor_int(a.x());
  f.ja = floor_int(a.y());
  f.ka = floor_int(a.z());
  f.fa_x = static_cast<float>(a.x() - f.ia);
  f.fa_y = static_cast<float>(a.y() - f.ja);
  f.d_x = static_cast<float>(bead.d.x()), f.d_y = static_cast<float>(bead.d.y());
  f.n_x = static_cast<float>(bead.n.x()), f.n_y = static_cast<float>(bead.n.y());
  f.m0_x = static_cast<float>(bead.m0.x()), f.m0_y = static_cast<float>(bead.m0.y());
  f.m1_x = static_cast<float>(bead.m1.x()), f.m1_y = static_cast<float>(bead.m1.y());
  f.e1 = static_cast<float>(bead.m1.dot(b2 - a2));
  f.c0 = static_cast<float>(a.z() - r - f.ka);
  f.slope = static_cast<float>(slope);
  f.r = static_cast<float>(r), f.r2 = static_cast<float>(r2), f.flat = static_cast<float>(flat);

  // The layers the section reaches, and its widest half-width over them.
  const int k_lo = std::max(0, static_cast<int>(std::floor(zt_lo - hh)));
  const int k_hi = std::min(nz_ - 1, static_cast<int>(std::ceil(zt_hi)) - 1);
  reached_.clear();
  hw = -1;
  for (int k = k_lo; k <= k_hi; ++k) {
    // Range of the height offset from the section's centre over this layer of voxels.
    const double dz_lo = std::max(k - zc_hi, -r);
    const double dz_hi = std::min(k + 1.0 - zc_lo, r);
    if (dz_lo >= dz_hi) continue;
    reached_.push_back(k);
    const double dz0 = std::clamp(0.0, dz_lo, dz_hi);
    hw = std::max(hw, flat + std::sqrt(std::max(0.0, r2 - dz0 * dz0)) + kBoundSlack);
  }
  return !reached_.empty();
}

// Tiles: the 8 x 8 cells of a block's z-slice. The bead's footprint at its widest over its
// voxel layers (half-width hw, widened by kBoundSlack) gives the block rows it reaches, the
// blocks of each row and the rows of each block, once per bead; each such tile's 64 sample
// points are then tested layer by layer and written as one occupancy word per layer. (Bounds
// per layer would be tighter at the rounded top and bottom, but computing them cost more than
// the few extra tile tests they save.) The tiles of one bead are disjoint and carry one tag,
// so the order they are written in changes nothing.
template <class Fn>
void BeadSweep::for_each_tile(const SweptBead& bead, const Vec2& a2, const Vec2& b2, double lo,
                              double hi, Fn&& fn) const {
  Footprint outer;
  outer.init(a2, b2, bead.d, bead.n, bead.m0, bead.m1, lo, hi);
  const double hw = std::max(-lo, hi);
  double ylo, yhi;
  outer.minor_range(ylo, yhi);
  const double box_lo_x = std::min(a2.x(), b2.x()) - 2 * hw - 2,
               box_hi_x = std::max(a2.x(), b2.x()) + 2 * hw + 2;
  if (exhaustive_)
    ylo = std::min(a2.y(), b2.y()) - 2 * hw - 2, yhi = std::max(a2.y(), b2.y()) + 2 * hw + 2;
  const int j_lo = std::max(0, floor_int(std::clamp(ylo - kBoundSlack, -2.0, ny_ + 1.0)));
  const int j_hi = std::min(ny_ - 1, floor_int(std::clamp(yhi + kBoundSlack, -2.0, ny_ + 1.0)));
  for (int by = j_lo >> 3; by <= j_hi >> 3; ++by) {
    const int row_lo = std::max(j_lo - 8 * by, 0);
    const int row_hi = std::min(j_hi - 8 * by + 1, 8);
    // x-range of the footprint over the band of sample lines y in [y0, y1].
    double xl, xh;
    outer.range_over(0, 8.0 * by + row_lo, 8.0 * by + row_hi, xl, xh);
    if (exhaustive_) xl = box_lo_x, xh = box_hi_x;
    if (!(xl <= xh)) continue;
    const int i_lo = std::max(0, floor_int(std::clamp(xl - kBoundSlack, -2.0, nx_ + 1.0)));
    const int i_hi = std::min(nx_ - 1, floor_int(std::clamp(xh + kBoundSlack, -2.0, nx_ + 1.0)));
    const bool one_tile = (i_lo >> 3) == (i_hi >> 3);
    for (int bx = i_lo >> 3; bx <= i_hi >> 3 && bx < block_dims_.x(); ++bx) {
      const int x_end = std::min(8, nx_ - 8 * bx);  // cells of this block inside the grid
      const unsigned lanes = (1u << x_end) - 1u;
      // Rows of this tile the footprint reaches (over its sample columns x in [8 bx, 8 bx + 8]).
      int t_lo = row_lo, t_hi = row_hi;
      if (!one_tile && !exhaustive_) {
        double tyl, tyh;
        if (!outer.range_over(1, 8.0 * bx, 8.0 * bx + 8.0, tyl, tyh)) continue;
        t_lo = std::max(row_lo, floor_int(std::clamp(tyl - kBoundSlack - 8.0 * by, -1.0, 9.0)));
        t_hi = std::min(row_hi, floor_int(std::clamp(tyh + kBoundSlack - 8.0 * by, -1.0, 9.0)) + 1);
        if (t_lo >= t_hi) continue;
      }
      if constexpr (std::is_same_v<std::invoke_result_t<Fn&, int, int, int, int, unsigned>, bool>) {
        if (!fn(bx, by, t_lo, t_hi, lanes)) return;  // fn asks for no more tiles
      } else {
        fn(bx, by, t_lo, t_hi, lanes);
      }
    }
  }
}

namespace {

/// The tile's voxels next to those of `m` (bit y * 8 + x) in x or y, and `m` itself; with
/// `diagonal`, also those next to them diagonally.
std::uint64_t dilate_xy(std::uint64_t m, bool diagonal = false) {
  constexpr std::uint64_t kColumn0 = 0x0101010101010101ull, kColumn7 = 0x8080808080808080ull;
  const std::uint64_t row = m | ((m << 1) & ~kColumn0) | ((m >> 1) & ~kColumn7);
  return diagonal ? row | (row << 8) | (row >> 8) : row | (m << 8) | (m >> 8);
}

/// The `n` lowest set bits of `m` (all of them when it has fewer).
std::uint64_t lowest_bits(std::uint64_t m, std::size_t n) {
  std::uint64_t out = 0;
  for (; m != 0 && n > 0; --n) {
    out |= m & (~m + 1);
    m &= m - 1;
  }
  return out;
}

/// The section of `f` grown by `by` voxels (a stadium is a segment's disc sweep: grow the disc).
BeadFrame grown(const BeadFrame& f, double by) {
  BeadFrame g = f;
  const double r = static_cast<double>(f.r) + by;
  g.r = static_cast<float>(r);
  g.r2 = static_cast<float>(r * r);
  return g;
}

/// Whether the sample-point test of `g` (kernels.cpp) fails for every voxel of layer k in the
/// box of the set bits of `room` (a tile's voxels, bit y * 8 + x, corner (i0, j0)): a bound
/// over the box's corners on the cut offsets, the lateral offset and the height above the
/// section's centre. The kernel's single-precision rounding is far inside its margin.
bool section_misses(const BeadFrame& g, int i0, int j0, std::uint64_t room, int k) {
  constexpr double kMargin = 0.05;  // voxels
  std::uint64_t cols = room | (room >> 32);
  cols |= cols >> 16;
  cols |= cols >> 8;
  cols &= 0xFFu;
  // The box of the sample points (voxel units, in the frame of g): [x0, x1] x [y0, y1].
  const double fx = static_cast<double>(i0 - g.ia) - static_cast<double>(g.fa_x);
  const double fy = static_cast<double>(j0 - g.ja) - static_cast<double>(g.fa_y);
  const double x0 = fx + __builtin_ctzll(cols), x1 = fx + (64 - __builtin_clzll(cols));
  const double y0 = fy + (__builtin_ctzll(room) >> 3),
               y1 = fy + ((63 - __builtin_clzll(room)) >> 3) + 1;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double l_lo = kInf, l_hi = -kInf, u_lo = kInf, u_hi = -kInf, s0_hi = -kInf, s1_lo = kInf;
  for (const double x : {x0, x1})
    for (const double y : {y0, y1}) {
      const double l = static_cast<double>(g.n_x) * x + static_cast<double>(g.n_y) * y;
      const double u = static_cast<double>(g.d_x) * x + static_cast<double>(g.d_y) * y;
      l_lo = std::min(l_lo, l), l_hi = std::max(l_hi, l);
      u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u);
      s0_hi = std::max(s0_hi, static_cast<double>(g.m0_x) * x + static_cast<double>(g.m0_y) * y);
      s1_lo = std::min(s1_lo, static_cast<double>(g.m1_x) * x + static_cast<double>(g.m1_y) * y -
                                  static_cast<double>(g.e1));
    }
  if (s0_hi < -kMargin || s1_lo > kMargin) return true;  // wholly before the start or past the end
  // Height above the centre line (c0 + slope u) over the layer and the box.
  const double z = static_cast<double>(k - g.ka), slope = static_cast<double>(g.slope);
  const double c_lo = static_cast<double>(g.c0) + std::min(slope * u_lo, slope * u_hi);
  const double c_hi = static_cast<double>(g.c0) + std::max(slope * u_lo, slope * u_hi);
  const double dz_lo = z - c_hi, dz_hi = z + 1.0 - c_lo;
  const double r = static_cast<double>(g.r);
  if (dz_lo > r + kMargin || dz_hi < -r - kMargin) return true;
  const double dz0 = std::clamp(0.0, dz_lo, dz_hi);
  const double reach =
      static_cast<double>(g.flat) + std::sqrt(std::max(0.0, r * r - dz0 * dz0)) + kMargin;
  const double near = l_lo <= 0.0 && l_hi >= 0.0 ? 0.0 : std::min(std::abs(l_lo), std::abs(l_hi));
  return near > reach;
}

}  // namespace

BeadSweep::Laid BeadSweep::lay(const SweptBead& bead, VoxelGrid& grid, std::uint32_t tag,
                               HeightMap& map) {
  BeadFrame f;
  Vec2 a2, b2;
  double hw;
  Laid laid;
  if (!set_up(bead, f, a2, b2, hw)) return laid;
  const std::size_t nk = reached_.size();
  const bool squeezing = bead.squeeze_mm > 0;
  const int steps = std::max(1, static_cast<int>(std::ceil(bead.squeeze_mm * inv_voxel_ - 1e-9)));
  // The squeeze's local ring, in the tile where the bead fell on earlier plastic: up to
  // squeeze_mm from the bead's voxels, over its own layers and as many below (their masks and
  // hits stay 0); what finds no room there moves on to the next tiles of the bead.
  const std::size_t below =
      squeezing ? static_cast<std::size_t>(std::min(steps, reached_.front())) : 0;
  local_layers_.clear();
  for (std::size_t n = below; n > 0; --n)
    local_layers_.push_back(reached_.front() - static_cast<std::int32_t>(n));
  local_layers_.insert(local_layers_.end(), reached_.begin(), reached_.end());
  masks_.assign(below + nk, 0);
  hits_.assign(squeezing ? below + nk : 0, 0);
  std::uint64_t* const masks = masks_.data() + below;
  std::uint64_t* const hits = hits_.data() + below;
  Sides sides;
  bool have_sides = false;
  Ring local{nullptr,
             masks_.data(),
             local_layers_.data(),
             static_cast<int>(below + nk),
             hits_.data(),
             bead.layer,
             &sides,
             steps,
             !bead.keeps_sides};
  local.bottom = reached_.front();
  std::size_t carry = 0;
  std::size_t rehit = 0;  // voxels of the bead that held squeezed material
  // A round join is laid first, outside the bead: it takes material the bead lays on earlier
  // plastic (the corner's inner overlap), which the squeeze then no longer places. (A join
  // larger than the bead's overlap, after a very short bead, adds the difference.)
  std::size_t credit = 0;
  joined_ = false;
  if (bead.join_w_mm > 0)
    credit =
        lay_disc(Disc{bead.a_mm, bead.join_h_mm, bead.join_w_mm, bead.join_d, bead.d, bead.layer},
                 grid, tag, map, nullptr);
  // Round end caps, outside the bead's square end cuts: the bead's own material (the bead
  // model took their volume from its section); where they fall on earlier plastic, that is
  // overlap like the bead's own.
  std::size_t cap_overlap = 0;
  if (bead.cap_start)
    lay_disc(Disc{bead.a_mm, bead.h_mm, bead.w_mm, Vec2(-bead.d), bead.d, bead.layer}, grid, tag,
             map, &cap_overlap);
  if (bead.cap_end)
    lay_disc(Disc{bead.b_mm, bead.h_mm, bead.w_mm, bead.d, Vec2(-bead.d), bead.layer}, grid, tag,
             map, &cap_overlap);
  // A flattened bead's material beyond the squeeze's bound is overflow like its overlap.
  const std::size_t overflow = squeezing ? overflow_voxels(bead) : 0;
  laid.overlap += cap_overlap + overflow;
  if (squeezing) carry = cap_overlap + overflow;
  for_each_tile(bead, a2, b2, -hw, hw, [&](int bx, int by, int t_lo, int t_hi, unsigned lanes) {
    const std::size_t at = map.index(8 * bx, 8 * by);
    test_tile_layers(f, 8 * bx, 8 * by, reached_.data(), static_cast<int>(nk), t_lo, t_hi, lanes,
                     masks);
    std::size_t tile_overlap = 0;
    std::size_t tile_rehit = 0;  // of it, squeezed material displaced again
    // Top layer first: a column is raised once, by its highest voxel (raising it by a lower
    // one after that changes nothing); all of the tile's columns in one call.
    std::uint64_t raised = 0;
    alignas(16) std::array<std::uint16_t, 64> rows{};
    for (std::size_t layer_at = nk; layer_at-- > 0;) {
      const std::uint64_t mask = masks[layer_at];
      if (squeezing) hits[layer_at] = 0;
      if (mask == 0) continue;
      const int k = reached_[layer_at];
      if (writer_ != nullptr) {
        writer_->bead(bx, by, k, mask, tag);  // without the squeeze: the writer counts
      } else {
        const std::uint64_t hit = mask & write_slice(grid, bx, by, k, mask, tag);
        tile_overlap += static_cast<std::size_t>(popcount64(hit));
        if (squeezing) hits[layer_at] = hit;
        if (squeezing && hit != 0) {
          if (std::uint64_t* w = words_.find(bx, by, k >> 3); w != nullptr) {
            std::uint64_t& sq = w[BlockWords::kSqueezed + (k & 7)];
            const std::uint64_t again = hit & sq;
            tile_rehit += static_cast<std::size_t>(popcount64(again));
            sq &= ~again;  // now the bead's own material
          }
        }
      }
      if ((mask & ~raised) != 0)
        HeightMap::set_columns(rows.data(), mask & ~raised, static_cast<std::uint16_t>(k + 1));
      raised |= mask;
    }
    if (raised != 0) map.raise_tile_columns(at, raised, rows.data(), bead.layer);
    if (joined_) writer_->end_tile();  // the writer counts the overlap and the join's credit
    laid.overlap += tile_overlap;
    rehit += tile_rehit;
    const std::size_t used = std::min(credit, tile_overlap);
    credit -= used;
    tile_overlap -= used;
    laid.squeezed += used;
    if (!squeezing || carry + tile_overlap == 0) return;
    if (!have_sides) sides = sides_of(f, bead, a2, b2, grid), have_sides = true;
    const std::size_t placed =
        squeeze_tile(local, bx, by, 0, std::min(8, ny_ - 8 * by),
                     (1u << std::min(8, nx_ - 8 * bx)) - 1u, carry + tile_overlap, grid, tag, map);
    laid.squeezed += placed;
    carry = carry + tile_overlap - placed;
  });
  if (joined_) writer_->end_piece();
  if (carry > 0) laid.squeezed += squeeze(bead, f, a2, b2, sides, carry, grid, tag, map);
  // Squeezed material the bead fell on was counted as overlap by the bead that squeezed it;
  // placed again, it is neither overlap nor squeezed a second time (what finds no room stays
  // counted as lost).
  const std::size_t once = std::min(rehit, laid.squeezed);
  laid.overlap -= once;
  laid.squeezed -= once;
  return laid;
}

std::size_t BeadSweep::overflow_voxels(const SweptBead& bead) const {
  if (!(bead.overflow_mm2 > 0)) return 0;
  const double len_mm = (bead.b_mm - bead.a_mm).head<2>().norm();
  const double v = inv_voxel_ * inv_voxel_ * inv_voxel_;
  return static_cast<std::size_t>(std::lround(bead.overflow_mm2 * len_mm * v));
}

std::size_t BeadSweep::lay_disc(const Disc& disc, VoxelGrid& grid, std::uint32_t tag,
                                HeightMap& map, std::size_t* overlap) {
  const Vec3 c = (disc.centre_mm - origin_) * inv_voxel_;
  const double z = snap_whole(c.z());
  const double hh = snap_whole(disc.h_mm * inv_voxel_);
  const double r = 0.5 * hh;
  const double flat = 0.5 * (disc.w_mm - disc.h_mm) * inv_voxel_;
  // The section revolved about the vertical through the centre, where m0 . q >= 0 and
  // m1 . q < 0 (q from the centre), in a frame on the centre's voxel.
  BeadFrame g;
  g.ia = floor_int(c.x()), g.ja = floor_int(c.y()), g.ka = floor_int(z);
  g.fa_x = static_cast<float>(c.x() - g.ia), g.fa_y = static_cast<float>(c.y() - g.ja);
  g.c0 = static_cast<float>(z - r - g.ka);
  g.r = static_cast<float>(r), g.r2 = static_cast<float>(r * r), g.flat = static_cast<float>(flat);
  g.m0_x = static_cast<float>(disc.m0.x()), g.m0_y = static_cast<float>(disc.m0.y());
  g.m1_x = static_cast<float>(disc.m1.x()), g.m1_y = static_cast<float>(disc.m1.y()), g.e1 = 0;
  // The wedge's box: its apex, the ends of its two edges and the disc's extreme points in x
  // and y that lie in it.
  const double reach = flat + r + kBoundSlack;
  Vec2 lo = Vec2::Zero(), hi = Vec2::Zero();
  auto take = [&](const Vec2& u) {
    if (disc.m0.dot(u) < -1e-9 || disc.m1.dot(u) > 1e-9) return;
    lo = lo.cwiseMin(reach * u), hi = hi.cwiseMax(reach * u);
  };
  const Vec2 n0(-disc.m0.y(), disc.m0.x()), n1(-disc.m1.y(), disc.m1.x());
  for (const Vec2& u : {n0, Vec2(-n0), n1, Vec2(-n1), Vec2(Vec2::UnitX()), Vec2(-Vec2::UnitX()),
                        Vec2(Vec2::UnitY()), Vec2(-Vec2::UnitY())})
    take(u);
  const int i_lo = std::max(0, floor_int(c.x() + lo.x() - kBoundSlack));
  const int i_hi = std::min(nx_ - 1, floor_int(c.x() + hi.x() + kBoundSlack));
  const int j_lo = std::max(0, floor_int(c.y() + lo.y() - kBoundSlack));
  const int j_hi = std::min(ny_ - 1, floor_int(c.y() + hi.y() + kBoundSlack));
  const int k_lo = std::max(0, floor_int(z - hh));
  const int k_hi = std::min(nz_ - 1, static_cast<int>(std::ceil(z)) - 1);
  std::size_t filled = 0;
  for (int by = j_lo >> 3; by <= j_hi >> 3; ++by) {
    const int row_lo = std::max(j_lo - 8 * by, 0), row_hi = std::min(j_hi - 8 * by + 1, 8);
    for (int bx = i_lo >> 3; bx <= i_hi >> 3; ++bx) {
      const int x_lo = std::max(i_lo - 8 * bx, 0), x_hi = std::min(i_hi - 8 * bx, 7);
      const unsigned lanes = ((2u << x_hi) - 1u) & ~((1u << x_lo) - 1u);
      const std::size_t at = map.index(8 * bx, 8 * by);
      std::uint64_t raised = 0;  // top layer first: each column raised by its highest voxel
      for (int k = k_hi; k >= k_lo; --k) {
        std::uint64_t mask = test_tile_disc(g, 8 * bx, 8 * by, k, row_lo, row_hi, lanes);
        if (mask == 0) continue;
        if (writer_ != nullptr) {
          // The writer writes and counts. A join fills only the free voxels: of the occupied
          // ones, those that are their column's top would hand the top to this layer; the
          // others lie below a higher top and raise nothing.
          if (overlap != nullptr) {
            writer_->cap(bx, by, k, mask, tag);
          } else {
            writer_->join(bx, by, k, mask, tag);
            joined_ = true;
            mask &= ~map.tops_equal(at, static_cast<std::uint16_t>(k + 1));
          }
        } else {
          if (overlap == nullptr) {  // a join: only the free voxels
            const std::uint64_t* occ = occupancy(grid, bx, by, k >> 3);
            mask &= ~(occ != nullptr ? occ[k & 7] : 0);
            if (mask == 0) continue;
          }
          const auto fresh =
              static_cast<std::size_t>(popcount64(mask & ~write_slice(grid, bx, by, k, mask, tag)));
          filled += fresh;
          if (overlap != nullptr) *overlap += static_cast<std::size_t>(popcount64(mask)) - fresh;
        }
        if ((mask & ~raised) != 0)
          map.raise_tile(at, mask & ~raised, static_cast<std::uint16_t>(k + 1), disc.layer);
        raised |= mask;
      }
    }
  }
  return filled;
}

// The squeeze: the material that fell on occupied voxels goes to the free voxels near the
// bead's section, within the bead's own cuts: the section grown a voxel at a time (beside it
// and, a voxel layer further each time, below it) up to squeeze_mm; then above the tip (the
// layer rising, as in an over-full solid layer), a voxel layer at a time.
std::size_t BeadSweep::squeeze(const SweptBead& bead, const BeadFrame& f, const Vec2& a2,
                               const Vec2& b2, const Sides& sides, std::size_t lost,
                               VoxelGrid& grid, std::uint32_t tag, HeightMap& map) {
  const double delta = bead.squeeze_mm * inv_voxel_;
  const int steps = std::max(1, static_cast<int>(std::ceil(delta - 1e-9)));
  const int k_lo = reached_.front(), k_hi = reached_.back();
  std::size_t placed = 0;
  // `keep`: remember each tile's grown masks (tile_masks_, the tile and its rows in
  // tile_keys_) for a second pass over the same layers; `reuse`: take them from there for
  // the tiles both passes visit with the same rows.
  auto pass = [&](const BeadFrame& g, double reach, const Sides* within, bool keep, bool reuse) {
    Ring ring{&g,      nullptr,    layers_.data(), static_cast<int>(layers_.size()),
              nullptr, bead.layer, within,         0,
              false};
    ring.bottom = k_lo;
    const auto nk = layers_.size();
    const double hw = static_cast<double>(f.flat) + static_cast<double>(f.r) + reach + kBoundSlack;
    // A side that ends at the flat part: no voxel centre beyond it is within it, so the tiles
    // whose cells lie wholly past it (by more than a cell's half-diagonal) need not be visited.
    double lo = -hw, hi = hw;
    if (within != nullptr && !std::isinf(within->pos))
      hi = std::min(hi, within->pos + 1.0 + kBoundSlack);
    if (within != nullptr && !std::isinf(within->neg))
      lo = std::max(lo, -(within->neg + 1.0 + kBoundSlack));
    std::size_t tile = 0;
    for_each_tile(bead, a2, b2, lo, hi, [&](int bx, int by, int t_lo, int t_hi, unsigned lanes) {
      const TileKey key{by, bx, t_lo, t_hi};
      ring.cache = nullptr, ring.known = nullptr;
      if (keep) {
        tile_masks_.resize((tile + 1) * nk), tile_known_.resize(tile + 1, 0);
        tile_keys_.push_back(key);
        ring.cache = tile_masks_.data() + tile * nk, ring.known = &tile_known_[tile];
        ++tile;
      } else if (reuse) {
        // Both walks go row of tiles by row, each row in x order.
        while (tile < tile_keys_.size() && tile_keys_[tile] < key) ++tile;
        if (tile < tile_keys_.size() && tile_keys_[tile] == key)
          ring.cache = tile_masks_.data() + tile * nk, ring.known = &tile_known_[tile];
      }
      placed += squeeze_tile(ring, bx, by, t_lo, t_hi, lanes, lost - placed, grid, tag, map);
      return placed < lost;
    });
  };
  // Beside and below, within the bead's reach: within the sides first, then on both sides.
  layers_.clear();
  for (int k = std::max(0, k_lo - steps); k <= k_hi; ++k) layers_.push_back(k);
  const BeadFrame reach = grown(f, delta);
  // The second pass visits the first's tiles and more (the first stops at an open side's
  // flat part); it reuses the first's masks where a tile's rows are the same.
  const bool second = !bead.keeps_sides || sides.open();
  tile_masks_.clear();
  tile_known_.clear();
  tile_keys_.clear();
  if (!sides.open()) pass(reach, delta, &sides, second, false);
  // A bead that keeps its sides goes no further: past an open side lie the grooves between
  // layers.
  if (!second) return placed;
  if (placed < lost) pass(reach, delta, nullptr, false, !sides.open());
  const int rise = bead.rise_voxels < 0 ? steps : std::min(steps, bead.rise_voxels);
  for (int k = k_hi + 1; k <= std::min(nz_ - 1, k_hi + rise) && placed < lost; ++k) {
    layers_.assign(1, k);
    pass(reach, delta, nullptr, false, false);
  }
  return placed;
}

std::size_t BeadSweep::squeeze_tile(const Ring& ring, int bx, int by, int row_lo, int row_hi,
                                    unsigned lanes, std::size_t need, VoxelGrid& grid,
                                    std::uint32_t tag, HeightMap& map) {
  const auto nk = static_cast<std::size_t>(ring.count);
  ring_.resize(nk);
  free_.resize(nk);
  // Voxels next to each other's in x, y (dilate_xy) or z (the layer list is consecutive).
  auto next_to = [&](const std::uint64_t* m, std::size_t n, bool diagonal = false) {
    std::uint64_t near = dilate_xy(m[n], diagonal);
    if (n > 0 && ring.layers[n - 1] == ring.layers[n] - 1) near |= m[n - 1];
    if (n + 1 < nk && ring.layers[n + 1] == ring.layers[n] + 1) near |= m[n + 1];
    return near;
  };
  const std::uint64_t rows =
      row_hi - row_lo >= 8 ? ~std::uint64_t{0}
                           : ((std::uint64_t{1} << (8 * (row_hi - row_lo))) - 1) << (8 * row_lo);
  const std::uint64_t inside = rows & (static_cast<std::uint64_t>(lanes) * 0x0101010101010101ull);
  const bool sided = ring.sides != nullptr && !ring.sides->open();
  std::uint64_t any_free = free_voxels(ring, grid, bx, by) & inside;
  if (ring.grown == nullptr) {
    // The local ring reaches no further (in x and y) than its steps from the bead's voxels.
    std::uint64_t zone = 0;
    for (std::size_t n = 0; n < nk; ++n) zone |= ring.masks[n];
    for (int step = 0; step < ring.steps && (any_free & ~zone) != 0; ++step)
      zone = dilate_xy(zone, (step & 1) != 0);
    any_free &= zone;
  }
  if (any_free == 0) return 0;  // no room: the limits and the section test are not needed
  // The local ring stays between the bead's own end cuts (the next bead's stretch is its own).
  const std::uint64_t cut = ring.grown == nullptr && ring.sides != nullptr
                                ? ring.sides->cut_mask(8 * bx, 8 * by)
                                : ~std::uint64_t{0};
  const std::uint64_t within =
      (sided ? ring.sides->tile_mask(8 * bx, 8 * by) & inside : inside) & cut;
  if ((any_free & (ring.grown != nullptr ? within : cut)) == 0) return 0;
  // What goes where is decided on the masks; each layer is written once at the end.
  std::size_t placed = 0;
  put_.assign(nk, 0);
  auto place = [&](std::size_t n, std::uint64_t room) {
    if (room == 0) return;
    const std::size_t left = need - placed;
    const auto count = static_cast<std::size_t>(popcount64(room));
    const std::uint64_t mask = count <= left ? room : lowest_bits(room, left);
    placed += std::min(count, left);
    put_[n] |= mask;
    free_[n] &= ~mask;
    ring_[n] &= ~mask;
  };
  if (ring.hits != nullptr) {
    hit_near_.resize(nk);
    for (std::size_t n = 0; n < nk; ++n) hit_near_[n] = next_to(ring.hits, n);
  }
  auto place_ring = [&] {
    if (ring.hits != nullptr)
      for (std::size_t n = 0; n < nk && placed < need; ++n) place(n, ring_[n] & hit_near_[n]);
    for (std::size_t n = 0; n < nk && placed < need; ++n) place(n, ring_[n]);
  };
  auto write = [&] {
    const std::size_t at = map.index(8 * bx, 8 * by);
    // Top layer first: a column is raised once, by its highest voxel.
    std::uint64_t raised = 0;
    for (std::size_t n = nk; n-- > 0;) {
      if (put_[n] == 0) continue;
      const int k = ring.layers[n];
      write_slice(grid, bx, by, k, put_[n], tag);
      if ((put_[n] & ~raised) != 0)
        map.raise_tile(at, put_[n] & ~raised, static_cast<std::uint16_t>(k + 1), ring.bead_layer);
      raised |= put_[n];
      words_.make(bx, by, k >> 3)[BlockWords::kSqueezed + (k & 7)] |= put_[n];
    }
    return placed;
  };
  if (ring.grown != nullptr) {
    grown_masks(ring, bx, by, row_lo, row_hi, lanes, within);
    for (std::size_t n = 0; n < nk; ++n) ring_[n] &= free_[n] & within;
    place_ring();
    return write();
  }
  // The local ring: a voxel further from the bead's voxels each step, through anything; first
  // within the sides, then (what is left) on both sides. The reach of each step is the same
  // for both: worked out once, when first needed (reach_: steps x nk words).
  reach_.resize(static_cast<std::size_t>(ring.steps) * nk);
  int reached = 0;  // steps of reach_ worked out
  for (const std::uint64_t room : {within, inside & cut}) {
    std::uint64_t left = 0;  // free voxels in the room, on any layer
    for (std::size_t n = 0; n < nk; ++n) left |= free_[n] & room;
    for (int step = 0; step < ring.steps && placed < need && left != 0; ++step) {
      std::uint64_t* const zone = reach_.data() + static_cast<std::size_t>(step) * nk;
      if (step == reached) {
        // Steps alternately square and diagonal: an octagon, about a disc of the reach.
        const std::uint64_t* const from = step == 0 ? ring.masks : zone - nk;
        for (std::size_t n = 0; n < nk; ++n) zone[n] = next_to(from, n, (step & 1) != 0) & inside;
        ++reached;
      }
      for (std::size_t n = 0; n < nk; ++n) ring_[n] = zone[n] & free_[n] & room;
      place_ring();
    }
    if (!sided || placed == need || !ring.past_sides) break;
  }
  return write();
}

std::uint64_t BeadSweep::free_voxels(const Ring& ring, const VoxelGrid& grid, int bx, int by) {
  const auto nk = static_cast<std::size_t>(ring.count);
  std::uint64_t any_free = 0;
  const std::uint64_t* occ = nullptr;
  int occ_bz = -1;          // the block of `occ` (the layers are in order: one or two blocks)
  std::uint64_t under = 0;  // the occupancy of the layer below (the bed: all)
  for (std::size_t n = 0; n < nk; ++n) {
    const int k = ring.layers[n];
    if (n == 0 || ring.layers[n - 1] != k - 1) {
      const std::uint64_t* b = k > 0 ? occupancy(grid, bx, by, (k - 1) >> 3) : nullptr;
      under = k == 0 ? ~std::uint64_t{0} : (b != nullptr ? b[(k - 1) & 7] : 0);
    }
    if ((k >> 3) != occ_bz) occ_bz = k >> 3, occ = occupancy(grid, bx, by, occ_bz);
    const std::uint64_t held = occ != nullptr ? occ[k & 7] : 0;
    free_[n] = ~held;
    // Below the bead's layers material goes only where plastic (or the bed) holds it from
    // beneath: into the cusps and gaps of the layer below, not into the air under a bridge.
    if (k < ring.bottom) free_[n] &= under;
    any_free |= free_[n];
    under = held;
  }
  return any_free;
}

void BeadSweep::grown_masks(const Ring& ring, int bx, int by, int row_lo, int row_hi,
                            unsigned lanes, std::uint64_t within) {
  // Only the layers with free voxels within the limits that the grown section may reach are
  // tested (the others take nothing); masks a first pass over the tile computed are taken
  // from ring.cache.
  const auto nk = static_cast<std::size_t>(ring.count);
  const bool cached = ring.cache != nullptr && nk <= 64;
  const std::uint64_t known = cached ? *ring.known : 0;
  test_layers_.clear();
  std::uint64_t rooms = 0;  // the free voxels within the limits of the layers tested
  for (std::size_t n = 0; n < nk; ++n) {
    ring_[n] = 0;
    const std::uint64_t room = free_[n] & within;
    if (room == 0) continue;
    if (((known >> n) & 1u) != 0) {
      ring_[n] = ring.cache[n];
    } else if (!section_misses(*ring.grown, 8 * bx, 8 * by, room, ring.layers[n])) {
      test_layers_.push_back(static_cast<std::int32_t>(n));
      rooms |= room;
    }
  }
  if (test_layers_.empty()) return;
  // Only their rows are tested, unless the masks are kept for a second pass (whose limits are
  // wider).
  if (ring.cache == nullptr) {
    row_lo = std::max(row_lo, __builtin_ctzll(rooms) >> 3);
    row_hi = std::min(row_hi, ((63 - __builtin_clzll(rooms)) >> 3) + 1);
  }
  test_ks_.resize(test_layers_.size());
  test_out_.resize(test_layers_.size());
  for (std::size_t t = 0; t < test_layers_.size(); ++t) test_ks_[t] = ring.layers[test_layers_[t]];
  test_tile_layers(*ring.grown, 8 * bx, 8 * by, test_ks_.data(), static_cast<int>(test_ks_.size()),
                   row_lo, row_hi, lanes, test_out_.data());
  std::uint64_t now = known;
  for (std::size_t t = 0; t < test_layers_.size(); ++t) {
    const auto n = static_cast<std::size_t>(test_layers_[t]);
    ring_[n] = test_out_[t];
    if (cached) ring.cache[n] = test_out_[t], now |= std::uint64_t{1} << n;
  }
  if (cached) *ring.known = now;
}

namespace {

/// The tile's voxels (bit y * 8 + x, tile corner (i0, j0)) whose centre q has lo <= n . (q - o)
/// <= hi (either limit may be infinite).
std::uint64_t band_mask(const Vec2& n, const Vec2& o, double lo, double hi, int i0, int j0) {
  // Offsets l(x, y) = n . (centre - o) are linear: per row, the x between the limits.
  std::uint64_t m = 0;
  const bool flat_x = std::abs(n.x()) < 1e-12;
  for (int y = 0; y < 8; ++y) {
    const double c = n.x() * (i0 + 0.5 - o.x()) + n.y() * (j0 + y + 0.5 - o.y());
    int x0 = 0, x1 = 7;
    if (flat_x) {
      if (c < lo || c > hi) continue;
    } else {
      double t0 = (lo - c) / n.x(), t1 = (hi - c) / n.x();
      if (t0 > t1) std::swap(t0, t1);
      // ceil(t0) and floor(t1), clamped to the tile (floor_int: no library call).
      if (t0 > 7 || t1 < 0) continue;
      if (t0 > 0) x0 = -floor_int(-t0);
      if (t1 < 7) x1 = floor_int(t1);
      if (x0 > x1) continue;
    }
    const std::uint64_t bits = ((2u << x1) - 1u) & ~((1u << x0) - 1u);
    m |= bits << (8 * y);
  }
  return m;
}

}  // namespace

std::uint64_t BeadSweep::Sides::tile_mask(int i0, int j0) const {
  return band_mask(n, a2, -neg, pos, i0, j0);
}

std::uint64_t BeadSweep::Sides::cut_mask(int i0, int j0) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // Most tiles lie wholly between the cuts: their four extreme voxel centres do.
  bool between = true;
  for (const double x : {i0 + 0.5, i0 + 7.5})
    for (const double y : {j0 + 0.5, j0 + 7.5}) {
      const Vec2 q(x, y);
      between = between && m0.dot(q - a2) >= 0.0 && m1.dot(q - b2) <= 0.0;
    }
  if (between) return ~std::uint64_t{0};
  return band_mask(m0, a2, 0.0, kInf, i0, j0) & band_mask(m1, b2, -kInf, 0.0, i0, j0);
}

BlockWords::BlockWords(const Eigen::Vector3i& block_dims)
    : dims_(block_dims), top_x_((block_dims.x() + 7) >> 3), top_y_((block_dims.y() + 7) >> 3) {}

std::uint64_t* BlockWords::make(int bx, int by, int bz) {
  if (bx == last_.x() && by == last_.y() && bz == last_.z()) return last_words_;
  if (bx < 0 || by < 0 || bz < 0 || bx >= dims_.x() || by >= dims_.y() || bz >= dims_.z())
    return nullptr;
  if (top_.empty())
    top_ = ZeroedArray<std::uint32_t>(static_cast<std::size_t>(top_x_) *
                                      static_cast<std::size_t>(top_y_) *
                                      static_cast<std::size_t>(dims_.z()));
  std::uint32_t& group = top_[top_index(bx, by, bz)];
  if (group == 0) group = groups_.add();
  std::uint32_t& block = groups_.at(group - 1)[group_slot(bx, by)];
  if (block == 0) block = words_.add();
  last_ = Eigen::Vector3i(bx, by, bz), last_words_ = words_.at(block - 1);
  return last_words_;
}

BeadSweep::Sides BeadSweep::sides_of(const BeadFrame& f, const SweptBead& bead, const Vec2& a2,
                                     const Vec2& b2, const VoxelGrid& grid) const {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Sides s;
  s.a2 = a2;
  s.n = bead.n;
  s.b2 = b2;
  s.m0 = bead.m0;
  s.m1 = bead.m1;
  const double flat = static_cast<double>(f.flat);
  const double out = flat + static_cast<double>(f.r) + 1.5;  // just beyond the edge
  int held[2] = {0, 0};                                      // +n, -n
  for (const double t : {0.25, 0.5, 0.75}) {
    const Vec2 q = a2 + t * (b2 - a2);
    const int k = floor_int(static_cast<double>(f.ka) + static_cast<double>(f.c0) +
                            static_cast<double>(f.slope) * t * (b2 - a2).norm());
    for (int side = 0; side < 2; ++side) {
      const Vec2 p = q + (side == 0 ? out : -out) * bead.n;
      const int i = floor_int(p.x()), j = floor_int(p.y());
      if (i < 0 || j < 0 || k < 0 || i >= nx_ || j >= ny_ || k >= nz_) continue;
      const std::uint64_t* occ = occupancy(grid, i >> 3, j >> 3, k >> 3);
      if (occ != nullptr && ((occ[k & 7] >> (8 * (j & 7) + (i & 7))) & 1u) != 0) ++held[side];
    }
  }
  // A side holding earlier plastic is inside; a side holding none ends at the flat part.
  s.pos = held[0] > 0 ? kInf : flat;
  s.neg = held[1] > 0 ? kInf : flat;
  return s;
}

}  // namespace printtwin::detail

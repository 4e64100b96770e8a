// The sweep (see sweep.hpp).
#include "deposit/sweep.hpp"
#include "deposit/voxel_blocks.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>
#include <tuple>

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

/// The bead's footprint at one half-width, in the (major, minor) plane of the sweep: the
/// strip |n.(q-a)| <= hw between the start cut (m0.(q-a) >= 0) and the end cut (m1.(q-b) < 0).
struct Footprint {
  Linear side, start, end;
  // Every corner of the footprint is among these: the side lines' crossings with the cuts,
  // and the crossing of the two cuts when it lies between the sides (a short bead between
  // two sharp mitres is a triangle). Corners outside the footprint only widen the ranges.
  std::array<Vec2, 5> vertices;

  void init(const Vec2& a, const Vec2& b, const Vec2& d, const Vec2& n, const Vec2& m0,
            const Vec2& m1, double hw) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    side.init(n.x(), n.y(), -n.dot(a), -hw, hw);
    start.init(m0.x(), m0.y(), -m0.dot(a), 0.0, kInf);
    end.init(m1.x(), m1.y(), -m1.dot(b), -kInf, 0.0);
    // Intersections of the side lines s = +-hw with the two cut lines.
    const double k0 = m0.dot(n) / m0.dot(d);
    const double k1 = m1.dot(n) / m1.dot(d);
    vertices = {a + (-hw * k0) * d + hw * n, a + (hw * k0) * d - hw * n,
                b + (-hw * k1) * d + hw * n, b + (hw * k1) * d - hw * n, a};
    const double det = m0.x() * m1.y() - m0.y() * m1.x();
    if (std::abs(det) > 1e-12) {
      const double c0 = m0.dot(a), c1 = m1.dot(b);
      const Vec2 cross((c0 * m1.y() - m0.y() * c1) / det, (m0.x() * c1 - c0 * m1.x()) / det);
      if (std::abs(n.dot(cross - a)) <= hw) vertices[4] = cross;
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
      exhaustive_(exhaustive) {}

bool BeadSweep::set_up(const SweptBead& bead, BeadFrame& f, Vec2& a2, Vec2& b2, double& hw) {
  // Heights that are whole voxels up to rounding (Z 0.4 / 0.05 = 7.9999999) are snapped, so
  // layer boundaries stay on voxel boundaries.
  auto snap = [](double v) {
    const double r = std::round(v);
    return std::abs(v - r) < 1e-6 ? r : v;
  };
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
void BeadSweep::for_each_tile(const SweptBead& bead, const Vec2& a2, const Vec2& b2, double hw,
                              Fn&& fn) const {
  Footprint outer;
  outer.init(a2, b2, bead.d, bead.n, bead.m0, bead.m1, hw);
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
      fn(bx, by, t_lo, t_hi, lanes);
    }
  }
}

BeadSweep::Laid BeadSweep::lay(const SweptBead& bead, VoxelGrid& grid, std::uint32_t tag,
                               HeightMap& map) {
  BeadFrame f;
  Vec2 a2, b2;
  double hw;
  Laid laid;
  if (!set_up(bead, f, a2, b2, hw)) return laid;
  masks_.resize(reached_.size());
  for_each_tile(bead, a2, b2, hw, [&](int bx, int by, int t_lo, int t_hi, unsigned lanes) {
    const std::size_t at = map.index(8 * bx, 8 * by);
    test_tile_layers(f, 8 * bx, 8 * by, reached_.data(), static_cast<int>(reached_.size()), t_lo,
                     t_hi, lanes, masks_.data());
    for (std::size_t layer_at = 0; layer_at < reached_.size(); ++layer_at) {
      const std::uint64_t mask = masks_[layer_at];
      if (mask == 0) continue;
      const int k = reached_[layer_at];
      const std::size_t fresh = detail::VoxelBlocks::write_tile(grid, bx, by, k, mask, tag);
      laid.overlap += static_cast<std::size_t>(std::popcount(mask)) - fresh;
      map.raise_tile(at, mask, static_cast<std::uint16_t>(k + 1), bead.layer);
    }
  });
  if (laid.overlap > 0 && bead.squeeze_mm > 0)
    laid.squeezed = squeeze(bead, f, a2, b2, laid.overlap, grid, tag, map);
  return laid;
}

// The squeeze: the material that fell on occupied voxels goes to the free voxels nearest the
// bead's section (distance from the section's stadium), up to squeeze_mm away, within the
// bead's own cuts: beside it and below it first; above the tip (the layer rising, as in an
// over-full solid layer) only when nothing beside or below is free.
std::size_t BeadSweep::squeeze(const SweptBead& bead, const BeadFrame& f, const Vec2& a2,
                               const Vec2& b2, std::size_t lost, VoxelGrid& grid, std::uint32_t tag,
                               HeightMap& map) {
  const double delta = bead.squeeze_mm * inv_voxel_;
  // The section grown by delta (a stadium is a segment's disc sweep: grow the disc).
  BeadFrame g = f;
  const double rg = static_cast<double>(f.r) + delta;
  g.r = static_cast<float>(rg);
  g.r2 = static_cast<float>(rg * rg);
  // Layers: from the lowest grown bottom to the highest grown top.
  const int k_top = std::min(nz_ - 1, reached_.back() + static_cast<int>(std::ceil(delta)) + 1);
  const int k_bottom = std::max(0, floor_int(static_cast<double>(reached_.front()) - delta - 1.0));
  layers_.clear();
  for (int k = k_bottom; k <= k_top; ++k) layers_.push_back(k);
  masks_.resize(layers_.size());
  const double hw = static_cast<double>(f.flat) + rg + kBoundSlack;
  const auto fdelta = static_cast<float>(delta);
  candidates_.clear();
  for_each_tile(bead, a2, b2, hw, [&](int bx, int by, int t_lo, int t_hi, unsigned lanes) {
    test_tile_layers(g, 8 * bx, 8 * by, layers_.data(), static_cast<int>(layers_.size()), t_lo,
                     t_hi, lanes, masks_.data());
    for (std::size_t n = 0; n < layers_.size(); ++n) {
      const int k = layers_[n];
      const std::uint64_t* occ = detail::VoxelBlocks::block_occupancy(grid, bx, by, k >> 3);
      std::uint64_t free = masks_[n] & ~(occ != nullptr ? occ[k & 7] : 0);
      for (; free != 0; free &= free - 1) {
        const int bit = std::countr_zero(free);
        const std::int32_t i = 8 * bx + (bit & 7), j = 8 * by + (bit >> 3);
        float l, dz;
        section_offset(f, i, j, k, l, dz);
        const float lp = std::max(l, 0.0f);
        float d = std::sqrt(lp * lp + dz * dz) - f.r;
        if (!(d <= fdelta)) continue;
        // Above the tip only when nothing beside or below is free: the layer rises there.
        if (!(dz < f.r)) d += 2.0f * fdelta;
        candidates_.push_back(Candidate{d, voxel_jitter_bits(i, j, k), i, j, k});
      }
    }
  });
  // The `lost` nearest (ties by the voxel's hash, then its key: the same choice every run).
  auto nearer = [](const Candidate& x, const Candidate& y) {
    if (x.d != y.d) return x.d < y.d;
    if (x.hash != y.hash) return x.hash < y.hash;
    return std::tie(x.k, x.j, x.i) < std::tie(y.k, y.j, y.i);
  };
  if (candidates_.size() > lost) {
    std::nth_element(candidates_.begin(), candidates_.begin() + static_cast<std::ptrdiff_t>(lost),
                     candidates_.end(), nearer);
    candidates_.resize(lost);
  }
  // Written tile by tile (block row, block, layer).
  std::sort(candidates_.begin(), candidates_.end(), [](const Candidate& x, const Candidate& y) {
    return std::make_tuple(x.j >> 3, x.i >> 3, x.k) < std::make_tuple(y.j >> 3, y.i >> 3, y.k);
  });
  std::size_t placed = 0;
  for (std::size_t c = 0; c < candidates_.size();) {
    const Candidate& first = candidates_[c];
    const int bx = first.i >> 3, by = first.j >> 3, k = first.k;
    std::uint64_t mask = 0;
    for (; c < candidates_.size() && candidates_[c].i >> 3 == bx && candidates_[c].j >> 3 == by &&
           candidates_[c].k == k;
         ++c)
      mask |= std::uint64_t{1} << ((candidates_[c].j & 7) * 8 + (candidates_[c].i & 7));
    placed += detail::VoxelBlocks::write_tile(grid, bx, by, k, mask, tag);
    map.raise_tile(map.index(8 * bx, 8 * by), mask, static_cast<std::uint16_t>(k + 1), bead.layer);
  }
  return placed;
}

}  // namespace printtwin::detail

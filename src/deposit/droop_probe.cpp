// Sag and droop of laid beads (see droop_probe.hpp).
#include "deposit/droop_probe.hpp"

#include <algorithm>
#include <cmath>

#include "deposit/bead_model.hpp"

namespace printtwin::detail {

namespace {
// Widest gap between support lines searched for across a bead: support grids are a few mm
// apart; a bead with no support line this close on both sides is not held by them.
constexpr double kSupportSpanMm = 10.0;
}  // namespace

void DroopProbe::begin_bead(const Move& mv, const Vec3& a, const Vec3& b, int samples, double h,
                            double w, const HeightMap& map) {
  map_ = &map;
  mv_ = mv;
  a_ = a;
  b_ = b;
  const double len = (b - a).head<2>().norm();
  d_ = (b - a).head<2>() / len;
  n_ = Vec2(-d_.y(), d_.x());
  samples_ = samples;
  h_ = h;
  w_ = w;
  step_mm_ = len / samples;
  // Sparse infill spans the cells below; support is removed after printing; solid infill is
  // laid as a sheet over support or infill, each line beside the last (not modelled: a limit).
  skip_ = !model_.deforms() || mv.feature == Feature::sparse_infill || is_support(mv.feature) ||
          mv.feature == Feature::solid_infill || mv.feature == Feature::top_solid_infill;
  oz_ = map.top_mm(a.x(), a.y()) - map.rows(a.x(), a.y()) * voxel_;
  support_laid_ = support_laid_ || is_support(mv.feature);
  drops_.assign(static_cast<std::size_t>(samples), 0.0);
  fwd_ = back_ = kNoAnchor;
  fwd_at_ = back_at_ = -1;
}

double DroopProbe::earlier_top(double x, double y) const {
  const auto layer = map_->top_layer_at(x, y);
  if (!layer || *layer > mv_.layer) return oz_;
  if (*layer < mv_.layer) return map_->top_mm(x, y);
  return oz_ + map_->rows_before_top_layer(x, y) * voxel_;
}

bool DroopProbe::holds(double x, double y, double bottom) const {
  const auto layer = map_->top_layer_at(x, y);
  if (!layer || *layer > mv_.layer) return false;
  if (*layer < mv_.layer) return map_->top_mm(x, y) >= bottom - 2.0 * h_;
  const int rows = map_->rows_before_top_layer(x, y);
  return rows > 0 && oz_ + rows * voxel_ >= bottom - 2.0 * h_;
}

bool DroopProbe::anchors(double x, double y, double bottom, double top, double& low) const {
  const auto layer = map_->top_layer_at(x, y);
  if (!layer) return false;
  const double t = map_->top_mm(x, y);
  low = std::max(0.0, top - t);
  if (*layer < mv_.layer) {
    low = std::max(0.0, bottom - t);
    return t >= bottom - 2.0 * h_;
  }
  return *layer == mv_.layer;  // a bead of this layer, hanging `low` below its tip
}

double DroopProbe::anchor_low(const Vec2& p, const Vec2& dir, double s, double bottom, double top,
                              double low) const {
  for (double t = s + voxel_; t <= s + w_ + 1e-9 && low > 0; t += voxel_) {
    const Vec2 q = p + t * dir;
    double l = 0;
    if (anchors(q.x(), q.y(), bottom, top, l)) low = std::min(low, l);
  }
  return low;
}

bool DroopProbe::rests(double x, double y, double bottom, double& gap) const {
  const auto layer = map_->top_layer_at(x, y);
  if (!layer || *layer >= mv_.layer || !map_->top_is_support(x, y)) return false;
  const double t = map_->top_mm(x, y);
  if (t < bottom - 2.0 * h_) return false;
  gap = std::max(0.0, bottom - t);
  return true;
}

double DroopProbe::support_line(const Vec2& p, const Vec2& dir, double bottom, double max_mm,
                                double& gap) const {
  double g = 0;
  auto rest = [&](double x, double y) { return rests(x, y, bottom, g); };
  const double s = distance_to_anchor(p, dir, voxel_, max_mm, rest);
  if (!(s < kNoAnchor)) return s;
  // The first column reached is the line's rounded flank: its crest lies within a bead width.
  gap = g;
  for (double t = s + voxel_; t <= s + w_ + 1e-9; t += voxel_) {
    const Vec2 q = p + t * dir;
    if (rests(q.x(), q.y(), bottom, g)) gap = std::min(gap, g);
  }
  return s;
}

void DroopProbe::rest_on_support(const Vec2& p, double bottom, double room, Drop& drop) const {
  if (!(drop.mm > 0) || !support_laid_) return;
  // Support lines across the path on both sides (a wall along the support lines): a bridge
  // from line to line, hanging from their crests.
  double gap_l = 0, gap_r = 0;
  const double l = support_line(p, n_, bottom, kSupportSpanMm, gap_l);
  const double r = support_line(p, -n_, bottom, kSupportSpanMm, gap_r);
  double held = kNoAnchor;
  if (l < kNoAnchor && r < kNoAnchor)
    held = gap_l + (gap_r - gap_l) * (l / (l + r)) + model_.bridge_sag(l + r, l);
  // A support line within the fall limit in any direction: the bead falls at most onto it.
  const double fall = model_.overhang_fall_mm;
  if (l <= fall) held = std::min(held, gap_l);
  if (r <= fall) held = std::min(held, gap_r);
  constexpr double kR = 0.70710678118654752;
  const Vec2 dirs[6] = {d_, -d_, kR * (d_ + n_), kR * (d_ - n_), kR * (n_ - d_), -kR * (d_ + n_)};
  for (const Vec2& dir : dirs) {
    double gap = 0;
    if (support_line(p, dir, bottom, fall, gap) < kNoAnchor) held = std::min(held, gap);
  }
  held = std::min(held, std::max(room, 0.0));
  if (held < drop.mm) {
    drop.mm = held;
    drop.kind = held > 0 ? DropKind::bridge : DropKind::none;
  }
}

Drop DroopProbe::sample(int i) {
  if (skip_) return Drop{};
  const Vec3 q = a_ + ((i + 0.5) / samples_) * (b_ - a_);
  const double bottom = q.z() - h_;
  const Vec2 p = q.head<2>();
  // Room beneath: the highest material of earlier layers (or the bed) under the bead's width;
  // this layer's beads beside it are no floor.
  const int across = std::max(3, static_cast<int>(std::ceil(w_ / voxel_)));
  double below = oz_;
  for (int j = 0; j < across; ++j) {
    const Vec2 at = p + (-0.5 * w_ + (j + 0.5) * w_ / across) * n_;
    below = std::max(below, earlier_top(at.x(), at.y()));
  }
  const double room = bottom - below;
  // The edge that holds it: nearest earlier-layer material within the fall limit.
  auto hold = [&](double x, double y) { return holds(x, y, bottom); };
  const double edge =
      hold(p.x(), p.y()) ? 0.0 : nearest_anchor(p, d_, voxel_, model_.overhang_fall_mm, hold);
  // Anchors ahead and behind along the path (a bridge), found once per bead and carried on.
  double low = 0;
  auto anchor = [&](double x, double y) { return anchors(x, y, bottom, q.z(), low); };
  if (fwd_at_ < 0 || fwd_ - (i - fwd_at_) * step_mm_ <= 0) {
    fwd_ = distance_to_anchor(p, d_, voxel_, model_.max_span_mm(), anchor);
    fwd_low_ = fwd_ < kNoAnchor ? anchor_low(p, d_, fwd_, bottom, q.z(), low) : 0;
    fwd_at_ = i;
  }
  if (back_at_ < 0) {
    back_ = distance_to_anchor(p, -d_, voxel_, model_.max_span_mm(), anchor);
    back_low_ = back_ < kNoAnchor ? anchor_low(p, -d_, back_, bottom, q.z(), low) : 0;
    back_at_ = i;
  }
  const double fwd = fwd_ - (i - fwd_at_) * step_mm_;
  const double back = back_ + (i - back_at_) * step_mm_;
  Drop drop = predict_drop(model_, back, fwd, edge, room, back_low_, fwd_low_);
  rest_on_support(p, bottom, room, drop);
  // Between half a layer and a layer of air beneath (the support test holds a bead on half a
  // layer): the bead settles onto what is there.
  if (room > drop.mm && room >= 0.5 * h_ && room <= h_) {
    drop.mm = room;
    if (drop.kind == DropKind::none) drop.kind = DropKind::cantilever;
  }
  drops_[static_cast<std::size_t>(i)] = drop.mm;
  return drop;
}

BeadSweep::Laid DroopProbe::lay(const SweptBead& bead, BeadSweep& sweep, VoxelGrid& grid,
                                std::uint32_t tag, HeightMap& map) {
  // Knots every half millimetre at most, kept where the lowering bends by a fifth of a voxel.
  const int stride = std::max(1, static_cast<int>(std::lround(0.5 / std::max(step_mm_, 1e-9))));
  if (skip_ || drops_.empty())
    knots_.clear();
  else
    drop_knots(drops_, stride, 0.2 * voxel_, knots_);
  if (knots_.empty()) return sweep.lay(bead, grid, tag, map);
  // Pieces between knots, joined by square cuts (the pieces are collinear in XY); the first
  // and last keep the bead's own cuts. Each piece keeps the section, so the volume stays.
  SweptBead piece = bead;
  BeadSweep::Laid total;
  for (std::size_t k = 0; k + 1 < knots_.size(); ++k) {
    const DropKnot& k0 = knots_[k];
    const DropKnot& k1 = knots_[k + 1];
    piece.a_mm = bead.a_mm + k0.t * (bead.b_mm - bead.a_mm) - Vec3(0, 0, k0.mm);
    piece.b_mm = bead.a_mm + k1.t * (bead.b_mm - bead.a_mm) - Vec3(0, 0, k1.mm);
    piece.m0 = k == 0 ? bead.m0 : bead.d;
    piece.m1 = k + 2 == knots_.size() ? bead.m1 : bead.d;
    if (k > 0) piece.join_w_mm = 0;
    piece.cap_start = k == 0 && bead.cap_start;
    piece.cap_end = k + 2 == knots_.size() && bead.cap_end;
    const BeadSweep::Laid laid = sweep.lay(piece, grid, tag, map);
    total.overlap += laid.overlap;
    total.squeezed += laid.squeezed;
  }
  return total;
}

void DroopProbe::elephant_foot(SweptBead& bead, Feature feature, double area_mm2,
                               const HeightMap& map) const {
  if (!(model_.elephant_foot_mm > 0)) return;
  if (feature != Feature::outer_perimeter && feature != Feature::overhang_perimeter) return;
  const double bottom_a = bead.a_mm.z() - bead.h_mm, bottom_b = bead.b_mm.z() - bead.h_mm;
  if (bottom_a > 0.5 * voxel_ || bottom_b > 0.5 * voxel_) return;  // not on the bed
  // A side is open when most of the points just beyond it hold nothing of this layer yet.
  auto open = [&](double side) {
    int empty = 0;
    for (const double t : {0.25, 0.5, 0.75}) {
      const Vec3 q = bead.a_mm + t * (bead.b_mm - bead.a_mm);
      const Vec2 at = q.head<2>() + side * (0.5 * bead.w_mm + 1.5 * voxel_) * bead.n;
      if (map.top_mm(at.x(), at.y()) < 0.5 * bead.h_mm) ++empty;
    }
    return empty >= 2;
  };
  const FootSection f = detail::elephant_foot(area_mm2, bead.w_mm, bead.h_mm,
                                              model_.elephant_foot_mm, open(1.0), open(-1.0));
  if (f.w == bead.w_mm) return;
  const Vec3 shift(f.shift * bead.n.x(), f.shift * bead.n.y(), -(bead.h_mm - f.h));
  bead.a_mm += shift;
  bead.b_mm += shift;
  bead.w_mm = f.w;
  bead.h_mm = f.h;
}

}  // namespace printtwin::detail

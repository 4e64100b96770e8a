// Sag, droop and elephant's foot (see droop.hpp and docs/deposit.md).
#include "deposit/droop.hpp"

#include <algorithm>
#include <cmath>

namespace printtwin::detail {

namespace {
constexpr double kPi = 3.14159265358979323846;
}  // namespace

DroopModel DroopModel::from(const PrinterProfile& p) {
  DroopModel m;
  m.bridge_sag_mm = p.bridge_sag_mm;
  m.bridge_sag_span_mm = p.bridge_sag_span_mm;
  m.overhang_fall_mm = p.overhang_fall_mm;
  m.overhang_droop_mm = p.overhang_droop_mm;
  m.elephant_foot_mm = p.elephant_foot_mm;
  return m;
}

double DroopModel::bridge_sag(double span_mm, double x_mm) const {
  if (!(span_mm > 0) || !(bridge_sag_span_mm > 0)) return 0;
  const double x = std::clamp(x_mm, 0.0, span_mm);
  const double mid =
      bridge_sag_mm * (span_mm / bridge_sag_span_mm) * (span_mm / bridge_sag_span_mm);
  return mid * 4.0 * x * (span_mm - x) / (span_mm * span_mm);
}

double DroopModel::cantilever_droop(double e_mm) const {
  if (!(e_mm > 0) || !(overhang_fall_mm > 0)) return 0;
  const double r = std::min(e_mm / overhang_fall_mm, 1.0);
  return overhang_droop_mm * r * r;
}

Drop predict_drop(const DroopModel& m, double back_mm, double fwd_mm, double edge_mm,
                  double room_mm, double back_low_mm, double fwd_low_mm) {
  Drop d;
  const double room = std::max(room_mm, 0.0);
  // Held along the path at both ends: a bridge; held by the edge below: a cantilever. A bead
  // held both ways takes the smaller drop (the stiffer hold).
  double drop = kNoAnchor;
  if (back_mm < kNoAnchor && fwd_mm < kNoAnchor) {
    const double span = back_mm + fwd_mm;
    drop =
        back_low_mm + (fwd_low_mm - back_low_mm) * (back_mm / span) + m.bridge_sag(span, back_mm);
    d.kind = DropKind::bridge;
  }
  const bool falls = !(edge_mm <= m.overhang_fall_mm);
  const double droop = falls ? m.overhang_droop_mm : m.cantilever_droop(edge_mm);
  if (droop < drop) {
    drop = droop;
    d.kind = falls ? DropKind::fallen : DropKind::cantilever;
  }
  d.mm = std::min(drop, room);
  if (!(d.mm > 0)) d.mm = 0;
  return d;
}

void drop_knots(std::span<const double> drops, int stride, double tol_mm,
                std::vector<DropKnot>& out) {
  out.clear();
  const auto n = static_cast<int>(drops.size());
  if (n == 0 || std::none_of(drops.begin(), drops.end(), [](double v) { return v > 0; })) return;
  stride = std::max(stride, 1);
  // Candidates: both ends (the end samples' drops) and every stride-th sample boundary (the
  // mean of the two samples beside it).
  std::vector<DropKnot> all;
  all.push_back({0.0, drops.front()});
  for (int k = stride; k < n; k += stride)
    all.push_back({static_cast<double>(k) / n, 0.5 * (drops[static_cast<std::size_t>(k - 1)] +
                                                      drops[static_cast<std::size_t>(k)])});
  all.push_back({1.0, drops.back()});
  // Keep a knot when the line from the last kept knot to the next candidate misses it or any
  // candidate since the last kept knot (a smooth sag bends little from one candidate to the
  // next, but much over many).
  out.push_back(all.front());
  std::size_t kept = 0;
  for (std::size_t i = 1; i + 1 < all.size(); ++i) {
    const DropKnot& a = all[kept];
    const DropKnot& c = all[i + 1];
    for (std::size_t j = kept + 1; j <= i; ++j) {
      const double along = (all[j].t - a.t) / (c.t - a.t);
      if (std::abs(a.mm + along * (c.mm - a.mm) - all[j].mm) > tol_mm) {
        out.push_back(all[i]);
        kept = i;
        break;
      }
    }
  }
  out.push_back(all.back());
}

FootSection elephant_foot(double area_mm2, double w_mm, double h_mm, double foot_mm, bool open_left,
                          bool open_right) {
  FootSection s{w_mm, h_mm, 0.0};
  const int sides = (open_left ? 1 : 0) + (open_right ? 1 : 0);
  if (!(foot_mm > 0) || sides == 0 || !(area_mm2 > 0)) return s;
  s.w = w_mm + sides * foot_mm;
  s.shift = sides == 1 ? (open_left ? 0.5 * foot_mm : -0.5 * foot_mm) : 0.0;
  // Area of a w x h stadium: (w - h) h + pi h^2 / 4 = A, so k h^2 - w h + A = 0 with k = 1 - pi/4;
  // the smaller root is the height of the flatter section.
  const double k = 1.0 - kPi / 4.0;
  const double disc = s.w * s.w - 4.0 * k * area_mm2;
  if (disc < 0) return FootSection{w_mm, h_mm, 0.0};
  s.h = std::min(h_mm, (s.w - std::sqrt(disc)) / (2.0 * k));
  return s;
}

}  // namespace printtwin::detail

#pragma once
// Sag, droop and elephant's foot: where an unsupported bead ends up, as pure functions.
//
// A bead laid over air does not stay where the nozzle left it:
// - a bridge (held at both ends along its path) sags in a parabola (a strand under its own
//   weight, held in tension at its anchors): mid-span sag S(L) = bridge_sag_mm (L /
//   bridge_sag_span_mm)^2, at distance x from one anchor S(L) 4 x (L - x) / L^2;
// - a cantilever (held on one side only) droops toward the edge of the layer below that holds
//   it: D(e) = overhang_droop_mm (e / overhang_fall_mm)^2 at distance e beyond that edge; beyond
//   overhang_fall_mm it falls: onto whatever is below it when that is within
//   overhang_droop_mm, else it hangs overhang_droop_mm down as a dangling string;
// - a bead never sinks into what is beneath it (the room below caps every drop);
// - a first-layer bead pressed down against the bed spreads: each side facing air bulges by
//   elephant_foot_mm, the bead getting lower so that its cross-section keeps its area.
// docs/deposit.md ("Sag, droop and elephant's foot") gives the sources of the defaults.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "printtwin/geometry.hpp"
#include "printtwin/machine.hpp"

namespace printtwin::detail {

struct DroopModel {
  double bridge_sag_mm = 0;        ///< mid-span sag of a bridge of bridge_sag_span_mm
  double bridge_sag_span_mm = 50;  ///< reference span of bridge_sag_mm
  double overhang_fall_mm = 1.5;   ///< a cantilever this far beyond its edge falls
  double overhang_droop_mm = 0;    ///< droop at overhang_fall_mm; the most a fallen bead hangs
  double elephant_foot_mm = 0;     ///< bulge of a first-layer bead's open side

  [[nodiscard]] static DroopModel from(const PrinterProfile& p);
  /// Any sag or droop at all (elephant's foot apart).
  [[nodiscard]] bool deforms() const { return bridge_sag_mm > 0 || overhang_droop_mm > 0; }
  /// Longest span searched for a bridge's anchors.
  [[nodiscard]] double max_span_mm() const { return 2.0 * bridge_sag_span_mm; }
  /// Sag at distance x from one anchor of a bridge of span L (mm).
  [[nodiscard]] double bridge_sag(double span_mm, double x_mm) const;
  /// Droop of a cantilever e mm beyond its supporting edge (the fall value beyond the limit).
  [[nodiscard]] double cantilever_droop(double e_mm) const;
};

enum class DropKind : std::uint8_t { none, bridge, cantilever, fallen };

struct Drop {
  double mm = 0;  ///< how far the bead's sample is lowered
  DropKind kind = DropKind::none;
};

constexpr double kNoAnchor = std::numeric_limits<double>::infinity();

/// The drop of one unsupported bead sample. back_mm / fwd_mm: distance along the path to the
/// anchor behind / ahead (kNoAnchor: none within max_span_mm); edge_mm: distance to the nearest
/// edge of the layer below (kNoAnchor: none within overhang_fall_mm); room_mm: how far the
/// bead can go down before it touches the deposit or the bed.
/// back_low_mm / fwd_low_mm: how far those anchors themselves were lowered (a bridge between
/// sagging anchors hangs from them).
[[nodiscard]] Drop predict_drop(const DroopModel& m, double back_mm, double fwd_mm, double edge_mm,
                                double room_mm, double back_low_mm = 0, double fwd_low_mm = 0);

/// A point of the piecewise-linear lowering of one bead: t in [0, 1] from its start to its end.
struct DropKnot {
  double t = 0;
  double mm = 0;
};

/// The knots of the lowering through per-sample drops (sample i at t = (i + 0.5) / n): the
/// bead's ends, then every `stride` samples, keeping only the knots that the straight line
/// between their kept neighbours misses by more than `tol_mm`. Empty when nothing drops.
void drop_knots(std::span<const double> drops, int stride, double tol_mm,
                std::vector<DropKnot>& out);

/// A bead section after the elephant's foot: width, height and the move of its centre line
/// along the left normal (positive to the left).
struct FootSection {
  double w = 0, h = 0, shift = 0;
};

/// The first-layer bead of section area `area` (w x h stadium) whose open sides (facing air)
/// bulge by `foot_mm` each; the height shrinks so that the stadium keeps `area`.
[[nodiscard]] FootSection elephant_foot(double area_mm2, double w_mm, double h_mm, double foot_mm,
                                        bool open_left, bool open_right);

/// Distance (mm) from p along the unit direction dir to the first point, stepping `step_mm`,
/// where anchor(x, y) holds; kNoAnchor when none within max_mm.
template <class Anchor>
[[nodiscard]] double distance_to_anchor(const Vec2& p, const Vec2& dir, double step_mm,
                                        double max_mm, Anchor&& anchor) {
  for (double s = step_mm; s <= max_mm + 1e-9; s += step_mm)
    if (anchor(p.x() + s * dir.x(), p.y() + s * dir.y())) return s;
  return kNoAnchor;
}

/// Distance to the nearest anchor in the 8 directions around p (rotated with the bead's
/// direction d), up to max_mm.
template <class Anchor>
[[nodiscard]] double nearest_anchor(const Vec2& p, const Vec2& d, double step_mm, double max_mm,
                                    Anchor&& anchor) {
  constexpr double kR = 0.70710678118654752;
  const Vec2 n(-d.y(), d.x());
  const Vec2 dirs[8] = {d, -d, n, -n, kR * (d + n), kR * (d - n), kR * (n - d), -kR * (d + n)};
  double best = kNoAnchor;
  for (const Vec2& dir : dirs) {
    const double dist = distance_to_anchor(p, dir, step_mm, std::min(max_mm, best), anchor);
    best = std::min(best, dist);
  }
  return best;
}

}  // namespace printtwin::detail

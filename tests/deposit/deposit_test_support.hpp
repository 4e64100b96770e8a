#pragma once
// Builds Moves in code, the way the G-code interpreter would resolve them: each call is one
// G-code line, E is computed from the wanted bead width and height (stadium model).
#include <gtest/gtest.h>

#include <numbers>
#include <span>
#include <vector>

#include "printtwin/deposit.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin::test {

/// The deposit of `moves` at `voxel_mm` voxels (the default settings otherwise); a failure
/// fails the calling test and gives an empty deposit.
inline DepositResult deposit_at(std::span<const Move> moves, const PrinterProfile& profile,
                                double voxel_mm = 0.05) {
  DepositSettings ds;
  ds.voxel_mm = voxel_mm;
  auto d = deposit_moves(moves, profile, ds);
  EXPECT_TRUE(d.ok());
  return d.ok() ? std::move(*d) : DepositResult{};
}

/// Filament (mm) for a bead of width w, height h and length len.
inline double bead_e_mm(double w, double h, double len, const PrinterProfile& p) {
  const double area = (w - h) * h + std::numbers::pi * h * h / 4.0;
  return area * len / p.filament_area_mm2();
}

struct BeadWriter {
  explicit BeadWriter(const PrinterProfile& p) : profile(p) {}

  PrinterProfile profile;
  std::vector<Move> moves;
  Vec3 pos = Vec3::Zero();
  long line = 0;
  int layer = 0;
  Feature feature = Feature::perimeter;

  Move& push(const Vec3& to, double e, MoveKind kind) {
    Move m;
    m.start_mm = pos;
    m.end_mm = to;
    m.e_mm = e;
    m.feedrate_mm_s = kind == MoveKind::extrude ? 40 : 150;
    m.line = ++line;
    m.layer = layer;
    m.feature = feature;
    m.kind = kind;
    pos = to;
    moves.push_back(m);
    return moves.back();
  }
  void travel(const Vec3& to) { push(to, 0, MoveKind::travel); }
  /// A bead of width w and height h (times `flow`: the bead keeps its width, h scales).
  void extrude(const Vec3& to, double w, double h, double flow = 1.0) {
    push(to, flow * bead_e_mm(w, h, (to - pos).head<2>().norm(), profile), MoveKind::extrude);
  }
  void retract(const Vec3& to, double e) { push(to, e, MoveKind::retract); }
  void unretract(double e) { push(pos, e, MoveKind::unretract); }
};

}  // namespace printtwin::test

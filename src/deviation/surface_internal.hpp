#pragma once
// Internals of the outer surface's sub-voxel step (surface_beads.cpp), for the tests.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "printtwin/deviation.hpp"

namespace printtwin {
struct DepositSurface;
}

namespace printtwin::detail {

/// Signed distance from p to a bead (negative inside), and the point of the bead's core
/// closest to p: the bead's surface point nearest p is that core point plus h / 2 towards p.
/// The core is the level ribbon of width w - h along the move, h / 2 below the nozzle tip,
/// ended by level half-discs of radius (w - h) / 2 about its end points: the stadium section
/// swept along the move, capped round at both ends by the section revolved half a turn about
/// the vertical through the end (a nozzle's footprint; the deposit's round caps at path ends
/// and round joins at turns; inside the next bead where a path goes on straight).
double bead_closest(const SurfaceBead& bead, const Vec3& p, Vec3& core_point);

/// A bead's core made ready for many distance queries: bead_closest without recomputing the
/// core's frame.
struct BeadCore {
  Vec3 a = Vec3::Zero();       ///< the core's centre line starts here (h / 2 below the tip)
  Vec3 d = Vec3::Zero();       ///< and runs along d
  Vec3 across = Vec3::Zero();  ///< level unit vector across the move (zero for a vertical move)
  double len2 = 0, half = 0, r = 0;

  static BeadCore of(const SurfaceBead& b);
  /// As bead_closest.
  double closest(const Vec3& p, Vec3& core_point) const {
    const double t = len2 > 0 ? (p - a).dot(d) / len2 : 0.0;
    if (t > 0 && t < 1 && (across.x() != 0 || across.y() != 0)) {  // beside the move
      const Vec3 q0 = a + t * d;
      core_point = q0 + std::clamp((p - q0).dot(across), -half, half) * across;
    } else {  // past an end (or along a vertical move): the level disc about the centre line
      const Vec3 q0 = a + std::clamp(t, 0.0, 1.0) * d;
      const Vec3 g(p.x() - q0.x(), p.y() - q0.y(), 0.0);
      const double rho = g.norm();
      core_point = rho > half ? Vec3(q0 + (half / rho) * g) : Vec3(q0 + g);
    }
    return (p - core_point).norm() - r;
  }
};

/// The beads of G-code line `line` (beads sorted by line): [first, last).
std::pair<std::size_t, std::size_t> beads_of_line(std::span<const SurfaceBead> beads,
                                                  std::uint32_t line);

struct BeadDistance {
  double signed_mm = std::numeric_limits<double>::infinity();
  std::uint32_t bead = kNoBead;  ///< index into the beads
  Vec3 core_point = Vec3::Zero();
};
/// The nearest (least signed distance) of the beads of `line` and their neighbours along the
/// path (the bead before and after); bead = kNoBead when the line laid no bead.
BeadDistance nearest_bead(std::span<const SurfaceBead> beads, std::uint32_t line, const Vec3& p);

/// The beads by G-code line, for many look-ups: a table of each line's first bead (one entry
/// per line up to the last bead's), so a look-up reads two entries instead of searching, and
/// each bead's core (BeadCore).
class BeadIndex {
 public:
  explicit BeadIndex(std::span<const SurfaceBead> beads);
  /// The cores, by bead.
  [[nodiscard]] const std::vector<BeadCore>& cores() const { return cores_; }
  /// As beads_of_line.
  [[nodiscard]] std::pair<std::size_t, std::size_t> of_line(std::uint32_t line) const {
    if (line + std::size_t{1} >= first_.size()) return {beads_.size(), beads_.size()};
    return {first_[line], first_[line + 1]};
  }
  /// As nearest_bead.
  [[nodiscard]] BeadDistance nearest(std::uint32_t line, const Vec3& p) const;

 private:
  std::span<const SurfaceBead> beads_;
  std::vector<BeadCore> cores_;
  std::vector<std::uint32_t> first_;  ///< first bead of line l (beads_.size() when none after)
};

/// place_on_beads with the beads' index made by the caller (compute_deviation builds it once
/// for the placement, the outline sampling and the mesh -> deposit distances to the beads).
void place_on_beads(DepositSurface& surface, std::span<const SurfaceBead> beads,
                    const BeadIndex& index, double max_shift_mm);
/// sample_bead_outlines with the beads' index made by the caller (its cores).
void sample_bead_outlines(DepositSurface& surface, std::span<const SurfaceBead> beads,
                          const BeadIndex& index, std::span<const Vec3> face_points,
                          std::span<const double> face_area_mm2);

}  // namespace printtwin::detail

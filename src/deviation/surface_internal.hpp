#pragma once
// Internals of the outer surface's sub-voxel step (surface_beads.cpp), for the tests.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "deviation/outer_surface.hpp"
#include "printtwin/deviation.hpp"

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
  Vec3 dir = Vec3::Zero();     ///< unit vector along the move (zero for no move)
  double len2 = 0, half = 0, r = 0, len = 0;

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
  /// A lower bound of the squared distance from p to the core: the core lies within `half`
  /// of the centre line across the move (across and dir are orthogonal unit vectors, or
  /// zero) and within `half` past its ends along it (the level end discs), so p is at least
  /// its excess across and its excess along away. Rounding aside: the caller adds a margin.
  [[nodiscard]] double gap2(const Vec3& p) const {
    const Vec3 q = p - a;
    const double ga = std::max(0.0, std::abs(q.dot(across)) - half);
    const double u = q.dot(dir);
    const double gd = std::max({0.0, u - len - half, -u - half});
    return ga * ga + gd * gd;
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

/// A bead's core as boxes that bound its distance from below (to_bead_surface's pruning):
/// its heights [z_bot, z_top] (the centre line's, h / 2 below the nozzle tip), its radius
/// rt = h / 2 and its level box [x_lo, x_hi] x [y_lo, y_hi] (the centre line's grown by the
/// core's half width).
struct BeadBox {
  double z_top, z_bot, rt, x_lo, x_hi, y_lo, y_hi;
  static BeadBox of(const SurfaceBead& b) {
    const double rt = 0.5 * b.height_mm;
    const double half = 0.5 * std::max(0.0, static_cast<double>(b.width_mm) - b.height_mm);
    return {std::max(b.start_mm.z(), b.end_mm.z()) - rt,
            std::min(b.start_mm.z(), b.end_mm.z()) - rt,
            rt,
            std::min(b.start_mm.x(), b.end_mm.x()) - half,
            std::max(b.start_mm.x(), b.end_mm.x()) + half,
            std::min(b.start_mm.y(), b.end_mm.y()) - half,
            std::max(b.start_mm.y(), b.end_mm.y()) + half};
  }
};

/// The beads by G-code line, for many look-ups: a table of each line's first bead (one entry
/// per line up to the last bead's), so a look-up reads two entries instead of searching, and
/// each bead's core (BeadCore) and boxes (BeadBox).
class BeadIndex {
 public:
  explicit BeadIndex(std::span<const SurfaceBead> beads);
  /// The cores, by bead.
  [[nodiscard]] const std::vector<BeadCore>& cores() const { return cores_; }
  /// The boxes, by bead.
  [[nodiscard]] const std::vector<BeadBox>& boxes() const { return boxes_; }
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
  std::vector<BeadBox> boxes_;
  std::vector<std::uint32_t> first_;  ///< first bead of line l (beads_.size() when none after)
};

/// The unit normal of a bead's surface at p (a face's centre) for p's closest point on the
/// bead's core; the face's own normal where p lies on the core.
inline Vec3 bead_normal(const Vec3& p, const Vec3& core_point, const SurfaceFace& face) {
  Vec3 nrm = p - core_point;
  const double len = nrm.norm();
  if (len > 1e-12) {
    nrm /= len;
  } else {
    nrm = Vec3::Zero();
    nrm[face.axis] = face.side;
  }
  return nrm;
}

/// The faces' points as place_on_beads leaves them, computed where they are read rather than
/// stored (32 bytes a face): a face placed on its bead (placed[i] != 0, the bead face_bead[i])
/// has its centre moved onto the bead's surface, any other keeps its centre.
struct PlacedFaces {
  const DepositSurface& surface;
  std::span<const SurfaceBead> beads;
  const std::vector<BeadCore>& cores;
  std::span<const std::uint8_t> placed;

  /// Face i's point and the true surface it stands for: voxel^2 / (|n_x| + |n_y| + |n_z|)
  /// for the bead surface's normal n where placed, else voxel^2.
  [[nodiscard]] Vec3 point(std::size_t i, double* area_mm2 = nullptr) const {
    const SurfaceFace& face = surface.faces[i];
    Vec3 p = surface.face_center(face);
    const double v = surface.voxel_mm;
    if (placed[i] == 0) {
      if (area_mm2 != nullptr) *area_mm2 = v * v;
      return p;
    }
    const std::uint32_t k = surface.face_bead[i];
    Vec3 core;
    cores[k].closest(p, core);
    const Vec3 nrm = bead_normal(p, core, face);
    // A surface of normal n is voxelised into faces of total area |n_x| + |n_y| + |n_z|
    // times its own: each face stands for its area over that sum.
    if (area_mm2 != nullptr)
      *area_mm2 = v * v / (std::abs(nrm.x()) + std::abs(nrm.y()) + std::abs(nrm.z()));
    return core + (0.5 * beads[k].height_mm) * nrm;
  }
};

/// place_on_beads with the beads' index made by the caller (compute_deviation builds it once
/// for the placement, the outline sampling and the mesh -> deposit distances to the beads).
void place_on_beads(DepositSurface& surface, std::span<const SurfaceBead> beads,
                    const BeadIndex& index, double max_shift_mm);
/// sample_bead_outlines with the beads' index made by the caller (its cores).
void sample_bead_outlines(DepositSurface& surface, std::span<const SurfaceBead> beads,
                          const BeadIndex& index, std::span<const std::uint8_t> placed);

}  // namespace printtwin::detail

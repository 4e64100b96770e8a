#pragma once
// The bead model: what one extruding move lays down, before it becomes voxels.
//
// The nozzle tip runs from A to B; the bead's top follows the tip, its height h is the gap to
// what lies beneath (read from the height map), its cross-section is a stadium of width w
// and height h (a (w-h) x h rectangle with half-discs of diameter h on its sides, area
// (w-h) h + pi h^2 / 4). Along the path the bead is cut by vertical planes: the mitre
// (bisector) plane at a joint with the previous/next move of the same continuous path, a
// plane square to the move at a path end or at a sharp turn. Mitred sweeps of a laterally
// symmetric section have exactly area x length volume and tile the path without gaps or
// double counting.
#include <vector>

#include "deposit/height_map.hpp"
#include "printtwin/geometry.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin::detail {

constexpr double kPi = 3.14159265358979323846;
constexpr double kJoinTolMm = 1e-3;  // path continuity: end of one move = start of next
// Joints of a continuous path turning by up to 60 deg are mitred (the mitre's outer tip lies
// within about a voxel column of the round join's arc); sharper ones are cut square and
// joined round (BeadSweep's round join).
constexpr double kMitreMinCos = 0.5;

/// Nominal layer height: the slicer's `;HEIGHT:` when given, else the Z step from the
/// previous layer's extrusions to this move (from the bed for the first layer, and for the
/// start code's lines before it). Sloped extrusions (vase-mode spirals, where every move has
/// its own Z) keep the nominal height of the last flat layer.
class LayerTracker {
 public:
  double nominal_mm(const Move& m, double nozzle_mm, double voxel_mm);

 private:
  static double clamp(double h, double nozzle_mm, double voxel_mm);
  bool have_layer_ = false;
  bool have_nominal_ = false;
  int layer_ = 0;
  double layer_z_ = 0;
  double prev_z_ = 0;
  double nominal_ = 0;
};

/// An extruding move with material (the moves the deposit lays or counts).
inline bool is_bead(const Move& m) { return m.kind == MoveKind::extrude && m.e_mm > 0; }
/// Support or support interface (removed after printing).
inline bool is_support(Feature f) {
  return f == Feature::support || f == Feature::support_interface;
}
/// Whether a bead of feature `f` may form the part's side surface: an outer or overhang
/// perimeter, or a bead whose feature the G-code does not say (SweptBead::keeps_sides).
inline bool may_form_sides(Feature f) {
  return f == Feature::outer_perimeter || f == Feature::overhang_perimeter || f == Feature::unknown;
}
/// How far (voxel layers) the squeezed material of a bead of feature `f` may rise above its
/// tip (SweptBead::rise_voxels): not at all for one that may form the part's sides, a voxel
/// for top solid infill (the part's top surface), else up to the squeeze's reach.
inline int rise_voxels(Feature f) {
  if (may_form_sides(f)) return 0;
  return f == Feature::top_solid_infill ? 2 : -1;
}

/// A bead waiting for the next move, which decides its end cut.
struct PendingBead {
  Move move;
  double nominal_h_mm = 0;
  bool continues_path = false;          // joined to the previous bead
  bool round_start = false;             // continues it with a square cut and a round join
  double join_h_mm = 0, join_w_mm = 0;  // the previous bead's section (for the round join)
  Vec2 join_d = Vec2::UnitX();          // and its direction
  Vec2 m0 = Vec2::Zero();               // cut normal at the start (xy, unit)
};

/// The section of one bead.
struct BeadSection {
  double h_mm = 0;  ///< height (tip to bottom)
  double w_mm = 0;  ///< width
};

/// The area of section `s`: the stadium (w - h) h + pi h^2 / 4.
inline double section_area_mm2(const BeadSection& s) {
  return (s.w_mm - s.h_mm) * s.h_mm + 0.25 * kPi * s.h_mm * s.h_mm;
}

/// The section of area `area_mm2` at height `h_mm`: the stadium, or a round strand when the
/// area is too small for a full-height bead.
BeadSection section_of(double area_mm2, double h_mm);

/// The length of bead of section `s` whose volume one round end cap holds: the section
/// revolved half a turn about the vertical through its centre.
double cap_length_mm(const BeadSection& s);

/// The section of a bead of length `len_mm` with `caps` (0-2) round end caps, all made of the
/// material of a bead of area `area_mm2` cut square: the section shrinks to pay for the caps
/// (to no less than half its area).
BeadSection capped_section(double area_mm2, double h_mm, double len_mm, int caps);

/// The squeeze's bound on a flattened bead: a bead laid in a gap thinner than its layer (over
/// earlier plastic that rose) spreads sideways, but its width grows by no more than `widen_mm`
/// over the bead it would be at its nominal height (`nominal_w_mm` wide). Narrows `s` to that
/// width at its height and returns the material it leaves out, per mm of the bead's path
/// (`len_mm` long, `caps` round end caps paid from its section): the squeeze places it
/// (SweptBead::overflow_mm2). 0 when `s` is within the bound.
double bound_flattened(BeadSection& s, double nominal_w_mm, double widen_mm, double len_mm,
                       int caps);

/// Which side of the bead from `a` to `b` (lateral normal `n`) is the part's inside, read from
/// the tops of the columns just beyond its edges (`half_w_mm` from its line) at a quarter, half
/// and three quarters of its length: +1 (+n) or -1 where that side's plastic stands higher by a
/// voxel or more in all, 0 when neither does.
int inside_side(const HeightMap& map, const Vec3& a, const Vec3& b, const Vec2& n, double half_w_mm,
                double voxel_mm);

/// The section of the bead `pb` with cross-section area `area_mm2` over the deposit in `map`,
/// sampled `samples` times along its centre line (`gaps`: scratch). Height: the gap between the tip
/// and the surface beneath the centre line. A column whose top is within half a layer of the tip
/// holds this layer's neighbours (or a partly covered corner) and says nothing about what is
/// beneath, unless its top voxel was laid by an earlier layer (the first turn of a vase-mode
/// spiral); gaps over 1.5 layers are air. The median of the remaining gaps is the bead height (the
/// nominal layer height when none remain, or when they agree with it to within the voxel
/// quantisation). Width: the stadium of that height and area; a round strand when the area is too
/// small. `caps` (0-2): the round end caps the bead pays for (capped_section).
BeadSection bead_section(const PendingBead& pb, double area_mm2, int samples, int caps,
                         const HeightMap& map, double voxel_mm, std::vector<double>& gaps);

}  // namespace printtwin::detail

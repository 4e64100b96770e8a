#pragma once
// Sag and droop of the beads the deposit lays: per unsupported bead sample, the anchors and
// the room beneath read from the height map, turned into a drop by the model of droop.hpp;
// then the bead is laid lowered along that drop profile. The elephant's foot of the first
// layer's outer beads. docs/deposit.md, "Sag, droop and elephant's foot".
#include <cstdint>
#include <span>
#include <vector>

#include "deposit/droop.hpp"
#include "deposit/height_map.hpp"
#include "deposit/sweep.hpp"
#include "printtwin/toolpath.hpp"

namespace printtwin::detail {

class DroopProbe {
 public:
  DroopProbe(const DroopModel& model, double voxel_mm) : model_(model), voxel_(voxel_mm) {}

  [[nodiscard]] const DroopModel& model() const { return model_; }
  /// Starts a bead (tip a -> b, `samples` samples, section h x w) before it is laid.
  void begin_bead(const Move& mv, const Vec3& a, const Vec3& b, int samples, double h, double w,
                  const HeightMap& map);
  /// The drop of unsupported sample i of the current bead (recorded for lay()).
  Drop sample(int i);
  /// Lays the current bead lowered by its samples' drops (as one bead when nothing drops).
  /// Lays the bead (lowered piece by piece where it droops) and returns what the sweep laid.
  BeadSweep::Laid lay(const SweptBead& bead, BeadSweep& sweep, VoxelGrid& grid, std::uint32_t tag,
                      HeightMap& map);

  /// The elephant's foot: a first-layer outer bead on the bed widens on its sides that face
  /// air and gets lower, keeping its section's area. Changes `bead` in place.
  void elephant_foot(SweptBead& bead, Feature feature, double area_mm2, const HeightMap& map) const;

 private:
  /// Earlier-layer material within 2 layers of the bead's bottom (an edge that holds it),
  /// also where a bead of this layer has covered it since (HeightMap::rows_before_top_layer).
  [[nodiscard]] bool holds(double x, double y, double bottom) const;
  /// Top (mm) of the earlier layers' material in the column under (x, y), the bed when none.
  [[nodiscard]] double earlier_top(double x, double y) const;
  /// An anchor along the path: material that holds, or a bead of this layer (lowered or not:
  /// `low` gets how far it hangs below `top`).
  [[nodiscard]] bool anchors(double x, double y, double bottom, double top, double& low) const;
  /// How far the anchor first reached at distance `s` along `dir` from `p` hangs below the
  /// tip: the least over a bead width past it (the first column reached is the rounded flank
  /// or end cap of the bead that holds it; its crest lies within a bead width).
  [[nodiscard]] double anchor_low(const Vec2& p, const Vec2& dir, double s, double bottom,
                                  double top, double low) const;

  /// Support of an earlier layer whose top is within 2 layers of the bead's bottom: a support
  /// line the bead rests on across the support's Z gap; `gap` gets how far below the bottom.
  [[nodiscard]] bool rests(double x, double y, double bottom, double& gap) const;
  /// Distance along the unit `dir` to the first support line the bead rests on (kNoAnchor:
  /// none within max_mm); `gap` gets how far below the bead's bottom the line's crest lies.
  [[nodiscard]] double support_line(const Vec2& p, const Vec2& dir, double bottom, double max_mm,
                                    double& gap) const;
  /// Lowers `drop` to what the support beneath holds: a bead within the fall limit of a
  /// support line falls at most onto its top; one between support lines on both sides across
  /// its path is a bridge from line to line. `room`: how far it can go down.
  void rest_on_support(const Vec2& p, double bottom, double room, Drop& drop) const;

  DroopModel model_;
  double voxel_;
  const HeightMap* map_ = nullptr;
  Move mv_;
  Vec3 a_ = Vec3::Zero(), b_ = Vec3::Zero();
  Vec2 d_ = Vec2::UnitX(), n_ = Vec2::UnitY();
  int samples_ = 0;
  double h_ = 0, w_ = 0, step_mm_ = 0;
  bool support_laid_ = false;  // a support bead was laid: beads may rest on support lines
  bool skip_ = false;          // sparse infill: its crossings of the cells below are not deformed
  std::vector<double> drops_;
  // Anchors along the path found for an earlier sample of this bead (distance, sample).
  double fwd_ = kNoAnchor, back_ = kNoAnchor;
  double fwd_low_ = 0, back_low_ = 0;  // how far those anchors hang below the tip
  int fwd_at_ = -1, back_at_ = -1;
  std::vector<DropKnot> knots_;  // scratch
  double oz_ = 0;                // the map's bottom (mm)
};

}  // namespace printtwin::detail

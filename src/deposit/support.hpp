#pragma once
// Extrusion into air: the support test along each bead and the unsupported stretches it
// finds, grouped into findings.
//
// Along each bead, once per voxel length, the height map is sampled across the bead's width
// (at voxel spacing, at least 3 points). A point is supported when the deposit (or bed) top
// beneath it is within h/2 of the bead's bottom; a sample is supported when at least
// `support_fraction` of its points are. Consecutive unsupported samples along one continuous
// path form a stretch: a bridge when supported material comes before and after it on the
// path, otherwise a cantilever.
#include <vector>

#include "deposit/droop_probe.hpp"
#include "deposit/height_map.hpp"
#include "printtwin/deposit.hpp"

namespace printtwin::detail {

class SupportTracker {
 public:
  SupportTracker(double support_fraction, double min_unsupported_mm, double voxel_mm)
      : support_fraction_(support_fraction),
        min_unsupported_mm_(min_unsupported_mm),
        voxel_(voxel_mm) {}

  /// Tests the bead `mv` (tip a -> b, `samples` samples along it, section h x w, lateral
  /// normal n) against the deposit in `map` before the bead is laid. `continues_path`: the
  /// bead joins the previous one (a stretch may run on across the joint).
  /// `droop` (optional, begun on this bead) predicts how far each unsupported sample drops;
  /// the stretches keep the largest drop.
  void check_bead(const Move& mv, const Vec3& a, const Vec3& b, const Vec2& n, int samples,
                  double h, double w, bool continues_path, const HeightMap& map,
                  DroopProbe* droop = nullptr);
  /// Ends the open stretch, if any; `end_supported`: supported material follows it.
  void close_stretch(bool end_supported);

  [[nodiscard]] double unsupported_mm() const { return unsupported_mm_; }
  /// The stretches of at least min_unsupported_mm, in the order they were laid.
  std::vector<UnsupportedStretch> take_stretches() { return std::move(stretches_); }

 private:
  void sample(const Move& mv, const Vec3& a, const Vec3& b, int i, int samples, double step_mm,
              bool supported, const Drop& drop);

  double support_fraction_, min_unsupported_mm_, voxel_;
  bool path_has_support_ = false;  // along the current continuous path
  bool active_ = false;            // a stretch is open
  UnsupportedStretch open_;
  std::vector<UnsupportedStretch> stretches_;
  double unsupported_mm_ = 0;
  std::vector<double> offsets_;  // scratch: across-bead sample offsets (voxel units)
};

/// One finding per region: stretches of the same layer and kind whose boxes come within
/// 1 mm of each other (one overhang, one bridged span) are merged.
std::vector<Finding> make_findings(const std::vector<UnsupportedStretch>& stretches);

}  // namespace printtwin::detail

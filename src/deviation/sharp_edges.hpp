#pragma once
// The design's sharp edges, for the layer-line figures: those measure walls as the analytic
// model of a layer line defines them (a straight wall face), so points near an edge of the
// design, where a nozzle rounds the plastic, are left out.
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "printtwin/mesh.hpp"

namespace printtwin {
class DeviationTarget;
}

namespace printtwin::detail {

/// The margin round the design's sharp edges (faces turning by more than kSharpDeg) that the
/// layer-line figures leave out: a nozzle rounds the plastic at a vertical edge with the
/// bead's half-width (0.225 mm for a 0.45 mm bead), where the straight wall's analytic value
/// does not hold.
constexpr double kWallEdgeMarginMm = 0.3;
constexpr double kSharpDeg = 30.0;

/// The edges of a mesh whose two faces turn by more than `min_angle_deg`, and the open or
/// non-manifold ones, with a hash grid for "is p within `margin_mm` of one of them".
class SharpEdges {
 public:
  SharpEdges(const Mesh& mesh, double min_angle_deg, double margin_mm);
  /// Whether p lies within the margin of a sharp edge.
  [[nodiscard]] bool near(const Vec3& p) const;
  [[nodiscard]] std::size_t size() const { return a_.size(); }

 private:
  [[nodiscard]] std::uint64_t key(const Vec3& p) const;
  double margin_ = 0, cell_ = 1;
  std::vector<Vec3> a_, b_;  ///< the edges' end points
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells_;
};

/// The sharp edges (kSharpDeg, kWallEdgeMarginMm) of a DeviationTarget's mesh, own frame: found
/// once with the target (beside the deposit in verify), not per deviation.
struct DeviationTargetAccess {
  static const SharpEdges& sharp_edges(const DeviationTarget& target);
};

}  // namespace printtwin::detail

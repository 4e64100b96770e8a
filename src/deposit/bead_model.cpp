// The bead model (see bead_model.hpp).
#include "deposit/bead_model.hpp"

#include <algorithm>
#include <cmath>

#include "printtwin/deposit.hpp"

namespace printtwin {

double stadium_width_mm(double area_mm2, double height_mm) {
  if (!(height_mm > 0)) return 0;
  return area_mm2 / height_mm + (1.0 - detail::kPi / 4.0) * height_mm;
}

namespace detail {

double LayerTracker::nominal_mm(const Move& m, double nozzle_mm, double voxel_mm) {
  if (m.height_hint_mm > 0) return clamp(m.height_hint_mm, nozzle_mm, voxel_mm);
  const double z = m.end_mm.z();
  const bool sloped = std::abs(m.end_mm.z() - m.start_mm.z()) > 1e-6;
  if (sloped && have_nominal_) return nominal_;
  if (!have_layer_ || m.layer != layer_ || z > layer_z_ + 1e-6) {
    if (have_layer_ && z > layer_z_ + 1e-6) prev_z_ = layer_z_;
    have_layer_ = true;
    layer_ = m.layer;
    layer_z_ = z;
  }
  double h = z - prev_z_;
  if (!(h > 0.25 * voxel_mm)) h = 0.5 * nozzle_mm;
  nominal_ = clamp(h, nozzle_mm, voxel_mm);
  have_nominal_ = true;
  return nominal_;
}

double LayerTracker::clamp(double h, double nozzle_mm, double voxel_mm) {
  return std::clamp(h, std::min(voxel_mm, 0.5 * nozzle_mm), 2.0 * nozzle_mm);
}

BeadSection bead_section(const PendingBead& pb, double area_mm2, int samples, const HeightMap& map,
                         double voxel_mm, std::vector<double>& gaps) {
  const Move& mv = pb.move;
  const Vec3 a = mv.start_mm;
  const Vec3 b = mv.end_mm;
  const double nominal = pb.nominal_h_mm;
  gaps.clear();
  for (int i = 0; i < samples; ++i) {
    const Vec3 q = a + ((i + 0.5) / samples) * (b - a);
    const double t = map.top_mm(q.x(), q.y());
    const double gap = q.z() - t;
    if (gap > 1.5 * nominal + 0.5 * voxel_mm || gap < 0.5 * voxel_mm) continue;
    if (gap < 0.5 * nominal) {  // the layer that laid the column's top voxel
      const auto top_of = map.top_layer_at(q.x(), q.y());
      if (!top_of || *top_of >= mv.layer) continue;
    }
    gaps.push_back(gap);
  }
  BeadSection s;
  s.h_mm = nominal;
  if (!gaps.empty()) {
    auto mid = gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2);
    std::nth_element(gaps.begin(), mid, gaps.end());
    if (std::abs(*mid - nominal) > voxel_mm + 1e-9) s.h_mm = *mid;
  }
  s.w_mm = stadium_width_mm(area_mm2, s.h_mm);
  if (s.w_mm < s.h_mm) {  // too little material for a full-height bead: a round strand
    s.h_mm = std::sqrt(4.0 * area_mm2 / kPi);
    s.w_mm = s.h_mm;
  }
  return s;
}

}  // namespace detail
}  // namespace printtwin

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
  // The start code's purge and calibration lines (before the first layer) lie on the bed,
  // whatever height an earlier line was drawn at (Bambu's X1 draws its purge at Z 0.2, then
  // its flow calibration line at Z 0.3): the gap to the bed is their height. The first layer
  // then steps from the bed too.
  const bool start_code = m.layer < 0 && m.feature == Feature::custom;
  if (!have_layer_ || m.layer != layer_ || z > layer_z_ + 1e-6) {
    if (have_layer_ && z > layer_z_ + 1e-6) prev_z_ = layer_z_;
    if (have_layer_ && layer_ < 0 && m.layer >= 0) prev_z_ = 0;
    have_layer_ = true;
    layer_ = m.layer;
    layer_z_ = z;
  }
  double h = start_code ? z : z - prev_z_;
  if (!(h > 0.25 * voxel_mm)) h = 0.5 * nozzle_mm;
  nominal_ = clamp(h, nozzle_mm, voxel_mm);
  have_nominal_ = true;
  return nominal_;
}

double LayerTracker::clamp(double h, double nozzle_mm, double voxel_mm) {
  return std::clamp(h, std::min(voxel_mm, 0.5 * nozzle_mm), 2.0 * nozzle_mm);
}

BeadSection bead_section(const PendingBead& pb, double area_mm2, int samples, int caps,
                         const HeightMap& map, double voxel_mm, std::vector<double>& gaps) {
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
  return capped_section(area_mm2, s.h_mm, pb.move.xy_length_mm(), caps);
}

BeadSection section_of(double area_mm2, double h_mm) {
  BeadSection s{h_mm, stadium_width_mm(area_mm2, h_mm)};
  if (s.w_mm < s.h_mm) {  // too little material for a full-height bead: a round strand
    s.h_mm = std::sqrt(4.0 * area_mm2 / kPi);
    s.w_mm = s.h_mm;
  }
  return s;
}

double cap_length_mm(const BeadSection& s) {
  // Half a turn of the stadium (flat half-width f, radius r) about its centre line's
  // vertical: (pi / 2) * integral of (f + sqrt(r^2 - z^2))^2 dz over [-r, r].
  const double f = 0.5 * (s.w_mm - s.h_mm), r = 0.5 * s.h_mm;
  const double volume = 0.5 * kPi * (2.0 * r * f * f + kPi * f * r * r + 4.0 / 3.0 * r * r * r);
  const double area = 2.0 * f * s.h_mm + kPi * r * r;
  return area > 0 ? volume / area : 0.0;
}

BeadSection capped_section(double area_mm2, double h_mm, double len_mm, int caps) {
  BeadSection s = section_of(area_mm2, h_mm);
  if (caps == 0) return s;
  // The caps' material comes out of the bead: area' (len + caps * cap_length(area')) =
  // area * len. The cap length changes little with the area: two rounds converge; a bead too
  // short to pay for its caps keeps at least half its section.
  for (int round = 0; round < 2; ++round) {
    const double a = area_mm2 * len_mm / (len_mm + caps * cap_length_mm(s));
    s = section_of(std::max(a, 0.5 * area_mm2), h_mm);
  }
  return s;
}

double bound_flattened(BeadSection& s, double nominal_w_mm, double widen_mm, double len_mm,
                       int caps) {
  const double w_max = nominal_w_mm + widen_mm;
  if (!(s.w_mm > w_max) || !(len_mm > 0)) return 0;
  // The material of the body and the caps, before and after (capped_section's balance).
  const double before = section_area_mm2(s) * (len_mm + caps * cap_length_mm(s));
  s.w_mm = w_max;
  const double after = section_area_mm2(s) * (len_mm + caps * cap_length_mm(s));
  return std::max(0.0, before - after) / len_mm;
}

int inside_side(const HeightMap& map, const Vec3& a, const Vec3& b, const Vec2& n, double half_w_mm,
                double voxel_mm) {
  double higher = 0;  // how much higher the +n side's columns stand, summed
  for (const double t : {0.25, 0.5, 0.75}) {
    const Vec2 q = (a + t * (b - a)).head<2>();
    const Vec2 pos = q + (half_w_mm + 1.5 * voxel_mm) * n,
               neg = q - (half_w_mm + 1.5 * voxel_mm) * n;
    higher += map.top_mm(pos.x(), pos.y()) - map.top_mm(neg.x(), neg.y());
  }
  if (higher >= voxel_mm - 1e-9) return 1;
  if (higher <= -voxel_mm + 1e-9) return -1;
  return 0;
}

}  // namespace detail
}  // namespace printtwin

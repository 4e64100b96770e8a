// Step 4 of the outer surface: sub-voxel placement. Each face centre moves onto the true
// surface of the bead that laid its voxel (the stadium bead of the deposit's model), and each
// face gets the area of true surface it stands for.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "deviation/outer_surface.hpp"
#include "deviation/surface_internal.hpp"
#include "printtwin/deposit.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

std::vector<SurfaceBead> surface_beads(std::span<const Move> moves, const PrinterProfile& profile) {
  std::vector<SurfaceBead> beads;
  const double filament_area = profile.filament_area_mm2();
  // The nominal layer height as the deposit takes it: the slicer's `;HEIGHT:`, else the Z
  // step from the previous layer's extrusions; sloped moves (spirals) keep the last one.
  double layer_z = std::numeric_limits<double>::quiet_NaN(), prev_z = 0,
         nominal = 0.5 * profile.nozzle_diameter_mm;
  for (const Move& m : moves) {
    if (m.kind != MoveKind::extrude || !(m.e_mm > 0) || is_auxiliary_feature(m.feature)) continue;
    const double len = m.xy_length_mm();
    if (!(len > 1e-9)) continue;
    const double z = m.end_mm.z();
    const bool sloped = std::abs(m.end_mm.z() - m.start_mm.z()) > 1e-6;
    if (!sloped && !(std::abs(z - layer_z) <= 1e-6)) {  // a new layer
      prev_z = std::isnan(layer_z) ? 0.0 : z > layer_z ? layer_z : std::max(0.0, z - nominal);
      layer_z = z;
      if (z - prev_z > 1e-3) nominal = z - prev_z;
    }
    const double h = m.height_hint_mm > 0 ? static_cast<double>(m.height_hint_mm) : nominal;
    const double area = m.e_mm * filament_area / len;
    double w = stadium_width_mm(area, h), hh = h;
    if (w < h) hh = w = std::sqrt(4.0 * area / 3.14159265358979323846);  // a round strand
    beads.push_back({m.start_mm, m.end_mm, static_cast<float>(w), static_cast<float>(hh),
                     static_cast<std::uint32_t>(std::max<long>(m.line, 0))});
  }
  // In line order (the moves' order; arcs give several beads of one line).
  std::stable_sort(beads.begin(), beads.end(),
                   [](const SurfaceBead& a, const SurfaceBead& b) { return a.line < b.line; });
  return beads;
}

namespace detail {

BeadCore BeadCore::of(const SurfaceBead& b) {
  // The bead is its core (a level ribbon of width w - h along the move, h / 2 below the nozzle
  // tip) grown by a ball of radius h / 2: the stadium section swept along the move.
  BeadCore c;
  c.r = 0.5 * b.height_mm;
  c.a = b.start_mm - Vec3(0, 0, c.r);
  const Vec3 e = b.end_mm - Vec3(0, 0, c.r);
  c.d = e - c.a;
  c.len2 = c.d.squaredNorm();
  Vec3 across(-c.d.y(), c.d.x(), 0.0);
  const double n = across.norm();
  c.half = 0.5 * std::max(0.0, static_cast<double>(b.width_mm) - b.height_mm);
  if (n > 0) c.across = across / n;
  c.len = std::sqrt(c.len2);
  if (c.len > 0) c.dir = c.d / c.len;
  return c;
}

double bead_closest(const SurfaceBead& b, const Vec3& p, Vec3& core_point) {
  return BeadCore::of(b).closest(p, core_point);
}

std::pair<std::size_t, std::size_t> beads_of_line(std::span<const SurfaceBead> beads,
                                                  std::uint32_t line) {
  const auto lo =
      std::lower_bound(beads.begin(), beads.end(), line,
                       [](const SurfaceBead& b, std::uint32_t l) { return b.line < l; });
  auto hi = lo;
  while (hi != beads.end() && hi->line == line) ++hi;
  return {static_cast<std::size_t>(lo - beads.begin()),
          static_cast<std::size_t>(hi - beads.begin())};
}

namespace {
/// The nearest of beads [lo, hi) of a line and their neighbours along the path (the moves
/// before and after): the least signed distance, the lowest index on a tie (as a scan in
/// index order). The line's beads go first; a neighbour that `clear(k, best)` shows to be
/// farther than the best so far is not computed.
template <class Closest, class Clear>
BeadDistance nearest_in(std::size_t n_beads, std::size_t lo, std::size_t hi, const Vec3& p,
                        const Closest& closest, const Clear& clear) {
  BeadDistance best;
  if (lo == hi) return best;
  const auto offer = [&](std::size_t k) {
    Vec3 c;
    const double sd = closest(k, p, c);
    if (sd < best.signed_mm || (best.bead != kNoBead && sd == best.signed_mm && k < best.bead)) {
      best.signed_mm = sd;
      best.bead = static_cast<std::uint32_t>(k);
      best.core_point = c;
    }
  };
  for (std::size_t k = lo; k < hi; ++k) offer(k);
  if (lo > 0 && !clear(lo - 1, best.signed_mm)) offer(lo - 1);
  if (hi < n_beads && !clear(hi, best.signed_mm)) offer(hi);
  return best;
}
}  // namespace

BeadDistance nearest_bead(std::span<const SurfaceBead> beads, std::uint32_t line, const Vec3& p) {
  if (beads.empty()) return {};
  const auto [lo, hi] = beads_of_line(beads, line);
  return nearest_in(
      beads.size(), lo, hi, p,
      [&](std::size_t k, const Vec3& q, Vec3& c) { return bead_closest(beads[k], q, c); },
      [](std::size_t, double) { return false; });
}

BeadIndex::BeadIndex(std::span<const SurfaceBead> beads) : beads_(beads) {
  if (beads.empty()) return;
  cores_.resize(beads.size());
  boxes_.resize(beads.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, beads.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) {
                        cores_[k] = BeadCore::of(beads[k]);
                        boxes_[k] = BeadBox::of(beads[k]);
                      }
                    });
  first_.assign(static_cast<std::size_t>(beads.back().line) + 2,
                static_cast<std::uint32_t>(beads.size()));
  // Beads are sorted by line: line l's first bead is the first with line >= l.
  std::size_t l = 0;
  for (std::size_t k = 0; k < beads.size(); ++k)
    for (; l <= beads[k].line; ++l) first_[l] = static_cast<std::uint32_t>(k);
}

BeadDistance BeadIndex::nearest(std::uint32_t line, const Vec3& p) const {
  const auto [lo, hi] = of_line(line);
  // A neighbour is no nearer than its core's gap (BeadCore::gap2) less its radius: it is
  // skipped when that exceeds the best by far more than the rounding of either (1e-9 of
  // the coordinates' size), so the result is the one of computing every bead.
  const double margin = 1e-9 * (1 + p.cwiseAbs().sum());
  return nearest_in(
      beads_.size(), lo, hi, p,
      [&](std::size_t k, const Vec3& q, Vec3& c) { return cores_[k].closest(q, c); },
      [&](std::size_t k, double best) {
        const BeadCore& c = cores_[k];
        const double lim = best + c.r + margin + 1e-9 * c.a.cwiseAbs().sum();
        return !(lim > 0) || c.gap2(p) > lim * lim;
      });
}

}  // namespace detail

namespace {
/// Whether a face that could not be placed lies in a pit of the voxelisation: the empty voxel
/// it faces has its centre inside the bead, less than half a voxel's diagonal deep. A voxel
/// is laid when its jittered sample point falls inside a bead (docs/deposit.md), so a voxel the
/// bead's outline only partly covers stays empty with the chance of the part uncovered; the
/// bead's outline (sample_bead_outlines) is the surface there, and the pit's faces are none of
/// it. Such a face belongs to the bead (it gives way to the outline like a placed face).
bool in_voxel_pit(const detail::BeadCore& core, const SurfaceFace& face, const Vec3& centre,
                  double v) {
  Vec3 empty = centre;
  empty[face.axis] += 0.5 * v * face.side;
  Vec3 c;
  const double sd = core.closest(empty, c);
  return sd < 0 && sd > -0.5 * std::sqrt(3.0) * v;
}
}  // namespace

void place_on_beads(DepositSurface& s, std::span<const SurfaceBead> beads, double max_shift_mm) {
  const detail::BeadIndex index(beads);
  detail::place_on_beads(s, beads, index, max_shift_mm);
}

void detail::place_on_beads(DepositSurface& s, std::span<const SurfaceBead> beads,
                            const BeadIndex& index, double max_shift_mm) {
  const double v = s.voxel_mm;
  const std::size_t n = s.faces.size();
  // Per face its bead and whether its point moved onto it; the points themselves are not
  // stored (PlacedFaces computes them from these). Without initial values: each element is
  // written once, below, in parallel.
  const auto placed = std::make_unique_for_overwrite<std::uint8_t[]>(n);
  s.face_bead.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const SurfaceFace& face = s.faces[i];
                        const Vec3 p = s.face_center(face);
                        s.face_bead[i] = kNoBead;
                        placed[i] = 0;
                        const detail::BeadDistance near = index.nearest(s.face_tags[i].line, p);
                        if (near.bead == kNoBead) continue;
                        // The face must face the way the bead's surface does: a face on the far
                        // side of a bead's core (a thin wall's back) belongs to another surface.
                        if (!(std::abs(near.signed_mm) <= max_shift_mm) ||
                            bead_normal(p, near.core_point, face)[face.axis] * face.side <= 0) {
                          if (in_voxel_pit(index.cores()[near.bead], face, p, v))
                            s.face_bead[i] = near.bead;
                          continue;
                        }
                        s.face_bead[i] = near.bead;
                        placed[i] = 1;
                      }
                    });
  sample_bead_outlines(s, beads, index, std::span<const std::uint8_t>(placed.get(), n));
}

}  // namespace printtwin

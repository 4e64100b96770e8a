// From layer outlines to toolpaths: perimeters by inward offsets, thin walls and gap fill as
// single lines of variable width, top / bottom / bridge / solid / sparse regions from the
// layers above and below, infill lines, skirt and brim. All in integer microns (Clipper).
#include <algorithm>
#include <cmath>
#include <numbers>

#include <tbb/parallel_for.h>

#include "slice/slice_internal.hpp"

namespace printtwin::slice_detail {

using namespace ClipperLib;

namespace {

struct LayerWidths {
  double ext = 0, per = 0, inf = 0, solid = 0, top = 0;  // mm
};

LayerWidths widths_for(const SliceSettings& s, int layer) {
  const ResolvedWidths r = resolve_widths(s);
  if (layer == 0) {
    const double w = r.first_layer_mm;
    return {w, w, w, w, w};
  }
  return {r.external_perimeter_mm, r.perimeter_mm, r.infill_mm, r.solid_infill_mm, r.top_infill_mm};
}

ExtrusionPath make_path(Role role, CPath pts, bool closed, double width_mm, double height_mm) {
  ExtrusionPath p;
  p.role = role;
  p.points = std::move(pts);
  p.closed = closed;
  p.width_mm = width_mm;
  p.area_mm2 = bead_area_mm2(width_mm, height_mm);
  return p;
}

Box3 box_of(const CPath& p) {
  Box3 b;
  for (const auto& q : p) b.extend(Vec3(to_mm(q.X), to_mm(q.Y), 0));
  return b;
}

// Single lines along narrow strips (thin walls and gap fill). Strips narrower than
// `min_width_mm` are dropped (reported through `dropped` when `report` is set).
void strips_to_lines(const CPaths& region, Role role, double min_width_mm, double max_width_mm,
                     double min_length_mm, double height_mm, int layer, bool report,
                     std::vector<ExtrusionPath>& out, std::vector<DroppedFeature>& dropped) {
  if (region.empty()) return;
  for (const ExPolygon& ex : to_expolygons(region)) {
    const Centerline c = centerline(ex);
    if (c.paths.empty() || c.width_mm <= 0) continue;
    double area = std::abs(Area(ex.contour));
    for (const auto& h : ex.holes) area -= std::abs(Area(h));
    const double area_mm2_v = area * 1e-6;
    const double length_mm = area_mm2_v / c.width_mm;
    // Corner slivers and offset rounding residue are not features.
    if (length_mm < min_length_mm || c.width_mm < 0.05 || area_mm2_v < 0.02) continue;
    if (c.width_mm < min_width_mm) {
      if (report) {
        const Box3 b = box_of(ex.contour);
        DroppedFeature d;
        d.layer = layer;
        d.width_mm = c.width_mm;
        d.area_mm2 = area_mm2_v;
        d.x_mm = b.center().x();
        d.y_mm = b.center().y();
        d.min_x_mm = b.min.x();
        d.min_y_mm = b.min.y();
        d.max_x_mm = b.max.x();
        d.max_y_mm = b.max.y();
        dropped.push_back(d);
      }
      continue;
    }
    const double w = std::min(c.width_mm, max_width_mm);
    for (const auto& p : c.paths) {
      if (p.size() < 2) continue;
      out.push_back(make_path(role, p, c.closed, w, height_mm));
    }
  }
}

// Principal direction (degrees) of the smallest second moment: bridges run across it.
double bridge_angle_deg(const CPaths& region) {
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0, n = 0;
  for (const auto& p : region)
    for (const auto& q : p) {
      const double x = to_mm(q.X), y = to_mm(q.Y);
      sx += x;
      sy += y;
      sxx += x * x;
      syy += y * y;
      sxy += x * y;
      n += 1;
    }
  if (n < 3) return 0;
  const double cxx = sxx / n - (sx / n) * (sx / n);
  const double cyy = syy / n - (sy / n) * (sy / n);
  const double cxy = sxy / n - (sx / n) * (sy / n);
  // Major axis angle; lines along the minor axis (perpendicular to the major one).
  const double major = 0.5 * std::atan2(2 * cxy, cxx - cyy);
  return major * 180.0 / std::numbers::pi + 90.0;
}

struct IslandWork {
  Island island;
  CPaths fill;  // where infill goes (inner edge of the perimeters)
};

// Convex hull (Andrew's monotone chain) of every point, CCW.
CPath convex_hull(CPath pts) {
  std::sort(pts.begin(), pts.end(), [](const IntPoint& a, const IntPoint& b) {
    return a.X < b.X || (a.X == b.X && a.Y < b.Y);
  });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  if (pts.size() < 3) return pts;
  auto cross = [](const IntPoint& o, const IntPoint& a, const IntPoint& b) {
    return double(a.X - o.X) * double(b.Y - o.Y) - double(a.Y - o.Y) * double(b.X - o.X);
  };
  CPath h(2 * pts.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], pts[i]) <= 0) --k;
    h[k++] = pts[i];
  }
  for (std::size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(h[k - 2], h[k - 1], pts[i - 1]) <= 0) --k;
    h[k++] = pts[i - 1];
  }
  h.resize(k - 1);
  return h;
}

}  // namespace

namespace {
/// Pass 1 for one island of a layer: perimeter loops (inner first unless
/// external_perimeters_first), thin walls, gap fill, and the area left for the fill.
IslandWork plan_island_perimeters(const ExPolygon& ex, const SliceSettings& s, int layer, double h,
                                  double min_thin_mm, LayerToolpaths& lt) {
  const LayerWidths w = widths_for(s, layer);
  const double s_ext = bead_spacing_mm(w.ext, h) * kUmPerMm;
  const double s_per = bead_spacing_mm(w.per, h) * kUmPerMm;
  IslandWork iw;
  iw.island.outline = ex.contour;
  const CPaths cur = to_paths(ExPolygons{ex});
  if (s.perimeters == 0) {
    iw.fill = cur;
    return iw;
  }
  std::vector<CPaths> loops;
  CPaths r = offset(cur, -0.5 * w.ext * kUmPerMm);
  if (s.thin_walls) {
    const CPaths thin = clip(cur, offset(r, 0.5 * w.ext * kUmPerMm), ctDifference);
    strips_to_lines(thin, Role::external_perimeter, min_thin_mm, w.ext, w.ext, h, layer, true,
                    iw.island.perimeters, lt.dropped);
  }
  // Loop k's centre line region is r_k; r_P is the "would-be" loop after the last one:
  // what it would cover is the fill area, and what lies between a loop's inner edge and
  // the next loop's outer edge is too narrow for a loop: gap fill.
  for (int k = 0; k <= s.perimeters && !r.empty(); ++k) {
    if (k == s.perimeters) {
      iw.fill = offset(r, 0.5 * s_per);
      break;
    }
    loops.push_back(r);
    const double sp_k = k == 0 ? s_ext : s_per;
    const double step = k == 0 ? 0.5 * (s_ext + s_per) : s_per;
    CPaths next = offset(r, -step);
    if (s.gap_fill) {
      const CPaths inner = offset(r, -0.5 * sp_k);
      const CPaths gaps =
          next.empty() ? inner : clip(inner, offset(next, 0.5 * s_per), ctDifference);
      strips_to_lines(gaps, Role::gap_fill, 0.25 * s_per / kUmPerMm, 2.0 * s_per / kUmPerMm,
                      0.5 * w.per, h, layer, false, iw.island.gap_fill, lt.dropped);
    }
    r = std::move(next);
  }
  // Perimeter paths, inner loops first (PrusaSlicer's default order).
  std::vector<ExtrusionPath> loop_paths;
  for (std::size_t k = 0; k < loops.size(); ++k) {
    const std::size_t kk = s.external_perimeters_first ? k : loops.size() - 1 - k;
    const bool external = kk == 0;
    for (const auto& p : loops[kk]) {
      if (p.size() < 3) continue;
      loop_paths.push_back(make_path(external ? Role::external_perimeter : Role::perimeter, p, true,
                                     external ? w.ext : w.per, h));
    }
  }
  // Thin walls go with the external perimeters.
  std::vector<ExtrusionPath> thin = std::move(iw.island.perimeters);
  iw.island.perimeters = std::move(loop_paths);
  if (s.external_perimeters_first)
    iw.island.perimeters.insert(iw.island.perimeters.begin(), thin.begin(), thin.end());
  else
    iw.island.perimeters.insert(iw.island.perimeters.end(), thin.begin(), thin.end());
  return iw;
}

/// What pass 3 needs to classify one layer's fill areas.
struct FillLayer {
  int layer = 0;
  double h = 0;
  const CPaths* below_slice = nullptr;  ///< the layer below's outline (null on the first)
  const CPaths* above_slice = nullptr;  ///< the layer above's outline (null on the last)
  const CPaths* above = nullptr;        ///< covered by all of the next top_solid_layers
  const CPaths* below = nullptr;        ///< covered by all of the previous bottom_solid_layers
};

/// Pass 3 for one island: splits its fill area into bridge, top, solid and sparse regions
/// and lays their infill lines.
void plan_island_fill(IslandWork& iw, const SliceSettings& s, const FillLayer& fl,
                      LayerToolpaths& lt) {
  const int layer = fl.layer;
  const double h = fl.h;
  const int T = s.top_solid_layers, B = s.bottom_solid_layers;
  const LayerWidths w = widths_for(s, layer);
  const double s_inf = bead_spacing_mm(w.inf, h) * kUmPerMm;
  const double s_solid = bead_spacing_mm(w.solid, h) * kUmPerMm;
  const double s_top = bead_spacing_mm(w.top, h) * kUmPerMm;
  const double angle = s.fill_angle_deg;
  const CPaths& F = iw.fill;
  if (F.empty()) {
    lt.islands.push_back(std::move(iw.island));
    return;
  }
  CPaths solid_region, top, bridge;
  const bool all_solid = layer == 0 || s.infill_density >= 0.9999;
  if (all_solid) {
    solid_region = F;
  } else {
    if (T > 0) solid_region = clip(F, *fl.above, ctDifference);
    if (B > 0) solid_region = clip(solid_region, clip(F, *fl.below, ctDifference), ctUnion);
  }
  if (layer > 0 && B > 0) {
    bridge = opening(clip(F, *fl.below_slice, ctDifference), 0.25 * w.solid * kUmPerMm);
  }
  if (T > 0) {
    const CPaths up = fl.above_slice != nullptr ? *fl.above_slice : CPaths{};
    top = opening(clip(F, up, ctDifference), 0.25 * w.top * kUmPerMm);
    top = clip(top, bridge, ctDifference);
  }
  CPaths sparse = clip(F, solid_region, ctDifference);
  // Narrow or small sparse areas print solid (PrusaSlicer's solid_infill_below_area).
  CPaths sparse_keep;
  if (!sparse.empty() && s.infill_density > 0) {
    for (const ExPolygon& ex : to_expolygons(opening(sparse, 0.5 * s_inf))) {
      double a = std::abs(Area(ex.contour));
      for (const auto& hh : ex.holes) a -= std::abs(Area(hh));
      if (a * 1e-6 >= s.solid_infill_below_area_mm2) {
        CPaths part = to_paths(ExPolygons{ex});
        sparse_keep.insert(sparse_keep.end(), part.begin(), part.end());
      }
    }
  } else if (!sparse.empty() && s.infill_density <= 0) {
    sparse_keep = sparse;  // 0 %: nothing printed there, and it is not solid either
  }
  CPaths solid =
      clip(clip(clip(F, sparse_keep, ctDifference), top, ctDifference), bridge, ctDifference);
  Island& isl = iw.island;
  auto add_lines = [&](const CPaths& lines, Role role, double width_mm, double area) {
    for (const auto& ln : lines) {
      if (ln.size() < 2) continue;
      ExtrusionPath p = make_path(role, ln, false, width_mm, h);
      if (area > 0) p.area_mm2 = area;
      isl.infill.push_back(std::move(p));
    }
  };
  // Solid infill lines alternate 45 / -45 degrees (monotonic order is made by the writer).
  const double solid_angle = angle + ((layer % 2) != 0 ? 90.0 : 0.0);
  if (!bridge.empty()) {
    // Bridges: round beads of the nozzle's diameter (PrusaSlicer, bridge_flow_ratio 1),
    // 0.05 mm apart, across the shortest span.
    const double d = s.nozzle_diameter_mm;
    const double area = std::numbers::pi * 0.25 * d * d;
    const double spacing = (d + 0.05) * kUmPerMm;
    CPaths lines =
        infill_lines(bridge, InfillPattern::rectilinear, spacing, bridge_angle_deg(bridge), 0);
    add_lines(lines, Role::bridge_infill, d, area);
    lt.has_bridge = true;
  }
  if (!solid.empty()) {
    add_lines(infill_lines(solid, InfillPattern::rectilinear, s_solid, solid_angle, 0),
              Role::solid_infill, w.solid, 0);
  }
  if (!top.empty()) {
    add_lines(infill_lines(top, InfillPattern::rectilinear, s_top, solid_angle, 0),
              Role::top_solid_infill, w.top, 0);
  }
  if (!sparse_keep.empty() && s.infill_density > 0) {
    const CPaths grown = clip(offset(sparse_keep, s.infill_overlap * w.per * kUmPerMm),
                              offset(F, s.infill_overlap * w.per * kUmPerMm), ctIntersection);
    add_lines(infill_lines(grown, s.infill_pattern, s_inf / s.infill_density, angle, layer),
              Role::sparse_infill, w.inf, 0);
  }
  lt.islands.push_back(std::move(isl));
}

/// Skirt loops around the convex hull of the first layer (up to skirt_height layers, at least
/// min_skirt_length) and brim loops around its outer contours.
void plan_skirt_and_brim(const std::vector<LayerOutline>& outlines, const CPaths& first,
                         const SliceSettings& s, RegionResult& result) {
  const std::size_t L = outlines.size();
  for (std::size_t li = 0; li < L; ++li) {
    const int layer = static_cast<int>(li);
    const double h = outlines[li].height_mm;
    const LayerWidths w = widths_for(s, layer);
    const double sp = bead_spacing_mm(w.per, h) * kUmPerMm;
    CPaths base = first;
    if (layer == 0 && s.brim_width_mm > 0) {
      const int n = std::max(1, static_cast<int>(std::floor(s.brim_width_mm * kUmPerMm / sp)));
      CPaths outer_only;
      for (const ExPolygon& ex : to_expolygons(first)) outer_only.push_back(ex.contour);
      for (int k = n - 1; k >= 0; --k) {  // from the outside in, ending at the part
        for (const auto& p : offset(outer_only, 0.5 * sp + k * sp, jtRound)) {
          if (p.size() < 3) continue;
          result.layers[li].skirt.push_back(make_path(Role::skirt, p, true, w.per, h));
        }
      }
      base = offset(outer_only, n * sp, jtRound);
    } else if (s.brim_width_mm > 0) {
      base = offset(first, s.brim_width_mm * kUmPerMm, jtRound);
    }
    if (s.skirts > 0 && layer < s.skirt_height) {
      CPath all;
      for (const auto& p : base) all.insert(all.end(), p.begin(), p.end());
      const CPath hull = convex_hull(all);
      double total_len = 0;
      std::vector<ExtrusionPath> loops;
      for (int k = 0; k < 1000; ++k) {
        if (k >= s.skirts && total_len >= s.min_skirt_length_mm * kUmPerMm) break;
        const double d = s.skirt_distance_mm * kUmPerMm + 0.5 * sp + k * sp;
        for (const auto& p : offset(CPaths{hull}, d, jtRound)) {
          if (p.size() < 3) continue;
          double len = 0;
          for (std::size_t q = 0; q < p.size(); ++q) {
            const auto& a = p[q];
            const auto& b = p[(q + 1) % p.size()];
            len += std::hypot(double(b.X - a.X), double(b.Y - a.Y));
          }
          total_len += len;
          loops.push_back(make_path(Role::skirt, p, true, w.per, h));
        }
      }
      // Outermost first, so the nozzle ends next to the part.
      std::reverse(loops.begin(), loops.end());
      auto& sk = result.layers[li].skirt;
      sk.insert(sk.begin(), loops.begin(), loops.end());
    }
    if (layer >= s.skirt_height && layer > 0) break;
  }
}
}  // namespace

RegionResult plan_layers(const std::vector<LayerOutline>& outlines, const SliceSettings& s) {
  const std::size_t L = outlines.size();
  RegionResult result;
  result.layers.resize(L);
  std::vector<CPaths> slices(L);
  for (std::size_t i = 0; i < L; ++i) slices[i] = to_paths(outlines[i].polygons);

  const double min_thin_mm = min_thin_wall_width_mm(s);

  // Pass 1: perimeters, thin walls, gap fill, fill areas (each layer on its own).
  std::vector<std::vector<IslandWork>> work(L);
  tbb::parallel_for(std::size_t(0), L, [&](std::size_t li) {
    LayerToolpaths& lt = result.layers[li];
    lt.index = static_cast<int>(li);
    lt.print_z_mm = outlines[li].print_z_mm;
    lt.height_mm = outlines[li].height_mm;
    lt.boundary = slices[li];
    for (const ExPolygon& ex : to_expolygons(slices[li]))
      work[li].push_back(plan_island_perimeters(ex, s, static_cast<int>(li), outlines[li].height_mm,
                                                min_thin_mm, lt));
  });

  // Pass 2: coverage of the layers above / below for the solid skins.
  const int T = s.top_solid_layers, B = s.bottom_solid_layers;
  std::vector<CPaths> above(L), below(L);
  tbb::parallel_for(std::size_t(0), L, [&](std::size_t li) {
    const long i = static_cast<long>(li);
    if (T > 0 && i + T <= static_cast<long>(L) - 1) {
      CPaths cover = slices[li + 1];
      for (long j = i + 2; j <= i + T && !cover.empty(); ++j)
        cover = clip(cover, slices[static_cast<std::size_t>(j)], ctIntersection);
      above[li] = std::move(cover);
    }
    if (B > 0 && i - B >= 0) {
      CPaths cover = slices[li - 1];
      for (long j = i - 2; j >= i - B && !cover.empty(); --j)
        cover = clip(cover, slices[static_cast<std::size_t>(j)], ctIntersection);
      below[li] = std::move(cover);
    }
  });

  // Pass 3: classify each island's fill area and lay the infill lines.
  tbb::parallel_for(std::size_t(0), L, [&](std::size_t li) {
    FillLayer fl;
    fl.layer = static_cast<int>(li);
    fl.h = outlines[li].height_mm;
    fl.below_slice = li > 0 ? &slices[li - 1] : nullptr;
    fl.above_slice = li + 1 < L ? &slices[li + 1] : nullptr;
    fl.above = &above[li];
    fl.below = &below[li];
    for (IslandWork& iw : work[li]) plan_island_fill(iw, s, fl, result.layers[li]);
  });

  // Skirt and brim around the first layer.
  if (L > 0 && (s.skirts > 0 || s.brim_width_mm > 0))
    plan_skirt_and_brim(outlines, slices[0], s, result);
  return result;
}

}  // namespace printtwin::slice_detail

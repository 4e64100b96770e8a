// compute_deviation: the two-sided comparison of a deposit and a placed mesh.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <span>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include "deviation/deposit_surface_internal.hpp"
#include "deviation/outer_surface.hpp"
#include "deviation/sharp_edges.hpp"
#include "deviation/surface_internal.hpp"
#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {
/// Whether a bead's core point (detail::bead_closest) lies strictly between its ends.
bool on_side(const SurfaceBead& b, const Vec3& core) {
  const Vec3 d = b.end_mm - b.start_mm;
  const double t = (core - (b.start_mm - Vec3(0, 0, 0.5 * b.height_mm))).dot(d);
  return t > 1e-12 * d.squaredNorm() && t < (1 - 1e-12) * d.squaredNorm();
}

/// Mesh -> deposit on the true bead surface: where a point's nearest face was placed on a bead,
/// its distance becomes the exact distance to the union of the beads of that face's line, their
/// path neighbours and the beads touching the face's bead, when that agrees with the distance
/// to the faces within a voxel and half the bead's height (the bead model describes that part
/// of the surface; the faces miss the cusp between two beads, up to h / 2 deep).
/// The points come cell by cell (as the face search visits them): neighbouring points read
/// the same faces and beads, and the arrays are read in order.
void to_bead_surface(const DepositSurface& s, std::span<const SurfaceBead> beads,
                     const detail::BeadIndex& index, std::span<const Vec3> points,
                     const std::vector<std::uint32_t>& nearest, std::vector<double>& signed_mm) {
  if (s.face_bead.empty()) return;
  const double v = s.voxel_mm;
  const std::vector<detail::BeadBox>& boxes = index.boxes();
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, points.size(), 4096),
      [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const std::uint32_t f = nearest[i];
          if (f >= s.face_bead.size() || s.face_bead[f] == kNoBead) continue;
          const std::uint32_t k = s.face_bead[f];
          detail::BeadDistance b = index.nearest(s.face_tags[f].line, points[i]);
          if (k + std::size_t{1} < s.bead_touch_begin.size())
            for (std::uint32_t j = s.bead_touch_begin[k]; j < s.bead_touch_begin[k + 1]; ++j) {
              // A bead is no nearer than the height from its core less its radius.
              const detail::BeadBox& t = boxes[s.bead_touch[j]];
              const double rt = t.rt, pz = points[i].z();
              const double gap = std::max({pz - t.z_top, t.z_bot - pz, 0.0}) - rt;
              if (gap >= b.signed_mm) continue;
              // Nor nearer than the box of its core (its centre line's box grown by the
              // core's half width across, level) less its radius: tested squared, with a
              // margin for rounding, so a bead that could be the nearest is never skipped.
              const double px = points[i].x(), py = points[i].y();
              const double dx = std::max({t.x_lo - px, px - t.x_hi, 0.0}),
                           dy = std::max({t.y_lo - py, py - t.y_hi, 0.0}), dz = gap + rt;
              const double lim = b.signed_mm + rt + 1e-9;
              if (lim <= 0 || dx * dx + dy * dy + dz * dz >= lim * lim) continue;
              Vec3 core;
              const double sd = index.cores()[s.bead_touch[j]].closest(points[i], core);
              if (sd < b.signed_mm) {
                b.signed_mm = sd;
                b.bead = s.bead_touch[j];
                b.core_point = core;
              }
            }
          // Beside a bead (not past its ends, where the deposit may cut it square), the faces
          // may miss a cusp up to h / 2 deep.
          const double tol = b.bead != kNoBead && on_side(beads[b.bead], b.core_point)
                                 ? v + 0.5 * beads[b.bead].height_mm
                                 : v;
          if (b.bead != kNoBead && std::abs(-b.signed_mm - signed_mm[i]) <= tol)
            signed_mm[i] = -b.signed_mm;
        }
      });
}

/// The mesh -> deposit queries in the order the searches visit them (cell by cell): the
/// searches read and write their arrays in that order, and the results go back to the
/// points' own order once.
struct SortedQueries {
  detail::DepositQueryGroups groups;
  std::vector<Vec3> points;            ///< in visiting order
  std::vector<double> d;               ///< signed distances to the deposit, in visiting order
  std::vector<std::uint32_t> nearest;  ///< nearest faces, in visiting order

  /// Groups `query` (the points in their own order) and lists them in visiting order.
  void sort(std::span<const Vec3> query, double voxel_mm) {
    groups = detail::group_deposit_queries(query, voxel_mm);
    points.resize(query.size());
    for (std::size_t q = 0; q < points.size(); ++q) points[q] = query[groups.order[q]];
  }
  /// The distances to the faces of `s` and the nearest faces.
  void search(const DepositSurface& s) {
    const detail::DepositQueryGroups in_order;  // no order: the points come sorted
    detail::distances_to_deposit_with(s, points, d, &nearest, &in_order);
  }
  /// The distances and nearest faces in the points' own order.
  void unsort(std::vector<double>& d_out, std::vector<std::uint32_t>& nearest_out) const {
    d_out.resize(d.size());
    nearest_out.resize(nearest.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, d.size(), 1 << 14),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t q = r.begin(); q != r.end(); ++q) {
                          const std::uint32_t i = groups.order[q];
                          d_out[i] = d[q];
                          nearest_out[i] = nearest[q];
                        }
                      });
  }
};

/// Layer lines on walls: per layer and over the part, the area-weighted RMS distance of the
/// deposit points whose closest design triangle is within 15 degrees of vertical and which lie
/// farther than kWallEdgeMarginMm from the design's sharp edges, and their RMS about the
/// layer's own mean (Rq); the RMS of the mesh samples on those walls (mesh -> deposit). The
/// points are in the G-code's frame, the mesh at `offset` from it.
void wall_roughness(const Mesh& mesh, const detail::SharpEdges& edges, std::span<const double> d,
                    std::span<const std::uint32_t> triangle, std::span<const VoxelTag> tags,
                    std::span<const double> area, std::span<const Vec3> points,
                    std::span<const double> d_mesh, std::span<const SurfaceSample> samples,
                    std::span<const Vec3> sample_points, const Vec3& offset, double v,
                    std::vector<LayerDeviation>& layers, DeviationResult& out) {
  std::vector<std::uint8_t> wall(mesh.triangles.size(), 0);
  const double sin_wall = std::sin(15.0 * std::numbers::pi / 180.0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Vec3 n = triangle_normal(mesh, t);
    const double len = n.norm();
    wall[t] = len > 0 && std::abs(n.z()) <= sin_wall * len ? 1 : 0;
  }
  // Per point: on a wall, away from its edges (in parallel; the sums below in order).
  const auto on_wall = [&](std::span<const Vec3> p, const auto& triangle_of) {
    std::vector<std::uint8_t> keep(p.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, p.size(), 1 << 14),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          const std::uint32_t t = triangle_of(i);
                          keep[i] =
                              t < wall.size() && wall[t] != 0 && !edges.near(p[i] - offset) ? 1 : 0;
                        }
                      });
    return keep;
  };
  const std::vector<std::uint8_t> keep =
      on_wall(points, [&](std::size_t i) { return triangle[i]; });
  struct Sums {
    long double w = 0, wd = 0, wd2 = 0;
  };
  std::vector<Sums> per(layers.size());
  for (std::size_t i = 0; i < d.size(); ++i) {
    const int l = tags[i].layer;
    if (keep[i] == 0 || l < 0 || static_cast<std::size_t>(l) >= per.size()) continue;
    const long double w = area.empty() ? v * v : area[i];
    Sums& p = per[static_cast<std::size_t>(l)];
    p.w += w;
    p.wd += w * d[i];
    p.wd2 += w * d[i] * d[i];
  }
  long double w = 0, wd2 = 0, wvar = 0;
  for (std::size_t l = 0; l < per.size(); ++l) {
    const Sums& p = per[l];
    if (!(p.w > 0)) continue;
    const long double mean = p.wd / p.w, var = std::max<long double>(0, p.wd2 / p.w - mean * mean);
    layers[l].wall_rms_mm = static_cast<double>(std::sqrt(p.wd2 / p.w));
    layers[l].wall_rq_mm = static_cast<double>(std::sqrt(var));
    w += p.w;
    wd2 += p.wd2;
    wvar += p.w * var;
  }
  if (w > 0) {
    out.wall_rms_mm = static_cast<double>(std::sqrt(wd2 / w));
    out.wall_rq_mm = static_cast<double>(std::sqrt(wvar / w));
    out.wall_area_mm2 = static_cast<double>(w);
  }
  const std::vector<std::uint8_t> keep_mesh =
      on_wall(sample_points, [&](std::size_t i) { return samples[i].triangle; });
  long double n = 0, sum2 = 0;
  for (std::size_t i = 0; i < d_mesh.size(); ++i)
    if (keep_mesh[i] != 0) {
      n += 1;
      sum2 += d_mesh[i] * d_mesh[i];
    }
  if (n > 0) out.wall_mesh_rms_mm = static_cast<double>(std::sqrt(sum2 / n));
}
/// Distances grouped by layer with a counting sort (sample order kept within a layer):
/// layer l's values are values[begin[l] .. begin[l + 1]), with their weights when w is given.
template <class LayerOf>
void group_by_layer(std::size_t n_layers, std::size_t n, const LayerOf& layer_of,
                    std::span<const double> d, std::vector<std::size_t>& begin,
                    std::vector<double>& values, std::span<const double> w = {},
                    std::vector<double>* weights = nullptr) {
  begin.assign(n_layers + 1, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (const int l = layer_of(i); l >= 0) ++begin[static_cast<std::size_t>(l) + 1];
  for (std::size_t l = 0; l < n_layers; ++l) begin[l + 1] += begin[l];
  values.resize(begin[n_layers]);
  if (weights != nullptr) weights->resize(w.empty() ? 0 : begin[n_layers]);
  std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    if (const int l = layer_of(i); l >= 0) {
      const std::size_t k = fill[static_cast<std::size_t>(l)]++;
      values[k] = d[i];
      if (weights != nullptr && !w.empty()) (*weights)[k] = w[i];
    }
}

/// One direction's per-layer statistics, layers in parallel.
void layer_stats(std::vector<LayerDeviation>& layers, const std::vector<std::size_t>& begin,
                 const std::vector<double>& values, DeviationStats LayerDeviation::*field,
                 double tolerance_mm, const std::vector<double>& weights = {}) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, layers.size()),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t l = r.begin(); l != r.end(); ++l) {
                        const std::size_t b = begin[l], n = begin[l + 1] - begin[l];
                        layers[l].*field = deviation_stats(
                            std::span<const double>(values).subspan(b, n),
                            weights.empty() ? std::span<const double>{}
                                            : std::span<const double>(weights).subspan(b, n),
                            tolerance_mm);
                      }
                    });
}
/// The regions out of tolerance (missing from the mesh samples below -tolerance, excess from
/// the deposit points above +tolerance), clustered; those under the minimum area are noise,
/// counted but neither regions nor in the worst figures.
template <class MeshSample, class DepSample>
void find_regions(const DeviationSettings& settings, double v, double spacing,
                  std::span<const double> d_mesh, std::span<const double> d_dep,
                  std::span<const double> dep_area, const MeshSample& mesh_sample,
                  const DepSample& dep_sample, DeviationResult& out) {
  const std::size_t ns = d_mesh.size();
  const double radius = settings.cluster_radius_mm > 0 ? settings.cluster_radius_mm
                                                       : std::max(2.0 * v, 3.0 * spacing);
  // Only the out-of-tolerance samples are clustered (in sample order: the same regions as
  // clustering all of them), so the full sample lists exist only when they are kept.
  const auto out_of_tolerance = [&](std::size_t n, std::span<const double> d, double sign,
                                    const auto& make) {
    std::vector<DeviationSample> list;
    for (std::size_t i = 0; i < n; ++i)
      if (sign * d[i] > settings.tolerance_mm) list.push_back(make(i));
    return list;
  };
  const std::vector<DeviationSample> mesh_out = out_of_tolerance(ns, d_mesh, -1.0, mesh_sample);
  const std::vector<DeviationSample> dep_out =
      out_of_tolerance(d_dep.size(), d_dep, 1.0, dep_sample);
  std::vector<double> dep_out_area;  // the area each deposit point stands for
  if (!dep_area.empty())
    for (std::size_t i = 0; i < d_dep.size(); ++i)
      if (d_dep[i] > settings.tolerance_mm) dep_out_area.push_back(dep_area[i]);
  std::vector<std::int32_t> missing_of, excess_of;
  auto missing = cluster_regions(mesh_out, settings.tolerance_mm, radius, spacing * spacing,
                                 RegionKind::missing, settings.max_region_lines, &missing_of);
  auto excess = cluster_regions(dep_out, settings.tolerance_mm, radius, v * v, RegionKind::excess,
                                settings.max_region_lines, &excess_of, dep_out_area);
  // Clusters below the minimum area are voxel noise: not regions, not in the gate figures.
  const auto is_noise = [&](const std::vector<DeviationRegion>& regions, std::int32_t r) {
    return r >= 0 && regions[static_cast<std::size_t>(r)].area_mm2 < settings.min_region_area_mm2;
  };
  // Within tolerance: in no region. Out of it: counted unless its region is noise.
  const auto max_within = [&](std::span<const double> d, double sign) {
    double m = 0;
    for (const double x : d)
      if (!(sign * x > settings.tolerance_mm)) m = std::max(m, sign * x);
    return m;
  };
  out.max_excess_mm = max_within(d_dep, 1.0);
  for (std::size_t k = 0; k < dep_out.size(); ++k)
    if (!is_noise(excess, excess_of[k]))
      out.max_excess_mm = std::max(out.max_excess_mm, dep_out[k].distance_mm);
  out.max_deficit_mm = max_within(d_mesh, -1.0);
  for (std::size_t k = 0; k < mesh_out.size(); ++k)
    if (!is_noise(missing, missing_of[k]))
      out.max_deficit_mm = std::max(out.max_deficit_mm, -mesh_out[k].distance_mm);
  for (auto* list : {&missing, &excess})
    for (auto& r : *list) {
      if (r.area_mm2 < settings.min_region_area_mm2) {
        ++out.noise_regions;
        out.noise_area_mm2 += r.area_mm2;
      } else {
        out.regions.push_back(std::move(r));
      }
    }
  std::stable_sort(out.regions.begin(), out.regions.end(),
                   [](const DeviationRegion& a, const DeviationRegion& b) {
                     if (a.area_mm2 != b.area_mm2) return a.area_mm2 > b.area_mm2;
                     return std::abs(a.worst_mm) > std::abs(b.worst_mm);
                   });
  if (settings.max_regions >= 0 &&
      out.regions.size() > static_cast<std::size_t>(settings.max_regions))
    out.regions.resize(static_cast<std::size_t>(settings.max_regions));
}

}  // namespace

Result<DeviationResult> compute_deviation(const Mesh& mesh, const VoxelGrid& deposit,
                                          const DeviationSettings& settings,
                                          const Box3& part_box_mm,
                                          std::span<const SurfaceBead> beads) {
  if (mesh.triangles.empty()) return bad_input("deviation: the mesh has no triangles");
  auto target = DeviationTarget::build(mesh, settings, deposit.voxel_mm());
  if (!target) return target.error();
  return compute_deviation(*target, Vec3::Zero(), deposit, settings, part_box_mm, beads);
}

namespace {
/// Each layer's number, and its height: the top of its highest surface voxel.
void number_layers(std::vector<LayerDeviation>& layers, const std::vector<int>& top_key,
                   const VoxelGrid& deposit) {
  for (std::size_t l = 0; l < layers.size(); ++l) {
    LayerDeviation& ld = layers[l];
    ld.layer = static_cast<int>(l);
    if (top_key[l] != std::numeric_limits<int>::min())
      ld.z_mm = deposit.center_mm(VoxelKey{0, 0, top_key[l]}).z() + 0.5 * deposit.voxel_mm();
  }
}

/// The voxels the faces belong to (a voxel's faces are consecutive), counted in parallel.
std::size_t count_surface_voxels(const std::vector<SurfaceFace>& faces) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, faces.size(), 1 << 16), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t n) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
          if (i == 0 || !(faces[i].voxel == faces[i - 1].voxel)) ++n;
        return n;
      },
      std::plus<>());
}

/// The highest layer of the tags (-1 when there is none), in parallel.
int highest_layer(const std::vector<VoxelTag>& tags) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, tags.size(), 1 << 16), -1,
      [&](const tbb::blocked_range<std::size_t>& r, int m) {
        for (std::size_t i = r.begin(); i != r.end(); ++i)
          m = std::max(m, static_cast<int>(tags[i].layer));
        return m;
      },
      [](int a, int b) { return std::max(a, b); });
}

/// The filled blocks of `surface` (moved out of it), for the as-printed mesh: the deviation
/// stage has already extracted them, so the mesh export need not do it again.
std::shared_ptr<DepositSurface> filled_volume_of(DepositSurface& surface) {
  auto kept = std::make_shared<DepositSurface>();
  kept->voxel_mm = surface.voxel_mm;
  kept->origin_mm = surface.origin_mm;
  kept->origin_key = surface.origin_key;
  kept->dims = surface.dims;
  kept->filled_blocks_lo = surface.filled_blocks_lo;
  kept->filled_blocks_dims = surface.filled_blocks_dims;
  kept->filled_block_code = std::move(surface.filled_block_code);
  kept->filled_masks = std::move(surface.filled_masks);
  kept->occupied_voxels = surface.occupied_voxels;
  kept->filled_voxels = surface.filled_voxels;
  return kept;
}
}  // namespace

Result<DeviationResult> compute_deviation(const DeviationTarget& target, const Vec3& offset,
                                          const VoxelGrid& deposit,
                                          const DeviationSettings& settings,
                                          const Box3& part_box_mm,
                                          std::span<const SurfaceBead> beads) {
  const Mesh& mesh = target.mesh();
  if (mesh.triangles.empty()) return bad_input("deviation: the mesh has no triangles");
  if (!(settings.tolerance_mm > 0))
    return usage_error("deviation: tolerance must be > 0 mm, got " +
                       std::to_string(settings.tolerance_mm));
  if (settings.mesh_sample_spacing_mm < 0)
    return usage_error("deviation: mesh sample spacing must be >= 0 mm");
  const double v = deposit.voxel_mm();
  const double spacing =
      settings.mesh_sample_spacing_mm > 0 ? settings.mesh_sample_spacing_mm : 2.0 * v;

  DeviationResult out;
  out.tolerance_mm = settings.tolerance_mm;
  out.mesh_volume_mm3 = target.volume_mm3();

  // The analysed region: the mesh and the part's extrusions, with a margin for excess.
  Box3 region{target.bbox_mm().min + offset, target.bbox_mm().max + offset};
  region.extend(part_box_mm);
  region.min -= Vec3::Constant(settings.region_margin_mm);
  region.max += Vec3::Constant(settings.region_margin_mm);
  // Mesh -> deposit, from area-uniform samples (the target's when drawn alike). Their query
  // points and visiting order are made side by side with the deposit's surface.
  DepositSurface surface;
  std::vector<SurfaceSample> own_samples;
  std::span<const SurfaceSample> samples = target.samples();
  if (target.sample_spacing_mm() != spacing || target.sample_seed() != settings.seed) {
    own_samples = sample_surface(mesh, spacing, settings.seed);
    samples = own_samples;
  }
  const std::size_t ns = samples.size();
  std::vector<Vec3> query_points(ns + mesh.vertices_mm.size());
  SortedQueries sorted;
  // The beads' index (their cores, by line), made once for the placement, the outline
  // sampling and the mesh -> deposit distances to the beads.
  std::optional<detail::BeadIndex> bead_index;
  tbb::parallel_invoke(
      [&] {
        surface =
            extract_outer_surface(deposit, region, settings.seal_gap_mm, settings.groove_depth_mm);
      },
      [&] {
        // The samples and the mesh's vertices (for the per-vertex deviation)
        // in one search.
        for (std::size_t i = 0; i < ns; ++i) query_points[i] = samples[i].position_mm + offset;
        for (std::size_t i = 0; i < mesh.vertices_mm.size(); ++i)
          query_points[ns + i] = mesh.vertices_mm[i] + offset;
        sorted.sort(query_points, v);
      },
      [&] {
        if (!beads.empty()) bead_index.emplace(beads);
      });
  // Mesh -> deposit to the faces needs only the faces: side by side with their placement on
  // the beads (which fills in the deposit -> mesh points).
  tbb::parallel_invoke(
      [&] {
        if (bead_index) detail::place_on_beads(surface, beads, *bead_index, v);
      },
      [&] { sorted.search(surface); });
  // In the points' order (from the sorted results, below).
  std::vector<double> d_query;
  std::vector<std::uint32_t> nearest;
  out.deposit_volume_mm3 = static_cast<double>(surface.occupied_voxels) * v * v * v;
  out.surface_faces = surface.faces.size();
  out.surface_voxels = count_surface_voxels(surface.faces);

  // Deposit -> mesh, from every exposed face centre (made here only without beads, which
  // fill points_mm).
  std::vector<Vec3> centres;
  if (surface.points_mm.empty()) centres = surface.face_centers_mm();
  const std::vector<Vec3>& face_points = surface.points_mm.empty() ? centres : surface.points_mm;
  const std::span<const double> face_area = surface.point_area_mm2;
  const std::vector<VoxelTag>& dep_tags =
      surface.point_tags.empty() ? surface.face_tags : surface.point_tags;
  const bool weighted = !beads.empty();
  std::vector<double> d_dep;
  std::vector<std::uint32_t> dep_triangles;
  const auto dep_sample = [&](std::size_t i) {
    return DeviationSample{face_points[i], d_dep[i], dep_tags[i].layer, dep_tags[i].line,
                           dep_triangles[i]};
  };

  // Per layer (layer of the nearest deposit voxel); z = top of that layer's surface voxels.
  // Distances grouped by layer with a counting sort (sample order kept within a layer).
  const int max_layer = highest_layer(surface.face_tags);
  const std::size_t n_layers = max_layer < 0 ? 0 : static_cast<std::size_t>(max_layer) + 1;
  std::vector<LayerDeviation> layers(n_layers);
  std::vector<std::size_t> dep_begin, mesh_begin;
  std::vector<double> dep_values, mesh_values, dep_weights;
  // The highest surface voxel of each layer (a voxel's centre height grows with its z key).
  std::vector<int> top_key(n_layers, std::numeric_limits<int>::min());
  // The two directions need nothing from each other: side by side, each with its statistics
  // and per-layer figures (each is parallel inside; together they fill the gaps of either).
  const auto mesh_tag = [&](std::size_t i) {
    return surface.faces.empty() ? VoxelTag{} : surface.face_tags[nearest[i]];
  };
  tbb::parallel_invoke(
      [&] {
        // The faces come cell by cell (cells of 4 voxels, near_mm at the defaults and no
        // wider): the non-empty cells are the groups.
        target.signed_distances(offset, face_points, std::max(4.0 * v, settings.tolerance_mm),
                                d_dep, &dep_triangles,
                                surface.point_groups.empty() ? detail::face_cell_groups(surface)
                                                             : surface.point_groups);
        // The longer direction: its figures for the whole and per layer side by side too.
        tbb::parallel_invoke(
            [&] { out.deposit_to_mesh = deviation_stats(d_dep, face_area, settings.tolerance_mm); },
            [&] {
              group_by_layer(
                  n_layers, d_dep.size(),
                  [&](std::size_t i) { return static_cast<int>(dep_tags[i].layer); }, d_dep,
                  dep_begin, dep_values, face_area, &dep_weights);
              layer_stats(layers, dep_begin, dep_values, &LayerDeviation::deposit_to_mesh,
                          settings.tolerance_mm, dep_weights);
            });
      },
      [&] {
        if (weighted && bead_index)
          to_bead_surface(surface, beads, *bead_index, sorted.points, sorted.nearest, sorted.d);
        sorted.unsort(d_query, nearest);
        const std::span<const double> d_mesh(d_query.data(), ns);
        out.mesh_to_deposit = deviation_stats(d_mesh, settings.tolerance_mm);
        group_by_layer(
            n_layers, ns, [&](std::size_t i) { return static_cast<int>(mesh_tag(i).layer); },
            d_mesh, mesh_begin, mesh_values);
        layer_stats(layers, mesh_begin, mesh_values, &LayerDeviation::mesh_to_deposit,
                    settings.tolerance_mm);
        for (std::size_t i = 0; i < surface.faces.size(); ++i) {
          const int layer = surface.face_tags[i].layer;
          if (layer < 0) continue;
          int& t = top_key[static_cast<std::size_t>(layer)];
          t = std::max(t, surface.faces[i].voxel.z);
        }
      });
  const std::span<const double> d_mesh(d_query.data(), ns);
  out.vertex_deviation_mm.assign(d_query.begin() + static_cast<std::ptrdiff_t>(ns), d_query.end());
  const auto mesh_sample = [&](std::size_t i) {
    const VoxelTag tag = mesh_tag(i);
    return DeviationSample{query_points[i], d_mesh[i], tag.layer, tag.line, samples[i].triangle};
  };
  number_layers(layers, top_key, deposit);
  wall_roughness(mesh, detail::DeviationTargetAccess::sharp_edges(target), d_dep, dep_triangles,
                 dep_tags, face_area, face_points, d_mesh, samples,
                 std::span<const Vec3>(query_points.data(), ns), offset, v, layers, out);
  for (std::size_t l = 0; l < n_layers;
       ++l)  // layers no sample of either direction is nearest to: none
    if (dep_begin[l] != dep_begin[l + 1] || mesh_begin[l] != mesh_begin[l + 1])
      out.per_layer.push_back(layers[l]);

  // Regions: missing = design surface the deposit does not reach; excess = deposit surface
  // beyond the design.
  find_regions(settings, v, spacing, d_mesh, d_dep, face_area, mesh_sample, dep_sample, out);

  if (settings.keep_samples) {  // the arrays computed above become the columns, no copy
    DeviationSamples& ms = out.mesh_samples;
    tbb::parallel_invoke([&] { ms.tags.resize(ns); }, [&] { ms.triangles.resize(ns); });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, ns, 1 << 14),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          ms.tags[i] = mesh_tag(i);
                          ms.triangles[i] = samples[i].triangle;
                        }
                      });
    query_points.resize(ns);
    ms.positions_mm = std::move(query_points);
    d_query.resize(ns);
    ms.distances_mm = std::move(d_query);
    DeviationSamples& ds = out.deposit_samples;
    ds.positions_mm = surface.points_mm.empty() ? std::move(centres) : std::move(surface.points_mm);
    ds.distances_mm = std::move(d_dep);
    ds.tags =
        surface.point_tags.empty() ? std::move(surface.face_tags) : std::move(surface.point_tags);
    ds.triangles = std::move(dep_triangles);
  }
  if (settings.keep_filled_volume) out.filled_volume = filled_volume_of(surface);
  return out;
}

}  // namespace printtwin

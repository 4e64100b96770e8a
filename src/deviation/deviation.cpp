// compute_deviation: the two-sided comparison of a deposit and a placed mesh.
#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

#include "printtwin/deviation.hpp"

namespace printtwin {

Result<DeviationResult> compute_deviation(const Mesh& mesh, const VoxelGrid& deposit,
                                          const DeviationSettings& settings, const Box3& part_box_mm) {
  if (mesh.triangles.empty()) return bad_input("deviation: the mesh has no triangles");
  auto target = DeviationTarget::build(mesh, settings, deposit.voxel_mm());
  if (!target) return target.error();
  return compute_deviation(*target, Vec3::Zero(), deposit, settings, part_box_mm);
}

Result<DeviationResult> compute_deviation(const DeviationTarget& target, const Vec3& offset,
                                          const VoxelGrid& deposit, const DeviationSettings& settings,
                                          const Box3& part_box_mm) {
  const Mesh& mesh = target.mesh();
  if (mesh.triangles.empty()) return bad_input("deviation: the mesh has no triangles");
  if (!(settings.tolerance_mm > 0))
    return usage_error("deviation: tolerance must be > 0 mm, got " + std::to_string(settings.tolerance_mm));
  if (settings.mesh_sample_spacing_mm < 0)
    return usage_error("deviation: mesh sample spacing must be >= 0 mm");
  const double v = deposit.voxel_mm();
  const double spacing = settings.mesh_sample_spacing_mm > 0 ? settings.mesh_sample_spacing_mm : 2.0 * v;

  DeviationResult out;
  out.tolerance_mm = settings.tolerance_mm;
  out.mesh_volume_mm3 = target.volume_mm3();

  // The analysed region: the mesh and the part's extrusions, with a margin for excess.
  Box3 region{target.bbox_mm().min + offset, target.bbox_mm().max + offset};
  region.extend(part_box_mm);
  region.min -= Vec3::Constant(settings.region_margin_mm);
  region.max += Vec3::Constant(settings.region_margin_mm);
  const DepositSurface surface = extract_outer_surface(deposit, region, settings.seal_gap_mm);
  out.deposit_volume_mm3 = static_cast<double>(surface.occupied_voxels) * v * v * v;
  out.surface_faces = surface.faces.size();
  for (std::size_t i = 0; i < surface.faces.size(); ++i)  // a voxel's faces are consecutive
    if (i == 0 || !(surface.faces[i].voxel == surface.faces[i - 1].voxel)) ++out.surface_voxels;

  // Deposit -> mesh, from every exposed face centre.
  const std::vector<Vec3>& face_points = surface.face_centers_mm;
  std::vector<double> d_dep;
  std::vector<std::uint32_t> dep_triangles;
  target.signed_distances(offset, face_points, std::max(4.0 * v, settings.tolerance_mm), d_dep, &dep_triangles);
  std::vector<DeviationSample> dep_samples(face_points.size());
  for (std::size_t i = 0; i < face_points.size(); ++i)
    dep_samples[i] = {face_points[i], d_dep[i], surface.face_tags[i].layer, surface.face_tags[i].line,
                      dep_triangles[i]};

  // Mesh -> deposit, from area-uniform samples (the target's when drawn alike).
  std::vector<SurfaceSample> own_samples;
  std::span<const SurfaceSample> samples = target.samples();
  if (target.sample_spacing_mm() != spacing || target.sample_seed() != settings.seed) {
    own_samples = sample_surface(mesh, spacing, settings.seed);
    samples = own_samples;
  }
  // The samples and the mesh's vertices (for the per-vertex deviation) in one search.
  const std::size_t ns = samples.size();
  std::vector<Vec3> query_points(ns + mesh.vertices_mm.size());
  for (std::size_t i = 0; i < ns; ++i) query_points[i] = samples[i].position_mm + offset;
  for (std::size_t i = 0; i < mesh.vertices_mm.size(); ++i) query_points[ns + i] = mesh.vertices_mm[i] + offset;
  std::vector<double> d_query;
  std::vector<std::uint32_t> nearest;
  distances_to_deposit(surface, query_points, d_query, &nearest);
  const std::span<const double> d_mesh(d_query.data(), ns);
  out.vertex_deviation_mm.assign(d_query.begin() + static_cast<std::ptrdiff_t>(ns), d_query.end());
  std::vector<DeviationSample> mesh_samples(ns);
  for (std::size_t i = 0; i < ns; ++i) {
    const VoxelTag tag = surface.faces.empty() ? VoxelTag{} : surface.face_tags[nearest[i]];
    mesh_samples[i] = {query_points[i], d_mesh[i], tag.layer, tag.line, samples[i].triangle};
  }

  out.deposit_to_mesh = deviation_stats(d_dep, settings.tolerance_mm);
  out.mesh_to_deposit = deviation_stats(d_mesh, settings.tolerance_mm);

  // Per layer (layer of the nearest deposit voxel); z = top of that layer's surface voxels.
  // Distances grouped by layer with a counting sort (sample order kept within a layer).
  int max_layer = -1;
  for (const auto& t : surface.face_tags) max_layer = std::max(max_layer, static_cast<int>(t.layer));
  const auto n_layers = static_cast<std::size_t>(max_layer + 1);
  const auto group = [&](const std::vector<DeviationSample>& list, std::vector<std::size_t>& begin,
                         std::vector<double>& values) {
    begin.assign(n_layers + 1, 0);
    for (const auto& x : list)
      if (x.layer >= 0) ++begin[static_cast<std::size_t>(x.layer) + 1];
    for (std::size_t l = 0; l < n_layers; ++l) begin[l + 1] += begin[l];
    values.resize(begin[n_layers]);
    std::vector<std::size_t> fill(begin.begin(), begin.end() - 1);
    for (const auto& x : list)
      if (x.layer >= 0) values[fill[static_cast<std::size_t>(x.layer)]++] = x.distance_mm;
  };
  std::vector<std::size_t> dep_begin, mesh_begin;
  std::vector<double> dep_values, mesh_values;
  group(dep_samples, dep_begin, dep_values);
  group(mesh_samples, mesh_begin, mesh_values);
  // The highest surface voxel of each layer (a voxel's centre height grows with its z key).
  std::vector<int> top_key(n_layers, std::numeric_limits<int>::min());
  for (std::size_t i = 0; i < dep_samples.size(); ++i) {
    const int layer = dep_samples[i].layer;
    if (layer < 0) continue;
    int& t = top_key[static_cast<std::size_t>(layer)];
    t = std::max(t, surface.faces[i].voxel.z);
  }
  std::vector<double> layer_top(n_layers, 0.0);
  for (std::size_t l = 0; l < n_layers; ++l)
    if (top_key[l] != std::numeric_limits<int>::min())
      layer_top[l] = deposit.center_mm(VoxelKey{0, 0, top_key[l]}).z() + 0.5 * v;
  for (std::size_t l = 0; l < n_layers; ++l) {
    if (dep_begin[l] == dep_begin[l + 1] && mesh_begin[l] == mesh_begin[l + 1]) continue;
    LayerDeviation ld;
    ld.layer = static_cast<int>(l);
    ld.z_mm = layer_top[l];
    ld.deposit_to_mesh = deviation_stats(std::span<const double>(dep_values).subspan(dep_begin[l], dep_begin[l + 1] - dep_begin[l]),
                                         settings.tolerance_mm);
    ld.mesh_to_deposit = deviation_stats(std::span<const double>(mesh_values).subspan(mesh_begin[l], mesh_begin[l + 1] - mesh_begin[l]),
                                         settings.tolerance_mm);
    out.per_layer.push_back(std::move(ld));
  }

  // Regions: missing = design surface the deposit does not reach; excess = deposit surface
  // beyond the design.
  const double radius = settings.cluster_radius_mm > 0 ? settings.cluster_radius_mm
                                                       : std::max(2.0 * v, 3.0 * spacing);
  std::vector<std::int32_t> missing_of, excess_of;
  auto missing = cluster_regions(mesh_samples, settings.tolerance_mm, radius, spacing * spacing,
                                 RegionKind::missing, settings.max_region_lines, &missing_of);
  auto excess = cluster_regions(dep_samples, settings.tolerance_mm, radius, v * v, RegionKind::excess,
                                settings.max_region_lines, &excess_of);
  // Clusters below the minimum area are voxel noise: not regions, not in the gate figures.
  const auto is_noise = [&](const std::vector<DeviationRegion>& regions, std::int32_t r) {
    return r >= 0 && regions[static_cast<std::size_t>(r)].area_mm2 < settings.min_region_area_mm2;
  };
  for (std::size_t i = 0; i < dep_samples.size(); ++i)
    if (!is_noise(excess, excess_of[i])) out.max_excess_mm = std::max(out.max_excess_mm, dep_samples[i].distance_mm);
  for (std::size_t i = 0; i < mesh_samples.size(); ++i)
    if (!is_noise(missing, missing_of[i]))
      out.max_deficit_mm = std::max(out.max_deficit_mm, -mesh_samples[i].distance_mm);
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
  if (settings.max_regions >= 0 && out.regions.size() > static_cast<std::size_t>(settings.max_regions))
    out.regions.resize(static_cast<std::size_t>(settings.max_regions));

  if (settings.keep_samples) {
    out.deposit_samples = std::move(dep_samples);
    out.mesh_samples = std::move(mesh_samples);
  }
  return out;
}

}  // namespace printtwin

// compute_deviation: the two-sided comparison of a deposit and a placed mesh.
#include <algorithm>
#include <cmath>
#include <map>

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
  std::vector<Vec3> face_points(surface.faces.size());
  for (std::size_t i = 0; i < surface.faces.size(); ++i) face_points[i] = surface.faces[i].center_mm;
  std::vector<double> d_dep;
  target.signed_distances(offset, face_points, std::max(4.0 * v, settings.tolerance_mm), d_dep);
  std::vector<DeviationSample> dep_samples(face_points.size());
  for (std::size_t i = 0; i < face_points.size(); ++i)
    dep_samples[i] = {face_points[i], d_dep[i], surface.face_tags[i].layer, surface.face_tags[i].line};

  // Mesh -> deposit, from area-uniform samples (the target's when drawn alike).
  std::vector<SurfaceSample> own_samples;
  std::span<const SurfaceSample> samples = target.samples();
  if (target.sample_spacing_mm() != spacing || target.sample_seed() != settings.seed) {
    own_samples = sample_surface(mesh, spacing, settings.seed);
    samples = own_samples;
  }
  std::vector<Vec3> mesh_points(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) mesh_points[i] = samples[i].position_mm + offset;
  std::vector<double> d_mesh;
  std::vector<std::uint32_t> nearest;
  distances_to_deposit(surface, mesh_points, d_mesh, &nearest);
  std::vector<DeviationSample> mesh_samples(mesh_points.size());
  for (std::size_t i = 0; i < mesh_points.size(); ++i) {
    const VoxelTag tag = surface.faces.empty() ? VoxelTag{} : surface.face_tags[nearest[i]];
    mesh_samples[i] = {mesh_points[i], d_mesh[i], tag.layer, tag.line};
  }
  std::vector<Vec3> vertices(mesh.vertices_mm.size());
  for (std::size_t i = 0; i < vertices.size(); ++i) vertices[i] = mesh.vertices_mm[i] + offset;
  distances_to_deposit(surface, vertices, out.vertex_deviation_mm, nullptr);

  out.deposit_to_mesh = deviation_stats(d_dep, settings.tolerance_mm);
  out.mesh_to_deposit = deviation_stats(d_mesh, settings.tolerance_mm);

  // Per layer (layer of the nearest deposit voxel); z = top of that layer's surface voxels.
  std::map<int, std::pair<std::vector<double>, std::vector<double>>> by_layer;
  std::map<int, double> layer_top;
  for (std::size_t i = 0; i < dep_samples.size(); ++i) {
    const int layer = dep_samples[i].layer;
    by_layer[layer].first.push_back(dep_samples[i].distance_mm);
    const double top = deposit.center_mm(surface.faces[i].voxel).z() + 0.5 * v;
    auto [it, inserted] = layer_top.try_emplace(layer, top);
    if (!inserted) it->second = std::max(it->second, top);
  }
  for (const auto& s : mesh_samples) by_layer[s.layer].second.push_back(s.distance_mm);
  for (const auto& [layer, d] : by_layer) {
    if (layer < 0) continue;
    LayerDeviation ld;
    ld.layer = layer;
    ld.z_mm = layer_top.count(layer) ? layer_top[layer] : 0.0;
    ld.deposit_to_mesh = deviation_stats(d.first, settings.tolerance_mm);
    ld.mesh_to_deposit = deviation_stats(d.second, settings.tolerance_mm);
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

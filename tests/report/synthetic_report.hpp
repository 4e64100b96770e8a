#pragma once
// A VerifyReport built in code, for the report tests and bench/report_bench.cpp: a UV
// sphere on the bed whose "print" has a known deviation field (layer-line ripple within
// tolerance, an excess bulge and a missing dent), with deposit and mesh samples, per-layer
// statistics, two regions, findings and gates. Deterministic.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "printtwin/verify.hpp"

namespace printtwin::test {

struct SyntheticSpec {
  int segments = 96;  ///< around the sphere (UV sphere: 2 * segments * (rings - 1) triangles)
  int rings = 48;
  double radius_mm = 12.0;
  double spacing_mm = 0.25;  ///< sample spacing of both sample sets
  double layer_mm = 0.2;
  double tolerance_mm = 0.2;
  /// Deposit samples per mesh sample (a voxel deposit exposes several faces per surface
  /// voxel: real runs have 2-4x more deposit samples than mesh samples).
  int deposit_per_mesh_sample = 1;
};

inline const Vec3 kSyntheticCenter(110.0, 110.0, 12.0);
inline const Vec3 kBulgeAt = kSyntheticCenter + Vec3(0.55, 0.45, 0.70).normalized() * 12.0;
inline const Vec3 kDentAt = kSyntheticCenter + Vec3(-0.30, -0.85, -0.45).normalized() * 12.0;

/// The known deviation field (mm) at a point of the sphere.
inline double synthetic_deviation(const Vec3& p, double layer_mm) {
  const double ripple = 0.04 * std::sin(2 * 3.14159265358979 * p.z() / layer_mm);
  const double bulge = 0.55 * std::exp(-(p - kBulgeAt).squaredNorm() / (2 * 2.2 * 2.2));
  const double dent = -0.85 * std::exp(-(p - kDentAt).squaredNorm() / (2 * 1.6 * 1.6));
  return ripple + bulge + dent;
}

inline Mesh make_uv_sphere(const Vec3& c, double r, int segments, int rings) {
  Mesh m;
  m.vertices_mm.push_back(c + Vec3(0, 0, -r));  // south pole
  for (int i = 1; i < rings; ++i) {
    const double th = 3.14159265358979 * i / rings - 0.5 * 3.14159265358979;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * 3.14159265358979 * j / segments;
      m.vertices_mm.push_back(
          c + r * Vec3(std::cos(th) * std::cos(ph), std::cos(th) * std::sin(ph), std::sin(th)));
    }
  }
  m.vertices_mm.push_back(c + Vec3(0, 0, r));  // north pole
  const auto ring = [&](int i, int j) {
    return static_cast<std::uint32_t>(1 + (i - 1) * segments + (j % segments));
  };
  const auto north = static_cast<std::uint32_t>(m.vertices_mm.size() - 1);
  for (int j = 0; j < segments; ++j) m.triangles.push_back({0, ring(1, j + 1), ring(1, j)});
  for (int i = 1; i + 1 < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      m.triangles.push_back({ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i + 1, j)});
    }
  for (int j = 0; j < segments; ++j)
    m.triangles.push_back({ring(rings - 1, j), ring(rings - 1, j + 1), north});
  return m;
}

inline DeviationStats synthetic_stats(std::vector<double> d, double tol) {
  DeviationStats s;
  s.samples = d.size();
  if (d.empty()) return s;
  double sum = 0, sum2 = 0, sum_abs = 0;
  std::size_t within = 0;
  s.min_mm = 1e300, s.max_mm = -1e300;
  for (double v : d) {
    sum += v, sum2 += v * v, sum_abs += std::abs(v);
    s.min_mm = std::min(s.min_mm, v), s.max_mm = std::max(s.max_mm, v);
    within += std::abs(v) <= tol ? 1 : 0;
  }
  const double n = static_cast<double>(d.size());
  s.mean_mm = sum / n;
  s.mean_abs_mm = sum_abs / n;
  s.rms_mm = std::sqrt(sum2 / n);
  s.std_mm = std::sqrt(std::max(0.0, sum2 / n - s.mean_mm * s.mean_mm));
  for (double& v : d) v = std::abs(v);
  std::sort(d.begin(), d.end());
  auto pct = [&](double p) {
    return d[std::min(d.size() - 1, static_cast<std::size_t>(p * (n - 1)))];
  };
  s.p50_abs_mm = pct(0.5), s.p95_abs_mm = pct(0.95), s.p99_abs_mm = pct(0.99);
  s.hausdorff_mm = d.back();
  s.within_tolerance_pct = 100.0 * static_cast<double>(within) / n;
  return s;
}

/// The whole synthetic report.
inline VerifyReport make_synthetic_report(const SyntheticSpec& spec = {}) {
  VerifyReport r;
  r.tool_version = "0.1.0-test";
  r.part_name = "synthetic_sphere";
  r.inputs = {{"mesh", "samples/models/synthetic_sphere.stl", std::string(64, 'a'), 12345},
              {"gcode", "synthetic_sphere.gcode", std::string(64, 'b'), 987654},
              {"printer", "ender3", "", 0}};
  r.settings.gates.tolerance_mm = spec.tolerance_mm;
  r.settings.voxel_mm = spec.spacing_mm;
  r.settings.mesh_sample_spacing_mm = spec.spacing_mm;
  r.settings.gcode_source = "file";
  r.placed_mesh = make_uv_sphere(kSyntheticCenter, spec.radius_mm, spec.segments, spec.rings);

  auto& dev = r.deviation;
  dev.tolerance_mm = spec.tolerance_mm;
  dev.registration_method = "auto";
  dev.registration_offset_mm = Vec3(110, 110, 0);
  for (const Vec3& v : r.placed_mesh.vertices_mm)
    dev.vertex_deviation_mm.push_back(synthetic_deviation(v, spec.layer_mm));

  // Fibonacci points on the sphere, one per spacing^2 of area.
  const double area = 4 * 3.14159265358979 * spec.radius_mm * spec.radius_mm;
  const auto n = static_cast<std::size_t>(area / (spec.spacing_mm * spec.spacing_mm));
  const double golden = 3.14159265358979 * (3.0 - std::sqrt(5.0));
  std::vector<double> dep_d, mesh_d;
  const int layers = static_cast<int>(std::ceil(2 * spec.radius_mm / spec.layer_mm));
  std::vector<std::vector<double>> layer_dep(static_cast<std::size_t>(layers)),
      layer_mesh(static_cast<std::size_t>(layers));
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double rr = std::sqrt(std::max(0.0, 1 - z * z));
    const Vec3 dir(rr * std::cos(golden * static_cast<double>(i)),
                   rr * std::sin(golden * static_cast<double>(i)), z);
    const Vec3 on = kSyntheticCenter + spec.radius_mm * dir;
    const double d = synthetic_deviation(on, spec.layer_mm);
    const int layer =
        std::clamp(static_cast<int>(std::floor(on.z() / spec.layer_mm)), 0, layers - 1);
    // Deposit surface sits at the deviation along the normal; the mesh sample on the surface.
    DeviationSample ds{on + d * dir, d, layer, static_cast<std::uint32_t>(1000 + 40 * layer)};
    DeviationSample ms{on, d, layer, static_cast<std::uint32_t>(1000 + 40 * layer)};
    dev.deposit_samples.push_back(ds);
    for (int k = 1; k < spec.deposit_per_mesh_sample; ++k) {
      DeviationSample extra = ds;
      extra.position_mm += 0.25 * spec.spacing_mm * k * Vec3(dir.y(), -dir.x(), 0.3);
      dev.deposit_samples.push_back(extra);
      dep_d.push_back(d);
      layer_dep[static_cast<std::size_t>(layer)].push_back(d);
    }
    dev.mesh_samples.push_back(ms);
    dep_d.push_back(d);
    mesh_d.push_back(d);
    layer_dep[static_cast<std::size_t>(layer)].push_back(d);
    layer_mesh[static_cast<std::size_t>(layer)].push_back(d);
  }
  dev.deposit_to_mesh = synthetic_stats(dep_d, spec.tolerance_mm);
  dev.mesh_to_deposit = synthetic_stats(mesh_d, spec.tolerance_mm);
  for (int l = 0; l < layers; ++l) {
    LayerDeviation ld;
    ld.layer = l;
    ld.z_mm = (l + 1) * spec.layer_mm;
    ld.deposit_to_mesh = synthetic_stats(layer_dep[static_cast<std::size_t>(l)], spec.tolerance_mm);
    ld.mesh_to_deposit =
        synthetic_stats(layer_mesh[static_cast<std::size_t>(l)], spec.tolerance_mm);
    dev.per_layer.push_back(ld);
  }
  // Two regions: the out-of-tolerance samples near the bulge and near the dent.
  for (const auto& [at, kind] :
       {std::pair{kBulgeAt, RegionKind::excess}, std::pair{kDentAt, RegionKind::missing}}) {
    DeviationRegion reg;
    reg.kind = kind;
    reg.layer_min = 1 << 30;
    for (const auto& s : dev.mesh_samples) {
      if (std::abs(s.distance_mm) <= spec.tolerance_mm || (s.position_mm - at).norm() > 6) continue;
      reg.bbox_mm.extend(s.position_mm);
      reg.layer_min = std::min(reg.layer_min, s.layer);
      reg.layer_max = std::max(reg.layer_max, s.layer);
      reg.area_mm2 += spec.spacing_mm * spec.spacing_mm;
      ++reg.samples;
      if (std::abs(s.distance_mm) > std::abs(reg.worst_mm)) {
        reg.worst_mm = s.distance_mm;
        reg.worst_position_mm = s.position_mm;
      }
    }
    for (long line = 1000 + 40L * reg.layer_min; line <= 1000 + 40L * reg.layer_max; line += 40)
      reg.gcode_lines.push_back(line);
    dev.regions.push_back(reg);
  }
  const double vol = 4.0 / 3.0 * 3.14159265358979 * std::pow(spec.radius_mm, 3);
  dev.mesh_volume_mm3 = vol;
  dev.deposit_volume_mm3 = vol * 1.004;

  r.check = {r.placed_mesh.triangles.size(),
             r.placed_mesh.vertices_mm.size(),
             vol,
             area,
             Box3{Vec3::Constant(-spec.radius_mm), Vec3::Constant(spec.radius_mm)},
             true,
             0,
             1,
             0};
  r.simulation.slicer = "PrusaSlicer";
  r.simulation.gcode_lines = 1000 + 40 * static_cast<std::size_t>(layers);
  r.simulation.moves = 30000;
  r.simulation.extrusion_moves = 25000;
  r.simulation.layers = layers;
  r.simulation.print_time_s = 3725.5;
  r.simulation.filament_mm = 2480.0;
  r.simulation.extruded_volume_mm3 = vol * 1.004;
  r.deposit.voxel_mm = spec.spacing_mm;
  r.deposit.voxels = 1000000;
  r.deposit.surface_voxels = dev.deposit_samples.size();
  r.deposit.part_bbox_mm = bounding_box(r.placed_mesh);
  r.deposit.bbox_mm = r.deposit.part_bbox_mm;

  Finding overhang;
  overhang.severity = Severity::warning;
  overhang.code = "overhang";
  overhang.message = "Overhang of 62 deg over 1.8 cm2 without support (limit 50 deg)";
  overhang.position_mm = kSyntheticCenter + Vec3(0, 0, -9);
  overhang.layer = 10;
  r.findings.push_back(overhang);
  for (std::size_t i = 0; i < dev.regions.size(); ++i) {
    const auto& reg = dev.regions[i];
    Finding f;
    f.severity = Severity::error;
    f.code = "deviation_out_of_tolerance";
    f.message = std::string(reg.kind == RegionKind::missing ? "Missing" : "Excess") +
                " material up to " + std::to_string(reg.worst_mm).substr(0, 5) +
                " mm <beyond> the \"tolerance\" & limit";
    f.position_mm = reg.worst_position_mm;
    f.layer = reg.layer_min;
    f.line = reg.gcode_lines.empty() ? 0 : reg.gcode_lines.front();
    r.findings.push_back(f);
  }
  const double excess = std::max(dev.deposit_to_mesh.max_mm, dev.mesh_to_deposit.max_mm);
  const double deficit = -std::min(dev.deposit_to_mesh.min_mm, dev.mesh_to_deposit.min_mm);
  dev.max_excess_mm = excess;
  dev.max_deficit_mm = deficit;
  r.gates = {{"max_excess", spec.tolerance_mm, excess, excess <= spec.tolerance_mm},
             {"max_deficit", spec.tolerance_mm, deficit, deficit <= spec.tolerance_mm},
             {"no_error_findings", 0, 2, false}};
  r.pass = false;
  r.timings = {{"load", 0.012}, {"simulate", 0.4}, {"deposit", 0.9}, {"deviation", 1.1}};
  return r;
}

}  // namespace printtwin::test

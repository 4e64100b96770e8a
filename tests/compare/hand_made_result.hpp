#pragma once
// A hand-made comparison (numbers chosen, not measured) shared by the compare tests.
#include <algorithm>

#include "printtwin/compare.hpp"

namespace printtwin::test {

// A hand-made comparison of 6 variants (numbers chosen, not measured).
inline CompareResult hand_made_result() {
  CompareResult r;
  r.tool_version = "0.1.0";
  r.part.name = "ramp";
  r.part.path = "samples/models/ramp.stl";
  r.part.sha256 = std::string(64, 'a');
  r.part.triangles = 12;
  r.part.volume_mm3 = 4000;
  r.part.area_mm2 = 1600.5;
  r.part.sloped_area_mm2 = 447.2;
  r.part.bbox_mm.min = Vec3(0, 0, 0);
  r.part.bbox_mm.max = Vec3(20, 20, 10);
  r.printer = "ender3";
  r.verify.gates.tolerance_mm = 0.2;
  r.verify.gates.max_rms_mm = 0.15;
  r.plan_id = std::string(64, 'b');
  SweepSpec spec;
  spec.axes = {*parse_sweep_axis("layer_height=0.1,0.15,0.2,0.3")};
  spec.gcodes = {"prusa.gcode", "broken.gcode"};
  auto variants = *expand_variants(spec);
  r.variant_count = static_cast<int>(variants.size());
  const double time_s[] = {3600, 2500, 1900, 1300, 2000, 0};
  const double d2m[] = {0.040, 0.055, 0.070, 0.105, 0.090, 0};
  const double m2d[] = {0.050, 0.060, 0.080, 0.115, 0.075, 0};
  for (std::size_t i = 0; i < variants.size(); ++i) {
    VariantResult v;
    v.variant = variants[i];
    if (i == 5) {
      v.ran = false;
      v.error = "broken.gcode:12: expected a number after X";
      r.variants.push_back(v);
      continue;
    }
    v.ran = true;
    v.slicer = i < 4 ? "printtwin" : "PrusaSlicer 2.5.0";
    v.layers = static_cast<int>(10 / (0.1 + 0.05 * static_cast<double>(i)));
    v.layer_height_mm = 0.1 + 0.05 * static_cast<double>(i);
    v.print_time_s = time_s[i];
    v.filament_m = 1.5 + 0.1 * static_cast<double>(i);
    v.filament_g = v.filament_m * 2.98;
    v.deposit_to_mesh.samples = 1000 + i;
    v.deposit_to_mesh.rms_mm = d2m[i];
    v.deposit_to_mesh.p95_mm = 2 * d2m[i];
    v.deposit_to_mesh.max_excess_mm = 3 * d2m[i];
    v.deposit_to_mesh.max_deficit_mm = 2.5 * d2m[i];
    v.deposit_to_mesh.slope_rms_mm = 1.5 * d2m[i];
    v.deposit_to_mesh.slope_samples = 300;
    v.mesh_to_deposit.samples = 2000 + i;
    v.mesh_to_deposit.rms_mm = m2d[i];
    v.mesh_to_deposit.p95_mm = 2 * m2d[i];
    v.mesh_to_deposit.max_excess_mm = 2 * m2d[i];
    v.mesh_to_deposit.max_deficit_mm = 3 * m2d[i];
    v.mesh_to_deposit.slope_rms_mm = 1.5 * m2d[i];
    v.mesh_to_deposit.slope_samples = 600;
    v.rms_mm = combined_rms_mm(d2m[i], m2d[i]);
    v.slope_rms_mm = combined_rms_mm(1.5 * d2m[i], 1.5 * m2d[i]);
    v.missing_regions = static_cast<int>(i);
    v.excess_regions = 1;
    v.warning_findings = 2;
    v.gates = {{"max_excess", 0.2, std::max(3 * d2m[i], 2 * m2d[i]), 3 * d2m[i] <= 0.2},
               {"max_rms", 0.15, v.rms_mm, v.rms_mm <= 0.15}};
    v.pass = v.gates[0].pass && v.gates[1].pass;
    v.top_regions = {{"missing", -0.31, 4.5, 3, 9, Vec3(110, 112.5, 1.2)}};
    v.report_dir = "variants/0" + std::to_string(i) + "-x";
    v.run_time_s = 1.25 * static_cast<double>(i + 1);
    r.variants.push_back(v);
  }
  mark_pareto(r.variants);
  return r;
}

}  // namespace printtwin::test

// report.json of `printtwin verify` (schema in docs/report-schema.md) and the output folder.
#include <cmath>
#include <nlohmann/json.hpp>

#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "printtwin/verify.hpp"

namespace printtwin {

namespace {

using nlohmann::ordered_json;

/// Numbers rounded to 1e-6 (a nanometre for mm values) so that the text does not depend on
/// the last bits of floating-point sums; non-finite values become null.
ordered_json num(double v) {
  if (!std::isfinite(v)) return nullptr;
  const double r = std::round(v * 1e6) / 1e6;
  return r == 0 ? 0.0 : r;  // no "-0.0"
}

ordered_json vec(const Vec3& v) {
  return ordered_json::array({num(v.x()), num(v.y()), num(v.z())});
}

ordered_json box(const Box3& b) {
  if (b.empty()) return nullptr;
  return ordered_json{{"min", vec(b.min)}, {"max", vec(b.max)}};
}

ordered_json stats(const DeviationStats& s) {
  return ordered_json{{"samples", s.samples},
                      {"min_mm", num(s.min_mm)},
                      {"max_mm", num(s.max_mm)},
                      {"mean_mm", num(s.mean_mm)},
                      {"mean_abs_mm", num(s.mean_abs_mm)},
                      {"rms_mm", num(s.rms_mm)},
                      {"std_mm", num(s.std_mm)},
                      {"p50_mm", num(s.p50_abs_mm)},
                      {"p95_mm", num(s.p95_abs_mm)},
                      {"p99_mm", num(s.p99_abs_mm)},
                      {"hausdorff_mm", num(s.hausdorff_mm)},
                      {"within_tolerance_pct", num(s.within_tolerance_pct)}};
}

ordered_json finding(const Finding& f) {
  ordered_json j{
      {"severity", std::string(to_string(f.severity))}, {"code", f.code}, {"message", f.message}};
  if (f.position_mm) j["position_mm"] = vec(*f.position_mm);
  if (f.extent_mm) j["extent_mm"] = box(*f.extent_mm);
  if (f.line) j["line"] = *f.line;
  if (f.layer) j["layer"] = *f.layer;
  if (f.face) j["face"] = *f.face;
  if (f.value) j["value"] = num(*f.value);
  j["count"] = f.count;
  return j;
}

ordered_json optional_mm(const std::optional<double>& v) {
  return v ? num(*v) : ordered_json(nullptr);
}

}  // namespace

namespace {
/// The registration: the transform (matrix, axis-angle, angles), how it was found and how
/// well it fits (docs/registration.md).
ordered_json registration_json(const Registration& reg, const DeviationResult& d) {
  const RigidTransform& t = reg.transform;
  ordered_json rows = ordered_json::array();
  for (int i = 0; i < 3; ++i)
    rows.push_back({num(t.rotation(i, 0)), num(t.rotation(i, 1)), num(t.rotation(i, 2))});
  const Eigen::AngleAxisd aa(t.rotation);
  const bool turned = std::abs(aa.angle()) > 1e-12;
  return ordered_json{
      {"offset_mm", vec(d.registration_offset_mm)},
      {"method", d.registration_method},
      {"rotation", rows},
      {"axis_angle",
       {{"axis", turned ? vec(aa.axis()) : vec(Vec3::UnitZ())},
        {"angle_deg", num(turned ? aa.angle() * 180.0 / M_PI : 0.0)}}},
      {"euler_xyz_deg", vec(xyz_deg_of(t.rotation))},
      {"translation_mm", vec(t.translation_mm)},
      {"scale", num(t.scale)},
      {"object", reg.object.empty() ? ordered_json(nullptr) : ordered_json(reg.object)},
      {"object_id", reg.object_id},
      {"residual_rms_mm", num(reg.residual_rms_mm)},
      {"residual_p50_mm", num(reg.residual_p50_mm)},
      {"coverage_pct", num(reg.coverage_pct)},
      {"wall_points", reg.wall_points},
      {"candidates", reg.candidates},
      {"mesh_size_mm", vec(reg.mesh_size_mm)},
      {"printed_size_mm", vec(reg.printed_size_mm)},
      {"matches", reg.matches},
      {"mismatch", reg.mismatch.empty() ? ordered_json(nullptr) : ordered_json(reg.mismatch)}};
}

ordered_json slice_overrides_json(const VerifySettings& st) {
  ordered_json o = ordered_json::object();
  for (const auto& [key, value] : st.slice_overrides) o[key] = value;
  return o;
}
}  // namespace

std::string verify_report_json(const VerifyReport& r) {
  const DeviationResult& d = r.deviation;
  ordered_json j;
  j["schema"] = "printtwin.verify/" + std::to_string(r.schema_version);
  j["schema_version"] = r.schema_version;
  j["tool"] = {{"name", "printtwin"}, {"version", r.tool_version}};
  j["part"] = r.part_name;
  j["pass"] = r.pass;
  j["tolerance_mm"] = num(r.settings.gates.tolerance_mm);
  ordered_json gates = ordered_json::array();
  for (const auto& g : r.gates)
    gates.push_back(
        {{"name", g.name}, {"limit", num(g.limit)}, {"value", num(g.value)}, {"pass", g.pass}});
  j["gates"] = gates;

  ordered_json dev;
  dev["deposit_to_mesh"] = stats(d.deposit_to_mesh);
  dev["mesh_to_deposit"] = stats(d.mesh_to_deposit);
  dev["max_excess_mm"] = num(d.max_excess_mm);
  dev["max_deficit_mm"] = num(d.max_deficit_mm);
  dev["noise_regions"] = d.noise_regions;
  dev["noise_area_mm2"] = num(d.noise_area_mm2);
  dev["mesh_volume_mm3"] = num(d.mesh_volume_mm3);
  dev["deposit_volume_mm3"] = num(d.deposit_volume_mm3);
  dev["volume_difference_pct"] =
      d.mesh_volume_mm3 != 0
          ? num(100.0 * (d.deposit_volume_mm3 - d.mesh_volume_mm3) / d.mesh_volume_mm3)
          : ordered_json(nullptr);
  dev["surface_faces"] = d.surface_faces;
  dev["surface_voxels"] = d.surface_voxels;
  dev["layer_lines"] = {{"wall_rms_mm", num(d.wall_rms_mm)},
                        {"wall_rq_mm", num(d.wall_rq_mm)},
                        {"wall_area_mm2", num(d.wall_area_mm2)},
                        {"wall_mesh_rms_mm", num(d.wall_mesh_rms_mm)}};
  dev["registration"] = registration_json(r.registration, d);
  j["deviation"] = dev;

  ordered_json regions = ordered_json::array();
  for (const auto& g : d.regions) {
    regions.push_back({{"kind", g.kind == RegionKind::missing ? "missing" : "excess"},
                       {"bbox_mm", box(g.bbox_mm)},
                       {"layers", ordered_json::array({g.layer_min, g.layer_max})},
                       {"area_mm2", num(g.area_mm2)},
                       {"worst_mm", num(g.worst_mm)},
                       {"worst_at_mm", vec(g.worst_position_mm)},
                       {"samples", g.samples},
                       {"gcode_lines", g.gcode_lines}});
  }
  j["regions"] = regions;

  ordered_json findings = ordered_json::array();
  for (const auto& f : r.findings) findings.push_back(finding(f));
  j["findings"] = findings;

  ordered_json layers = ordered_json::array();
  for (const auto& l : d.per_layer) {
    const auto brief = [](const DeviationStats& s) {
      return ordered_json{{"samples", s.samples},
                          {"min_mm", num(s.min_mm)},
                          {"max_mm", num(s.max_mm)},
                          {"mean_mm", num(s.mean_mm)},
                          {"rms_mm", num(s.rms_mm)},
                          {"p95_mm", num(s.p95_abs_mm)},
                          {"within_tolerance_pct", num(s.within_tolerance_pct)}};
    };
    layers.push_back({{"layer", l.layer},
                      {"z_mm", num(l.z_mm)},
                      {"deposit_to_mesh", brief(l.deposit_to_mesh)},
                      {"mesh_to_deposit", brief(l.mesh_to_deposit)},
                      {"wall_rms_mm", num(l.wall_rms_mm)},
                      {"wall_rq_mm", num(l.wall_rq_mm)}});
  }
  j["per_layer"] = layers;

  j["check"] = {{"triangles", r.check.triangles},
                {"vertices", r.check.vertices},
                {"volume_mm3", num(r.check.volume_mm3)},
                {"area_mm2", num(r.check.area_mm2)},
                {"bbox_mm", box(r.check.bbox_mm)},
                {"watertight", r.check.watertight},
                {"errors", r.check.errors},
                {"warnings", r.check.warnings},
                {"infos", r.check.infos}};
  const SimulationSummary& s = r.simulation;
  j["simulate"] = {{"slicer", s.slicer},
                   {"gcode_lines", s.gcode_lines},
                   {"moves", s.moves},
                   {"extrusion_moves", s.extrusion_moves},
                   {"layers", s.layers},
                   {"print_time_s", num(s.print_time_s)},
                   {"filament_mm", num(s.filament_mm)},
                   {"extruded_volume_mm3", num(s.extruded_volume_mm3)},
                   {"extrusion_bbox_mm", box(s.extrusion_bbox_mm)},
                   {"errors", s.errors},
                   {"warnings", s.warnings},
                   {"infos", s.infos}};
  const DepositSummary& p = r.deposit;
  j["deposit"] = {{"voxel_mm", num(p.voxel_mm)},
                  {"voxels", p.voxels},
                  {"surface_voxels", p.surface_voxels},
                  {"volume_mm3", num(p.volume_mm3)},
                  {"extruded_volume_mm3", num(p.extruded_volume_mm3)},
                  {"bbox_mm", box(p.bbox_mm)},
                  {"part_bbox_mm", box(p.part_bbox_mm)},
                  {"memory_bytes", p.memory_bytes}};

  ordered_json inputs = ordered_json::array();
  for (const auto& in : r.inputs)
    inputs.push_back({{"role", in.role},
                      {"path", in.path},
                      {"sha256", in.sha256},
                      {"size_bytes", in.size_bytes}});
  j["inputs"] = inputs;
  j["printer"] = ordered_json::parse(printer_provenance_json(r.printer));
  const VerifySettings& st = r.settings;
  j["settings"] = {
      {"tolerance_mm", num(st.gates.tolerance_mm)},
      {"max_excess_mm", optional_mm(st.gates.max_excess_mm)},
      {"max_deficit_mm", optional_mm(st.gates.max_deficit_mm)},
      {"max_rms_mm", optional_mm(st.gates.max_rms_mm)},
      {"voxel_mm", num(st.voxel_mm)},
      {"conserve_volume", st.conserve_volume},
      {"mesh_sample_spacing_mm",
       num(st.mesh_sample_spacing_mm > 0 ? st.mesh_sample_spacing_mm : 2 * st.voxel_mm)},
      {"place_mm", st.place_mm ? vec(*st.place_mm) : ordered_json(nullptr)},
      {"place_rotation_deg",
       st.place_rotation_deg ? vec(*st.place_rotation_deg) : ordered_json(nullptr)},
      {"mesh_scale", st.mesh_scale ? num(*st.mesh_scale) : ordered_json(nullptr)},
      {"object", st.object.empty() ? ordered_json(nullptr) : ordered_json(st.object)},
      {"printer", st.printer},
      {"gcode_source", st.gcode_source},
      {"slice_config",
       st.slice_config_ini.empty() ? ordered_json(nullptr) : ordered_json(st.slice_config_ini)},
      {"slice_overrides", slice_overrides_json(st)},
      {"seed", st.seed},
      {"max_regions", st.max_regions}};
  ordered_json timings;
  for (const auto& t : r.timings) timings[t.stage] = num(t.seconds);
  if (!r.timings.empty()) timings["total"] = num(total_time_s(r));
  j["timings_s"] = timings;
  return j.dump(2) + "\n";
}

Status write_verify_outputs(const VerifyReport& report, const std::filesystem::path& out_dir) {
  if (auto s = write_file_atomic(out_dir / "report.json", verify_report_json(report)); !s) return s;
  return write_file_atomic(out_dir / "deviation.ply",
                           deviation_ply(report.placed_mesh, report.deviation.vertex_deviation_mm,
                                         report.settings.gates.tolerance_mm));
}

}  // namespace printtwin

// The part's side of verify: load, check and index the mesh once (PreparedPart).
#include <memory>

#include "printtwin/check.hpp"
#include "printtwin/io.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {

using verify_detail::count_severities;
using verify_detail::describe_input;
using verify_detail::deviation_settings_of;
using verify_detail::StageClock;
using verify_detail::validate_verify_settings;

namespace {

/// The part's size against the printer's build volume (wherever the G-code places it).
Status check_fits_printer(const Mesh& mesh, const PrinterProfile& printer,
                          const std::string& file) {
  const Vec3 size = bounding_box(mesh).size();
  const Vec3 room(printer.bed_max_x_mm - printer.bed_min_x_mm,
                  printer.bed_max_y_mm - printer.bed_min_y_mm, printer.max_z_mm);
  constexpr double eps = 1e-6;
  if (size.allFinite() && (size.array() <= room.array() + eps).all()) return Ok{};
  auto box = [](const Vec3& v) {
    return format_fixed(v.x(), 2) + " x " + format_fixed(v.y(), 2) + " x " +
           format_fixed(v.z(), 2) + " mm";
  };
  return bad_input("the part (" + box(size) + ") is larger than the build volume of " +
                       printer.name + " (" + box(room) +
                       "): it cannot print, so there is nothing to verify",
                   file);
}

}  // namespace

Status verify_detail::check_part(const Mesh& mesh, const PrinterProfile& printer,
                                 const MeshQuery* query, CheckSummary& summary,
                                 std::vector<Finding>& findings) {
  CheckSettings check_settings;
  check_settings.mesh_query = query;
  check_settings.thickness_beyond_limit =
      false;  // verify reports the thin-wall finding, not the thinnest wall
  auto check = check_printability(mesh, printer, check_settings);
  if (!check) return check.error();
  CheckSummary& c = summary;
  c = CheckSummary{};
  c.triangles = check->health.triangles;
  c.vertices = check->health.vertices;
  c.volume_mm3 = check->health.volume_mm3;
  c.area_mm2 = check->health.area_mm2;
  c.bbox_mm = check->health.bbox_mm;
  c.watertight = check->health.closed;
  count_severities(check->findings, c.errors, c.warnings, c.infos);
  findings = std::move(check->findings);
  return Ok{};
}

Result<PreparedPart> prepare_part(Mesh mesh, std::string name, VerifyInput mesh_input,
                                  const PrinterProfile& printer, const VerifySettings& settings) {
  if (mesh.triangles.empty()) return bad_input("the mesh has no triangles", mesh_input.path);
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  // The fit first, as check and slice do: a part larger than the printer cannot print, and
  // its deviation samples could outgrow the memory.
  if (auto st = check_fits_printer(mesh, printer, mesh_input.path); !st) return st.error();
  PreparedPart part;
  part.name = std::move(name);
  part.mesh_input = std::move(mesh_input);
  StageClock clock(part.timings);
  // The deviation's design side first: its BVH also serves the check's thickness rays.
  auto target = DeviationTarget::build(mesh, deviation_settings_of(settings), settings.voxel_mm);
  if (!target) return target.error();
  part.target = std::make_shared<const DeviationTarget>(std::move(*target));
  clock.lap("index");
  if (auto st = verify_detail::check_part(mesh, printer, &part.target->query(), part.check,
                                          part.check_findings);
      !st)
    return st.error();
  clock.lap("check");
  part.mesh = std::move(mesh);
  return part;
}

Result<PreparedPart> prepare_part(const std::filesystem::path& mesh_path,
                                  const PrinterProfile& printer, const VerifySettings& settings) {
  std::vector<StageTiming> load_timing;
  StageClock clock(load_timing);
  std::string bytes;  // read once: hashed for the provenance, then parsed
  auto mesh_in = describe_input("mesh", mesh_path, &bytes);
  if (!mesh_in) return mesh_in.error();
  auto mesh = load_mesh_from_memory(bytes, mesh_path);
  if (!mesh) return mesh.error();
  bytes = {};
  clock.lap("load");
  auto part = prepare_part(std::move(*mesh), mesh_path.stem().string(), std::move(*mesh_in),
                           printer, settings);
  if (!part) return part.error();
  part->timings.insert(part->timings.begin(), load_timing.begin(), load_timing.end());
  return part;
}

}  // namespace printtwin

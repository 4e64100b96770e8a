// What the steps of the verify pipeline share (pipeline.hpp): input provenance, settings
// checks, the deviation settings and the placement of the part in the G-code frame.
#include <optional>

#include "printtwin/io.hpp"
#include "printtwin/mesh_query.hpp"
#include "verify/pipeline.hpp"

namespace printtwin::verify_detail {

void count_severities(const std::vector<Finding>& findings, int& errors, int& warnings,
                      int& infos) {
  for (const auto& f : findings) {
    if (f.severity == Severity::error)
      ++errors;
    else if (f.severity == Severity::warning)
      ++warnings;
    else
      ++infos;
  }
}

Result<VerifyInput> describe_input(const std::string& role, const std::filesystem::path& path,
                                   std::string* content) {
  auto text = read_file(path);
  if (!text) return text.error();
  VerifyInput in{role, path.string(), sha256_hex(*text), text->size()};
  if (content != nullptr) *content = std::move(*text);
  return in;
}

namespace {

/// The transform of --place (rotation, then translation; --units scale first).
RigidTransform place_transform(const VerifySettings& settings) {
  RigidTransform t;
  if (settings.place_rotation_deg) t.rotation = rotation_from_xyz_deg(*settings.place_rotation_deg);
  t.scale = settings.mesh_scale.value_or(1.0);
  t.translation_mm = settings.place_mm.value_or(Vec3::Zero());
  return t;
}

}  // namespace

Result<Registration> place_part(const PreparedPart& part, const PartExtent& extent,
                                const VerifySettings& settings) {
  RegistrationOptions options;
  options.scale = settings.mesh_scale;
  options.object = settings.object;
  std::optional<MeshQuery> own;
  if (!part.target) {
    auto built = MeshQuery::build(part.mesh);
    if (!built) return built.error();
    own.emplace(std::move(*built));
  }
  const MeshQuery& query = part.target ? part.target->query() : *own;
  if (settings.place_mm) {
    if (extent.objects.empty()) {
      Registration r;
      r.transform = place_transform(settings);
      r.method = "--place";
      return r;
    }
    return evaluate_registration(part.mesh, query, extent, place_transform(settings), options);
  }
  return register_mesh(part.mesh, query, extent, options);
}

Mesh placed(const Mesh& mesh, const RigidTransform& t) {
  return t.translation_only() ? translated(mesh, t.translation_mm) : transformed(mesh, t);
}

Status validate_verify_settings(const VerifySettings& settings) {
  if (!(settings.gates.tolerance_mm > 0)) return usage_error("--tolerance must be > 0 mm");
  for (const auto& limit :
       {settings.gates.max_excess_mm, settings.gates.max_deficit_mm, settings.gates.max_rms_mm})
    if (limit && !(*limit >= 0))
      return usage_error("gate limits (--max-excess, --max-deficit, --max-rms) must be >= 0 mm");
  if (!(settings.voxel_mm >= 0.01 && settings.voxel_mm <= 1.0))
    return usage_error("--voxel must be between 0.01 and 1 mm, got " +
                       format_number(settings.voxel_mm));
  return Ok{};
}

DeviationSettings deviation_settings_of(const VerifySettings& settings) {
  DeviationSettings d;
  d.tolerance_mm = settings.gates.tolerance_mm;
  d.mesh_sample_spacing_mm = settings.mesh_sample_spacing_mm;
  d.seed = settings.seed;
  d.max_regions = settings.max_regions;
  d.keep_samples = true;
  return d;
}

}  // namespace printtwin::verify_detail

// The `printtwin check` JSON report (schema "printtwin.check", docs/check.md).
#include <cmath>
#include <nlohmann/json.hpp>

#include "printtwin/check.hpp"

namespace printtwin {

namespace {

using nlohmann::json;

/// Rounded to 1e-4 so that the text is stable across platforms; non-finite -> null.
json num(double v) {
  if (!std::isfinite(v)) return nullptr;
  const double r = std::round(v * 1e4) / 1e4;
  return r == 0 ? 0.0 : r;  // no "-0.0"
}

json vec(const Vec3& p) { return json::array({num(p.x()), num(p.y()), num(p.z())}); }

json box(const Box3& b) {
  if (b.empty()) return nullptr;
  return json{{"min", vec(b.min)}, {"max", vec(b.max)}, {"size", vec(b.size())}};
}

json opt_vec(const std::optional<Vec3>& p) { return p ? vec(*p) : json(nullptr); }

json health_json(const MeshHealth& h, const Vec3& offset) {
  json locations = json::array();
  for (const auto& p : h.self_intersection_locations_mm) locations.push_back(vec(p + offset));
  return json{{"triangles", h.triangles},
              {"vertices", h.vertices},
              {"shells", h.shells},
              {"closed", h.closed},
              {"volume_mm3", num(h.volume_mm3)},
              {"area_mm2", num(h.area_mm2)},
              {"bbox_mm", box(h.bbox_mm)},
              {"boundary_edges", h.boundary_edges},
              {"non_manifold_edges", h.non_manifold_edges},
              {"touching_edges", h.touching_edges},
              {"non_manifold_vertices", h.non_manifold_vertices},
              {"degenerate_faces", h.degenerate_faces},
              {"duplicate_faces", h.duplicate_faces},
              {"inconsistent_edges", h.inconsistent_edges},
              {"inverted_shells", h.inverted_shells},
              {"self_intersections_checked", h.self_intersections_checked},
              {"self_intersections", h.self_intersections},
              {"self_intersection_locations_mm", locations}};
}

}  // namespace

std::string check_report_to_json(const CheckReport& r, const CheckSource& source,
                                 const RepairResult* repair, const std::string& repair_file) {
  json doc;
  doc["schema"] = "printtwin.check";
  doc["schema_version"] = kCheckJsonVersion;
  doc["input"] = {{"file", source.file},
                  {"sha256", source.sha256},
                  {"units", source.units},
                  {"scale", num(source.scale)}};
  doc["printer"] = source.printer;
  doc["settings"] = {{"overhang_angle_deg", num(r.overhang_angle_deg)},
                     {"min_thickness_mm", num(r.min_thickness_limit_mm)},
                     {"line_width_mm", num(r.line_width_mm)}};
  // Mesh health is measured in the file's frame (bbox_mm there); positions elsewhere are in
  // the placed, machine frame.
  doc["mesh"] = health_json(r.health, r.placement.offset_mm);
  doc["placement"] = {{"offset_mm", vec(r.placement.offset_mm)},
                      {"bbox_mm", box(r.placement.bbox_mm)},
                      {"fits", r.placement.fits},
                      {"footprint_area_mm2", num(r.placement.footprint_area_mm2)},
                      {"footprint_mm", box(r.placement.footprint_mm)}};
  if (r.thickness) {
    const ThicknessResult& t = *r.thickness;
    doc["thickness"] = {
        {"min_thickness_mm", num(t.min_thickness_mm)},
        {"min_thickness_at_mm",
         std::isfinite(t.min_thickness_mm) ? vec(t.min_thickness_at_mm) : json(nullptr)},
        {"thin_faces", t.thin_faces},
        {"thin_area_mm2", num(t.thin_area_mm2)},
        {"min_gap_mm", num(t.min_gap_mm)},
        {"min_gap_at_mm", std::isfinite(t.min_gap_mm) ? vec(t.min_gap_at_mm) : json(nullptr)},
        {"narrow_gap_faces", t.narrow_gap_faces},
        {"narrow_gap_area_mm2", num(t.narrow_gap_area_mm2)}};
  } else {
    doc["thickness"] = nullptr;
  }
  json overhangs = json::array();
  for (const auto& o : r.overhangs) {
    json bridge = nullptr;
    if (o.bridge)
      bridge = {{"span_mm", num(o.bridge->span_mm)},
                {"direction_deg", num(o.bridge->direction_deg)},
                {"sag_mm", num(o.bridge->sag_mm)},
                {"flat", o.bridge->flat},
                {"ledge", o.bridge->ledge}};
    overhangs.push_back({{"area_mm2", num(o.area_mm2)},
                         {"max_angle_deg", num(o.max_angle_deg)},
                         {"centroid_mm", vec(o.centroid_mm)},
                         {"bbox_mm", box(o.bbox_mm)},
                         {"faces", o.faces},
                         {"bridge", bridge}});
  }
  doc["overhangs"] = overhangs;
  if (r.intersection_effect) {
    const IntersectionEffect& e = *r.intersection_effect;
    doc["intersection_effect"] = {{"measured", e.measured},
                                  {"layer_height_mm", num(e.layer_height_mm)},
                                  {"layers", e.layers},
                                  {"layers_changed", e.layers_changed},
                                  {"twice_volume_mm3", num(e.twice_volume_mm3)},
                                  {"max_twice_area_mm2", num(e.max_twice_area_mm2)},
                                  {"inverted_volume_mm3", num(e.inverted_volume_mm3)},
                                  {"max_inverted_area_mm2", num(e.max_inverted_area_mm2)}};
  }
  if (r.orientation) {
    auto cand = [](const OrientationCandidate& c) {
      return json{{"label", c.label},
                  {"down", vec(c.down)},
                  {"rotation_xyz_deg", vec(c.rotation_xyz_deg)},
                  {"overhang_mm2", num(c.overhang_mm2)},
                  {"contact_mm2", num(c.contact_mm2)},
                  {"height_mm", num(c.height_mm)}};
    };
    doc["orientation"] = {{"candidates", r.orientation->candidates},
                          {"better", r.orientation->better},
                          {"current", cand(r.orientation->current)},
                          {"best", cand(r.orientation->best)}};
  }
  json findings = json::array();
  std::size_t counts[3] = {0, 0, 0};
  for (const auto& f : r.findings) {
    ++counts[static_cast<int>(f.severity)];
    json j = {{"severity", std::string(to_string(f.severity))},
              {"code", f.code},
              {"message", f.message},
              {"position_mm", opt_vec(f.position_mm)},
              {"count", f.count}};
    if (f.extent_mm) j["extent_mm"] = box(*f.extent_mm);
    if (f.value) j["value"] = num(*f.value);
    if (f.face) j["face"] = *f.face;
    findings.push_back(j);
  }
  doc["findings"] = findings;
  doc["summary"] = {{"errors", counts[2]}, {"warnings", counts[1]}, {"info", counts[0]}};
  if (repair != nullptr) {
    json changes = json::array();
    for (const auto& c : repair->changes)
      changes.push_back({{"code", c.code}, {"count", c.count}, {"message", c.message}});
    const RepairCounters& k = repair->counters;
    doc["repair"] = {{"output", repair_file},
                     {"weld_tolerance_mm", repair->weld_tolerance_mm},
                     {"counters",
                      {{"edges_fixed", k.edges_fixed},
                       {"facets_removed", k.facets_removed},
                       {"facets_added", k.facets_added},
                       {"facets_reversed", k.facets_reversed},
                       {"backwards_edges", k.backwards_edges},
                       {"holes_filled", k.holes_filled},
                       {"degenerate_facets", k.degenerate_facets},
                       {"parts", k.parts},
                       {"nearby_edges", k.nearby_edges},
                       {"t_junction_edges", k.t_junction_edges}}},
                     {"changes", changes},
                     {"after", health_json(repair->after, Vec3::Zero())}};
  }
  doc["printable"] = r.printable;
  return doc.dump(2) + "\n";
}

}  // namespace printtwin

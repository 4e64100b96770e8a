// check_printability: mesh health, placement and print risks turned into Findings.
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {

constexpr double kPi = 3.14159265358979323846;
/// Layer height at which the effect of self-intersections is measured (a common 0.4 mm
/// nozzle layer; the outlines of finer layers differ by the same areas).
constexpr double kEffectLayerMm = 0.2;

std::string mm(double v) { return format_fixed(v, 2) + " mm"; }

std::string xyz(const Vec3& p) {
  return "(" + format_fixed(p.x(), 2) + ", " + format_fixed(p.y(), 2) + ", " +
         format_fixed(p.z(), 2) + ")";
}

Finding make_finding(Severity severity, std::string code, std::string message,
                     std::optional<Vec3> position = {}, long count = 1) {
  Finding f;
  f.severity = severity;
  f.code = std::move(code);
  f.message = std::move(message);
  f.position_mm = std::move(position);
  f.count = count;
  return f;
}

std::string plural(std::size_t n, const std::string& word) {
  if (n == 1) return "1 " + word;
  if (word == "vertex") return std::to_string(n) + " vertices";
  return std::to_string(n) + " " + word + "s";
}

Placement place(const Mesh& mesh, const PrinterProfile& printer, const CheckSettings& s,
                Mesh& placed) {
  Placement p;
  const Box3 box = bounding_box(mesh);
  Vec3 offset(0, 0, -box.min.z());
  if (s.center) {
    const double cx = s.center_x_mm.value_or(printer.bed_center_x_mm());
    const double cy = s.center_y_mm.value_or(printer.bed_center_y_mm());
    offset.x() = cx - box.center().x();
    offset.y() = cy - box.center().y();
  }
  placed = translated(mesh, offset);
  p.offset_mm = offset;
  p.bbox_mm = bounding_box(placed);
  constexpr double eps = 1e-6;
  p.fits = p.bbox_mm.min.x() >= printer.bed_min_x_mm - eps &&
           p.bbox_mm.min.y() >= printer.bed_min_y_mm - eps &&
           p.bbox_mm.max.x() <= printer.bed_max_x_mm + eps &&
           p.bbox_mm.max.y() <= printer.bed_max_y_mm + eps &&
           p.bbox_mm.max.z() <= printer.max_z_mm + eps;
  for (std::size_t f = 0; f < placed.triangles.size(); ++f) {
    const auto& t = placed.triangles[f];
    bool on_bed = true;
    for (auto v : t) on_bed = on_bed && placed.vertices_mm[v].z() <= s.bed_contact_mm;
    if (!on_bed) continue;
    const Vec3 n = triangle_normal(placed, f);
    if (!(n.z() < 0)) continue;  // only faces looking down at the bed hold the part
    p.footprint_area_mm2 += 0.5 * n.norm();
    for (auto v : t) p.footprint_mm.extend(placed.vertices_mm[v]);
  }
  return p;
}

void health_findings(const MeshHealth& h, const Vec3& offset, std::vector<Finding>& out) {
  auto at = [&](const std::optional<Vec3>& p) -> std::optional<Vec3> {
    if (!p) return std::nullopt;
    return Vec3(*p + offset);
  };
  if (h.boundary_edges > 0)
    out.push_back(make_finding(Severity::error, "open_mesh",
                               "the mesh is not closed: " + plural(h.boundary_edges, "open edge") +
                                   " (first at " + xyz(*at(h.first_boundary_edge_mm)) + ")",
                               at(h.first_boundary_edge_mm), static_cast<long>(h.boundary_edges)));
  if (h.non_manifold_edges > 0)
    out.push_back(make_finding(
        Severity::error, "non_manifold_edge",
        plural(h.non_manifold_edges, "edge") + " shared by more than two faces (first at " +
            xyz(*at(h.first_non_manifold_edge_mm)) + ")",
        at(h.first_non_manifold_edge_mm), static_cast<long>(h.non_manifold_edges)));
  if (h.inconsistent_edges > 0)
    out.push_back(make_finding(
        Severity::error, "inconsistent_orientation",
        plural(h.inconsistent_edges, "edge") +
            " between faces that point opposite ways (first at " +
            xyz(*at(h.first_inconsistent_edge_mm)) + "); inside and outside are ambiguous",
        at(h.first_inconsistent_edge_mm), static_cast<long>(h.inconsistent_edges)));
  if (h.inverted_shells > 0)
    out.push_back(make_finding(
        Severity::error, "inverted_shell",
        plural(h.inverted_shells, "closed shell") + " inside out (negative volume, not a cavity)",
        std::nullopt, static_cast<long>(h.inverted_shells)));
  if (h.non_manifold_vertices > 0)
    out.push_back(make_finding(Severity::warning, "non_manifold_vertex",
                               plural(h.non_manifold_vertices, "vertex") +
                                   " where separate fans of faces touch (first at " +
                                   xyz(*at(h.first_non_manifold_vertex_mm)) + ")",
                               at(h.first_non_manifold_vertex_mm),
                               static_cast<long>(h.non_manifold_vertices)));
  if (h.degenerate_faces > 0)
    out.push_back(make_finding(Severity::warning, "degenerate_face",
                               plural(h.degenerate_faces, "face") + " with zero area (first at " +
                                   xyz(*at(h.first_degenerate_face_mm)) + ")",
                               at(h.first_degenerate_face_mm),
                               static_cast<long>(h.degenerate_faces)));
  if (h.duplicate_faces > 0)
    out.push_back(
        make_finding(Severity::warning, "duplicate_face",
                     plural(h.duplicate_faces, "face") + " repeating the vertices of another face",
                     std::nullopt, static_cast<long>(h.duplicate_faces)));
  if (h.shells > 1)
    out.push_back(make_finding(
        Severity::info, "multiple_shells",
        "the mesh has " + std::to_string(h.shells) + " separate shells (parts or cavities)" +
            (h.touching_edges > 0 ? "; they touch along " + plural(h.touching_edges, "edge") +
                                        " (bodies exported together: the slicer merges them)"
                                  : ""),
        std::nullopt, static_cast<long>(h.shells)));
}

/// "; it fits rotated ..." or "; the largest scale that fits is ..." for does_not_fit.
std::string fit_advice_text(const Vec3& size, const PrinterProfile& printer) {
  const FitAdvice a = advise_fit(size, printer);
  const std::string dims = format_fixed(a.size_mm.x(), 2) + " x " + format_fixed(a.size_mm.y(), 2) +
                           " x " + format_fixed(a.size_mm.z(), 2) + " mm";
  if (a.scale >= 1.0) return "; it fits " + a.rotation + " (" + dims + ")";
  if (!(a.scale > 0)) return "";
  return "; no rotation by quarter turns fits; the largest scale that fits is " +
         format_fixed(100.0 * a.scale, 1) + " % (--scale " + format_fixed(a.scale, 3) + ")" +
         (a.rotation.empty() ? std::string(" as it stands") : ", " + a.rotation) + ": " + dims;
}

/// The self-intersection finding, graded by what the intersections do to the layers.
void self_intersection_finding(const MeshHealth& h, const std::optional<IntersectionEffect>& eff,
                               double line_width_mm, const Vec3& offset,
                               std::vector<Finding>& out) {
  if (h.self_intersections == 0) return;
  std::string where;
  for (std::size_t i = 0; i < h.self_intersection_locations_mm.size() && i < 3; ++i)
    where += (i ? ", " : "") + xyz(h.self_intersection_locations_mm[i] + offset);
  std::optional<Vec3> first;
  if (!h.self_intersection_locations_mm.empty())
    first = h.self_intersection_locations_mm.front() + offset;
  const std::string pairs = plural(h.self_intersections, "pair") + " of intersecting faces";
  const std::string at = " (first at " + where + ")";
  Severity sev = Severity::info;
  std::string msg;
  if (!eff || !eff->measured) {
    sev = Severity::warning;
    msg = pairs + at + "; their effect on the layers is not measured because the mesh is open";
  } else {
    const IntersectionEffect& e = *eff;
    const std::string layers = plural(e.layers_changed, "layer") + " of " +
                               std::to_string(e.layers) + " at " +
                               format_fixed(e.layer_height_mm, 2) + " mm";
    const std::string zr =
        e.changed_bbox_mm.empty()
            ? std::string()
            : ", z " + format_fixed(e.changed_bbox_mm.min.z() + offset.z(), 2) + ".." +
                  format_fixed(e.changed_bbox_mm.max.z() + offset.z(), 2) + " mm";
    const std::string twice = e.twice_volume_mm3 > 0
                                  ? format_fixed(e.twice_volume_mm3, 2) +
                                        " mm3 enclosed twice (up to " +
                                        format_fixed(e.max_twice_area_mm2, 2) + " mm2 per layer)"
                                  : std::string();
    if (e.inverted_volume_mm3 > 0) {
      // A fold at least one line square in some layer changes what is printed there.
      sev = e.max_inverted_area_mm2 >= line_width_mm * line_width_mm ? Severity::error
                                                                     : Severity::warning;
      msg = pairs + " fold the surface inside out in " + layers + zr + ": up to " +
            format_fixed(e.max_inverted_area_mm2, 2) + " mm2 per layer (" +
            format_fixed(e.inverted_volume_mm3, 2) +
            " mm3) is solid or empty depending on the slicer's fill rule" +
            (twice.empty() ? std::string() : "; " + twice) + at;
    } else if (e.twice_volume_mm3 > 0) {
      msg =
          pairs + " where the surface overlaps itself: " + twice + " in " + layers + zr +
          "; slicers merge the overlap and print it once (the layer outlines do not change), only "
          "volumes taken from the mesh count it twice" +
          at;
    } else {
      msg = pairs + " touch or cross without changing any layer outline (" +
            std::to_string(e.layers) + " layers cut at " + format_fixed(e.layer_height_mm, 2) +
            " mm through them: no area enclosed twice or inside out)" + at;
    }
  }
  Finding f =
      make_finding(sev, "self_intersection", msg, first, static_cast<long>(h.self_intersections));
  if (eff && !eff->changed_bbox_mm.empty()) {
    f.extent_mm = eff->changed_bbox_mm;
    f.extent_mm->min += offset;
    f.extent_mm->max += offset;
  }
  out.push_back(f);
}

}  // namespace

std::vector<OverhangRegion> find_overhangs(const Mesh& placed, const CheckSettings& settings) {
  const std::size_t nf = placed.triangles.size();
  // Leaning more than the limit from vertical: -n_z > sin(limit).
  const double limit = std::sin((settings.overhang_angle_deg + 0.01) * kPi / 180.0);
  std::vector<char> over(nf, 0);
  std::vector<double> angle(nf, 0);
  for (std::size_t f = 0; f < nf; ++f) {
    const auto& t = placed.triangles[f];
    bool on_bed = true;
    for (auto v : t) on_bed = on_bed && placed.vertices_mm[v].z() <= settings.bed_contact_mm;
    if (on_bed) continue;
    Vec3 n = triangle_normal(placed, f);
    const double len = n.norm();
    if (!(len > 0)) continue;
    n /= len;
    if (-n.z() > limit) {
      over[f] = 1;
      angle[f] = std::asin(std::clamp(-n.z(), -1.0, 1.0)) * 180.0 / kPi;
    }
  }
  // Regions: overhang faces joined across shared edges.
  std::vector<char> skip(nf);
  for (std::size_t f = 0; f < nf; ++f) skip[f] = over[f] == 0;
  const detail::EdgeTable edges = detail::build_edge_table(placed, skip);
  detail::UnionFind uf(nf);
  for (const auto& [b, e] : edges.groups)
    for (std::size_t i = b + 1; i < e; ++i)
      uf.unite(edges.half_edges[b].face, edges.half_edges[i].face);
  std::vector<std::uint32_t> region_of(nf, UINT32_MAX);
  std::vector<OverhangRegion> regions;
  std::vector<Vec3> weighted;
  for (std::size_t f = 0; f < nf; ++f) {
    if (over[f] == 0) continue;
    const std::uint32_t root = uf.find(static_cast<std::uint32_t>(f));
    if (region_of[root] == UINT32_MAX) {
      region_of[root] = static_cast<std::uint32_t>(regions.size());
      regions.emplace_back();
      regions.back().first_face = static_cast<std::uint32_t>(f);
      weighted.emplace_back(Vec3::Zero());
    }
    const std::uint32_t r = region_of[root];
    OverhangRegion& reg = regions[r];
    const double area = 0.5 * triangle_normal(placed, f).norm();
    reg.area_mm2 += area;
    reg.max_angle_deg = std::max(reg.max_angle_deg, angle[f]);
    ++reg.faces;
    weighted[r] += area * detail::face_centroid(placed, f);
    for (auto v : placed.triangles[f]) reg.bbox_mm.extend(placed.vertices_mm[v]);
  }
  // Each face's region (for the bridges' borders; until now only the roots held theirs).
  for (std::size_t f = 0; f < nf; ++f)
    if (over[f] != 0) region_of[f] = region_of[uf.find(static_cast<std::uint32_t>(f))];
  const auto bridges =
      detail::find_bridges(placed, region_of, regions, settings.min_overhang_area_mm2,
                           0.5 * (settings.line_width_mm > 0 ? settings.line_width_mm : 0.45),
                           settings.bridge_sag_mm, settings.bridge_sag_span_mm);
  std::vector<OverhangRegion> out;
  for (std::size_t r = 0; r < regions.size(); ++r) {
    if (regions[r].area_mm2 < settings.min_overhang_area_mm2) continue;
    regions[r].bridge = bridges[r];
    regions[r].centroid_mm = weighted[r] / regions[r].area_mm2;
    out.push_back(regions[r]);
  }
  std::stable_sort(out.begin(), out.end(), [](const OverhangRegion& a, const OverhangRegion& b) {
    return a.area_mm2 > b.area_mm2;
  });
  return out;
}

namespace {
/// Stray shells: small bodies far from the main one (a facet left kilometres away) make the
/// slicer place, scale and centre the whole object around them. Returns the box of the part
/// without them when there are any.
std::optional<Box3> stray_shell_findings(const CheckReport& rep, const Vec3& offset,
                                         std::vector<Finding>& out) {
  std::optional<Box3> main_body;
  const auto& boxes = rep.health.shell_bbox_mm;
  const auto& faces = rep.health.shell_faces;
  std::size_t main = 0;
  for (std::size_t i = 1; i < faces.size(); ++i)
    if (faces[i] > faces[main]) main = i;
  std::size_t stray = 0;
  double farthest = 0;
  std::optional<Vec3> first;
  Box3 kept;
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const double main_size = boxes[main].size().norm();
    const Vec3 gap =
        (boxes[i].min - boxes[main].max).cwiseMax(boxes[main].min - boxes[i].max).cwiseMax(0.0);
    // Stray: at most 1 % of the main body's faces, and farther from it than its own size.
    if (i != main && faces[i] * 100 <= faces[main] && gap.norm() > main_size) {
      ++stray;
      farthest = std::max(farthest, gap.norm());
      if (!first) first = boxes[i].center() + offset;
    } else {
      kept.extend(boxes[i]);
    }
  }
  if (stray > 0) {
    main_body = kept;
    const Vec3 ks = kept.size();
    out.push_back(make_finding(
        Severity::error, "stray_shell",
        plural(stray, "stray shell") + " up to " + mm(farthest) + " away from the part (first at " +
            xyz(*first) + "): the slicer places and sizes the object with them, " +
            format_fixed(rep.placement.bbox_mm.size().x(), 1) + " x " +
            format_fixed(rep.placement.bbox_mm.size().y(), 1) + " x " +
            format_fixed(rep.placement.bbox_mm.size().z(), 1) + " mm instead of " +
            format_fixed(ks.x(), 1) + " x " + format_fixed(ks.y(), 1) + " x " +
            format_fixed(ks.z(), 1) + " mm; delete them (admesh --remove-unconnected)",
        first, static_cast<long>(stray)));
  }
  return main_body;
}

/// Placement: does the part fit, does it rest on enough bed, is it tall and slender.
void placement_findings(const CheckReport& rep, const PrinterProfile& printer,
                        const CheckSettings& settings, const std::optional<Box3>& main_body,
                        std::vector<Finding>& out) {
  const Box3& pb = rep.placement.bbox_mm;
  const Vec3 size = pb.size();
  if (!rep.placement.fits) {
    Finding f = make_finding(
        Severity::error, "does_not_fit",
        "the part (" + format_fixed(size.x(), 2) + " x " + format_fixed(size.y(), 2) + " x " +
            format_fixed(size.z(), 2) + " mm, placed at x " + format_fixed(pb.min.x(), 2) + ".." +
            format_fixed(pb.max.x(), 2) + ", y " + format_fixed(pb.min.y(), 2) + ".." +
            format_fixed(pb.max.y(), 2) + ") does not fit the build volume of " + printer.name +
            " (x " + format_fixed(printer.bed_min_x_mm, 0) + ".." +
            format_fixed(printer.bed_max_x_mm, 0) + ", y " + format_fixed(printer.bed_min_y_mm, 0) +
            ".." + format_fixed(printer.bed_max_y_mm, 0) + ", z 0.." +
            format_fixed(printer.max_z_mm, 0) + " mm)" +
            (main_body ? std::string(
                             main_body->size().x() <= printer.bed_max_x_mm - printer.bed_min_x_mm &&
                                     main_body->size().y() <=
                                         printer.bed_max_y_mm - printer.bed_min_y_mm &&
                                     main_body->size().z() <= printer.max_z_mm
                                 ? "; without the stray shells it fits"
                                 : "; without the stray shells: " +
                                       fit_advice_text(main_body->size(), printer).substr(2))
                       : fit_advice_text(size, printer)),
        pb.center());
    f.extent_mm = pb;
    out.push_back(f);
  }
  const double bbox_xy_area = size.x() * size.y();
  if (rep.placement.footprint_area_mm2 < 0.05 * bbox_xy_area) {
    out.push_back(make_finding(
        Severity::warning, "small_bed_contact",
        "only " + format_fixed(rep.placement.footprint_area_mm2, 2) +
            " mm2 of the part rests on the bed (" +
            format_fixed(100.0 * rep.placement.footprint_area_mm2 / std::max(bbox_xy_area, 1e-12),
                         1) +
            " % of its footprint box): it may come loose; add a brim or a flat base",
        Vec3(pb.center().x(), pb.center().y(), 0.0)));
  }
  {
    const Box3& fp = rep.placement.footprint_mm.empty() ? pb : rep.placement.footprint_mm;
    const double base = std::min(fp.size().x(), fp.size().y());
    const double ratio = base > 0 ? size.z() / base : std::numeric_limits<double>::infinity();
    if (ratio > settings.slender_ratio) {
      Finding f = make_finding(Severity::warning, "tall_slender",
                               "the part is " + mm(size.z()) + " tall on a base " + mm(base) +
                                   " wide (ratio " + format_fixed(ratio, 1) + " > " +
                                   format_fixed(settings.slender_ratio, 1) +
                                   "): it may wobble or break while printing",
                               Vec3(pb.center().x(), pb.center().y(), pb.max.z()));
      f.value = ratio;
      out.push_back(f);
    }
  }
}

/// A bridge region's finding: info while its predicted sag is small, else a warning.
Finding bridge_finding(const OverhangRegion& r, const CheckSettings& settings) {
  const BridgeSpan& b = *r.bridge;
  const bool sags = b.sag_mm > settings.bridge_sag_warn_mm;
  const std::string where = format_fixed(r.area_mm2, 1) + " mm2 of " +
                            (b.flat ? "flat" : "arched") + " ceiling at " + xyz(r.centroid_mm) +
                            ", z " + format_fixed(r.bbox_mm.min.z(), 2) + ".." +
                            format_fixed(r.bbox_mm.max.z(), 2) + " mm,";
  const std::string what =
      b.ledge ? " reaches at most " + mm(b.span_mm) +
                    " beyond what holds it: a ledge that narrow prints without support"
              : " is held at both ends: it prints without support as a bridge of up to " +
                    mm(b.span_mm) + " (lines at " + format_fixed(b.direction_deg, 0) +
                    " deg), predicted to sag " + mm(b.sag_mm) + " at mid-span" +
                    (sags ? " (that much lower and rougher underside; support or a shorter "
                            "span keeps it flat)"
                          : "");
  Finding f =
      make_finding(sags ? Severity::warning : Severity::info, sags ? "bridge_sag" : "bridge",
                   where + what, r.centroid_mm, static_cast<long>(r.faces));
  f.extent_mm = r.bbox_mm;
  f.face = r.first_face;
  f.value = b.sag_mm;
  return f;
}

/// One finding per overhang region and per bridge (the largest `max_locations` of each), then
/// a count of the rest.
void overhang_findings(const CheckReport& rep, const CheckSettings& settings,
                       std::vector<Finding>& out) {
  double overhang_total = 0;
  std::size_t overhangs = 0, bridges = 0;
  for (const auto& r : rep.overhangs) {
    if (r.bridge) {
      if (bridges++ < settings.max_locations) out.push_back(bridge_finding(r, settings));
      continue;
    }
    overhang_total += r.area_mm2;
    if (overhangs++ >= settings.max_locations) continue;
    Finding f = make_finding(Severity::warning, "overhang",
                             format_fixed(r.area_mm2, 1) + " mm2 of surface leans up to " +
                                 format_fixed(r.max_angle_deg, 1) + " deg from vertical (limit " +
                                 format_fixed(settings.overhang_angle_deg, 1) + " deg) at " +
                                 xyz(r.centroid_mm) + ", z " + format_fixed(r.bbox_mm.min.z(), 2) +
                                 ".." + format_fixed(r.bbox_mm.max.z(), 2) + " mm: needs support",
                             r.centroid_mm, static_cast<long>(r.faces));
    f.extent_mm = r.bbox_mm;
    f.face = r.first_face;
    f.value = r.max_angle_deg;
    out.push_back(f);
  }
  if (overhangs > settings.max_locations)
    out.push_back(make_finding(
        Severity::info, "overhang_more",
        std::to_string(overhangs - settings.max_locations) + " more overhang regions not listed; " +
            format_fixed(overhang_total, 1) + " mm2 of overhang in all",
        std::nullopt, static_cast<long>(overhangs - settings.max_locations)));
  if (bridges > settings.max_locations)
    out.push_back(
        make_finding(Severity::info, "bridge_more",
                     std::to_string(bridges - settings.max_locations) + " more bridges not listed",
                     std::nullopt, static_cast<long>(bridges - settings.max_locations)));
}

/// Thin walls and narrow gaps from the thickness rays.
void thickness_findings(const CheckReport& rep, const ThicknessResult& t,
                        std::vector<Finding>& out) {
  if (t.thin_faces > 0) {
    Finding f = make_finding(
        Severity::warning, "thin_wall",
        "walls down to " + format_fixed(t.min_thickness_mm, 2) + " mm thick at " +
            xyz(t.min_thickness_at_mm) + ", thinner than " + mm(rep.min_thickness_limit_mm) +
            " over " + format_fixed(t.thin_area_mm2, 1) + " mm2 (z " +
            format_fixed(t.thin_bbox_mm.min.z(), 2) + ".." +
            format_fixed(t.thin_bbox_mm.max.z(), 2) + " mm): the slicer may drop or weaken them",
        t.min_thickness_at_mm, static_cast<long>(t.thin_faces));
    f.extent_mm = t.thin_bbox_mm;
    f.value = t.min_thickness_mm;
    out.push_back(f);
  }
  if (t.narrow_gap_faces > 0) {
    Finding f = make_finding(
        Severity::warning, "narrow_gap",
        "gaps or holes down to " + format_fixed(t.min_gap_mm, 2) + " mm wide at " +
            xyz(t.min_gap_at_mm) + ", narrower than one line width (" + mm(rep.line_width_mm) +
            ") over " + format_fixed(t.narrow_gap_area_mm2, 1) + " mm2 (z " +
            format_fixed(t.narrow_gap_bbox_mm.min.z(), 2) + ".." +
            format_fixed(t.narrow_gap_bbox_mm.max.z(), 2) + " mm): they will close up",
        t.min_gap_at_mm, static_cast<long>(t.narrow_gap_faces));
    f.extent_mm = t.narrow_gap_bbox_mm;
    f.value = t.min_gap_mm;
    out.push_back(f);
  }
}

/// Shells narrower than a line width across print as one thin line at best; narrower than
/// the thinnest line a slicer prints (about a third of the nozzle, PrusaSlicer's thin-wall
/// limit and printtwin's slicer default), not at all. When no shell prints, nothing does:
/// an error, so that the verdict says what the finding says.
void small_feature_findings(const CheckReport& rep, const PrinterProfile& printer,
                            const Vec3& offset, std::vector<Finding>& out) {
  const double vanish_mm = printer.nozzle_diameter_mm / 3.0;
  std::size_t narrow = 0, vanishing = 0;
  std::optional<Vec3> first_narrow, first_vanishing;
  for (const Box3& b : rep.health.shell_bbox_mm) {
    const double across = std::min(b.size().x(), b.size().y());
    if (across >= rep.line_width_mm) continue;
    ++narrow;
    if (!first_narrow) first_narrow = b.center() + offset;
    if (across < vanish_mm) {
      ++vanishing;
      if (!first_vanishing) first_vanishing = b.center() + offset;
    }
  }
  const std::size_t shells = rep.health.shell_bbox_mm.size();
  if (vanishing > 0 && vanishing == shells) {
    out.push_back(make_finding(Severity::error, "small_feature",
                               std::string(shells == 1 ? "the part is" : "every part is") +
                                   " narrower than the thinnest line a slicer prints (" +
                                   mm(vanish_mm) + ", a third of the nozzle) (at " +
                                   xyz(*first_vanishing) + "): nothing will print",
                               first_vanishing, static_cast<long>(vanishing)));
  } else if (vanishing > 0) {
    out.push_back(
        make_finding(Severity::warning, "small_feature",
                     plural(vanishing, "separate part") + " of " + std::to_string(shells) +
                         " narrower than the thinnest line a slicer prints (" + mm(vanish_mm) +
                         ") (first at " + xyz(*first_vanishing) + "): they will not print",
                     first_vanishing, static_cast<long>(vanishing)));
  } else if (narrow > 0) {
    out.push_back(make_finding(Severity::warning, "small_feature",
                               plural(narrow, "separate part") + " narrower than one line width (" +
                                   mm(rep.line_width_mm) + ") (first at " + xyz(*first_narrow) +
                                   "): printed as one thin line at best, weak or incomplete",
                               first_narrow, static_cast<long>(narrow)));
  }
}

/// The side to stand the part on (advice only; --orient applies it).
void orientation_finding(const OrientationAdvice& a, std::vector<Finding>& out) {
  if (!a.better) return;
  const Vec3& r = a.best.rotation_xyz_deg;
  Finding f =
      make_finding(Severity::info, "orientation",
                   "stood on " + a.best.label + " (rotate " + format_fixed(r.x(), 1) + ", " +
                       format_fixed(r.y(), 1) + ", " + format_fixed(r.z(), 1) +
                       " deg about X, Y, Z; --orient applies it) it needs " +
                       format_fixed(a.best.overhang_mm2, 1) + " mm2 of support instead of " +
                       format_fixed(a.current.overhang_mm2, 1) + " mm2 and rests " +
                       format_fixed(a.best.contact_mm2, 1) + " mm2 on the bed instead of " +
                       format_fixed(a.current.contact_mm2, 1) + " mm2 (best of " +
                       std::to_string(a.candidates) + " orientations)");
  f.value = a.current.overhang_mm2 - a.best.overhang_mm2;
  out.push_back(f);
}
}  // namespace

Result<CheckReport> check_printability(const Mesh& mesh, const PrinterProfile& printer,
                                       const CheckSettings& settings) {
  if (mesh.triangles.empty()) return bad_input("the mesh has no triangles");
  CheckReport rep;
  rep.min_thickness_limit_mm =
      settings.min_thickness_mm > 0 ? settings.min_thickness_mm : printer.nozzle_diameter_mm;
  rep.line_width_mm =
      settings.line_width_mm > 0 ? settings.line_width_mm : 1.125 * printer.nozzle_diameter_mm;

  rep.overhang_angle_deg = settings.overhang_angle_deg;
  rep.health = analyze_mesh_health(mesh);
  if (settings.self_intersections) {
    const SelfIntersections si = find_self_intersections(mesh, settings.max_locations, &rep.health);
    rep.health.self_intersections = si.pairs;
    rep.health.self_intersection_locations_mm = si.locations_mm;
    rep.health.self_intersections_checked = true;
    if (si.pairs > 0)
      rep.intersection_effect = rep.health.closed
                                    ? measure_intersection_effect(mesh, si.faces, kEffectLayerMm)
                                    : IntersectionEffect{};
  }

  Mesh placed;
  rep.placement = place(mesh, printer, settings, placed);
  const Vec3 offset = rep.placement.offset_mm;
  std::vector<Finding>& out = rep.findings;
  health_findings(rep.health, offset, out);
  self_intersection_finding(rep.health, rep.intersection_effect, rep.line_width_mm, offset, out);

  const std::optional<Box3> main_body = stray_shell_findings(rep, offset, out);

  placement_findings(rep, printer, settings, main_body, out);

  CheckSettings overhang_settings = settings;  // bridges sag as the printer's profile says
  overhang_settings.bridge_sag_mm = printer.bridge_sag_mm;
  overhang_settings.bridge_sag_span_mm = printer.bridge_sag_span_mm;
  overhang_settings.line_width_mm = rep.line_width_mm;
  rep.overhangs = find_overhangs(placed, overhang_settings);
  overhang_findings(rep, settings, out);

  // Thin walls and narrow gaps.
  auto thick =
      measure_thickness(placed, rep.min_thickness_limit_mm, rep.line_width_mm, settings.mesh_query,
                        rep.placement.offset_mm, settings.thickness_beyond_limit,
                        rep.health.shells > 1 || rep.health.self_intersections > 0);
  if (!thick) return thick.error();
  rep.thickness = *thick;
  thickness_findings(rep, *thick, out);
  small_feature_findings(rep, printer, offset, out);

  // Orientation: the side to stand it on (advice only; --orient applies it).
  rep.orientation = advise_orientation(mesh, settings);
  orientation_finding(*rep.orientation, out);

  std::stable_sort(out.begin(), out.end(), [](const Finding& a, const Finding& b) {
    return static_cast<int>(a.severity) > static_cast<int>(b.severity);
  });
  rep.printable = !has_errors(out);
  return rep;
}

}  // namespace printtwin

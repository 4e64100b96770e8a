// repair_mesh: CGAL Polygon_mesh_processing on a polygon soup, then a Surface_mesh.
// With self_intersections_cgal.cpp, the only files that include CGAL.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/stitch_borders.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/boost/graph/helpers.h>

#include <algorithm>
#include <map>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<P3>;
namespace PMP = CGAL::Polygon_mesh_processing;
using Polygon = std::vector<std::size_t>;

/// True when `b` lists the same points as `a` in the same cyclic order.
bool same_cycle(const std::vector<P3>& pa, const Polygon& a, const std::vector<P3>& pb,
                const Polygon& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t shift = 0; shift < a.size(); ++shift) {
    bool all = true;
    for (std::size_t i = 0; i < a.size() && all; ++i)
      all = pa[a[i]] == pb[b[(i + shift) % b.size()]];
    if (all) return true;
  }
  return false;
}

void add(std::vector<RepairChange>& changes, std::string code, std::size_t count,
         const std::string& message) {
  if (count > 0)
    changes.push_back({std::move(code), count, message + ": " + std::to_string(count)});
}

}  // namespace

Result<RepairResult> repair_mesh(const Mesh& mesh, const RepairSettings& settings) {
  RepairResult out;
  out.before = analyze_mesh_health(mesh);
  // Open seams first (admesh --nearby): their ends move together, then merge as duplicates.
  out.weld_tolerance_mm =
      settings.weld_tolerance_mm < 0 ? nearby_weld_tolerance_mm(mesh) : settings.weld_tolerance_mm;
  std::size_t welded = 0;
  const Mesh moved = out.weld_tolerance_mm > 0
                         ? detail::weld_nearby_vertices(mesh, out.weld_tolerance_mm, welded)
                         : mesh;
  // Then T-junctions: a face whose open edge has the other side's vertices on its middle is
  // split there (admesh has no such step; its --nearby leaves them open).
  std::size_t t_split = 0;
  // (Edges open by position are open by index, so a mesh without open edges has none.)
  const Mesh joined = out.weld_tolerance_mm > 0 && out.before.boundary_edges > 0
                          ? detail::split_t_junctions(moved, out.weld_tolerance_mm, t_split)
                          : moved;
  try {
    std::vector<P3> points;
    points.reserve(joined.vertices_mm.size());
    for (const auto& v : joined.vertices_mm) points.emplace_back(v.x(), v.y(), v.z());
    std::vector<Polygon> polygons;
    polygons.reserve(joined.triangles.size());
    for (const auto& t : joined.triangles) polygons.push_back({t[0], t[1], t[2]});

    // Each welded vertex now repeats its group's position and merges once.
    const std::size_t merged = PMP::merge_duplicate_points_in_polygon_soup(points, polygons);
    add(out.changes, "welded_vertices", welded,
        "vertices moved onto a vertex across an open seam (within " +
            format_fixed(out.weld_tolerance_mm, 4) + " mm)");
    add(out.changes, "merged_vertices", merged - std::min(merged, welded),
        "duplicate vertices merged");
    add(out.changes, "split_t_junctions", t_split,
        "faces split where the other side's vertices lay on their open edge (T-junctions)");

    // Zero-area faces (repeated index or collinear corners) carry no surface.
    std::size_t degenerate = 0;
    {
      Mesh tmp;
      tmp.vertices_mm.reserve(points.size());
      for (const auto& p : points) tmp.vertices_mm.emplace_back(p.x(), p.y(), p.z());
      std::vector<Polygon> kept;
      kept.reserve(polygons.size());
      for (const auto& poly : polygons) {
        tmp.triangles = {{static_cast<std::uint32_t>(poly[0]), static_cast<std::uint32_t>(poly[1]),
                          static_cast<std::uint32_t>(poly[2])}};
        if (detail::is_degenerate_face(tmp, 0))
          ++degenerate;
        else
          kept.push_back(poly);
      }
      polygons.swap(kept);
    }
    add(out.changes, "removed_degenerate_faces", degenerate, "zero-area faces removed");

    const std::size_t duplicates = PMP::merge_duplicate_polygons_in_polygon_soup(points, polygons);
    add(out.changes, "removed_duplicate_faces", duplicates, "duplicate faces removed");
    PMP::remove_isolated_points_in_polygon_soup(points, polygons);
    if (polygons.empty())
      return bad_input(
          "repair would leave no triangles: every face is degenerate (zero area); "
          "nothing to write");

    const std::vector<P3> points_before = points;
    const std::vector<Polygon> polygons_before = polygons;
    PMP::orient_polygon_soup(points, polygons);  // may duplicate non-manifold vertices
    std::size_t flipped = 0;
    for (std::size_t i = 0; i < polygons.size() && i < polygons_before.size(); ++i)
      if (!same_cycle(points_before, polygons_before[i], points, polygons[i])) ++flipped;
    add(out.changes, "reoriented_faces", flipped, "faces turned to agree with their neighbours");
    const std::size_t split = points.size() - points_before.size();
    add(out.changes, "split_non_manifold_vertices", split,
        "vertices duplicated to separate fans that only touched at a point");

    SurfaceMesh sm;
    PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
    const std::size_t stitched = PMP::stitch_borders(sm);
    add(out.changes, "stitched_edges", stitched, "pairs of open edges stitched together");

    // Pieces of fewer than 4 faces cannot bound a volume (a fin, a stray triangle): filling
    // their "hole" would only add a reversed copy of them.
    const std::size_t pieces = PMP::keep_large_connected_components(sm, 4);
    sm.collect_garbage();
    if (sm.number_of_faces() == 0)
      return bad_input(
          "repair would leave no triangles: the mesh is only loose pieces of fewer than 4 "
          "faces, which cannot bound a volume; nothing to write");
    add(out.changes, "removed_small_pieces", pieces,
        "loose pieces of fewer than 4 faces removed (fins, stray triangles)");

    // Fill the holes that are small enough; larger ones stay open (and are reported).
    std::vector<SurfaceMesh::Halfedge_index> border_starts;
    {
      std::vector<char> seen(sm.number_of_halfedges(), 0);
      for (auto h : sm.halfedges()) {
        if (!sm.is_border(h) || seen[h.idx()] != 0) continue;
        std::size_t len = 0;
        for (auto g : CGAL::halfedges_around_face(h, sm)) {
          seen[g.idx()] = 1;
          ++len;
        }
        if (len <= settings.max_hole_edges) border_starts.push_back(h);
      }
    }
    std::size_t filled = 0;
    std::size_t added = 0;
    for (auto h : border_starts) {
      if (!sm.is_border(h)) continue;
      std::vector<SurfaceMesh::Face_index> new_faces;
      PMP::triangulate_hole(sm, h, std::back_inserter(new_faces));
      if (!new_faces.empty()) {
        ++filled;
        added += new_faces.size();
      }
    }
    add(out.changes, "filled_holes", filled, "holes filled");
    add(out.changes, "added_faces", added, "faces added to fill holes");

    Mesh& m = out.mesh;
    std::map<SurfaceMesh::Vertex_index, std::uint32_t> index;
    for (auto v : sm.vertices()) {
      index[v] = static_cast<std::uint32_t>(m.vertices_mm.size());
      const P3& p = sm.point(v);
      m.vertices_mm.emplace_back(p.x(), p.y(), p.z());
    }
    for (auto f : sm.faces()) {
      std::vector<std::uint32_t> ids;
      for (auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) ids.push_back(index[v]);
      for (std::size_t k = 1; k + 1 < ids.size(); ++k)
        m.triangles.push_back({ids[0], ids[k], ids[k + 1]});
    }
  } catch (const std::exception& e) {
    return internal_error(std::string("mesh repair failed: ") + e.what());
  }
  const std::size_t inverted = detail::flip_inverted_shells(out.mesh);
  add(out.changes, "inverted_shells_flipped", inverted, "inside-out shells turned right side out");
  // Judged as the written file will be read: vertices split to separate fans that met at a
  // point are one vertex again there.
  out.after = analyze_mesh_health(detail::welded_by_position(out.mesh));
  out.counters = measure_repair(
      mesh, out.mesh, out.weld_tolerance_mm > 0 ? out.weld_tolerance_mm : kNearbyEdgeMm, &moved);
  return out;
}

}  // namespace printtwin

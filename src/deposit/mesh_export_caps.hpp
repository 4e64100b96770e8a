#pragma once
// The caps of the layered surface (mesh_export_layers.cpp): the exclusive-or of a slab's top
// rings and the next slab's bottom rings, triangulated, each ring's split points kept for the
// sides. Two triangulators give the same kind of result: a constrained Delaunay triangulation
// of all rings (CGAL, mesh_export_layers.cpp) and the planar walk of mesh_export_caps.cpp.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace printtwin::detail {

/// A closed ring of a cap (the first point not repeated), its region on its left.
using CapRing = std::vector<Eigen::Vector2d>;

/// A point put on a ring's edge (from vertex `after` to the next, at `t` along it): the
/// other ring's vertex that lies a few micrometres from the edge. It is a split point of the
/// ring, not one of its vertices.
struct CapExtra {
  std::uint32_t after = 0;
  double t = 0;
  Eigen::Vector2d p;
  std::uint32_t ring = 0, vertex = 0;  ///< the other ring's vertex it comes from
};
using CapExtras = std::vector<std::vector<CapExtra>>;  // per ring, by edge and t

/// A boundary between slabs: its vertices, the cap triangles, and each ring's vertices in
/// order with its split points (`pos[k]`: the place of the ring's vertex k in `seq`).
struct Boundary {
  std::vector<Eigen::Vector2d> verts;
  std::vector<std::array<std::uint32_t, 3>> tris;
  std::vector<std::uint32_t> seq;       // all rings, each closed (first repeated at the end)
  std::vector<std::uint32_t> pos;       // all rings: n + 1 entries each, into seq
  std::vector<std::uint32_t> pos_base;  // per ring: its first entry in pos
  bool ok = true;
  /// Rings that cross themselves or another ring of their side (the region is not on
  /// their left): 0 / 1 for below / above, and the outline.
  std::vector<std::array<std::size_t, 2>> crossed;
};

/// The cap of `rings` (the first `n_below` the lower slab's top rings, the others the upper
/// slab's bottom rings; `extras` their split points) by the planar walk: the crossings of
/// the two sets found with exact predicates and shared by both rings, the faces of the
/// rings' arrangement walked and labelled by the regions they lie in, the faces inside
/// exactly one region cut into triangles (ear clipping; a constrained Delaunay triangulation
/// of the face for faces with holes or many points). Rings that cross a ring of their own
/// set (or themselves) are listed in `out.crossed`, with no cap. False, `out` unspecified,
/// when it cannot prove its result: rings of one set that touch, rings that touch without
/// sharing a vertex, overlapping edges, a ring that does not bound its region; the caller
/// then takes the triangulation of all rings.
bool cap_by_walk(const std::vector<CapRing>& rings, std::size_t n_below, const CapExtras& extras,
                 Boundary& out);

}  // namespace printtwin::detail

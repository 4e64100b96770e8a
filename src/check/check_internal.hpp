#pragma once
// Internals shared by the src/check/*.cpp files (not installed, not public).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "printtwin/check.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin::detail {

/// Zero area: a repeated index, or vertices collinear to ~1e-8 of the longest edge. Inline:
/// every stage asks it of every face.
inline bool is_degenerate_face(const Mesh& mesh, std::size_t f) {
  const auto& t = mesh.triangles[f];
  if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) return true;
  const Vec3& a = mesh.vertices_mm[t[0]];
  const Vec3& b = mesh.vertices_mm[t[1]];
  const Vec3& c = mesh.vertices_mm[t[2]];
  const double longest2 =
      std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  // Zero area relative to the face's size: collinear to about 1e-8 of its longest edge.
  return (b - a).cross(c - a).squaredNorm() <= 1e-16 * longest2 * longest2;
}
Vec3 face_centroid(const Mesh& mesh, std::size_t f);

/// Stable LSD radix sort of `items` by `key(item)` (an unsigned integer below 2^key_bits),
/// at most 12 bits per pass: equal keys keep their order, so ties stay in insertion order.
template <class T, class KeyFn>
void radix_sort_stable(std::vector<T>& items, KeyFn key, int key_bits) {
  const int passes = (key_bits + 11) / 12;
  const int digit_bits = (key_bits + passes - 1) / passes;
  const std::size_t buckets = std::size_t{1} << digit_bits;
  std::vector<T> tmp(items.size());
  std::vector<std::size_t> count(buckets + 1);
  for (int shift = 0; shift < key_bits; shift += digit_bits) {
    std::fill(count.begin(), count.end(), 0);
    for (const T& x : items) ++count[((key(x) >> shift) & (buckets - 1)) + 1];
    for (std::size_t b = 1; b <= buckets; ++b) count[b] += count[b - 1];
    for (const T& x : items) tmp[count[(key(x) >> shift) & (buckets - 1)]++] = x;
    items.swap(tmp);
  }
}

struct UnionFind {
  explicit UnionFind(std::size_t n);
  /// The root of x's set (paths halved on the way). Inline: called per face or corner.
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) {
      parent[x] = parent[parent[x]];
      x = parent[x];
    }
    return x;
  }
  /// Joins the sets of a and b; the lower root becomes the root.
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<std::uint32_t> parent;
};

/// One side of an undirected edge (lo < hi): the face it belongs to and whether the face
/// runs lo -> hi (1) or hi -> lo (0). `forward` is a full word, not a bool: a record of four
/// words copies as two 8-byte moves, where 13 bytes copied as two overlapping ones stall the
/// sorts on store forwarding (build_edge_table took about twice as long).
struct HalfEdge {
  std::uint32_t lo = 0, hi = 0, face = 0;
  std::uint32_t forward = 0;
};

/// Half-edges sorted by (lo, hi, face); `groups` are [begin, end) runs of one edge.
struct EdgeTable {
  std::vector<HalfEdge> half_edges;
  std::vector<std::pair<std::size_t, std::size_t>> groups;
};

/// `skip_face[f] != 0` leaves face f out (empty = keep all).
EdgeTable build_edge_table(const Mesh& mesh, const std::vector<char>& skip_face);

/// Faces of one edge that continue one surface, as pairs. Where closed bodies touch along
/// an edge (a multi-body STL: Voron's multibody parts, CAD bodies exported together), more
/// than two faces share it: sorted by angle around the edge, each face where a body's wedge
/// opens is paired with the next, where it closes, so each body keeps its own surface.
/// Returns false (no pairs) when they do not alternate: a true non-manifold edge.
bool pair_faces_around_edge(const Mesh& mesh, const EdgeTable& edges, std::size_t begin,
                            std::size_t end,
                            std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs);

/// Which overhang regions print as bridges (src/check/bridges.cpp). region_of: each face's
/// index in `regions` (UINT32_MAX: none); regions under min_area_mm2 are not classified.
/// Points within cantilever_mm of an anchored edge are held by it; sag_mm at sag_span_mm is
/// the printer's sag model.
std::vector<std::optional<BridgeSpan>> find_bridges(const Mesh& placed,
                                                    std::span<const std::uint32_t> region_of,
                                                    std::span<const OverhangRegion> regions,
                                                    double min_area_mm2, double cantilever_mm,
                                                    double sag_mm, double sag_span_mm);

/// Marks faces with a repeated vertex index and every repeat of an earlier face (same vertex
/// set, either orientation). `duplicates` receives the number of repeats; `reverse_twins`
/// (when given) the (face, repeat) pairs where the repeat runs the other way.
std::vector<char> duplicate_or_index_degenerate_faces(
    const Mesh& mesh, std::size_t* duplicates,
    std::vector<std::pair<std::uint32_t, std::uint32_t>>* reverse_twins = nullptr);

/// The faces the edge analysis leaves out: those of duplicate_or_index_degenerate_faces, but
/// reverse twins stay in where a patch of them (faces joined across shared edges) has an
/// edge shared by more than two faces: two bodies touching face to face, each keeping its
/// own faces there.
std::vector<char> faces_left_out(const Mesh& mesh, std::size_t* duplicates);

struct Shell {
  double six_volume = 0;  ///< 6 x signed volume
  bool open = false;      ///< has an open or non-manifold edge
  bool inverted = false;  ///< closed, negative volume, not inside another shell's box
  Box3 box;
};
struct ShellTable {
  std::vector<Shell> shells;
  std::vector<std::uint32_t> shell_of_face;  ///< UINT32_MAX for skipped faces
};
/// Shells = faces connected across shared edges (faces with skip[f] != 0 left out).
ShellTable compute_shells(const Mesh& mesh, const std::vector<char>& skip, const EdgeTable& edges);

/// Every pair of non-degenerate faces (f < g) that find_self_intersections must report,
/// by CGAL's exact predicates alone on all pairs, no broad phase and no filter (tests).
std::vector<std::array<std::uint32_t, 2>> self_intersecting_pairs_exhaustive(const Mesh& mesh);

/// True when every face certainly keeps one orientation seen from the mean of the vertices
/// (exact orient3d) and the faces' solid angles sum to one whole sphere: the surface is
/// star-shaped about that point and wraps it once. On a closed, consistently oriented,
/// manifold mesh no two faces then meet other than along what they share: the central
/// projection onto a sphere around the point maps each face one-to-one, keeps its
/// orientation and has degree 1, so it covers the sphere once (a vertex whose fan wound
/// twice would give the points near it two preimages) and every ray from the point meets
/// the surface once, while two faces meeting in a point they do not share would put that
/// point on one ray twice. Convex parts and blobs pass in one pass over the faces; any
/// other surface fails at its first face turned away from the point.
bool star_shaped_surface(const Mesh& mesh);

/// The mesh with vertices at the same position joined (as a reader of its STL sees it).
Mesh welded_by_position(const Mesh& mesh);

/// admesh's --nearby on `mesh`: every open facet edge is paired with the nearest open facet
/// edge of another face running the other way whose ends each lie within `tolerance_mm` of
/// its own (not at them), and the paired ends are joined: each group of joined vertices
/// takes the position of its lowest-numbered vertex. Returns the mesh with those vertices
/// moved (same vertices and faces); `moved` counts the vertices that changed position.
Mesh weld_nearby_vertices(const Mesh& mesh, double tolerance_mm, std::size_t& moved);

/// Closes T-junctions: each open facet edge with vertices of other open edges on its middle
/// (within `tolerance_mm` and 1 % of its length of its line, with an open edge of theirs
/// running back along it) has its face split at them into a fan from the opposite corner,
/// so that the other side's short edges find partners. Same vertices; `split` counts the
/// edges split.
Mesh split_t_junctions(const Mesh& mesh, double tolerance_mm, std::size_t& split);

/// Reverses every inverted shell (see Shell::inverted); returns how many.
std::size_t flip_inverted_shells(Mesh& mesh);

}  // namespace printtwin::detail

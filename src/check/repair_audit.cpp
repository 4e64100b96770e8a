// measure_repair: what a repair changed, found by comparing the meshes (not by trusting the
// repair steps' own counts), in admesh's counters.
//
// Faces are matched by their corner positions (the input's after the weld, the only step
// that moves vertices), so vertices that were split or merged by index do not matter.
// Within a group of faces on the same
// three positions, faces of the same winding pair first; the rest pair across windings
// (reversed); what is left over was removed (input) or added (result).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"

namespace printtwin {

namespace {

constexpr std::uint32_t kNone = UINT32_MAX;

/// A canonical id per distinct position over both meshes: ids_a[v], ids_b[v].
void canonical_ids(const Mesh& a, const Mesh& b, std::vector<std::uint32_t>& ids_a,
                   std::vector<std::uint32_t>& ids_b) {
  std::vector<Vec3> all;
  all.reserve(a.vertices_mm.size() + b.vertices_mm.size());
  all.insert(all.end(), a.vertices_mm.begin(), a.vertices_mm.end());
  all.insert(all.end(), b.vertices_mm.begin(), b.vertices_mm.end());
  const auto less = [](const Vec3& p, const Vec3& q) {
    return std::tie(p.x(), p.y(), p.z()) < std::tie(q.x(), q.y(), q.z());
  };
  std::vector<Vec3> sorted = all;
  std::sort(sorted.begin(), sorted.end(), less);
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  const auto id = [&](const Vec3& p) {
    return static_cast<std::uint32_t>(std::lower_bound(sorted.begin(), sorted.end(), p, less) -
                                      sorted.begin());
  };
  ids_a.resize(a.vertices_mm.size());
  ids_b.resize(b.vertices_mm.size());
  for (std::size_t i = 0; i < ids_a.size(); ++i) ids_a[i] = id(a.vertices_mm[i]);
  for (std::size_t i = 0; i < ids_b.size(); ++i) ids_b[i] = id(b.vertices_mm[i]);
}

/// A face by its sorted position ids, its winding (parity of the sort) and its index.
struct FaceKey {
  std::array<std::uint32_t, 3> ids{};
  bool odd = false;
  std::uint32_t face = 0;
  bool operator<(const FaceKey& o) const {
    return std::tie(ids, odd, face) < std::tie(o.ids, o.odd, o.face);
  }
};

std::vector<FaceKey> face_keys(const Mesh& m, const std::vector<std::uint32_t>& ids) {
  std::vector<FaceKey> keys(m.triangles.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    std::array<std::uint32_t, 3> v = {ids[m.triangles[f][0]], ids[m.triangles[f][1]],
                                      ids[m.triangles[f][2]]};
    bool odd = false;  // bubble sort of three, counting swaps
    for (int pass = 0; pass < 2; ++pass)
      for (int i = 0; i < 2 - pass; ++i)
        if (v[i] > v[i + 1]) {
          std::swap(v[i], v[i + 1]);
          odd = !odd;
        }
    if (v[0] == v[1] || v[1] == v[2]) odd = false;  // repeated corner: no winding
    keys[f] = {v, odd, static_cast<std::uint32_t>(f)};
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

/// Per facet edge (3 f + k, the edge from corner k to k + 1) the index of its edge group
/// (faces sharing the two vertex indices) and the size of each group.
struct FacetEdges {
  std::vector<std::uint32_t> group;
  std::vector<std::uint32_t> group_size;
};

FacetEdges facet_edges(const Mesh& m) {
  struct E {
    std::uint32_t lo, hi, slot;
  };
  std::vector<E> es;
  es.reserve(3 * m.triangles.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f)
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t a = m.triangles[f][k], b = m.triangles[f][(k + 1) % 3];
      es.push_back({std::min(a, b), std::max(a, b), static_cast<std::uint32_t>(3 * f + k)});
    }
  std::sort(es.begin(), es.end(), [](const E& x, const E& y) {
    return std::tie(x.lo, x.hi, x.slot) < std::tie(y.lo, y.hi, y.slot);
  });
  FacetEdges out;
  out.group.assign(es.size(), kNone);
  for (std::size_t i = 0; i < es.size();) {
    std::size_t j = i;
    while (j < es.size() && es[j].lo == es[i].lo && es[j].hi == es[i].hi) ++j;
    for (std::size_t k = i; k < j; ++k)
      out.group[es[k].slot] = static_cast<std::uint32_t>(out.group_size.size());
    out.group_size.push_back(static_cast<std::uint32_t>(j - i));
    i = j;
  }
  return out;
}

/// Each open facet edge of `m` (its facet edges `e`) with a partner for the tolerance `tol`:
/// {slot, partner slot}: the nearest open facet edge of another face that runs the other way
/// with each end within `tol` of this edge's (ties to the lower one), when this edge is its
/// nearest too and they are apart (an edge with a partner exactly at it is stitched, not
/// welded). Slot 3 f + k is the edge from corner k to k + 1 of face f.
std::vector<std::array<std::uint32_t, 2>> nearby_open_edges(const Mesh& m, const FacetEdges& e,
                                                            double tol) {
  std::vector<std::array<std::uint32_t, 2>> pairs;
  if (!(tol > 0)) return pairs;
  struct Open {
    Vec3 from, to;
    std::uint32_t slot;
  };
  std::vector<Open> open;
  for (std::size_t s = 0; s < e.group.size(); ++s) {
    if (e.group_size[e.group[s]] != 1) continue;
    const auto& t = m.triangles[s / 3];
    const std::uint32_t a = t[s % 3], b = t[(s % 3 + 1) % 3];
    if (a != b) open.push_back({m.vertices_mm[a], m.vertices_mm[b], static_cast<std::uint32_t>(s)});
  }
  // The open edges by the cell (of edge `tol`) of their end; a partner's end lies in one of
  // the 27 cells around an edge's start. Coordinates too large for cell numbers have none.
  using Cell = std::array<std::int64_t, 3>;
  const auto cell_of = [tol](const Vec3& p, Cell& c) {
    for (int a = 0; a < 3; ++a) {
      const double q = std::floor(p[a] / tol);
      if (!(std::abs(q) < 1e15)) return false;
      c[static_cast<std::size_t>(a)] = static_cast<std::int64_t>(q);
    }
    return true;
  };
  std::vector<std::pair<Cell, std::uint32_t>> by_end;
  for (std::size_t i = 0; i < open.size(); ++i)
    if (Cell c{}; cell_of(open[i].to, c)) by_end.emplace_back(c, static_cast<std::uint32_t>(i));
  std::sort(by_end.begin(), by_end.end());
  // Each edge's nearest partner (an exact one, at distance 0, is stitched without a weld).
  std::vector<std::uint32_t> nearest(open.size(), kNone);
  std::vector<double> distance(open.size(), 0);
  for (std::size_t i = 0; i < open.size(); ++i) {
    Cell c{};
    if (!cell_of(open[i].from, c)) continue;
    double best = std::numeric_limits<double>::infinity();
    for (int d = 0; d < 27; ++d) {
      const Cell n{c[0] + d % 3 - 1, c[1] + d / 3 % 3 - 1, c[2] + d / 9 - 1};
      auto it = std::lower_bound(by_end.begin(), by_end.end(), std::make_pair(n, 0U));
      for (; it != by_end.end() && it->first == n; ++it) {
        const Open& o = open[it->second];
        if (o.slot / 3 == open[i].slot / 3) continue;  // the same face
        const double err = std::max((o.to - open[i].from).norm(), (o.from - open[i].to).norm());
        if (err <= tol && (err < best || (err == best && it->second < nearest[i]))) {
          best = err;
          nearest[i] = it->second;
        }
      }
    }
    distance[i] = best;
  }
  // Pairs: each the other's nearest, apart.
  for (std::size_t i = 0; i < open.size(); ++i) {
    const std::uint32_t p = nearest[i];
    if (p != kNone && nearest[p] == i && distance[i] > 0)
      pairs.push_back({open[i].slot, open[p].slot});
  }
  return pairs;
}

/// The T-junctions of `m`: open facet edges (a -> b) with vertices of other open edges on
/// their middle (a vertex in the middle of an edge: the other side's chain of short open
/// edges b -> ... -> a). A vertex counts when it lies strictly between a and b, within `tol`
/// and 1 % of the edge's length of the line through them (so the split faces keep the
/// face's plane within about half a degree), and one of its open edges runs from it back
/// towards a along the line (to a itself or to another such vertex): a chain, not a vertex
/// that happens to lie near the edge. Positions decide (vertices at one position are one);
/// each edge's vertices come sorted from a to b.
struct TJunction {
  std::uint32_t slot = 0;               ///< 3 f + k: the edge from corner k to k + 1 of face f
  std::vector<std::uint32_t> vertices;  ///< on the edge, from a to b (vertices of `m`)
};

std::vector<TJunction> t_junctions(const Mesh& m, double tol) {
  std::vector<TJunction> out;
  if (!(tol > 0)) return out;
  std::vector<std::uint32_t> ids, unused;
  canonical_ids(m, Mesh{}, ids, unused);
  // m on its distinct positions (faces in the same order); zero-area faces, removed by the
  // repair, have no edges here.
  Mesh w;
  w.triangles.reserve(m.triangles.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    const auto& t = m.triangles[f];
    w.triangles.push_back(detail::is_degenerate_face(m, f)
                              ? std::array<std::uint32_t, 3>{0, 0, 0}
                              : std::array<std::uint32_t, 3>{ids[t[0]], ids[t[1]], ids[t[2]]});
  }
  std::uint32_t count = 0;
  for (const std::uint32_t id : ids) count = std::max(count, id + 1);
  w.vertices_mm.resize(count);
  std::vector<std::uint32_t> rep(count, kNone);  // the lowest vertex of m at each position
  for (std::uint32_t v = 0; v < ids.size(); ++v) {
    w.vertices_mm[ids[v]] = m.vertices_mm[v];
    if (rep[ids[v]] == kNone) rep[ids[v]] = v;
  }
  const FacetEdges e = facet_edges(w);
  // Open facet edges (from, to, slot), by their start.
  std::vector<std::array<std::uint32_t, 3>> open;
  for (std::size_t s = 0; s < e.group.size(); ++s) {
    if (e.group_size[e.group[s]] != 1) continue;
    const auto& t = w.triangles[s / 3];
    const std::uint32_t a = t[s % 3], b = t[(s % 3 + 1) % 3];
    if (a != b) open.push_back({a, b, static_cast<std::uint32_t>(s)});
  }
  if (open.size() < 3) return out;
  std::sort(open.begin(), open.end());
  // The open edges' starts by x, to find those near an edge.
  std::vector<std::uint32_t> starts;
  starts.reserve(open.size());
  for (const auto& o : open) starts.push_back(o[0]);
  starts.erase(std::unique(starts.begin(), starts.end()), starts.end());
  const auto& p = w.vertices_mm;
  std::sort(starts.begin(), starts.end(),
            [&](std::uint32_t i, std::uint32_t j) { return p[i].x() < p[j].x(); });
  for (const auto& [a, b, slot] : open) {
    const Vec3 d = p[b] - p[a];
    const double len2 = d.squaredNorm();
    if (!(len2 > 0)) continue;
    const double lim = std::min(tol, 0.01 * std::sqrt(len2));
    // Position along a -> b (0 at a, 1 at b) of q, or -1 when q is off the line.
    const Vec3 pa = p[a];  // clang before 16 cannot capture a structured binding
    const auto along = [&](const Vec3& q) {
      const double t = (q - pa).dot(d) / len2;
      return (q - pa - t * d).norm() <= lim ? t : -1.0;
    };
    const double lo = std::min(p[a].x(), p[b].x()) - lim, hi = std::max(p[a].x(), p[b].x()) + lim;
    auto it = std::lower_bound(starts.begin(), starts.end(), lo,
                               [&](std::uint32_t i, double x) { return p[i].x() < x; });
    std::vector<std::pair<double, std::uint32_t>> on;
    for (; it != starts.end() && p[*it].x() <= hi; ++it) {
      const std::uint32_t v = *it;
      if (v == a || v == b) continue;
      const double t = along(p[v]);
      if (!(t > 0 && t < 1)) continue;
      // An open edge from v back towards a, along the line.
      auto from = std::lower_bound(open.begin(), open.end(), std::array<std::uint32_t, 3>{v, 0, 0});
      bool chain = false;
      for (; from != open.end() && (*from)[0] == v && !chain; ++from) {
        const std::uint32_t x = (*from)[1];
        chain = x == a || (x != b && along(p[x]) >= 0 && along(p[x]) < t);
      }
      if (chain) on.emplace_back(t, v);
    }
    if (on.empty()) continue;
    std::sort(on.begin(), on.end());
    TJunction j;
    j.slot = slot;
    for (const auto& [t, v] : on) j.vertices.push_back(rep[v]);
    out.push_back(std::move(j));
  }
  std::sort(out.begin(), out.end(),
            [](const TJunction& x, const TJunction& y) { return x.slot < y.slot; });
  return out;
}

}  // namespace

Mesh detail::welded_by_position(const Mesh& mesh) {
  Mesh out;
  std::vector<std::uint32_t> ids, unused;
  canonical_ids(mesh, Mesh{}, ids, unused);
  std::uint32_t count = 0;
  for (const std::uint32_t id : ids) count = std::max(count, id + 1);
  out.vertices_mm.resize(count);
  for (std::size_t v = 0; v < ids.size(); ++v) out.vertices_mm[ids[v]] = mesh.vertices_mm[v];
  out.triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) out.triangles.push_back({ids[t[0]], ids[t[1]], ids[t[2]]});
  return out;
}

double nearby_weld_tolerance_mm(const Mesh& mesh) {
  double shortest = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) continue;
    for (int k = 0; k < 3; ++k) {
      const Vec3 d = mesh.vertices_mm[t[k]] - mesh.vertices_mm[t[(k + 1) % 3]];
      shortest = std::min(shortest, d.cwiseAbs().maxCoeff());
    }
  }
  if (!std::isfinite(shortest)) return 0;
  return shortest + 1e-4 * bounding_box(mesh).size().norm();
}

Mesh detail::weld_nearby_vertices(const Mesh& mesh, double tolerance_mm, std::size_t& moved) {
  Mesh out = mesh;
  moved = 0;
  const FacetEdges e = facet_edges(mesh);
  const auto pairs = nearby_open_edges(mesh, e, tolerance_mm);
  if (pairs.empty()) return out;
  const auto corner = [&](std::uint32_t slot, std::uint32_t k) {
    return mesh.triangles[slot / 3][(slot % 3 + k) % 3];
  };
  // Two ends of one edge are never joined (that would collapse a face: the ends of a small
  // hole are each other's nearest open edges).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k)
      edges.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
  std::sort(edges.begin(), edges.end());
  const auto joins_an_edge = [&](std::uint32_t a, std::uint32_t b) {
    return a != b && std::binary_search(edges.begin(), edges.end(),
                                        std::make_pair(std::min(a, b), std::max(a, b)));
  };
  detail::UnionFind uf(mesh.vertices_mm.size());
  for (const auto& [s, p] : pairs) {
    // This edge's start with the partner's end, its end with the partner's start.
    if (joins_an_edge(corner(s, 0), corner(p, 1)) || joins_an_edge(corner(s, 1), corner(p, 0)))
      continue;
    uf.unite(corner(s, 0), corner(p, 1));
    uf.unite(corner(s, 1), corner(p, 0));
  }
  std::vector<std::uint32_t> lowest(mesh.vertices_mm.size(), kNone);
  for (std::uint32_t v = 0; v < mesh.vertices_mm.size(); ++v) {
    std::uint32_t& l = lowest[uf.find(v)];
    if (l == kNone) l = v;
  }
  for (std::uint32_t v = 0; v < mesh.vertices_mm.size(); ++v) {
    const Vec3& to = mesh.vertices_mm[lowest[uf.find(v)]];
    if (to == mesh.vertices_mm[v]) continue;
    out.vertices_mm[v] = to;
    ++moved;
  }
  return out;
}

Mesh detail::split_t_junctions(const Mesh& mesh, double tolerance_mm, std::size_t& split) {
  Mesh out = mesh;
  split = 0;
  // A face with T-junctions on two or three edges is split along one per pass.
  for (int pass = 0; pass < 3; ++pass) {
    const std::vector<TJunction> found = t_junctions(out, tolerance_mm);
    std::vector<char> done(out.triangles.size(), 0);
    bool again = false;
    for (const TJunction& j : found) {
      const std::uint32_t f = j.slot / 3, k = j.slot % 3;
      if (done[f] != 0) {
        again = true;
        continue;
      }
      done[f] = 1;
      ++split;
      // Face (a, b, c) with the vertices m1..mn on a -> b: (a, m1, c), (m1, m2, c), ...,
      // (mn, b, c), the same winding. The first replaces the face, the others go at the end.
      const auto t = out.triangles[f];
      const std::uint32_t a = t[k], b = t[(k + 1) % 3], c = t[(k + 2) % 3];
      std::vector<std::uint32_t> chain{a};
      chain.insert(chain.end(), j.vertices.begin(), j.vertices.end());
      chain.push_back(b);
      out.triangles[f] = {chain[0], chain[1], c};
      for (std::size_t i = 1; i + 1 < chain.size(); ++i)
        out.triangles.push_back({chain[i], chain[i + 1], c});
    }
    if (!again) break;
  }
  return out;
}

RepairCounters measure_repair(const Mesh& before, const Mesh& after, double nearby_mm,
                              const Mesh* moved) {
  RepairCounters c;
  std::vector<std::uint32_t> ids_b, ids_a;
  // Faces and edges are matched on the positions after the weld (the input's when none).
  canonical_ids(moved != nullptr ? *moved : before, after, ids_b, ids_a);
  const std::vector<FaceKey> kb = face_keys(before, ids_b);
  const std::vector<FaceKey> ka = face_keys(after, ids_a);

  // Match faces group by group: match_of[input face] = result face (kNone: removed).
  std::vector<std::uint32_t> match_of(before.triangles.size(), kNone);
  std::vector<char> added(after.triangles.size(), 1);
  for (std::size_t i = 0, j = 0; i < kb.size() || j < ka.size();) {
    if (j == ka.size() || (i < kb.size() && kb[i].ids < ka[j].ids)) {
      ++c.facets_removed;
      ++i;
      continue;
    }
    if (i == kb.size() || ka[j].ids < kb[i].ids) {
      ++j;  // added: counted below from `added`
      continue;
    }
    std::size_t ie = i, je = j;
    while (ie < kb.size() && kb[ie].ids == kb[i].ids) ++ie;
    while (je < ka.size() && ka[je].ids == ka[j].ids) ++je;
    std::vector<char> used_b(ie - i, 0), used_a(je - j, 0);
    for (int pass = 0; pass < 2; ++pass)  // same winding first, then reversed
      for (std::size_t x = i; x < ie; ++x)
        for (std::size_t y = j; y < je && used_b[x - i] == 0; ++y)
          if (used_a[y - j] == 0 && (pass == 1 || kb[x].odd == ka[y].odd)) {
            used_b[x - i] = used_a[y - j] = 1;
            match_of[kb[x].face] = ka[y].face;
            added[ka[y].face] = 0;
            if (kb[x].odd != ka[y].odd) ++c.facets_reversed;
          }
    for (char u : used_b) c.facets_removed += u == 0;
    i = ie;
    j = je;
  }
  for (char a : added) c.facets_added += a != 0;

  // The faces a T-junction split makes (the fan of each split face) are added, but they
  // fill no hole: edges they close are fixed, and they are no hole patch.
  const Mesh& base = moved != nullptr ? *moved : before;
  const MeshHealth hb = analyze_mesh_health(before);
  // Edges open by position are open by index: without open edges, no T-junction.
  const Mesh split =
      hb.boundary_edges > 0 ? detail::split_t_junctions(base, nearby_mm, c.t_junction_edges) : base;
  std::vector<std::array<std::uint32_t, 3>> fan;
  for (std::size_t f = 0; f < split.triangles.size(); ++f) {
    const auto& t = split.triangles[f];
    if (f < base.triangles.size() && t == base.triangles[f]) continue;
    std::array<std::uint32_t, 3> key{ids_b[t[0]], ids_b[t[1]], ids_b[t[2]]};
    std::sort(key.begin(), key.end());
    fan.push_back(key);
  }
  std::sort(fan.begin(), fan.end());
  for (const FaceKey& k : ka)
    if (added[k.face] != 0 && std::binary_search(fan.begin(), fan.end(), k.ids))
      added[k.face] = 2;  // a piece of a split face

  // The result as a reader of its file sees it: vertices at one position are one vertex
  // (faces keep their indices), so vertices split apart by the repair do not close edges.
  const Mesh welded = detail::welded_by_position(after);
  const FacetEdges eb = facet_edges(before);
  const FacetEdges ea = facet_edges(welded);
  std::vector<char> group_has_added(ea.group_size.size(), 0);
  for (std::size_t s = 0; s < ea.group.size(); ++s)
    if (added[s / 3] == 1) group_has_added[ea.group[s]] = 1;

  // Edges fixed: open or non-manifold facet edges of kept faces, closed by input faces.
  for (std::size_t f = 0; f < before.triangles.size(); ++f) {
    const std::uint32_t g = match_of[f];
    if (g == kNone) continue;
    for (std::uint32_t k = 0; k < 3; ++k) {
      if (eb.group_size[eb.group[3 * f + k]] == 2) continue;
      const std::uint32_t p = ids_b[before.triangles[f][k]],
                          q = ids_b[before.triangles[f][(k + 1) % 3]];
      if (p == q) continue;
      for (std::uint32_t m = 0; m < 3; ++m) {
        const std::uint32_t r = ids_a[after.triangles[g][m]],
                            s = ids_a[after.triangles[g][(m + 1) % 3]];
        if (!((r == p && s == q) || (r == q && s == p))) continue;
        const std::uint32_t grp = ea.group[3 * g + m];
        if (ea.group_size[grp] == 2 && group_has_added[grp] == 0) ++c.edges_fixed;
        break;
      }
    }
  }

  // Holes filled: added faces connected over shared edges.
  detail::UnionFind uf(after.triangles.size());
  std::vector<std::uint32_t> first_added_in_group(ea.group_size.size(), kNone);
  for (std::size_t s = 0; s < ea.group.size(); ++s) {
    const auto f = static_cast<std::uint32_t>(s / 3);
    if (added[f] != 1) continue;
    std::uint32_t& first = first_added_in_group[ea.group[s]];
    if (first == kNone)
      first = f;
    else
      uf.unite(first, f);
  }
  for (std::uint32_t f = 0; f < after.triangles.size(); ++f)
    c.holes_filled += added[f] == 1 && uf.find(f) == f;

  const MeshHealth ha = analyze_mesh_health(welded);
  c.degenerate_facets = hb.degenerate_faces;
  c.backwards_edges = 2 * ha.inconsistent_edges;
  c.parts = ha.shells;
  c.nearby_edges = nearby_open_edges(before, eb, nearby_mm).size();
  return c;
}

std::string repair_counters_text(const RepairCounters& c) {
  std::string t;
  for (const auto& [name, n] : {std::pair<const char*, std::size_t>{"edges fixed", c.edges_fixed},
                                {"facets removed", c.facets_removed},
                                {"facets added", c.facets_added},
                                {"facets reversed", c.facets_reversed},
                                {"backwards edges", c.backwards_edges},
                                {"holes filled", c.holes_filled},
                                {"degenerate facets", c.degenerate_facets},
                                {"parts", c.parts},
                                {"nearby edges", c.nearby_edges},
                                {"T-junction edges", c.t_junction_edges}})
    t += (t.empty() ? "" : ", ") + std::string(name) + " " + std::to_string(n);
  return t;
}

}  // namespace printtwin

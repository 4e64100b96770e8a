// Mesh health: topology counts from sorted edge lists and union-find (no third-party code).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"

namespace printtwin {

namespace detail {

Vec3 face_centroid(const Mesh& mesh, std::size_t f) {
  const auto& t = mesh.triangles[f];
  return (mesh.vertices_mm[t[0]] + mesh.vertices_mm[t[1]] + mesh.vertices_mm[t[2]]) / 3.0;
}

UnionFind::UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0U); }

EdgeTable build_edge_table(const Mesh& mesh, const std::vector<char>& skip_face) {
  EdgeTable table;
  const std::size_t nv = mesh.vertices_mm.size();
  const auto kept = [&](std::size_t f) { return skip_face.empty() || skip_face[f] == 0; };
  // Sorted by (lo, hi, face): half-edges are placed by lo with a counting sort in face order,
  // then each vertex's few half-edges are sorted by hi, stably (one face never holds an
  // undirected edge twice once repeated indices are skipped; if it did, both would sit
  // together in face order). A vertex has about six half-edges starting at it: insertion
  // sort, or a stable sort for a large fan.
  std::vector<std::uint32_t> start(nv + 1, 0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!kept(f)) continue;
    const auto& t = mesh.triangles[f];
    for (int k = 0; k < 3; ++k) ++start[std::size_t{std::min(t[k], t[(k + 1) % 3])} + 1];
  }
  for (std::size_t v = 1; v <= nv; ++v) start[v] += start[v - 1];
  table.half_edges.resize(start[nv]);
  std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    if (!kept(f)) continue;
    const auto& t = mesh.triangles[f];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k];
      const std::uint32_t b = t[(k + 1) % 3];
      const std::uint32_t lo = std::min(a, b);
      table.half_edges[next[lo]++] = {lo, std::max(a, b), static_cast<std::uint32_t>(f), a < b};
    }
  }
  const auto by_hi = [](const HalfEdge& x, const HalfEdge& y) { return x.hi < y.hi; };
  for (std::size_t v = 0; v < nv; ++v) {
    const auto first = table.half_edges.begin() + start[v];
    const auto last = table.half_edges.begin() + start[v + 1];
    if (last - first < 2) continue;  // nothing to order (and no first + 1 past an empty run)
    if (last - first > 32) {
      std::stable_sort(first, last, by_hi);
      continue;
    }
    for (auto i = first + 1; i < last; ++i) {
      const HalfEdge e = *i;
      auto j = i;
      for (; j > first && e.hi < (j - 1)->hi; --j) *j = *(j - 1);
      *j = e;
    }
  }
  table.groups.reserve(table.half_edges.size() / 2 + 1);
  for (std::size_t i = 0; i < table.half_edges.size();) {
    std::size_t j = i + 1;
    while (j < table.half_edges.size() && table.half_edges[j].lo == table.half_edges[i].lo &&
           table.half_edges[j].hi == table.half_edges[i].hi)
      ++j;
    table.groups.push_back({i, j});
    i = j;
  }
  return table;
}

bool pair_faces_around_edge(const Mesh& mesh, const EdgeTable& edges, std::size_t begin,
                            std::size_t end,
                            std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs) {
  pairs.clear();
  const std::size_t n = end - begin;
  if (n < 4 || n % 2 != 0) return false;
  const HalfEdge& e0 = edges.half_edges[begin];
  const Vec3 p = mesh.vertices_mm[e0.lo];
  const Vec3 d = (mesh.vertices_mm[e0.hi] - p).normalized();
  if (!d.allFinite()) return false;
  // Each face's angle about the edge (its third corner's direction across it). A face that
  // runs lo -> hi has its outward normal along d x r, towards growing angles: the body lies
  // at smaller angles and the face closes its wedge; one running hi -> lo opens a wedge.
  struct Around {
    double angle;
    bool closes;
    std::uint32_t face;
  };
  std::vector<Around> around;
  around.reserve(n);
  Vec3 u = Vec3::Zero();
  Vec3 w = Vec3::Zero();
  std::size_t closing = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const HalfEdge& e = edges.half_edges[i];
    const auto& t = mesh.triangles[e.face];
    const std::uint32_t c =
        t[0] != e.lo && t[0] != e.hi ? t[0] : (t[1] != e.lo && t[1] != e.hi ? t[1] : t[2]);
    Vec3 r = mesh.vertices_mm[c] - p;
    r -= r.dot(d) * d;
    if (!(r.norm() > 0)) return false;  // a face without width about the edge
    if (i == begin) {
      u = r.normalized();
      w = d.cross(u);
    }
    around.push_back({std::atan2(r.dot(w), r.dot(u)), e.forward != 0, e.face});
    closing += e.forward != 0 ? 1 : 0;
  }
  if (2 * closing != n) return false;
  // At equal angles a wedge closes before the next one opens (bodies touching face to face).
  // Faces of two bodies lying in one plane have angles equal up to the rounding of their
  // corners: angles closer than kCoplanarRad count as equal. The sequence starts after the
  // widest gap, so that no such group straddles its start.
  constexpr double kCoplanarRad = 1e-3;
  constexpr double kTwoPi = 6.283185307179586;
  std::sort(around.begin(), around.end(),
            [](const Around& a, const Around& b) { return a.angle < b.angle; });
  std::size_t widest = 0;
  double widest_gap = around.front().angle + kTwoPi - around.back().angle;
  for (std::size_t i = 1; i < n; ++i)
    if (around[i].angle - around[i - 1].angle > widest_gap) {
      widest_gap = around[i].angle - around[i - 1].angle;
      widest = i;
    }
  std::rotate(around.begin(), around.begin() + static_cast<std::ptrdiff_t>(widest), around.end());
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i + 1;
    while (j < n && std::remainder(around[j].angle - around[j - 1].angle, kTwoPi) < kCoplanarRad)
      ++j;
    std::stable_partition(around.begin() + static_cast<std::ptrdiff_t>(i),
                          around.begin() + static_cast<std::ptrdiff_t>(j),
                          [](const Around& a) { return a.closes; });
    i = j;
  }
  std::size_t s = 0;
  while (around[s].closes) ++s;
  for (std::size_t k = 0; k < n; k += 2) {
    const Around& open = around[(s + k) % n];
    const Around& close = around[(s + k + 1) % n];
    if (open.closes || !close.closes) {
      pairs.clear();
      return false;
    }
    pairs.emplace_back(open.face, close.face);
  }
  return true;
}

std::vector<char> duplicate_or_index_degenerate_faces(
    const Mesh& mesh, std::size_t* duplicates,
    std::vector<std::pair<std::uint32_t, std::uint32_t>>* reverse_twins) {
  const std::size_t n = mesh.triangles.size();
  const std::size_t nv = mesh.vertices_mm.size();
  std::vector<char> skip(n, 0);
  // Faces by their lowest vertex (a counting sort in face order), then within each vertex's
  // few faces every face whose vertex set an earlier face already has is a repeat: the
  // first face stays, its repeats are marked.
  const auto sorted = [&](std::size_t f) {
    auto t = mesh.triangles[f];
    std::sort(t.begin(), t.end());
    return t;
  };
  std::vector<std::uint32_t> start(nv + 1, 0);
  for (std::size_t f = 0; f < n; ++f) {
    const auto& t = mesh.triangles[f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      skip[f] = 1;
      continue;
    }
    ++start[std::size_t{std::min({t[0], t[1], t[2]})} + 1];
  }
  for (std::size_t v = 1; v <= nv; ++v) start[v] += start[v - 1];
  std::vector<std::pair<std::array<std::uint32_t, 3>, std::uint32_t>> keys(start[nv]);
  std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < n; ++f) {
    if (skip[f] != 0) continue;
    const auto t = sorted(f);
    keys[next[t[0]]++] = {t, static_cast<std::uint32_t>(f)};
  }
  // Within one vertex set, in face order: the first face stays, every repeat is marked; a
  // repeat running the other way is a reverse twin of the face that stays.
  const auto same_way = [&](std::uint32_t f, std::uint32_t g) {
    const auto& a = mesh.triangles[f];
    const auto& b = mesh.triangles[g];
    const std::size_t k = b[0] == a[0] ? 0 : (b[1] == a[0] ? 1 : 2);
    return b[(k + 1) % 3] == a[1];
  };
  std::size_t dup = 0;
  const auto repeat = [&](std::uint32_t staying, std::uint32_t f) {
    ++dup;
    skip[f] = 1;
    if (reverse_twins != nullptr && !same_way(staying, f)) reverse_twins->emplace_back(staying, f);
  };
  for (std::size_t v = 0; v < nv; ++v) {
    const auto first = keys.begin() + start[v];
    const auto last = keys.begin() + start[v + 1];
    if (last - first < 2) continue;  // no repeat possible (and no first + 1 past an empty run)
    if (last - first > 32) {         // a large fan: sorted by vertex set, faces ascending in a set
      std::sort(first, last);
      auto staying = first;
      for (auto i = first + 1; i < last; ++i) {
        if (i->first != staying->first)
          staying = i;
        else
          repeat(staying->second, i->second);
      }
      continue;
    }
    for (auto i = first + 1; i < last; ++i)
      for (auto j = first; j < i; ++j)
        if (j->first == i->first) {
          repeat(j->second, i->second);
          break;
        }
  }
  if (duplicates != nullptr) *duplicates = dup;
  return skip;
}

std::vector<char> faces_left_out(const Mesh& mesh, std::size_t* duplicates) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> twins;
  std::vector<char> skip = duplicate_or_index_degenerate_faces(mesh, duplicates, &twins);
  if (twins.empty()) return skip;
  // Faces with a reverse twin, joined across the edges they share: one contact patch where
  // two bodies touch face to face. A patch with an edge shared by more than two faces (its
  // border, where each body's own faces go on) takes its twins in, so that the faces pair
  // up around those edges, each body with its own.
  const EdgeTable edges = build_edge_table(mesh, skip);
  const std::size_t nf = mesh.triangles.size();
  std::vector<char> twinned(nf, 0);
  for (const auto& [f, g] : twins) twinned[f] = 1;
  UnionFind patch(nf);
  for (const auto& [begin, end] : edges.groups) {
    std::uint32_t first = UINT32_MAX;
    for (std::size_t i = begin; i < end; ++i) {
      const std::uint32_t f = edges.half_edges[i].face;
      if (twinned[f] == 0) continue;
      if (first == UINT32_MAX)
        first = f;
      else
        patch.unite(first, f);
    }
  }
  std::vector<char> crowded(nf, 0);
  for (const auto& [begin, end] : edges.groups)
    if (end - begin > 2)
      for (std::size_t i = begin; i < end; ++i) {
        const std::uint32_t f = edges.half_edges[i].face;
        if (twinned[f] != 0) crowded[patch.find(f)] = 1;
      }
  for (const auto& [f, g] : twins)
    if (crowded[patch.find(f)] != 0) skip[g] = 0;
  return skip;
}

ShellTable compute_shells(const Mesh& mesh, const std::vector<char>& skip, const EdgeTable& edges) {
  const std::size_t nf = mesh.triangles.size();
  UnionFind uf(nf);
  std::vector<char> open_face(nf, 0);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (const auto& [begin, end] : edges.groups) {
    if (end - begin > 2 && pair_faces_around_edge(mesh, edges, begin, end, pairs)) {
      for (const auto& [f, g] : pairs) uf.unite(f, g);  // touching bodies stay apart
      continue;
    }
    for (std::size_t i = begin + 1; i < end; ++i)
      uf.unite(edges.half_edges[begin].face, edges.half_edges[i].face);
    if (end - begin != 2)
      for (std::size_t i = begin; i < end; ++i) open_face[edges.half_edges[i].face] = 1;
  }
  ShellTable table;
  table.shell_of_face.assign(nf, UINT32_MAX);
  std::vector<std::uint32_t> index_of_root(nf, UINT32_MAX);
  const Box3 box = bounding_box(mesh);
  const Vec3 ref = box.empty() ? Vec3::Zero() : box.center();
  for (std::size_t f = 0; f < nf; ++f) {
    if (!skip.empty() && skip[f] != 0) continue;
    const std::uint32_t root = uf.find(static_cast<std::uint32_t>(f));
    if (index_of_root[root] == UINT32_MAX) {
      index_of_root[root] = static_cast<std::uint32_t>(table.shells.size());
      table.shells.emplace_back();
    }
    table.shell_of_face[f] = index_of_root[root];
    Shell& s = table.shells[index_of_root[root]];
    const auto& t = mesh.triangles[f];
    const Vec3 a = mesh.vertices_mm[t[0]] - ref;
    const Vec3 b = mesh.vertices_mm[t[1]] - ref;
    const Vec3 c = mesh.vertices_mm[t[2]] - ref;
    s.six_volume += a.dot(b.cross(c));
    s.open = s.open || open_face[f] != 0;
    for (auto v : t) s.box.extend(mesh.vertices_mm[v]);
  }
  // A closed shell with negative volume is a cavity when another, positive shell's box
  // holds it; otherwise it is inside out.
  for (std::size_t i = 0; i < table.shells.size(); ++i) {
    Shell& si = table.shells[i];
    if (si.open || si.six_volume >= 0) continue;
    bool cavity = false;
    for (std::size_t j = 0; j < table.shells.size() && !cavity; ++j) {
      const Shell& sj = table.shells[j];
      cavity = j != i && sj.six_volume > 0 && sj.box.contains(si.box.min) &&
               sj.box.contains(si.box.max) && !(sj.box == si.box);
    }
    si.inverted = !cavity;
  }
  return table;
}

std::size_t flip_inverted_shells(Mesh& mesh) {
  const std::vector<char> skip = faces_left_out(mesh, nullptr);
  const ShellTable table = compute_shells(mesh, skip, build_edge_table(mesh, skip));
  std::size_t flipped = 0;
  for (const auto& s : table.shells) flipped += s.inverted ? 1 : 0;
  if (flipped == 0) return 0;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const std::uint32_t s = table.shell_of_face[f];
    if (s != UINT32_MAX && table.shells[s].inverted)
      std::swap(mesh.triangles[f][1], mesh.triangles[f][2]);
  }
  return flipped;
}

}  // namespace detail

MeshHealth analyze_mesh_health(const Mesh& mesh) {
  using namespace detail;
  MeshHealth h;
  const std::size_t nf = mesh.triangles.size();
  h.triangles = nf;
  h.volume_mm3 = signed_volume_mm3(mesh);
  h.area_mm2 = surface_area_mm2(mesh);

  std::vector<char> used(mesh.vertices_mm.size(), 0);
  for (const auto& t : mesh.triangles)
    for (auto v : t) used[v] = 1;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v] != 0) {
      ++h.vertices;
      h.bbox_mm.extend(mesh.vertices_mm[v]);
    }

  for (std::size_t f = 0; f < nf; ++f)
    if (is_degenerate_face(mesh, f)) {
      if (h.degenerate_faces == 0) h.first_degenerate_face_mm = face_centroid(mesh, f);
      ++h.degenerate_faces;
    }

  // Duplicates and faces with a repeated index stay out of the edge analysis: each is
  // reported once as such, not again as the non-manifold or open edges it would cause.
  const std::vector<char> skip = faces_left_out(mesh, &h.duplicate_faces);
  const EdgeTable edges = build_edge_table(mesh, skip);

  UnionFind corners(3 * nf);  // fans around each vertex, joined across manifold edges
  auto corner_of = [&](std::uint32_t f, std::uint32_t v) {
    const auto& t = mesh.triangles[f];
    const std::uint32_t k = t[0] == v ? 0 : (t[1] == v ? 1 : 2);
    return 3 * f + k;
  };
  auto midpoint = [&](const HalfEdge& e) {
    return Vec3(0.5 * (mesh.vertices_mm[e.lo] + mesh.vertices_mm[e.hi]));
  };
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (const auto& [begin, end] : edges.groups) {
    const HalfEdge& e0 = edges.half_edges[begin];
    const std::size_t count = end - begin;
    if (count == 1) {
      if (h.boundary_edges == 0) h.first_boundary_edge_mm = midpoint(e0);
      ++h.boundary_edges;
    } else if (count == 2) {
      const HalfEdge& e1 = edges.half_edges[begin + 1];
      corners.unite(corner_of(e0.face, e0.lo), corner_of(e1.face, e0.lo));
      corners.unite(corner_of(e0.face, e0.hi), corner_of(e1.face, e0.hi));
      if (e0.forward == e1.forward) {
        if (h.inconsistent_edges == 0) h.first_inconsistent_edge_mm = midpoint(e0);
        ++h.inconsistent_edges;
      }
    } else if (pair_faces_around_edge(mesh, edges, begin, end, pairs)) {
      ++h.touching_edges;
      for (const auto& [f, g] : pairs) {
        corners.unite(corner_of(f, e0.lo), corner_of(g, e0.lo));
        corners.unite(corner_of(f, e0.hi), corner_of(g, e0.hi));
      }
    } else {
      if (h.non_manifold_edges == 0) h.first_non_manifold_edge_mm = midpoint(e0);
      ++h.non_manifold_edges;
    }
  }
  h.closed = h.boundary_edges == 0 && h.non_manifold_edges == 0;

  // Non-manifold vertices: more than one fan of faces around the vertex.
  std::vector<std::uint32_t> first_root(mesh.vertices_mm.size(), UINT32_MAX);
  std::vector<char> flagged(mesh.vertices_mm.size(), 0);
  for (std::size_t f = 0; f < nf; ++f) {
    if (skip[f] != 0) continue;
    for (std::uint32_t k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.triangles[f][k];
      const std::uint32_t root = corners.find(static_cast<std::uint32_t>(3 * f + k));
      if (first_root[v] == UINT32_MAX) {
        first_root[v] = root;
      } else if (first_root[v] != root && flagged[v] == 0) {
        flagged[v] = 1;
        if (h.non_manifold_vertices == 0) h.first_non_manifold_vertex_mm = mesh.vertices_mm[v];
        ++h.non_manifold_vertices;
      }
    }
  }

  const ShellTable shells_table = compute_shells(mesh, skip, edges);
  h.shells = shells_table.shells.size();
  for (const auto& s : shells_table.shells) h.shell_bbox_mm.push_back(s.box);
  h.shell_faces.assign(shells_table.shells.size(), 0);
  for (auto sh : shells_table.shell_of_face)
    if (sh != UINT32_MAX) ++h.shell_faces[sh];
  for (const auto& s : shells_table.shells) h.inverted_shells += s.inverted ? 1 : 0;
  return h;
}

}  // namespace printtwin
